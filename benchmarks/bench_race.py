"""The peer race (issue 27): isodesign's time to reach the global optimum against SciPy's
``differential_evolution`` on the same analysis, both measured the same way.

The vertical study (``vertical_study()``, worst-band margin). Differential evolution (SciPy):
the same free variables in the same scaled log coordinates ``z`` in ``[-1, 1]``
(:func:`isodesign.optimization.variables.log_scaling`), the objective (the negated
worst-band margin) and every constraint row of the NLP evaluated on the NumPy analysis path
(:func:`isodesign.optimization.recheck.evaluate_design`: sigma and the tube velocity from
the NumPy solvers, the study's grid), the constraints as SciPy takes them (one
``NonlinearConstraint`` of all the rows with their bounds), ``vectorized=True`` (one call
per generation for the objective and one for the constraints; the designs of a generation
are evaluated one after the other, each once, shared by the two calls),
``updating="deferred"``, ``polish=False``, seed 0. Its time to reach: the instant (a
callback's timestamp, from the start of its set-up) at which the best feasible design of a
generation is first within 0.01 dB of the global optimum, the better of isodesign's
answer and of everything differential evolution found; a time budget
(``ISODESIGN_BENCH_RACE_BUDGET_S``, default 900 s) stops it, and the row then gives a bound.

isodesign: :func:`isodesign.optimize` of the study in this process with its own settings
(8 starts on 2 forked workers, the branches' refinement, the tie-break, the re-check;
``analyze=False``), after a warm-up of the imports. Its time to reach, the same rule: the
first instant at which a solve of that run has finished with a design that is

* feasible: judged after the race on the same NumPy analysis as differential evolution,
  every constraint row within the product's feasibility tolerance
  (:data:`~isodesign.optimization.solution.FEASIBILITY_TOLERANCE`, 1e-6 in the NLP's units;
  IPOPT holds the NLP's own rows to 1e-9, the NumPy path agrees to the re-check's 1e-6)
  and the continuous peak of |T| between the grid's frequencies within
  ``PEAK_TOLERANCE_DB`` of the study's bound (the product's own standard: a start's
  optimum above it is not an answer until its peak refinement);
* within 0.01 dB of the global optimum (its margin on the same analysis);
* the incumbent: the best feasible design among the solves finished by then, which is what
  the product's selection picks (it keeps the best feasible refined branch; a design whose
  peak needs no refinement is its own refined branch), and the product's final answer must
  be as good as it within the tie-break's 0.01 dB (the tie-break trades up to that for the
  largest bore), else the row fails.

The solves and their instants come from the result: each start's ``finished_s``
(``starts_frame()``), each branch's refinement re-solve (run as soon as its start has
finished, in the starts' workers: ``docs/optimization.md`` section 8) and the winner's
tie-break (``OptimizationResult.solves``), on ``time.perf_counter`` (system-wide, so the forked
workers' instants compare with the driver's), plus the call's time outside the driver's
clock. Judged row: that time over differential evolution's (target at most 0.05x).
Informative row: isodesign's whole ``optimize`` call over the same (what the race measured
before); with the CPU times of both sides. The load average is reported (the machine is
shared).
"""

from __future__ import annotations

import math
import os
import time
import warnings

#: Target: isodesign's time to reach the optimum over differential evolution's.
TARGET_RATIO = 0.05
#: "Reached": within this of the global optimum (dB).
WITHIN_DB = 0.01
POPSIZE = 15


def _cpu_s() -> float:
    """CPU time of this process and of its finished children (user + system), s."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _isodesign(study, starts: int) -> tuple[float, float, float, object]:
    """Wall time, optimum, CPU time (this process and its forked workers) and result of
    ``isodesign.optimize`` with ``starts`` starts (the NLP's build, the starts in 2
    workers, peak refinement, tie-break and the NumPy re-check; not the fine-grid band
    responses of the result, which are no part of the search)."""
    import isodesign

    st = study.with_changes(solver={"starts": starts})
    c0 = _cpu_s()
    t0 = time.perf_counter()
    r = isodesign.optimize(st, analyze=False)
    return time.perf_counter() - t0, float(r.objective_value), _cpu_s() - c0, r


def _solves(r, offset_s: float) -> list[dict]:
    """isodesign's solves of the run ``r`` in finish order: each start's optimum
    (``StartRecord.finished_s``, where IPOPT stopped) and the winner's refinement and
    tie-break solves (``OptimizationResult.solves``), with ``at_s``: the instant, s from the
    ``optimize`` call (``offset_s``: the call's time outside the driver's clock, added)."""
    rows = [{"what": f"start {s.index}", "at_s": s.finished_s + offset_s,
             "solve_s": s.wall_s, "values": s.final, "nlp_feasible": s.feasible}
            for s in r.starts if math.isfinite(s.finished_s)]
    rows += [{"what": f"{x['stage']} (start {x['start']})", "at_s": x["finished_s"] + offset_s,
              "values": x["values"], "nlp_feasible": True} for x in r.solves]
    return sorted(rows, key=lambda x: x["at_s"])


def _judge(study, rows: list[dict]) -> list[dict]:
    """Each solve's design judged as the product judges its answer, after the race (not
    timed): the margin and every constraint row on the NumPy analysis (``evaluate_design``,
    the analysis differential evolution is judged on), feasible when no row is violated by
    more than :data:`~isodesign.optimization.solution.FEASIBILITY_TOLERANCE` and the
    continuous peak of |T| (between the grid's frequencies, ``continuous_peak_db``) is
    within ``PEAK_TOLERANCE_DB`` of the study's bound; then the incumbent after each solve:
    the best margin among the feasible designs finished so far."""
    from isodesign.optimization.grid import build_grid
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.recheck import evaluate_design
    from isodesign.optimization.refine import PEAK_TOLERANCE_DB, continuous_peak_db
    from isodesign.optimization.solution import FEASIBILITY_TOLERANCE

    prob = Problem(study)  # its peak grid and diaphragm, for the continuous peak
    grid = build_grid(study)  # the grid differential evolution is judged on
    kind = study.objective["kind"]
    bound = study.constraints.get("max_peak_transmissibility_db")
    best = float("-inf")
    for x in rows:
        e = evaluate_design(study, x["values"], grid=grid)
        x["margin_db"] = float(e["objectives"][kind])
        x["max_violation"] = float(e["max_violation"])
        pk = continuous_peak_db(prob, x["values"], e["sigma"], e["tube_rms"])[0]
        x["peak_db"] = pk
        x["feasible"] = bool(x["nlp_feasible"] and x["max_violation"] <= FEASIBILITY_TOLERANCE
                             and (bound is None or pk <= bound + PEAK_TOLERANCE_DB))
        if x["feasible"]:
            best = max(best, x["margin_db"])
        x["incumbent_db"] = best
    return rows


def _de(study, target_db: float, budget_s: float) -> dict:
    import numpy as np
    from scipy.optimize import NonlinearConstraint, differential_evolution

    from isodesign.optimization.grid import build_grid
    from isodesign.optimization.recheck import evaluate_design
    from isodesign.optimization.variables import log_scaling

    # the clock starts before the set-up (scaling, grid, the first evaluation for the rows'
    # bounds), as isodesign's starts at its optimize call (the NLP's build included)
    t0 = time.perf_counter()
    c0 = _cpu_s()
    sc = log_scaling(study)
    grid = build_grid(study)
    kind = study.objective["kind"]
    cache: dict = {}
    stats = {"evaluations": 0, "eval_s": 0.0}

    def ev(z):
        key = np.asarray(z, float).tobytes()
        if key not in cache:
            t = time.perf_counter()
            try:
                r = evaluate_design(study, sc.to_values(np.asarray(z, float)), grid=grid)
                cache[key] = (-float(r["objectives"][kind]),
                              np.concatenate([np.atleast_1d(c["value"])
                                              for c in r["constraints"].values()]))
            except Exception:  # a design the NumPy solvers do not close: infeasible
                cache[key] = (1e3, None)
            stats["evaluations"] += 1
            stats["eval_s"] += time.perf_counter() - t
        return cache[key]

    first = evaluate_design(study, sc.to_values(np.zeros(len(sc.names))), grid=grid)
    lo = np.concatenate([np.full(np.size(c["value"]), c["lower"])
                         for c in first["constraints"].values()])
    hi = np.concatenate([np.full(np.size(c["value"]), c["upper"])
                         for c in first["constraints"].values()])
    m = lo.size

    def fobj(zs):
        zs = np.asarray(zs, float)
        if zs.ndim == 1:
            return ev(zs)[0]
        return np.array([ev(zs[:, s])[0] for s in range(zs.shape[1])])

    def fcon(zs):
        zs = np.asarray(zs, float)
        if zs.ndim == 1:
            c = ev(zs)[1]
            return hi + 1e3 if c is None else c
        out = np.empty((m, zs.shape[1]))
        for s in range(zs.shape[1]):
            c = ev(zs[:, s])[1]
            out[:, s] = hi + 1e3 if c is None else c
        return out

    trace: list = []

    def callback(intermediate_result):
        # the best feasible design found so far (differential evolution's incumbent is
        # feasible whenever any member is)
        best = -float(intermediate_result.fun)
        feas = ev(intermediate_result.x)[1] is not None and bool(np.all(
            (ev(intermediate_result.x)[1] >= lo - 1e-9) & (ev(intermediate_result.x)[1]
                                                          <= hi + 1e-9)))
        el = time.perf_counter() - t0
        trace.append((el, best if feas else float("-inf"), _cpu_s() - c0))
        return (feas and best >= target_db - WITHIN_DB) or el > budget_s

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = differential_evolution(
            fobj, [(-1.0, 1.0)] * len(sc.names), constraints=NonlinearConstraint(fcon, lo, hi),
            vectorized=True, updating="deferred", polish=False, popsize=POPSIZE, rng=0,
            maxiter=100000, tol=0.0, atol=0.0, callback=callback)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - c0
    hit = next(((t, c) for t, v, c in trace if v >= target_db - WITHIN_DB), None)
    reached, reached_cpu = hit if hit is not None else (None, None)
    best = max((v for _, v, _ in trace), default=float("-inf"))
    return {"wall_s": wall, "reached_s": reached, "cpu_s": cpu, "reached_cpu_s": reached_cpu,
            "variables": len(sc.names), "best_db": best,
            "generations": len(trace), "evaluations": stats["evaluations"],
            "eval_ms": 1e3 * stats["eval_s"] / max(stats["evaluations"], 1),
            "values": sc.to_values(res.x), "message": str(res.message)}


def run() -> list[dict]:
    """The race's rows: the judged time-to-reach ratio, the whole call's ratio (informative)."""
    # the tie-break's tolerance (dB): the design the product returns may trade this much of
    # the margin for the largest capillary bore
    from isodesign.optimization.refine import FLAT_TOLERANCE_DB
    from isodesign.optimization.study import vertical_study

    warnings.simplefilter("ignore")
    budget = float(os.environ.get("ISODESIGN_BENCH_RACE_BUDGET_S", "900"))
    # models.distortion = false: the question of the race's earlier figures (the
    # distortion's own cost is bench_distortion.py's)
    study = vertical_study().with_changes({"models.distortion": False})
    load0 = os.getloadavg()[0]
    _isodesign(study, 1)  # warm-up: imports, CasADi's first build
    n = study.solver["starts"]
    t_iso, j_iso, c_iso, res = _isodesign(study, n)
    t_one, j_one, _, _ = _isodesign(study, 1)
    de = _de(study, j_iso, budget)
    load1 = os.getloadavg()[0]
    j_star = max(j_iso, de["best_db"])
    iso_ok = j_iso >= j_star - WITHIN_DB
    one_ok = j_one >= j_star - WITHIN_DB
    # isodesign's time to reach, measured as differential evolution's: the first instant a
    # solve of its run has finished with a feasible design within WITHIN_DB of the optimum
    # that is the incumbent (the best feasible design finished by then)
    rows = _judge(study, _solves(res, max(t_iso - res.wall_s, 0.0)))
    hit = next((x for x in rows if x["feasible"] and x["margin_db"] == x["incumbent_db"]
                and x["margin_db"] >= j_star - WITHIN_DB), None)
    # what the product returned is that incumbent or one as good: within the tie-break's
    # tolerance below it (the tie-break trades up to FLAT_TOLERANCE_DB for the largest bore)
    as_good = hit is not None and j_iso >= hit["margin_db"] - FLAT_TOLERANCE_DB - 1e-6
    t_reach = hit["at_s"] if hit is not None else t_iso
    timeline = "; ".join(
        f"{x['what']} {x['at_s']:.2f} s {x['margin_db']:.3f} dB "
        + ("feasible" if x["feasible"] else f"infeasible (peak {x['peak_db']:.3f} dB, "
           f"violation {x['max_violation']:.1g})") for x in rows)
    # the profile of the time to reach: before the first solve's IPOPT began (the NLP's
    # build, the fork, the first initial guess), the starts, what followed them
    starts = [x for x in rows if x["what"].startswith("start ")]
    before = starts[0]["at_s"] - starts[0]["solve_s"] if starts else float("nan")
    last = starts[-1]["at_s"] if starts else float("nan")
    first = starts[0]["at_s"] if starts else float("nan")
    n_by = sum(1 for x in starts if x["at_s"] <= t_reach)
    profile = (f"profile of the {t_reach:.2f} s: {before:.2f} s before the first start's IPOPT "
               f"began (the NLP's build, the fork, an initial guess), the first start "
               f"finished at {first:.2f} s, {n_by} of the {len(starts)} starts by the "
               f"incumbent (the branches' refinements run beside the starts on the 2 "
               f"workers), the last start at {last:.2f} s")
    if de["reached_s"] is not None:
        de_t, bound = de["reached_s"], ""
    else:
        de_t, bound = de["wall_s"], (f"differential evolution did not reach it in "
                                     f"{de['wall_s']:.0f} s (the budget): the ratio is at "
                                     f"most this; ")
    ratio, whole = t_reach / de_t, t_iso / de_t
    cpu_ratio = c_iso / (de["reached_cpu_s"] or de["cpu_s"])
    de_note = (f"differential evolution (pop {POPSIZE} x {de['variables']} variables, "
               f"vectorized, the NLP's constraint rows as one NonlinearConstraint on the NumPy "
               f"analysis, {de['eval_ms']:.0f} ms per evaluation) reached it at "
               f"{de_t:.1f} s (best {de['best_db']:.3f} dB after {de['generations']} "
               f"generations, {de['evaluations']} evaluations; its clock from the start of its "
               f"set-up); {bound}global optimum {j_star:.3f} dB")
    load = f"load average {load0:.1f} -> {load1:.1f} on 2 cores"
    reached = (f"isodesign reached it at {t_reach:.2f} s ({hit['what']}, "
               f"{hit['margin_db']:.3f} dB, feasible, the incumbent; the product returned "
               f"{j_iso:.3f} dB, as good within the tie-break's {FLAT_TOLERANCE_DB} dB: "
               f"{as_good})" if hit is not None else
               "isodesign's run holds no feasible incumbent within "
               f"{WITHIN_DB} dB: its whole call counted")
    return [{
        "name": "race: time to reach the global optimum (0.01 dB), isodesign vs SciPy "
                "differential_evolution",
        "target": f"<= {TARGET_RATIO}", "median": ratio, "unit": "x",
        "ratio": ratio / TARGET_RATIO,
        "passed": bool(iso_ok and as_good and ratio <= TARGET_RATIO), "repeats": 1,
        "notes": f"vertical study (worst-band margin), isodesign.optimize ({n} starts, the "
                 f"study's, 2 workers, analyze=False): {reached}; its solves (finish instant, "
                 f"margin on the NumPy analysis, feasibility with the continuous peak): "
                 f"{timeline}; {profile}; {de_note}; {load}"}, {
        "name": "race (informative): isodesign's whole optimize call vs differential "
                "evolution's time to reach",
        "target": "", "median": whole, "unit": "x",
        "repeats": 1,
        "notes": f"isodesign.optimize {t_iso:.2f} s in all (build, {n} starts on 2 forked "
                 f"workers, branch refinement, tie-break, re-check) to {j_iso:.3f} dB, within "
                 f"{WITHIN_DB} dB: {iso_ok} (with 1 start: {t_one:.1f} s to {j_one:.3f} dB, "
                 f"within {WITHIN_DB} dB: {one_ok}); CPU time (user + system) isodesign "
                 f"{c_iso:.1f} s (its process and 2 forked workers), differential evolution "
                 f"{de['reached_cpu_s'] or de['cpu_s']:.1f} s (one process): CPU-time ratio "
                 f"{cpu_ratio:.3f}; {load}"}]


if __name__ == "__main__":
    for row in run():
        print(row)
