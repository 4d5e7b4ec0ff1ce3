"""Sweeps on Dask (target): 64 optimize points (the default study with one start per point,
32 payload masses x 2 floors) on a local cluster of 2 worker processes against the same
points serially in one process: speed-up at least 1.8. Informative: the cluster's start,
the end-to-end speed-up with it, the scheduler overhead per task (the wall time of the
cluster not spent inside the tasks, per task; and a round trip of 200 empty tasks), and
the table writes. Each side is timed once (about 20-60 s each on 2 cores), after a warm-up
sweep of 2 points on each side (imports, CasADi's first NLP build).

Run alone with ``python benchmarks/bench_sweep.py`` or ``python benchmarks/run.py sweep``.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
import warnings
from pathlib import Path

#: Target speed-up of the local cluster (2 workers) over the serial run.
TARGET_SPEEDUP = 1.8
WORKERS = 2
#: 32 masses x 2 floors = 64 points.
VARY = ["payload.mass_kg=300:1540:32", "floor.criterion=VC-A,VC-B"]
WARMUP = ["payload.mass_kg=555,777"]
STARTS = 1
EMPTY_TASKS = 200


def _noop(i):
    return i


def _study():
    from isodesign.optimization.study import default_study

    return default_study().with_changes(solver={"starts": STARTS})


def run() -> list[dict]:
    """The rows: speed-up (target), then the informative ones."""
    import isodesign
    from isodesign.sweeps.cluster import connect

    warnings.simplefilter("ignore")
    study = _study()
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        isodesign.sweep(study, WARMUP, output=tmp / "warm_serial", scheduler="serial",
                        charts=False)
        t0 = time.perf_counter()
        serial = isodesign.sweep(study, VARY, output=tmp / "serial", scheduler="serial",
                                 charts=False)
        t_serial = time.perf_counter() - t0
        t0 = time.perf_counter()
        conn = connect(workers=WORKERS)
        t_start = time.perf_counter() - t0
        try:
            address = conn.client.scheduler.address
            isodesign.sweep(study, WARMUP, output=tmp / "warm_dask", scheduler=address,
                            charts=False)
            t0 = time.perf_counter()
            dask = isodesign.sweep(study, VARY, output=tmp / "dask", scheduler=address,
                                   charts=False)
            t_dask = time.perf_counter() - t0
            t0 = time.perf_counter()
            futs = conn.client.map(_noop, range(EMPTY_TASKS), pure=False)
            conn.client.gather(futs)
            t_empty = (time.perf_counter() - t0) / EMPTY_TASKS
        finally:
            conn.close()
    load1 = os.getloadavg()[0]
    n = len(dask.table)
    busy = float(sum(dask.point_wall_s))
    overhead = (WORKERS * t_dask - busy) / n
    same = bool((serial.table.set_index("point")["objective_value"].sort_index()
                 - dask.table.set_index("point")["objective_value"].sort_index()).abs().max()
                < 1e-9)
    speedup = t_serial / t_dask
    per_point = statistics.median(serial.point_wall_s)
    busy_fraction = busy / (WORKERS * t_dask)
    slowdown = busy / float(sum(serial.point_wall_s))
    notes = (f"{n} points (default study, {STARTS} start each, {VARY[0]} x {VARY[1]}); serial "
             f"{t_serial:.1f} s in one process (median point {per_point:.2f} s), local cluster "
             f"of {WORKERS} worker processes {t_dask:.1f} s (warm: started and warmed up "
             f"before timing); results identical: {same}; the workers were busy "
             f"{busy_fraction:.0%} of the time, and their points took {slowdown:.2f} x the "
             "serial points' time (CPU shared with other processes: the speed-up is "
             f"{WORKERS} x busy / slowdown); load average {load0:.1f} -> {load1:.1f}")
    return [
        {"name": f"sweep: {n} optimize points, local cluster ({WORKERS} workers) vs serial",
         "target": f">= {TARGET_SPEEDUP}", "median": speedup, "unit": "x",
         "ratio": speedup / TARGET_SPEEDUP, "passed": speedup >= TARGET_SPEEDUP,
         "repeats": 1, "notes": notes},
        {"name": "sweep: end to end with the cluster's start", "target": "", "unit": "x",
         "median": t_serial / (t_dask + t_start), "ratio": "",
         "notes": f"LocalCluster({WORKERS} workers) start {t_start:.1f} s added to the "
                  "cluster's time (the warm-up sweep, which pays the workers' imports, is not)"},
        {"name": "sweep: scheduler overhead per task", "target": "", "unit": "s",
         "median": overhead, "ratio": "",
         "notes": f"({WORKERS} x {t_dask:.1f} s - {busy:.1f} s inside the tasks) / {n}: "
                  "scheduling, transfer, the table rewrite after each point and the idle "
                  f"tail; a round trip of {EMPTY_TASKS} empty tasks: {t_empty * 1e3:.2f} ms "
                  "per task"},
    ]


if __name__ == "__main__":
    for row in run():
        print(row)
