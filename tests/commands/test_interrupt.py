"""SIGINT and SIGTERM to a running ``isodesign optimize``: exit 130, one line, no traceback,
no worker left, the partial run set aside and marked interrupted (never in place).

Each test starts a real subprocess on a small study (4 starts on 2 forked workers), waits
until the workers exist, and signals it: to the whole process group (what Ctrl-C does)
or to the main process only (what ``kill`` does).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="reads /proc to find the workers")

STUDY = """\
name = "interrupt"

[models]
points_per_band = 4
peak_points = 30

[solver]
starts = 6
workers = 2
"""


def _children(pid: int) -> list[int]:
    out = []
    task_dir = Path(f"/proc/{pid}/task")
    try:
        tasks = list(task_dir.iterdir())
    except FileNotFoundError:
        return out
    for t in tasks:
        try:
            out += [int(c) for c in (t / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError):
            pass
    return out


def _alive(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    state = next((ln.split()[1] for ln in status.splitlines() if ln.startswith("State:")), "")
    return state not in ("Z", "X")  # a zombie has ended (it awaits its new parent's wait)


def _start(tmp_path: Path, command: str = "optimize", study_text: str = STUDY,
           extra=()) -> tuple[subprocess.Popen, Path]:
    study = tmp_path / "study.toml"
    study.write_text(study_text, encoding="utf-8")
    out = tmp_path / "run"
    env = dict(os.environ)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[2]) + os.pathsep + \
        env.get("PYTHONPATH", "")
    proc = subprocess.Popen(
        [sys.executable, "-m", "isodesign", command, str(study), "-o", str(out), "--quiet",
         *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        start_new_session=True,  # its own process group: the test's group is not signalled
    )
    return proc, out


def _wait_for_workers(proc: subprocess.Popen, n: int = 2, timeout: float = 60.0) -> list[int]:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        kids = _children(proc.pid)
        if len(kids) >= n:
            time.sleep(0.3)  # let them start solving
            return _children(proc.pid)
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    proc.kill()
    _out, err = proc.communicate()
    pytest.fail(f"no workers appeared (status {proc.returncode}); stderr: {err}")


def _check_interrupted(proc, out: Path, workers: list[int], signame: str) -> None:
    try:
        stdout, stderr = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("the run did not end after the signal")
    assert proc.returncode == 130, (proc.returncode, stderr)
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith(f"isodesign: interrupted by {signame}"), stderr
    for bad in ("Traceback", "KeyboardInterrupt", "ForkPoolWorker", "Exception"):
        assert bad not in stderr + stdout, (bad, stderr)
    # every worker has ended
    t0 = time.monotonic()
    while any(_alive(w) for w in workers) and time.monotonic() - t0 < 5:
        time.sleep(0.05)
    assert not [w for w in workers if _alive(w)], "workers outlived the run"
    # on disk: no run at the target; the partial run is set aside, marked interrupted
    assert not out.exists()
    aside = out.with_name(out.name + ".interrupted")
    rec = json.loads((aside / "record.json").read_text())
    assert rec["run_status"] == "interrupted"
    assert rec["error"] == f"interrupted by {signame}"
    assert "design.json" not in rec["files"]
    assert str(aside) in lines[0]
    leftovers = [p.name for p in out.parent.iterdir() if "isodesign-partial" in p.name]
    assert not leftovers
    # no half-written temporary file inside
    assert not [p for p in aside.rglob(".*.tmp*")]


def test_sigint_to_the_process_group_mid_run(tmp_path):
    proc, out = _start(tmp_path)
    workers = _wait_for_workers(proc)
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
    _check_interrupted(proc, out, workers, "SIGINT")


def test_sigterm_to_the_main_process_mid_run(tmp_path):
    proc, out = _start(tmp_path)
    workers = _wait_for_workers(proc)
    os.kill(proc.pid, signal.SIGTERM)
    _check_interrupted(proc, out, workers, "SIGTERM")


def test_sigint_to_pareto_mid_run(tmp_path):
    proc, out = _start(tmp_path, "pareto", extra=("--points", "3"))
    workers = _wait_for_workers(proc)
    os.killpg(proc.pid, signal.SIGINT)
    _check_interrupted(proc, out, workers, "SIGINT")


def test_sigint_while_ipopt_runs_in_the_main_process(tmp_path):
    # one worker: the starts are solved in the main process, inside CasADi/IPOPT
    proc, out = _start(tmp_path, study_text=STUDY.replace("workers = 2", "workers = 1"))
    t0 = time.monotonic()
    while not list(tmp_path.glob(".run.isodesign-partial-*")):
        assert proc.poll() is None and time.monotonic() - t0 < 60, proc.communicate()
        time.sleep(0.02)
    time.sleep(1.0)  # building the NLP or solving a start
    assert proc.poll() is None
    os.killpg(proc.pid, signal.SIGINT)
    _check_interrupted(proc, out, [], "SIGINT")


def test_sigint_to_stiffness_leaves_no_partial_file(tmp_path):
    # a single-file command: the CSV and the plot appear whole or not at all
    out = tmp_path / "k.csv"
    (tmp_path / "k.png").write_bytes(b"an earlier plot")
    env = dict(os.environ)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[2]) + os.pathsep + \
        env.get("PYTHONPATH", "")
    proc = subprocess.Popen(
        [sys.executable, "-m", "isodesign", "stiffness", "--freq", "0.1:50:4000",
         "--amplitude", "0.01:1:40mm", "-o", str(out), "--plot", str(tmp_path / "k.png")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        start_new_session=True,
    )
    time.sleep(1.5)
    assert proc.poll() is None, proc.communicate()
    os.killpg(proc.pid, signal.SIGINT)
    _stdout, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 130, stderr
    lines = stderr.strip().splitlines()
    assert lines[-1] == "isodesign: interrupted by SIGINT", stderr
    assert all(ln.startswith("isodesign: warning: ") for ln in lines[:-1]), stderr
    assert "Traceback" not in stderr
    # each file is the earlier one, absent, or whole: never a truncated one
    if out.exists():
        assert len(out.read_text().splitlines()) == 1 + 4000 * 40
    png = (tmp_path / "k.png").read_bytes()
    assert png == b"an earlier plot" or (png.startswith(b"\x89PNG") and png.endswith(
        b"IEND\xaeB`\x82"))
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
