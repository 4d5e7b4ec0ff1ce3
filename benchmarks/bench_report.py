"""HTML reports (informative): ``isodesign.report`` for one design file, one optimize run
directory and a three-candidate comparison (the run, the reference spring's design file,
the vertical study's start design), each with its file size.

The optimize run directory is made once, untimed (``isodesign optimize`` of the default
study, ``--no-plots``). Each timed call loads the inputs, analyses them (band responses on
the judged and on all bands, harmonic transmissibility at three floor amplitudes, complex
stiffness at four strokes), draws the figures as SVG and renders the template.

Run alone with ``python benchmarks/bench_report.py`` or through ``python benchmarks/run.py``.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
import warnings
from pathlib import Path

from run import median_time


def _inputs(tmp: Path) -> dict[str, list]:
    from isodesign.cli import main
    from isodesign.io.designfile import reference_design_path

    run_dir = tmp / "optimize"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        status = main(["optimize", "-o", str(run_dir), "--quiet", "--no-plots"])
    if status != 0:
        raise RuntimeError(f"isodesign optimize failed with status {status}")
    study = Path(__file__).resolve().parent.parent / "isodesign" / "data" / "vertical_study.toml"
    design = reference_design_path()
    return {
        "one design file": [design],
        "one optimize run": [run_dir],
        "comparison of three candidates": [run_dir, design, study],
    }


def _row(name: str, inputs: list, out: Path) -> dict:
    from isodesign.reporting import report

    t = median_time(lambda: report(inputs, out), n_repeats=7)
    size = out.stat().st_size
    text = out.read_text(encoding="utf-8")
    return {
        "name": f"report: {name}",
        "target": "",
        "unit": "s",
        **t,
        "notes": f"{size / 1024:.0f} kB self-contained HTML, {text.count('<svg')} inline SVG "
                 f"figures, {text.count('<table')} tables",
    }


def run() -> list[dict]:
    """All report benchmarks.

    Returns
    -------
    list of dict
        One row per benchmark.
    """
    with warnings.catch_warnings(), tempfile.TemporaryDirectory() as d:
        warnings.simplefilter("ignore")
        tmp = Path(d)
        return [_row(name, inputs, tmp / f"r{i}.html")
                for i, (name, inputs) in enumerate(_inputs(tmp).items())]


if __name__ == "__main__":
    for row in run():
        print(row)
