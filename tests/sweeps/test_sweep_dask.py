"""Sweeps on a real Dask scheduler and two worker processes on 127.0.0.1 (started here).

One worker is killed mid-sweep: every point is still there, once, and identical to a
serial run of the same points; a rerun does no work; an extension runs only the new
points; SIGINT leaves the finished points usable and a rerun completes the sweep.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import isodesign
from isodesign.sweeps.table import read_table

VARY = ["payload.mass_kg=300:1400:12", "floor.criterion=VC-A,VC-B"]  # 24 points
COMPARED = ("objective_value", "volume_ratio", "top_volume_m3", "capillary_length_m",
            "capillary_diameter_m", "worst_band_margin_db")


def _worker_address(client, name: str) -> str:
    info = client.scheduler_info(n_workers=-1)["workers"]
    return next(a for a, w in info.items() if w.get("name") == name)


@pytest.fixture(scope="module")
def killed_sweep(dask_processes, cheap_study, tmp_path_factory):
    """24 optimize points on the scheduler; worker w1 SIGKILLed while it computes a point."""
    from distributed import Client

    out = tmp_path_factory.mktemp("killed") / "sweep"
    seen: dict = {}
    with Client(dask_processes.address, timeout="10s") as watcher:
        w1 = _worker_address(watcher, "w1")

        def progress(done, total, row, running):
            if row is None or seen or done < 4:
                return
            t0 = time.monotonic()
            while not watcher.processing().get(w1) and time.monotonic() - t0 < 10:
                time.sleep(0.02)
            seen["busy"] = list(watcher.processing().get(w1, ()))
            seen["done_before"] = done
            dask_processes.kill("w1")

        res = isodesign.sweep(cheap_study, VARY, output=out, scheduler=dask_processes.address,
                              progress=progress)
    return res, seen, w1


def test_a_killed_worker_loses_no_point(killed_sweep):
    res, seen, w1 = killed_sweep
    assert seen["busy"], "worker w1 was computing a point when it was killed"
    df = res.table
    assert res.status == "complete" and res.failed == 0
    assert len(df) == 24 and df["point"].is_unique and df["study_hash"].is_unique
    assert set(df["status"]) <= {"complete", "infeasible"}
    pairs = set(zip(df["payload.mass_kg"], df["floor.criterion"], strict=True))
    assert len(pairs) == 24
    # w1 computed some points before it died, the other worker every point after
    workers = set(df["worker"])
    assert w1 in workers and len(workers) == 2
    # the task w1 was running when it died ran again elsewhere, and appears once
    killed_points = [k.split("-")[2] for k in seen["busy"]]
    for p in killed_points:
        row = df[df["point"] == p]
        assert len(row) == 1 and row["worker"].iloc[0] != w1
    # each point's run directory is in place, whole; no staging directory left behind
    entries = sorted(os.listdir(res.directory / "points"))
    assert entries == sorted(df["point"])
    for p in df["point"]:
        rec = json.loads((res.directory / "points" / p / "record.json").read_text())
        assert rec["kind"] == "isodesign optimize" and rec["run_status"] in ("complete",
                                                                            "infeasible")
    rec = json.loads((res.directory / "record.json").read_text())
    assert rec["run_status"] == "complete" and rec["counts"]["missing"] == 0
    assert (res.directory / "charts" / "worst_band_margin.png").is_file()


def test_the_distributed_sweep_equals_a_serial_run(killed_sweep, cheap_study, tmp_path):
    res, _, _ = killed_sweep
    serial = isodesign.sweep(cheap_study, VARY, output=tmp_path / "serial", scheduler="serial",
                             charts=False)
    a = res.table.set_index("point").sort_index()
    b = serial.table.set_index("point").sort_index()
    assert list(a.index) == list(b.index)
    assert list(a["status"]) == list(b["status"])
    assert list(a["binding"]) == list(b["binding"])
    for c in COMPARED:
        np.testing.assert_allclose(a[c].to_numpy(float), b[c].to_numpy(float), rtol=1e-9,
                                   err_msg=c)
    assert set(b["worker"]) == {w for w in b["worker"] if w.startswith("local:")}


def test_a_rerun_does_no_work_and_an_extension_runs_only_the_new_points(killed_sweep,
                                                                       cheap_study,
                                                                       dask_processes):
    res, _, _ = killed_sweep
    out = res.directory
    stamps = {p: (out / "points" / p / "record.json").stat().st_mtime_ns
              for p in res.table["point"]}
    # nothing to do: the scheduler is never contacted (this address does not answer)
    again = isodesign.sweep(cheap_study, VARY, output=out, scheduler="tcp://127.0.0.1:9")
    assert (again.ran, again.reused, again.failed) == (0, 24, 0)
    assert again.where == "nothing to run"
    assert {p: (out / "points" / p / "record.json").stat().st_mtime_ns
            for p in res.table["point"]} == stamps
    # two more masses x two floors: exactly those 4 points run
    more = isodesign.sweep(cheap_study, ["payload.mass_kg=300:1600:14", VARY[1]], output=out,
                           scheduler=dask_processes.address)
    assert (more.ran, more.reused, more.failed) == (4, 24, 0)
    df = read_table(out)
    assert len(df) == 28 and df["point"].is_unique
    new = df[df["payload.mass_kg"] > 1400]
    assert sorted(new["payload.mass_kg"]) == [1500, 1500, 1600, 1600]
    assert {p: (out / "points" / p / "record.json").stat().st_mtime_ns
            for p in res.table["point"]} == stamps


@pytest.mark.slow
def test_sigint_keeps_the_finished_points_and_a_rerun_completes(dask_processes, cheap_study,
                                                                tmp_path):
    out = tmp_path / "interrupted"
    cmd = [sys.executable, "-m", "isodesign", "sweep", str(cheap_study), "--vary",
           "payload.mass_kg=300:1500:13", "--scheduler", dask_processes.address, "-o",
           str(out), "--quiet", "--no-plots"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    n = 0
    while time.monotonic() - t0 < 120 and proc.poll() is None:
        try:
            n = len(read_table(out))
        except (OSError, ValueError):
            n = 0
        if n >= 2:
            break
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    _stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "interrupted by SIGINT" in lines[0], stderr
    df = read_table(out)  # the table is whole and holds the finished points
    assert 2 <= len(df) < 13 and set(df["status"]) == {"complete"}
    rec = json.loads((out / "record.json").read_text())
    assert rec["run_status"] == "interrupted"
    for p in df["point"]:
        assert json.loads((out / "points" / p / "record.json").read_text())["run_status"] \
            == "complete"
    time.sleep(1.0)  # a task cancelled while running may still finish on its worker
    res = isodesign.sweep(cheap_study, ["payload.mass_kg=300:1500:13"], output=out,
                          scheduler=dask_processes.address, charts=False)
    assert res.status == "complete" and len(res.table) == 13
    assert res.ran + res.reused == 13 and res.reused >= len(df)
