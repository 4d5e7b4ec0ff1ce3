"""Where the whole-process time of ``isodesign optimize --builtin vertical -o tmpdir --quiet``
goes (informative; the vertical study by name: the default study is the co-designed table).

The target row (``< 3 s`` whole process) is in ``bench_optimize.py``
(:func:`bench_optimize.bench_cli_optimize`). Here the same command runs as the program
(``python -m isodesign``, so it ends the way the ``isodesign`` script does: no interpreter
teardown) in a few fresh processes, with wall-clock marks at the phases' boundaries: the
time to the start of the NLP build (interpreter start, imports, study, run directory), the
NLP build, the starts, the tie-break and peak refinement, the re-check and band analyses,
the output files, the plot and the exit. Each phase's median over the processes is shown
(the medians need not add up to the median total), and the CPU time of each phase in the
main process and of the forked workers (on a shared machine the steadier figure). Then the
same runs import a byte-compiled copy of the package: without ``.pyc`` files
(``PYTHONDONTWRITEBYTECODE`` set, as on the team's machines) every process compiles the
package's sources, which an installed wheel never does.

Run alone with ``python benchmarks/bench_cli.py`` or ``python benchmarks/run.py cli``
(about 40 s).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPEATS = 3

#: Runs in the fresh process: wraps the phases' functions with wall-clock marks, then
#: runs the command line as the program; the marks are printed by an atexit handler
#: (the program ends with os._exit after the atexit handlers).
_CHILD = r"""
import atexit, json, os, sys, time
T0 = time.perf_counter()
marks, cpu = [], []
def mark(name):
    marks.append((name, time.perf_counter() - T0))
    cpu.append((name, time.process_time()))
def report():
    t = os.times()  # the forked workers, waited for by their pools
    print("MARKS " + json.dumps(marks), flush=True)
    print("CPU " + json.dumps(cpu + [("workers", t.children_user + t.children_system)]),
          flush=True)
atexit.register(report)
import isodesign.commands.optimize as cmd
import isodesign.optimization.driver as drv
import isodesign.optimization.problem as pb
def wrap(owner, name, label):
    fn = getattr(owner, name)
    def inner(*a, **k):
        mark(label + " start")
        try:
            return fn(*a, **k)
        finally:
            mark(label + " end")
    setattr(owner, name, inner)
_init = pb.Problem.__init__
def init(self, *a, **k):
    mark("build start")
    _init(self, *a, **k)
    mark("build end")
pb.Problem.__init__ = init
wrap(drv, "run_starts", "starts")
wrap(drv, "refine_branches", "refine")
wrap(cmd, "write_outputs", "outputs")
wrap(cmd, "optimization_plot", "plot")
import isodesign.cli as cli
sys.argv = [cli.__file__.replace("cli.py", "__main__.py"), "optimize", "--builtin", "vertical",
            "-o", OUT, "--quiet"]
mark("imports")
sys.exit(cli.main())
"""


def _load() -> str:
    try:
        return "load " + "/".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "load unknown"


def _one_run(package_dir: str | None = None) -> dict:
    """One fresh process: the phases' durations (s) and the process wall time.

    ``package_dir``: a directory holding a copy of the ``isodesign`` package to import
    instead of the installed one (the bytecode-compiled copy of :func:`_compiled_copy`).
    """
    env = dict(os.environ)
    if package_dir is not None:
        env["PYTHONPATH"] = package_dir + os.pathsep + env.get("PYTHONPATH", "")
    with tempfile.TemporaryDirectory(prefix="bench_cli_") as tmp:
        out = str(Path(tmp) / "run")
        code = f"OUT = {out!r}\n" + _CHILD
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=600, cwd=tmp, env=env)
        wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"isodesign optimize exited {p.returncode}: {p.stderr[-300:]}")
    line = next(x for x in p.stdout.splitlines() if x.startswith("MARKS "))
    m = dict(json.loads(line[6:]))
    line = next(x for x in p.stdout.splitlines() if x.startswith("CPU "))
    c = dict(json.loads(line[4:]))
    plot = m["plot end"] - m["plot start"]
    cpu = {  # CPU time of the main process (its threads) in each phase, and of the workers
        "to the NLP build": c["build start"],
        "NLP build": c["build end"] - c["build start"],
        "starts": c["starts end"] - c["starts start"],
        "refinement": c["refine end"] - c["refine start"],
        "re-check, analyses": c["outputs start"] - c["refine end"],
        "output files": c["outputs end"] - c["outputs start"] - (c["plot end"]
                                                                  - c["plot start"]),
        "response.png": c["plot end"] - c["plot start"],
        "workers": c["workers"],
    }
    return {"cpu": cpu, **{
        "to the NLP build": m["build start"],
        "NLP build": m["build end"] - m["build start"],
        "starts": m["starts end"] - m["starts start"],
        "refinement": m["refine end"] - m["refine start"],
        "re-check, analyses": m["outputs start"] - m["refine end"],
        "output files": m["outputs end"] - m["outputs start"] - plot,
        "response.png": plot,
        "exit (and interpreter start)": wall - m["outputs end"],
        "total": wall,
    }}


def _compiled_copy(dest: Path) -> str:
    """A copy of the ``isodesign`` package in ``dest`` with every module byte-compiled."""
    import compileall
    import shutil

    import isodesign

    src = Path(isodesign.__file__).resolve().parent
    shutil.copytree(src, dest / "isodesign", ignore=shutil.ignore_patterns("__pycache__"))
    compileall.compile_dir(str(dest / "isodesign"), quiet=1)
    return str(dest)


def bench_cli_breakdown() -> dict:
    """Informative: phases of ``isodesign optimize --builtin vertical -o tmpdir --quiet`` in
    fresh processes."""
    load0 = _load()
    runs = [_one_run() for _ in range(REPEATS)]
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0] if k != "cpu"}
    parts = "; ".join(f"{k} {v:.2f} s" for k, v in med.items() if k != "total")
    cmed = {k: statistics.median(r["cpu"][k] for r in runs) for k in runs[0]["cpu"]}
    cpu_parts = "; ".join(f"{k} {v:.2f} s" for k, v in cmed.items() if k != "workers")
    # without bytecode (PYTHONDONTWRITEBYTECODE, or a source tree nobody imported yet)
    # every process compiles the package's modules from source: compare with the
    # bytecode an installed wheel carries
    import isodesign

    src = Path(isodesign.__file__).resolve().parent
    has_pyc = any(src.glob("__pycache__/*.pyc"))
    with tempfile.TemporaryDirectory(prefix="bench_cli_pyc_") as tmp:
        pkg = _compiled_copy(Path(tmp))
        runs_c = [_one_run(pkg) for _ in range(REPEATS)]
    med_c = {k: statistics.median(r[k] for r in runs_c) for k in runs_c[0] if k != "cpu"}
    bytecode = (
        f"The package as imported here {'has' if has_pyc else 'has NO'} bytecode "
        f"(PYTHONDONTWRITEBYTECODE={os.environ.get('PYTHONDONTWRITEBYTECODE', 'unset')}); a "
        f"byte-compiled copy of it (as a wheel installs it), same runs: total "
        f"{med_c['total']:.2f} s, to the NLP build {med_c['to the NLP build']:.2f} s, NLP "
        f"build {med_c['NLP build']:.2f} s, response.png {med_c['response.png']:.2f} s"
    )
    return {
        "name": "informative: where `isodesign optimize --builtin vertical -o tmpdir --quiet`'s "
                "time goes",
        "target": "",
        "unit": "s",
        "median": med["total"],
        "min": min(r["total"] for r in runs),
        "max": max(r["total"] for r in runs),
        "repeats": REPEATS,
        "notes": f"medians of {REPEATS} fresh processes (`python -m isodesign`, which ends "
        f"like the script), {load0} before, {_load()} after: {parts}. 'to the NLP build': "
        f"imports, study, run directory; 'exit' includes the interpreter's start before "
        f"the first mark. CPU time (user + system; steadier than the wall times on a "
        f"shared machine), medians: the main process {cpu_parts}; its forked workers (the "
        f"starts and the refinement) {cmed['workers']:.2f} s. {bytecode}",
    }


def run() -> list[dict]:
    """The command-line benchmark rows (about 40 s).

    Returns
    -------
    list of dict
        One row per benchmark.
    """
    return [bench_cli_breakdown()]


if __name__ == "__main__":
    for row in run():
        print(row)
