"""The local cluster's configuration for seconds-long points, the cpu_s column, the table
written for every point even when a batch of finished points is cut short."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

import isodesign
import isodesign.sweeps.cluster as cluster
from isodesign.sweeps.table import read_table

DOCS = Path(__file__).resolve().parents[2] / "docs" / "sweep.md"


def test_the_local_cluster_workers_run_with_its_configuration_and_leave_this_process_alone(
        monkeypatch):
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    before = dict(os.environ)

    def settings():
        import os

        import dask

        return (os.environ.get("MALLOC_TRIM_THRESHOLD_"), os.environ.get("OMP_NUM_THREADS"),
                dask.config.get("distributed.worker.profile.enabled"),
                dask.config.get("distributed.worker.memory.monitor-interval"),
                dask.config.get("distributed.admin.tick.interval"))

    with cluster.connect(workers=2) as conn:
        got = conn.client.run(settings)
        sched = conn.client.run_on_scheduler(
            lambda dask_scheduler: (dask_scheduler.WORKER_SATURATION,
                                    "stealing" in dask_scheduler.extensions))
        assert len(got) == 2
        # no 64 KiB trim threshold, one BLAS/OpenMP thread, no profiler, slow monitors
        assert set(got.values()) == {(None, "1", False, "1s", "1s")}, got
        assert sched == (1.0, False)
    # the nannies' variables (OMP_NUM_THREADS=1 ...) stay out of this process
    assert dict(os.environ) == before


def test_the_documented_configuration_file_for_an_external_cluster_is_the_local_one(
        tmp_path, monkeypatch):
    import dask

    block = re.search(r"```yaml\n(.*?)```", DOCS.read_text(encoding="utf-8"), re.S)
    assert block, "docs/sweep.md has the configuration file"
    (tmp_path / "isodesign-sweep.yaml").write_text(block.group(1), encoding="utf-8")
    cfg = dask.config.collect(paths=[str(tmp_path)], env={})
    with dask.config.set(cfg):
        from distributed.nanny import _get_env_variables

        for key, value in cluster.LOCAL_CONFIG.items():
            if key.startswith("distributed.nanny.pre-spawn-environ."):
                assert key.rsplit(".", 1)[1] not in _get_env_variables(
                    "distributed.nanny.pre-spawn-environ")
            elif key not in ("distributed.worker.daemon",  # a local cluster's own
                             "distributed.admin.system-monitor.gil.enabled"):
                assert dask.config.get(key) == value, key


class _FakeConnection:
    workers, where, client = 2, "fake cluster", None

    def close(self):
        pass


def test_the_rows_of_a_batch_cut_short_by_an_interrupt_reach_the_table(tmp_path,
                                                                         monkeypatch):
    """Rows handed over without their table write (more of the batch to come), then SIGINT:
    the table holds them all the same."""
    import isodesign.sweeps.runner as runner
    from isodesign.sweeps.tasks import run_point

    def fake_dask(client, pts, order, todo_hashes, rows, task, options, points_dir, finished,
                  again=None):
        todo = [pts[i] for ch in order for i in ch if pts[i].study_hash in todo_hashes]
        for p in todo[:2]:
            row = run_point(task, runner.resolved_study_dict(p.study), p.study_hash,
                            p.changes, str(points_dir / p.key), options)
            finished(p, row, write=False)
        raise KeyboardInterrupt("SIGINT")

    monkeypatch.setattr(cluster, "connect", lambda *a, **k: _FakeConnection())
    monkeypatch.setattr(runner, "_run_dask", fake_dask)
    out = tmp_path / "s"
    with pytest.raises(KeyboardInterrupt):
        isodesign.sweep(vary={"payload.mass_kg": [400, 800, 1200]}, task="response",
                        output=out, scheduler="local", charts=False)
    df = read_table(out)
    assert sorted(df["payload.mass_kg"]) == [400, 800]
    assert set(df["status"]) == {"complete"}


def test_cpu_s_is_the_points_cpu_time(tmp_path):
    res = isodesign.sweep(vary={"payload.mass_kg": [400, 800]}, task="response",
                          output=tmp_path / "s", scheduler="serial", charts=False)
    df = res.table
    assert list(df.columns).index("cpu_s") == list(df.columns).index("wall_s") + 1
    assert (df["cpu_s"] > 0).all()
    assert (df["cpu_s"] <= df["wall_s"] + 0.01).all()  # one thread's CPU within its wall


def test_a_worker_of_the_local_cluster_killed_mid_sweep_loses_no_point(cheap_study, tmp_path,
                                                                       monkeypatch):
    """The local cluster's configuration keeps Dask's fault tolerance: the killed worker's
    point runs again (on the other worker, or on the worker its nanny restarts)."""
    import signal
    import time

    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    killed: dict = {}
    with cluster.connect(workers=2) as conn:
        client = conn.client
        pids = client.run(os.getpid)

        def progress(done, total, row, running):
            if row is None or killed or done < 2:
                return
            t0 = time.monotonic()
            while time.monotonic() - t0 < 10:
                busy = {a: list(k) for a, k in client.processing().items() if k}
                if busy:
                    break
                time.sleep(0.02)
            addr, keys = next(iter(busy.items()))
            killed.update(address=addr, keys=keys)
            os.kill(pids[addr], signal.SIGKILL)

        res = isodesign.sweep(cheap_study, ["payload.mass_kg=300:1400:12"], output=tmp_path / "s",
                              scheduler=client.scheduler.address, charts=False,
                              progress=progress)
    assert killed["keys"], "a worker was computing a point when it was killed"
    df = res.table
    assert res.status == "complete" and res.failed == 0
    assert len(df) == 12 and df["point"].is_unique
    assert sorted(os.listdir(res.directory / "points")) == sorted(df["point"])
    for key in killed["keys"]:  # the killed point is there, once, computed by another worker
        row = df[df["point"] == key.split("-")[2]]
        assert len(row) == 1 and row["worker"].iloc[0] != killed["address"]
