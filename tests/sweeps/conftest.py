"""Fixtures of the sweep tests: a real Dask scheduler and two worker processes on 127.0.0.1.

The scheduler and the workers are separate processes started here (``python -m
distributed.cli.dask_scheduler`` / ``dask_worker``), bound to 127.0.0.1, without
dashboards, the scheduler told to give up on a task after its second worker death
(``allowed-failures = 1``). Workers run without a nanny, so killing one kills it for good.
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

#: A cheap optimize point: one start, a coarse grid, no tie-break (about 0.3 s).
CHEAP_STUDY = """\
name = "cheap"
description = "the default study on a coarse grid, one start, no tie-break (sweep tests)"

[models]
points_per_band = 3
peak_points = 10

[solver]
starts = 1
tie_break = false
"""


@pytest.fixture(scope="session")
def cheap_study(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("sweep_study") / "cheap.toml"
    p.write_text(CHEAP_STUDY, encoding="utf-8")
    return p


class DaskProcesses:
    """A scheduler and named workers in subprocesses; ``kill(name)`` SIGKILLs a worker."""

    def __init__(self, tmp: Path):
        self.tmp = tmp
        self.env = {**os.environ, "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1",
                    "DASK_DISTRIBUTED__WORKER__DAEMON": "True", "PYTHONWARNINGS": "ignore"}
        self.env.pop("DASK_SCHEDULER_ADDRESS", None)
        self.file = tmp / "scheduler.json"
        self.scheduler = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", "0", "--no-dashboard", "--scheduler-file", str(self.file)],
            env=self.env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t0 = time.monotonic()
        while not self.file.is_file() or not self.file.read_text().strip():
            if time.monotonic() - t0 > 60 or self.scheduler.poll() is not None:
                self.close()
                raise RuntimeError("the Dask scheduler did not start")
            time.sleep(0.1)
        time.sleep(0.2)
        self.address = json.loads(self.file.read_text())["address"]
        assert self.address.startswith("tcp://127.0.0.1:")
        self.workers: dict[str, subprocess.Popen] = {}

    def start_worker(self, name: str) -> None:
        self.workers[name] = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--host",
             "127.0.0.1", "--nthreads", "1", "--no-nanny", "--no-dashboard", "--name", name],
            env=self.env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def wait_for_workers(self, n: int, timeout: float = 90.0) -> None:
        from distributed import Client

        with Client(self.address, timeout="10s") as c:
            c.wait_for_workers(n, timeout=timeout)

    def kill(self, name: str) -> None:
        p = self.workers[name]
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=10)

    def close(self) -> None:
        for p in [*getattr(self, "workers", {}).values(), self.scheduler]:
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(timeout=5)


@pytest.fixture(scope="module")
def dask_processes(tmp_path_factory):
    """A scheduler and two workers (``w1``, ``w2``) on 127.0.0.1, ended after the module."""
    procs = DaskProcesses(tmp_path_factory.mktemp("dask"))
    try:
        procs.start_worker("w1")
        procs.start_worker("w2")
        procs.wait_for_workers(2)
        yield procs
    finally:
        procs.close()
