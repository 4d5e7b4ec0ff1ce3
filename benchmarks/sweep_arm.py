"""One arm of the sweep benchmark (benchmarks/bench_sweep.py), run as a subprocess.

``python benchmarks/sweep_arm.py sweep`` runs the 64-point benchmark sweep (the vertical
study, one start per point, 32 payloads x 2 floors) on a local cluster of 2 worker
processes, started and warmed up (imports, with 4 ``response`` points: no NLP built)
before the timed sweep. The isodesign imported is the one on ``PYTHONPATH``: this tree, or an
older commit's worktree, so that both arms run the same script. Prints one JSON line.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
import warnings

VARY = ["payload.mass_kg=300:1540:32", "floor.criterion=VC-A,VC-B"]
WARMUP = ["payload.mass_kg=555,666,777,888"]
WORKERS = 2


def sweep_arm() -> dict:
    """The timed sweep; its wall time, the points' summed CPU time, objective values and NLP
    builds."""
    import isodesign
    from isodesign.optimization.study import vertical_study
    from isodesign.sweeps.cluster import connect

    study = vertical_study().with_changes(solver={"starts": 1})
    if "distortion" in study.models:  # the old commit's question (it predates the key): off
        study = study.with_changes({"models.distortion": False})
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        conn = connect(workers=WORKERS)
        try:
            address = conn.client.scheduler.address
            warmed: set = set()
            for i in range(3):  # until every worker has imported isodesign
                w = isodesign.sweep(study, WARMUP, task="response", output=f"{tmp}/warm{i}",
                                    scheduler=address, charts=False)
                warmed |= set(w.table["worker"])
                if len(warmed) >= WORKERS:
                    break
            t0 = time.perf_counter()
            res = isodesign.sweep(study, VARY, output=f"{tmp}/sweep", scheduler=address,
                                  charts=False)
            wall = time.perf_counter() - t0
        finally:
            conn.close()
    df = res.table
    points = [[float(m), str(c), None if v != v else float(v)]
              for m, c, v in zip(df["payload.mass_kg"], df["floor.criterion"],
                                 df["objective_value"], strict=True)]
    # the points' own CPU time (each point's computing thread): less sensitive to the load of
    # a shared machine than the wall time
    cpu = float(df["cpu_s"].sum()) if "cpu_s" in df else None
    return {"wall_s": wall, "cpu_s": cpu, "points": points,
            "nlp_builds": getattr(res, "nlp_builds", None),
            "branch_changed": int(df["branch_changed"].fillna(False).astype(bool).sum())
            if "branch_changed" in df else None,
            "resolved": int(df["resolved"].fillna(False).astype(bool).sum())
            if "resolved" in df else None,
            "status": sorted(set(df["status"])), "load": [load0, os.getloadavg()[0]]}


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    if sys.argv[1:] != ["sweep"]:
        sys.exit("usage: python benchmarks/sweep_arm.py sweep")
    print(json.dumps(sweep_arm()))
