"""SIGINT to a running ``isodesign sweep`` (issue 23): one line, exit 130, a readable table of
the finished points named only if it exists, nothing else left behind.

Each test starts a real subprocess in its own session and waits for an event (the sweep's
lock file, a finished point's file, the next point's staging directory) before it sends
SIGINT to the whole process group, as Ctrl-C in a terminal does.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="process groups and signals as on Linux")


def _start(cli, tmp_path: Path, cheap_study: Path, *extra):
    out = tmp_path / "sw"
    proc = cli.start("sweep", cheap_study, "--vary", "payload.mass_kg=500:800:6", "-o", out,
                     "--quiet", "--no-plots", *extra)
    return proc, out


def _ended(cli, proc) -> tuple[str, str]:
    """SIGINT to the sweep; its stdout and its one stderr line, checked."""
    out, err = cli.interrupt(proc)
    assert proc.returncode == 130, (proc.returncode, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isodesign: interrupted by SIGINT"), err
    for bad in ("Traceback", "KeyboardInterrupt", "CasADi", "Exception"):
        assert bad not in err + out, (bad, err)
    return out, lines[0]


def test_sigint_while_the_local_cluster_starts_names_nothing_that_does_not_exist(
        tmp_path, cheap_study, cli_process):
    proc, out = _start(cli_process, tmp_path, cheap_study, "--workers", "2")
    cli_process.wait_for(proc, lambda: (out / ".sweep.lock").exists(), "the sweep's lock file")
    _, line = _ended(cli_process, proc)  # the cluster is starting (seconds, not ms)
    table = out / "sweep.parquet"
    if table.exists():  # the cluster had started and the sweep had begun: named
        assert str(table) in line
    else:
        assert "nothing was written" in line and str(out) not in line


def test_sigint_inside_a_serial_point_stops_the_sweep_and_keeps_the_finished(
        tmp_path, cheap_study, cli_process):
    import pandas as pd

    proc, out = _start(cli_process, tmp_path, cheap_study, "--scheduler", "serial")
    pts = out / "points"

    def second_point_started() -> bool:
        if not pts.is_dir():
            return False
        done = {q.parent.name for q in pts.glob("*/sweep_point.json")
                if not q.parent.name.startswith(".")}  # in place (pathlib's * matches dots)
        return bool(done) and any(not any(q.name.startswith(f".{k}.") for k in done)
                                  for q in pts.glob(".*isodesign-partial-*"))

    cli_process.wait_for(proc, second_point_started, "the second point's start")
    _, line = _ended(cli_process, proc)  # the second point is being computed
    table = out / "sweep.parquet"
    assert str(table) in line
    df = pd.read_parquet(table)
    assert 1 <= len(df) < 6  # stopped: not every point ran after the interrupt
    assert set(df["status"]) <= {"complete", "infeasible"}
    kept = [p for p in pts.iterdir() if not p.name.startswith(".")
            and not p.name.endswith(".interrupted")]
    assert sorted(p.name for p in kept) == sorted(df["point"])
