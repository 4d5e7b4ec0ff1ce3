"""Spring model throughput (targets): the default self-consistent model on a
200 x 500 grid, the paper's literal model in points per second, and the CLI start-up.

Run alone with ``python benchmarks/bench_spring.py`` (prints the rows) or through
``python benchmarks/run.py``.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
from run import median_time

#: Targets.
TARGET_DEFAULT_S = 0.1
TARGET_LITERAL_POINTS_PER_S = 1e7
TARGET_HELP_S = 0.3


def bench_default_model() -> dict:
    """(a) Default model (self-consistent, quasi_steady, viscoelastic), 200 x 500 points.

    Returns
    -------
    dict
        A result row.
    """
    from isodesign.spring.design import SpringDesign
    from isodesign.spring.stiffness import complex_stiffness

    design = SpringDesign.reference()
    f = np.geomspace(0.2, 24.0, 200)
    x = np.geomspace(0.05e-3, 0.5e-3, 500)
    holder = {}

    def call():
        holder["r"] = complex_stiffness(design, f, x, warn=False)

    t = median_time(call)
    res = holder["r"]
    it = res.diagnostics.iterations
    notes = (
        f"{f.size * x.size:.0e} points (0.2-24 Hz log x 0.05-0.5 mm log); "
        f"{t['median'] / (f.size * x.size) * 1e9:.0f} ns/point; solver iterations "
        f"median {np.median(it):.0f}, max {np.max(it)}; includes diagnostics"
    )
    return {
        "name": "default model, 200 x 500 grid",
        "target": f"< {TARGET_DEFAULT_S} s",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_DEFAULT_S,
        "passed": t["median"] < TARGET_DEFAULT_S,
        "notes": notes,
    }


def bench_literal_model() -> dict:
    """(b) The paper's model (zhao, kinematic), points per second on 1000 x 1000 points.

    Returns
    -------
    dict
        A result row (the median is in points per second; ``min``/``max`` are the
        slowest and fastest repeats converted the same way).
    """
    from isodesign.spring.design import SpringDesign
    from isodesign.spring.stiffness import complex_stiffness

    design = SpringDesign.reference()
    f = np.geomspace(0.2, 24.0, 1000)
    x = np.geomspace(0.05e-3, 0.5e-3, 1000)
    n = f.size * x.size

    def call():
        complex_stiffness(design, f, x, flow="zhao", amplitude_mode="kinematic", warn=False)

    t = median_time(call)
    rate = n / t["median"]
    return {
        "name": "literal model (zhao, kinematic), 1000 x 1000 grid",
        "target": f"> {TARGET_LITERAL_POINTS_PER_S:.0e} points/s",
        "unit": "points/s",
        "median": rate,
        "min": n / t["max"],
        "max": n / t["min"],
        "repeats": t["repeats"],
        "ratio": rate / TARGET_LITERAL_POINTS_PER_S,
        "passed": rate > TARGET_LITERAL_POINTS_PER_S,
        "notes": (
            f"{n:.0e} points; median wall time {t['median']:.4f} s per call; includes "
            "diagnostics (validity checks for every point)"
        ),
    }


def _cli_command() -> list[str]:
    exe = Path(sys.executable).with_name("isodesign")
    if exe.exists():
        return [str(exe), "--help"]
    found = shutil.which("isodesign")
    if found:
        return [found, "--help"]
    return [sys.executable, "-c", "import sys; from isodesign.cli import main; sys.exit(main())",
            "--help"]  # fmt: skip


def bench_cli_help() -> dict:
    """(c) Wall time of ``isodesign --help`` in a fresh process.

    Returns
    -------
    dict
        A result row; the notes say whether the CLI printed a help text.
    """
    cmd = _cli_command()
    holder = {}

    def call():
        holder["p"] = subprocess.run(cmd, capture_output=True, text=True, timeout=60)

    t = median_time(call)
    p = holder["p"]
    lines = p.stdout.strip().splitlines()
    if p.returncode != 0:
        state = f"exit status {p.returncode}: {p.stderr.strip()[:120]}"
    elif not lines:
        state = "prints nothing: isodesign.cli.main is still a stub; re-measure when it exists"
    else:
        state = f"help text of {len(lines)} lines"
    return {
        "name": "`isodesign --help` (subprocess)",
        "target": f"< {TARGET_HELP_S} s",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_HELP_S,
        "passed": t["median"] < TARGET_HELP_S,
        "notes": f"`{' '.join(Path(c).name if i == 0 else c for i, c in enumerate(cmd))}`; "
        + state,
    }


def run() -> list[dict]:
    """All spring benchmarks.

    Returns
    -------
    list of dict
        One row per benchmark: ``name, target, median, unit, min, max, repeats,
        ratio, passed, notes``.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [bench_default_model(), bench_literal_model(), bench_cli_help()]


if __name__ == "__main__":
    for row in run():
        print(row)
