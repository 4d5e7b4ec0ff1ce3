"""Sweeps (issue 27): the 64-point benchmark sweep (the vertical study, one start per point,
32 payload masses x 2 floors) on a local cluster of 2 worker processes, with one NLP per
worker and continuation along the lines, against the same sweep of commit c243645 (an NLP
built per point, no continuation) on the same 2 workers: speed-up at least 3.5. Both arms
run ``benchmarks/sweep_arm.py`` in a subprocess, the old one with ``PYTHONPATH`` on a
worktree of c243645 (``ISODESIGN_BENCH_OLD``, default ``/tmp/sweep27-old``: ``git worktree
add /tmp/sweep27-old c243645``), interleaved (old, new, old, new...), medians reported
with the load average. Then every point of the new sweep must be within 0.01 dB of an
8-start cold optimize of the same point (the reference: 8 starts, no neighbours, each point
on the parametric NLP of :mod:`isodesign.optimization.parametric`, which is the point's
own NLP: tests/optimization/test_parametric.py; run in 2 forked workers). And ``isodesign
optimize`` of the vertical study, whole process (``python -m isodesign optimize FILE -o
DIR --quiet``), against c243645's, interleaved: target at most 0.75x (alone, without the
sweep rows: ``ISODESIGN_BENCH_SWEEP_ROWS=optimize python benchmarks/run.py sweep``).
Informative: a robust sweep (the vertical study with ``[scenarios]``) continued along a
payload line against the same points each solved alone, on the same process's NLPs
(:func:`robust_line_rows`; alone: ``ISODESIGN_BENCH_SWEEP_ROWS=robust``).

The machine is shared: the rows say the load average during each arm.

Run alone with ``python benchmarks/bench_sweep.py`` or ``python benchmarks/run.py sweep``;
``python benchmarks/bench_sweep.py --cluster-vs-serial`` measures the former rows (the
local cluster against the same points serially in one process, see
:func:`run_cluster_vs_serial`).

Former rows
-----------
Sweeps on Dask (target): 64 optimize points (the vertical study with one start per point,
32 payload masses x 2 floors) on a local cluster of 2 worker processes against the same
points serially in one process: speed-up at least 1.8. Both sides run the same
:func:`isodesign.sweeps.tasks.run_point` per point (the point's whole run directory, no
plots) and the same table rewrite after each point (in the serial process between the
points, in the client while the workers compute). Informative: the cluster's start, the
end-to-end speed-up with it, the scheduler overhead per task (the wall time of the
cluster not spent inside the tasks, per task; and a round trip of 200 empty tasks), the
CPU time per task spent outside the points (the client process: the sweep loop, the table,
the scheduler and the nannies; the worker processes beside their task and its helper
threads), the cores the serial process used (a point keeps to one thread of computation,
its NLP build included; the speed-up's ceiling is the workers over those cores), a point's
CPU time
on a worker against the serial process (the ``cpu_s`` column: the thread that computed it)
and the idle tail (the last point running alone). CPU times are less noisy than wall times
on a shared machine. Each side is timed once (about 1 and 2 min on 2 cores), after a
warm-up sweep of 4 points on each side (imports, CasADi's first NLP build, on every
worker: checked).

Run alone with ``python benchmarks/bench_sweep.py`` or ``python benchmarks/run.py sweep``;
``python benchmarks/bench_sweep.py --compare`` also runs the cluster with Dask's default
configuration (what the local cluster used before ``isodesign.sweeps.cluster.LOCAL_CONFIG``)
in the same run and prints both.
"""

from __future__ import annotations

import math
import os
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

#: Target speed-up of the local cluster (2 workers) over the serial run.
TARGET_SPEEDUP = 1.8
WORKERS = 2
#: 32 masses x 2 floors = 64 points.
VARY = ["payload.mass_kg=300:1540:32", "floor.criterion=VC-A,VC-B"]
#: Two points per worker: every worker has imported isodesign and built an NLP.
WARMUP = ["payload.mass_kg=555,666,777,888"]
STARTS = 1
EMPTY_TASKS = 200
#: The local cluster's configuration before LOCAL_CONFIG: Dask's defaults but these.
DASK_DEFAULTS = {"distributed.scheduler.allowed-failures": 1,
                 "distributed.worker.daemon": True,
                 "distributed.admin.system-monitor.gil.enabled": False}


def _noop(i):
    return i


def _process_cpu_s() -> float:
    """CPU seconds of the calling process, every thread (run on the workers)."""
    import psutil

    t = psutil.Process(os.getpid()).cpu_times()
    return t.user + t.system


def _study():
    from isodesign.optimization.study import vertical_study

    # models.distortion off: the question of c243645, which predates the key
    return vertical_study().with_changes({"models.distortion": False},
                                         solver={"starts": STARTS})


def _sum(res, col) -> float:
    return float(sum(v for v in res.table[col] if v == v and v is not None))


def _serial(study, tmp: Path) -> dict:
    import isodesign

    isodesign.sweep(study, WARMUP, output=tmp / "warm_serial", scheduler="serial",
                    charts=False)
    t0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
    res = isodesign.sweep(study, VARY, output=tmp / "serial", scheduler="serial",
                          charts=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    main = time.thread_time() - m0
    n = len(res.table)
    task_cpu = _sum(res, "cpu_s")
    return {"res": res, "wall": wall, "n": n, "task_cpu": task_cpu, "cpu": cpu,
            "busy": float(sum(res.point_wall_s)),
            # this thread beside the points: the loop, the table rewrites, the points' set-up
            "loop_cpu": (main - task_cpu) / n,
            # the points' own helper threads (the run directory's fsyncs; the NLP build
            # keeps to the point's thread in a sweep): a worker runs them too
            "helper_cpu": (cpu - main) / n}


def _cluster(study, tmp: Path, config: dict | None, tag: str) -> dict:
    import isodesign
    from isodesign.sweeps.cluster import connect

    t0 = time.perf_counter()
    conn = connect(workers=WORKERS, config=config)
    t_start = time.perf_counter() - t0
    arrivals: list[float] = []

    def progress(done, total, row, running):
        if row is not None:
            arrivals.append(time.perf_counter())

    try:
        client = conn.client
        address = client.scheduler.address
        warmed: set = set()
        for i in range(3):  # until every worker has computed a point
            w = isodesign.sweep(study, WARMUP, output=tmp / f"warm_{tag}_{i}",
                                scheduler=address, charts=False)
            warmed |= set(w.table["worker"])
            if len(warmed) >= WORKERS:
                break
        cpu0 = client.run(_process_cpu_s)
        t0, c0 = time.perf_counter(), time.process_time()
        res = isodesign.sweep(study, VARY, output=tmp / tag, scheduler=address, charts=False,
                              progress=progress)
        wall, client_cpu = time.perf_counter() - t0, time.process_time() - c0
        t_end = time.perf_counter()
        cpu1 = client.run(_process_cpu_s)
        t0 = time.perf_counter()
        futs = client.map(_noop, range(EMPTY_TASKS), pure=False)
        client.gather(futs)
        t_empty = (time.perf_counter() - t0) / EMPTY_TASKS
    finally:
        conn.close()
    n = len(res.table)
    task_cpu = _sum(res, "cpu_s")
    workers_cpu = sum(cpu1[k] - cpu0[k] for k in cpu1 if k in cpu0)
    busy = float(sum(res.point_wall_s))
    # after the last-but-one point arrives, one worker has nothing left: the last point
    # runs alone (the 2-worker case; the sweep's end follows at once)
    tail = (t_end - arrivals[-2]) if len(arrivals) >= 2 else 0.0
    return {"res": res, "wall": wall, "n": n, "start": t_start, "empty": t_empty,
            "task_cpu": task_cpu, "busy": busy, "tail": tail,
            "client_cpu": client_cpu / n, "workers_cpu": (workers_cpu - task_cpu) / n,
            "warmed": len(warmed)}


def _rows(s: dict, d: dict, load: tuple, label: str = "") -> list[dict]:
    n = d["n"]
    t_serial, t_dask = s["wall"], d["wall"]
    a = s["res"].table.set_index("point")["objective_value"].sort_index()
    b = d["res"].table.set_index("point")["objective_value"].sort_index()
    same = bool(list(a.index) == list(b.index) and (a - b).abs().max() < 1e-9)
    speedup = t_serial / t_dask
    per_point = statistics.median(s["res"].point_wall_s)
    busy_fraction = d["busy"] / (WORKERS * t_dask)
    slowdown = d["busy"] / s["busy"]
    cpu_ratio = d["task_cpu"] / s["task_cpu"]
    overhead = (WORKERS * t_dask - d["busy"]) / n
    dask_workers = d["workers_cpu"] - s["helper_cpu"]  # beside the task and its helpers
    outside = d["client_cpu"] + dask_workers
    cores = s["cpu"] / t_serial
    ceiling = WORKERS / max(cores, 1.0)
    notes = (f"{n} points (vertical study, {STARTS} start each, {VARY[0]} x {VARY[1]}); serial "
             f"{t_serial:.1f} s in one process (median point {per_point:.2f} s), local cluster "
             f"of {WORKERS} worker processes{label} {t_dask:.1f} s (warm: started and warmed "
             f"up before timing, {d['warmed']} of {WORKERS} workers warmed); results "
             f"identical: {same}; the workers were busy {busy_fraction:.0%} of the time, and "
             f"their points took {slowdown:.2f} x the serial points' wall time, "
             f"{cpu_ratio:.3f} x their CPU time (CPU shared with other processes: the "
             f"speed-up is {WORKERS} x busy / slowdown); the serial process used "
             f"{cores:.2f} cores on average (a point's helper threads: "
             f"{s['helper_cpu']:.2f} s CPU per point beside its own "
             f"{s['task_cpu'] / n:.2f} s), so {WORKERS} workers on {WORKERS} cores reach at "
             f"most {ceiling:.2f}; load average {load[0]:.1f} -> {load[1]:.1f}")
    return [
        {"name": f"sweep: {n} optimize points, local cluster ({WORKERS} workers{label}) "
                 "vs serial",
         "target": f">= {TARGET_SPEEDUP}", "median": speedup, "unit": "x",
         "ratio": speedup / TARGET_SPEEDUP, "passed": speedup >= TARGET_SPEEDUP,
         "repeats": 1, "notes": notes},
        {"name": f"sweep: end to end with the cluster's start{label}", "target": "",
         "unit": "x", "median": t_serial / (t_dask + d["start"]), "ratio": "",
         "notes": f"LocalCluster({WORKERS} workers) start {d['start']:.1f} s added to the "
                  "cluster's time (the warm-up sweep, which pays the workers' imports, is not)"},
        {"name": f"sweep: scheduler overhead per task{label}", "target": "", "unit": "s",
         "median": overhead, "ratio": "",
         "notes": f"({WORKERS} x {t_dask:.1f} s - {d['busy']:.1f} s inside the tasks) / {n}: "
                  "scheduling, transfer and the idle tail (the last point alone: "
                  f"{d['tail']:.2f} s, {d['tail'] / (WORKERS * t_dask):.1%} of the workers' "
                  f"time); a round trip of {EMPTY_TASKS} empty tasks: "
                  f"{d['empty'] * 1e3:.2f} ms per task"},
        {"name": f"sweep: CPU per task outside the points{label}", "target": "", "unit": "ms",
         "median": outside * 1e3, "ratio": "",
         "notes": f"the client process {d['client_cpu'] * 1e3:.1f} ms (the sweep loop, the "
                  "table rewrites, the scheduler, the nannies) + the worker processes "
                  f"{dask_workers * 1e3:.1f} ms (event loop, heartbeats, monitors: their CPU "
                  f"beside the tasks, {d['workers_cpu'] * 1e3:.1f} ms, less the points' helper "
                  f"threads measured serially, {s['helper_cpu'] * 1e3:.1f} ms); the serial "
                  f"process spends {s['loop_cpu'] * 1e3:.1f} ms per point beside the points "
                  "(the loop and the table rewrites); a point's CPU time is "
                  f"{s['task_cpu'] / s['n']:.2f} s in its thread"},
        {"name": f"sweep: a point's CPU time on a worker / in the serial process{label}",
         "target": "", "unit": "x", "median": cpu_ratio, "ratio": "",
         "notes": f"the cpu_s column (CPU time of the thread computing the point) summed: "
                  f"{d['task_cpu']:.1f} s on the workers, {s['task_cpu']:.1f} s serially"},
    ]


def run_cluster_vs_serial(compare: bool = False) -> list[dict]:
    """The former rows: speed-up of the cluster over serial (target), then informative ones.

    With ``compare``, the cluster also runs with :data:`DASK_DEFAULTS` (rows labelled).
    """
    warnings.simplefilter("ignore")
    study = _study()
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        s = _serial(study, tmp)
        d = _cluster(study, tmp, None, "dask")
        load1 = os.getloadavg()[0]
        rows = _rows(s, d, (load0, load1))
        if compare:
            d0 = _cluster(study, tmp, DASK_DEFAULTS, "dask_defaults")
            rows += _rows(s, d0, (load1, os.getloadavg()[0]), label=", Dask's defaults")
    return rows


# ---------------------------------------------------------------------------------------
# issue 27: one NLP per worker, continuation; against c243645
# ---------------------------------------------------------------------------------------
#: Target speed-up of this sweep over c243645's on the same 2 workers.
TARGET_SWEEP_SPEEDUP = 3.5
#: Every point within this of an 8-start cold optimize (dB).
TARGET_GAP_DB = 0.01
#: Target whole-process time of ``isodesign optimize`` (vertical study) over c243645's.
TARGET_OPTIMIZE_RATIO = 0.75
REFERENCE_STARTS = 8
OLD_COMMIT = "c243645"
HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def _old_tree() -> Path:
    old = Path(os.environ.get("ISODESIGN_BENCH_OLD", "/tmp/sweep27-old"))
    if not (old / "isodesign" / "__init__.py").is_file():
        raise RuntimeError(f"no worktree of {OLD_COMMIT} at {old}: git worktree add {old} "
                           f"{OLD_COMMIT} (or set ISODESIGN_BENCH_OLD)")
    return old


def _env(tree: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONWARNINGS": "ignore"}
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    return env


def _sweep_arm(tree: Path) -> dict:
    import json
    import subprocess

    out = subprocess.run([sys.executable, str(HERE / "sweep_arm.py"), "sweep"], env=_env(tree),
                         capture_output=True, text=True, cwd=str(tree), check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _optimize_arm(tree: Path, study_file: Path, tmp: Path, tag: str) -> tuple[float, float]:
    """Wall time and CPU time (the process and its worker processes, user + system) of one
    ``python -m isodesign optimize`` of ``tree`` at the niceness of this process."""
    import subprocess

    c0 = os.times()
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "isodesign", "optimize", str(study_file), "-o",
                    str(tmp / tag), "--quiet"], env=_env(tree), cwd=str(tree), check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    c1 = os.times()
    return wall, (c1.children_user - c0.children_user) + (c1.children_system
                                                           - c0.children_system)


def _points() -> list[tuple[float, str]]:
    """The benchmark sweep's points (payload mass, floor criterion)."""
    from isodesign.sweeps.spec import combine, parse_vary

    return [(float(t["payload.mass_kg"]), str(t["floor.criterion"]))
            for t in combine([parse_vary(v) for v in VARY])]


def _key(m, c) -> tuple[float, str]:
    return (round(float(m), 6), str(c))


def _reference(points) -> dict:
    """8-start cold optima of the points (no neighbours), in 2 forked workers that share the
    parametric NLP built once in this process."""
    from isodesign.optimization.driver import optimize_vertical
    from isodesign.optimization.executor import SerialExecutor, use_executor
    from isodesign.optimization.multistart import map_in_workers
    from isodesign.optimization.parametric import ParametricProblem
    from isodesign.optimization.study import vertical_study

    base = vertical_study().with_changes({"models.distortion": False},  # c243645's question
                                         solver={"starts": REFERENCE_STARTS, "workers": 1})
    prob = ParametricProblem(base)

    def cold(pt):
        m, c = pt
        st = base.with_changes({"payload.mass_kg": m, "floor.criterion": c})
        view = prob.at(st)
        with use_executor(SerialExecutor()):
            r = optimize_vertical(st, problem=view, analyze=False)
        return float(r.objective_value) if r.feasible else math.nan

    vals = map_in_workers(cold, points, workers=WORKERS)
    return {_key(m, c): v for (m, c), v in zip(points, vals, strict=True)}


def _reference_in_background(out: Path):
    """The reference computed by another process while the arms run (the machine's load
    is the same for both arms, which alternate); its stderr beside ``out``."""
    import subprocess

    with open(out.with_suffix(".log"), "w") as err:
        return subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--reference",
                                 str(out)], env=_env(ROOT), cwd=str(ROOT),
                                stdout=subprocess.DEVNULL, stderr=err)


def _wait_for(path: Path, proc, timeout_s: float = 3600.0) -> dict:
    """The reference file (written by ``proc``, or by a ``--reference`` run started
    beforehand when ``proc`` is None); computed here if that process failed."""
    import json

    t0 = time.perf_counter()
    while not path.is_file():
        if proc is not None and proc.poll() is not None and not path.is_file():
            break  # failed: computed here
        if time.perf_counter() - t0 > timeout_s:
            break
        time.sleep(5)
    if path.is_file():
        return {_key(m, c): v for m, c, v in json.loads(path.read_text())}
    return _reference(_points())


def _cpus(olds, new) -> str:
    """The points' summed CPU seconds of both arms (medians) and their ratio."""
    co = [a.get("cpu_s") for a in olds if a.get("cpu_s")]
    cn = [a.get("cpu_s") for a in new if a.get("cpu_s")]
    if not co or not cn:
        return "points' CPU time not reported"
    o, n = statistics.median(co), statistics.median(cn)
    return (f"the points' CPU time (summed, medians) {OLD_COMMIT} {o:.1f} s, this {n:.1f} s: "
            f"{o / n:.2f}x")


def _walls(arms) -> str:
    return ", ".join(f"{a['wall_s']:.1f}" for a in arms)


def optimize_process_row(old: Path, repeats: int | None = None) -> dict:
    """The row ``isodesign optimize`` whole process (vertical study) against c243645's.

    ``python -m isodesign optimize vertical.toml -o DIR --quiet`` of both trees,
    interleaved (old, new, old, new...), ``repeats`` times each (default
    ``ISODESIGN_BENCH_OPTIMIZE_REPEATS``, else 3); the ratio of the median wall times, with
    each arm's CPU time (user + system of the process and its workers) in the notes: on a
    shared machine the CPU times are the steadier figure. Run alone (without the sweep
    rows) with ``ISODESIGN_BENCH_SWEEP_ROWS=optimize python benchmarks/run.py sweep``.
    """
    from isodesign.io.record import study_toml
    from isodesign.optimization.study import vertical_study

    if repeats is None:
        repeats = int(os.environ.get("ISODESIGN_BENCH_OPTIMIZE_REPEATS", "3"))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        study_file, old_file = tmp / "vertical.toml", tmp / "vertical_old.toml"
        # one question: models.distortion = false in the new arm's file; c243645 predates
        # the key (its physics is the key off) and refuses a key it does not know
        full = study_toml(vertical_study().with_changes({"models.distortion": False}))
        study_file.write_text(full, encoding="utf-8")
        old_file.write_text("\n".join(line for line in full.splitlines()
                                      if line.strip() != "distortion = false") + "\n",
                            encoding="utf-8")
        t_o, t_n = [], []
        l0 = os.getloadavg()[0]
        for i in range(repeats):
            t_o.append(_optimize_arm(old, old_file, tmp, f"old{i}"))
            t_n.append(_optimize_arm(ROOT, study_file, tmp, f"new{i}"))
        l1 = os.getloadavg()[0]
    w_o = statistics.median(t[0] for t in t_o)
    w_n = statistics.median(t[0] for t in t_n)
    c_o = statistics.median(t[1] for t in t_o)
    c_n = statistics.median(t[1] for t in t_n)
    r = w_n / w_o
    return {"name": f"optimize: whole process, vertical study, vs {OLD_COMMIT}",
            "target": f"<= {TARGET_OPTIMIZE_RATIO}", "median": r, "unit": "x",
            "ratio": r / TARGET_OPTIMIZE_RATIO, "passed": r <= TARGET_OPTIMIZE_RATIO,
            "repeats": repeats,
            "notes": f"python -m isodesign optimize vertical.toml -o DIR --quiet, interleaved: "
                     f"{OLD_COMMIT} median {w_o:.1f} s "
                     f"({', '.join(f'{t[0]:.1f}' for t in t_o)}), this {w_n:.1f} s "
                     f"({', '.join(f'{t[0]:.1f}' for t in t_n)}); CPU time (process and "
                     f"workers, user + system) medians {c_o:.2f} s and {c_n:.2f} s (ratio "
                     f"{c_n / c_o:.2f}); load average {l0:.1f} -> {l1:.1f}"}


#: The robust line (informative rows): the coarse vertical study with [scenarios], one
#: start, serially in one process, along a payload line (docs/sweep.md, section 7).
ROBUST_MASSES = (360.0, 380.0, 400.0, 420.0, 440.0, 460.0)


def _robust_study():
    from isodesign.optimization.study import vertical_study

    return vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 10},
        solver={"starts": 1, "tie_break": False},
        scenarios={"payload_mass_kg": {"relative": 0.05},
                   "capillary_diameter_m": {"relative": 0.02}})


def _robust_arm(tmp: Path, tag: str, continued: bool) -> dict:
    """One arm of the robust line: the sweep of every mass (a chain: each point continued
    from its predecessor), or each mass as a sweep of its own (no neighbour); the same
    process, so both solve on the NLPs its worker cache built once."""
    import isodesign
    from isodesign.sweeps.table import read_table

    vary = {"payload.mass_kg": list(ROBUST_MASSES)}
    t0, c0 = time.perf_counter(), _process_cpu_s()
    if continued:
        dirs = [tmp / f"{tag}-line"]
        isodesign.sweep(_robust_study(), vary=vary, output=dirs[0], scheduler="serial",
                        options={"yield_samples": 0}, charts=False)
    else:
        dirs = []
        for m in ROBUST_MASSES:
            dirs.append(tmp / f"{tag}-{m:g}")
            isodesign.sweep(_robust_study(), vary={"payload.mass_kg": [m]}, output=dirs[-1],
                            scheduler="serial", options={"yield_samples": 0}, charts=False)
    wall, cpu = time.perf_counter() - t0, _process_cpu_s() - c0
    rows = [r for d in dirs for _, r in read_table(d).iterrows()]
    return {"wall_s": wall, "cpu_s": cpu,
            "values": {float(r["payload.mass_kg"]): float(r["objective_value"]) for r in rows},
            "rounds": int(sum(int(r["rounds"]) for r in rows)),
            "status": sorted({str(r["status"]) for r in rows})}


def robust_line_rows(repeats: int | None = None) -> list[dict]:
    """Informative rows: a robust sweep continued along its line against the same points
    each solved alone (no neighbour), interleaved, on the same process's NLPs (the
    continuation alone differs), and the largest difference of a point's worst case.
    Run alone with ``ISODESIGN_BENCH_SWEEP_ROWS=robust python benchmarks/run.py sweep``."""
    if repeats is None:
        repeats = int(os.environ.get("ISODESIGN_BENCH_SWEEP_REPEATS", "2"))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        _robust_arm(tmp, "warm", continued=False)  # imports and every NLP built, once
        alone, line = [], []
        l0 = os.getloadavg()[0]
        for i in range(repeats):
            alone.append(_robust_arm(tmp, f"alone{i}", continued=False))
            line.append(_robust_arm(tmp, f"line{i}", continued=True))
        l1 = os.getloadavg()[0]
    t_a = statistics.median(a["wall_s"] for a in alone)
    t_l = statistics.median(a["wall_s"] for a in line)
    c_a = statistics.median(a["cpu_s"] for a in alone)
    c_l = statistics.median(a["cpu_s"] for a in line)
    diffs = [line[-1]["values"][m] - alone[-1]["values"][m] for m in ROBUST_MASSES]
    n = len(ROBUST_MASSES)
    head = (f"vertical study with [scenarios] payload +-5 %, capillary diameter +-2 %, coarse "
            f"(3 points per band, 10 peak points), 1 start, payload.mass_kg="
            f"{','.join(f'{m:g}' for m in ROBUST_MASSES)}, serial in one process (its NLPs "
            f"built by a warm-up before timing); ")
    return [
        {"name": f"robust sweep (informative): {n} points continued along the line vs each "
                 "solved alone", "target": "", "median": t_l / t_a, "unit": "x",
         "repeats": repeats,
         "notes": head + f"medians of {repeats} interleaved runs: alone {t_a:.1f} s "
                  f"({_walls(alone)}), continued "
                  f"{t_l:.1f} s ({_walls(line)}); CPU time "
                  f"{c_a:.1f} s and {c_l:.1f} s (ratio {c_l / c_a:.2f}); exchange rounds "
                  f"{alone[-1]['rounds']} alone, {line[-1]['rounds']} continued; statuses "
                  f"{alone[-1]['status']} / {line[-1]['status']}; load average {l0:.1f} -> "
                  f"{l1:.1f}"},
        {"name": "robust sweep (informative): largest difference of a continued point's "
                 "worst case to its cold one", "target": "", "median": max(diffs, key=abs),
         "unit": "dB", "repeats": 1,
         "notes": head + "continued minus alone, per point: "
                  + ", ".join(f"{m:g} kg {d:+.4f}" for m, d in zip(ROBUST_MASSES, diffs,
                                                                    strict=True))
                  + " (the exchange's tolerance is 0.01 dB: docs/sweep.md, section 7)"},
    ]


def run(repeats: int | None = None) -> list[dict]:
    """The issue-27 rows: sweep speed-up (target 3.5), gap to 8-start optima (target 0.01
    dB), ``isodesign optimize`` whole-process ratio (target 0.75).

    ``repeats``: interleaved runs of each arm (default ``ISODESIGN_BENCH_SWEEP_REPEATS``,
    else 2). The 8-start reference is computed by another process after the arms, or read from
    ``ISODESIGN_BENCH_SWEEP_REFERENCE`` (a ``--reference PATH`` run started beforehand;
    waited for). ``ISODESIGN_BENCH_SWEEP_ROWS=optimize``: only the optimize row
    (:func:`optimize_process_row`); ``=sweep``: only the sweep rows; ``=robust``: only the
    robust line's informative rows (:func:`robust_line_rows`).
    """
    warnings.simplefilter("ignore")
    if os.environ.get("ISODESIGN_BENCH_SWEEP_ROWS", "").strip() == "optimize":
        return [optimize_process_row(_old_tree())]
    if os.environ.get("ISODESIGN_BENCH_SWEEP_ROWS", "").strip() == "robust":
        return robust_line_rows()
    if repeats is None:
        repeats = int(os.environ.get("ISODESIGN_BENCH_SWEEP_REPEATS", "2"))
    old = _old_tree()
    ref_dir = tempfile.TemporaryDirectory()
    given = os.environ.get("ISODESIGN_BENCH_SWEEP_REFERENCE")
    if given:  # a reference run started beforehand (python bench_sweep.py --reference PATH)
        ref_file, ref_proc = Path(given), None
    else:
        ref_file, ref_proc = Path(ref_dir.name) / "reference.json", None
    new, olds, loads = [], [], []
    for _ in range(repeats):  # interleaved
        o = _sweep_arm(old)
        n = _sweep_arm(ROOT)
        olds.append(o)
        new.append(n)
        loads += o["load"] + n["load"]
    if not given:
        # after the arms, not beside them: run beside the first pair it took the cores
        # from the first arm (c243645's) for most of its run and from the second for less
        ref_proc = _reference_in_background(ref_file)
    t_old = statistics.median(a["wall_s"] for a in olds)
    t_new = statistics.median(a["wall_s"] for a in new)
    speedup = t_old / t_new
    ref = _wait_for(ref_file, ref_proc)
    ref_dir.cleanup()
    gaps = [ref[_key(m, c)] - v for m, c, v in new[-1]["points"]]
    gaps_old = [ref[_key(m, c)] - v for m, c, v in olds[-1]["points"]]
    worst = max(gaps)
    worst_old = max(gaps_old)
    n_pts = len(gaps)
    rows = [
        {"name": f"sweep: {n_pts} optimize points on {WORKERS} workers, one NLP per worker + "
                 f"continuation vs {OLD_COMMIT}", "target": f">= {TARGET_SWEEP_SPEEDUP}",
         "median": speedup, "unit": "x", "ratio": speedup / TARGET_SWEEP_SPEEDUP,
         "passed": speedup >= TARGET_SWEEP_SPEEDUP, "repeats": repeats,
         "notes": f"vertical study, 1 start per point, {VARY[0]} x {VARY[1]}, local cluster "
                  f"of {WORKERS} workers started and warmed up (imports) before timing; "
                  f"medians of {repeats} interleaved runs: {OLD_COMMIT} "
                  f"{t_old:.1f} s ({_walls(olds)}), this "
                  f"{t_new:.1f} s ({_walls(new)}); NLPs built "
                  f"{new[-1]['nlp_builds']} (c243645: one per point), points that changed "
                  f"branch {new[-1]['branch_changed']}, solved again {new[-1]['resolved']}; "
                  f"load average {min(loads):.1f}-{max(loads):.1f} on 2 cores; "
                  f"{_cpus(olds, new)}"},
        {"name": f"sweep: worst gap of a point to an {REFERENCE_STARTS}-start cold optimize",
         "target": f"<= {TARGET_GAP_DB}", "median": worst, "unit": "dB",
         "ratio": worst / TARGET_GAP_DB if worst > 0 else 0.0,
         "passed": bool(worst <= TARGET_GAP_DB), "repeats": 1,
         "notes": f"reference minus the sweep's worst-band margin, worst of {n_pts} points "
                  f"({sum(g > TARGET_GAP_DB for g in gaps)} beyond {TARGET_GAP_DB} dB); "
                  f"{OLD_COMMIT}'s one-start sweep: worst {worst_old:.3f} dB, "
                  f"{sum(g > TARGET_GAP_DB for g in gaps_old)} points beyond"},
    ]
    if os.environ.get("ISODESIGN_BENCH_SWEEP_ROWS", "").strip() != "sweep":
        rows.append(optimize_process_row(old))
        rows += robust_line_rows()
    return rows


if __name__ == "__main__":
    if sys.argv[1:2] == ["--reference"]:
        import json

        warnings.simplefilter("ignore")
        r = _reference(_points())
        Path(sys.argv[2]).write_text(json.dumps([[m, c, v] for (m, c), v in r.items()]))
    elif "--cluster-vs-serial" in sys.argv[1:]:
        for row in run_cluster_vs_serial(compare="--compare" in sys.argv[1:]):
            print(row)
    else:
        for row in run():
            print(row)
