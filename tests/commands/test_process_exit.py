"""How ``isodesign optimize`` ends: the program skips the interpreter's teardown once its
run directory is complete (``isodesign.cli``, "Process exit"); the NLP is freed in a thread
beside the writing of the outputs and the objects frozen for the garbage collector during
the run are unfrozen; ``main`` called from Python always returns.
"""

from __future__ import annotations

import gc
import json
import subprocess
import sys
import threading
import weakref

import pytest

from isodesign import cli
from isodesign.commands import optimize as optimize_cmd
from isodesign.commands.optimize import OUTPUT_FILES

FAST_STUDY = """\
name = "fast"

[models]
points_per_band = 4
peak_points = 30

[solver]
starts = 2
"""


@pytest.fixture(scope="module")
def fast_study(tmp_path_factory):
    p = tmp_path_factory.mktemp("study") / "fast.toml"
    p.write_text(FAST_STUDY, encoding="utf-8")
    return p


@pytest.mark.parametrize(("argv0", "program"), [
    ("/venv/bin/isodesign", True),
    ("/venv/Scripts/isodesign-script.py", True),
    ("/src/isodesign/__main__.py", True),
    ("/venv/bin/pytest", False),
    ("/src/other/__main__.py", False),
    ("", False),
])
def test_only_the_isodesign_program_may_end_the_process(monkeypatch, argv0, program):
    monkeypatch.setattr(sys, "argv", [argv0, "optimize"])
    assert cli._is_program() is program


def test_exit_process_runs_atexit_handlers_and_flushes_before_ending():
    code = (
        "import atexit, sys\n"
        "from isodesign import cli\n"
        "atexit.register(lambda: print('atexit handler ran'))\n"
        "print('buffered line', end='')\n"
        "sys.stderr.write('buffered error')\n"
        "cli._exit_process(3)\n"
        "print('not reached')\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 3, p.stderr
    assert p.stdout == "buffered lineatexit handler ran\n"
    assert p.stderr == "buffered error"


def test_exit_process_returns_while_another_thread_runs():
    # the interpreter would wait for a non-daemon thread: so does _exit_process (it returns)
    go = threading.Event()
    t = threading.Thread(target=go.wait, daemon=False)
    t.start()
    try:
        assert cli._exit_process(0) is None
    finally:
        go.set()
        t.join()


def test_optimize_run_as_the_program_writes_every_file(fast_study, tmp_path):
    out = tmp_path / "run"
    p = subprocess.run([sys.executable, "-m", "isodesign", "optimize", str(fast_study),
                        "-o", str(out), "--quiet"], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("fast: worst_band_margin "), p.stdout
    assert "Traceback" not in p.stderr
    assert sorted(x.name for x in out.iterdir()) == sorted(OUTPUT_FILES)
    rec = json.loads((out / "record.json").read_text(encoding="utf-8"))
    assert rec["run_status"] == "complete"
    assert (out / "response.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_in_process_optimize_returns_and_frees_the_nlp(monkeypatch, fast_study, tmp_path,
                                                       capsys):
    built = []

    class Recorded(optimize_cmd._PrefetchingProblem):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            built.append(weakref.ref(self))

    prefetched = []
    real_prefetch = optimize_cmd.prefetch_imports

    def spy(*a, **kw):
        prefetched.append(len(built))  # 0: during the build of the (first) NLP
        return real_prefetch(*a, **kw)

    monkeypatch.setattr(optimize_cmd, "_PrefetchingProblem", Recorded)
    monkeypatch.setattr(optimize_cmd, "prefetch_imports", spy)
    status = cli.main(["optimize", str(fast_study), "-o", str(tmp_path / "run"), "--quiet"])
    assert status == 0, capsys.readouterr().err
    assert len(built) == 1
    # freed by the release thread, joined before main returned (no collection needed)
    assert built[0]() is None, gc.get_referrers(built[0]())
    assert not any(t.name == "isodesign-release" for t in threading.enumerate())
    # the output writers' modules were imported while the solver was built, once
    assert prefetched == [0]
    # the objects frozen for the collector during the run are given back to it
    assert gc.get_freeze_count() == 0


def test_a_failed_run_records_its_environment(monkeypatch, fast_study, tmp_path, capsys):
    # the package versions are looked up while the NLP is built; a run that fails after
    # the build still records them
    from isodesign.errors import SolverError

    def fail(*a, **kw):
        raise SolverError("solver exploded (test)")

    monkeypatch.setattr(optimize_cmd, "optimize", fail)
    out = tmp_path / "run"
    status = cli.main(["optimize", str(fast_study), "-o", str(out), "--quiet"])
    assert status == 1
    assert "solver exploded (test)" in capsys.readouterr().err
    rec = json.loads((out / "record.json").read_text(encoding="utf-8"))
    assert rec["run_status"] == "failed"
    assert rec["environment"]["packages"]["casadi"]
    assert gc.get_freeze_count() == 0
