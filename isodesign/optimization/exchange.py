"""The exchange method of robust design: :func:`robust_optimize`.

The scenario box is semi-infinite (every payload, every drill size in the tolerance):
like the peak refinement (:mod:`.refine`), the robust NLP is solved on a finite set of
scenarios and the box is searched for the scenario that hurts most at the new design:

1. solve the stacked NLP (:class:`.robust.RobustProblem`) on the current scenarios from
   the previous design, the nominal optimum and the best robust design so far (the best
   feasible solution is kept); place movable peak frequencies where a
   scenario's continuous peak of |T| exceeds its bound (as :func:`.refine.refine_peak`);
2. search the box with the NumPy analysis (:func:`.recheck.evaluate_design` on
   :class:`.uncertainty.ScenarioStudy`): every corner (every value of a listed
   parameter), ``search_samples`` uniform samples and the centre are scored, then the
   three best are refined by a bounded local maximization (L-BFGS-B) of the quantity
   that scored them: the objective's shortfall below the stated worst case, a
   constraint's worst row or the continuous peak of |T|;
3. add the worst scenario found; stop when nothing in the box exceeds the tolerances
   (objective ``tolerance_db``, constraints :data:`CONSTRAINT_TOLERANCE` in the NLP's
   log units, continuous peak :data:`.refine.PEAK_TOLERANCE_DB`) or after ``max_rounds``.

The worst case of a tolerance box is not always a corner for this nonlinear model
(the local maximization finds interior maxima), and a worst case for the objective is
often not the worst case for a constraint: each is searched.
"""

from __future__ import annotations

import math
import time

import numpy as np

from isodesign.errors import InputError
from isodesign.optimization.driver import optimize_vertical
from isodesign.optimization.grid import build_grid
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.problem import PEAK_ROUNDS
from isodesign.optimization.refine import (
    FLAT_TOLERANCE_REL,
    PEAK_TOLERANCE_DB,
    continuous_peak_db,
    peak_slots,
)
from isodesign.optimization.robust import RobustBuilds, add_scenarios, best_solve
from isodesign.optimization.robust_result import (
    RobustResult,
    scenario_constraints,
    scenario_rows,
)
from isodesign.optimization.scenario_check import scenario_check

__all__ = ["CONSTRAINT_TOLERANCE", "robust_optimize", "scenario_check", "worst_case"]

#: A constraint may exceed its bound by this much (NLP units: the log of the quantity)
#: anywhere in the box when the exchange stops.
CONSTRAINT_TOLERANCE = 1e-6
_LN10_DB = math.log(10.0) / 10.0


def _score(chk: dict, tol_obj: float) -> tuple[float, str]:
    """(largest excess over its tolerance, which quantity) of a scenario check."""
    items = [(chk["gap"] / tol_obj, "objective")] if chk["gap"] is not None else []
    items += [(v / CONSTRAINT_TOLERANCE, f"constraint:{n}") for n, v in chk["violations"].items()
              if n != "peak_transmissibility" or chk["peak_excess_db"] is None]
    if chk["peak_excess_db"] is not None:
        items.append((chk["peak_excess_db"] / PEAK_TOLERANCE_DB, "peak"))
    return max(items)


def _quantity(chk: dict, which: str) -> float:
    if which == "objective":
        return chk["gap"]
    if which == "peak":
        return chk["peak_excess_db"]
    return chk["violations"][which.split(":", 1)[1]]


def worst_case(study, values: dict, reference: float, *, grid=None, samples: int = 16,
               seed: int = 0, refine: int = 3) -> dict:
    """Search the scenario box for the worst scenario at a drawn design.

    Parameters
    ----------
    study : Study
        With ``scenarios``.
    values : dict
        The drawn design (SI).
    reference : float
        The stated worst-case J (the objective's shortfall is measured from it).
    grid : Grid, optional
    samples : int
        Uniform samples scored besides the corners and the centre; 0: the corners and the
        centre alone, without the local maximization (``scenarios.search_samples = 0``, as
        the table's search, :func:`.table_search.search_box`).
    seed : int
    refine : int
        How many of the best-scored candidates are refined by local maximization.

    Returns
    -------
    dict
        ``theta`` (the worst scenario), ``score`` (its largest excess over the
        tolerance: above 1 means it must be added), ``which`` (the quantity),
        ``check`` (:func:`scenario_check` there) and ``evaluations``.
    """
    from scipy.optimize import minimize

    space = study.scenarios
    grid = grid or build_grid(study)
    kind = study.objective["kind"]
    tol_obj = (space.settings["tolerance_db"] if OBJECTIVES[kind].db else FLAT_TOLERANCE_REL)
    rng = np.random.default_rng(seed)
    cands = np.vstack([space.corners(rng=rng), space.center()[None, :],
                       space.box_samples(samples, rng)])
    if samples == 0:  # search_samples = 0: the corners and the centre alone (both bodies)
        refine = 0
    n_eval = 0
    scored = []
    for th in cands:
        chk = scenario_check(study, values, th, grid=grid, reference=reference)
        n_eval += 1
        s, which = _score(chk, tol_obj)
        scored.append((s, which, th, chk))
    scored.sort(key=lambda r: -r[0])
    best = scored[0]
    lo, hi = space.lower(), space.upper()
    cont = np.array([not p.discrete for p in space.parameters])
    width = np.where(hi > lo, hi - lo, 1.0)
    seen = []
    for _s0, which, th0, _ in scored[: max(refine * 3, refine)]:
        if len(seen) >= refine or not cont.any():
            break
        key = (which, tuple(np.round((th0 - lo) / width, 2)))
        if key in seen:
            continue
        seen.append(key)

        def f(u, which=which, th0=th0):
            nonlocal n_eval
            th = th0.copy()
            th[cont] = lo[cont] + u * width[cont]
            n_eval += 1
            return -_quantity(scenario_check(study, values, th, grid=grid, reference=reference),
                              which)

        u0 = (th0[cont] - lo[cont]) / width[cont]
        try:
            r = minimize(f, u0, method="L-BFGS-B", bounds=[(0.0, 1.0)] * int(cont.sum()),
                         options={"maxiter": 30, "eps": 1e-6})
        except (InputError, FloatingPointError, ValueError):
            continue
        th = th0.copy()
        th[cont] = lo[cont] + np.clip(r.x, 0.0, 1.0) * width[cont]
        chk = scenario_check(study, values, th, grid=grid, reference=reference)
        s, w2 = _score(chk, tol_obj)
        if s > best[0]:
            best = (s, w2, th, chk)
    return {"theta": best[2], "score": best[0], "which": best[1], "check": best[3],
            "evaluations": n_eval}


def robust_optimize(study, *, nominal=None, progress=None, builds=None, extra_starts=(),
                    seed_scenarios=(), seed_peaks_hz=()):
    """Robust optimum of a study with ``[scenarios]`` (see the module docstring).

    Parameters
    ----------
    study : Study
        A study with ``scenarios`` (:class:`~.uncertainty.UncertaintySpace`).
    nominal : OptimizationResult, optional
        The nominal optimum (run here by default: :func:`.driver.optimize_vertical` of the
        study's nominal scenario); the exchange starts from it.
    progress : callable, optional
        ``progress(message)`` after each round.
    builds : RobustBuilds, optional
        Built scenario blocks and stacked NLPs to reuse (a sweep worker's,
        :class:`.robust.RobustBuilds`: a study whose ``[scenarios]`` ranges alone differ
        from one solved before builds nothing); default: built here for this study.
    extra_starts : sequence of dict, optional
        Further designs (SI values by name) the first round's solve starts from, besides
        the nominal optimum (a sweep point's finished neighbours' robust optima).
    seed_scenarios : sequence of array, optional
        Scenarios (``theta`` vectors in the study's box) in the set from the first round,
        besides the box's centre and the first search's worst case (a sweep point's
        neighbours' active scenarios, :func:`isodesign.sweeps.continuation.robust_seeds`).
        The answer is checked by the same search of the box as without them.
    seed_peaks_hz : sequence of float or None, optional
        With ``seed_scenarios``, one each: the frequency (Hz) where that scenario's
        continuous peak |T| is expected (its neighbour's, scaled to the point's mass). Its
        last refinement round's movable peak frequencies are placed there before the first
        solve, as the vertical sweep point does (docs/sweep.md, section 7); None: none.

    Returns
    -------
    RobustResult
    """
    if study.scenarios is None:
        raise InputError("robust_optimize: the study has no [scenarios] table")
    if getattr(study, "table", None) is not None:  # never the vertical answer to a table
        raise InputError("[table]: robust_optimize is the vertical robust design; a table "
                         "study's is isodesign.optimize (robust_optimize_table)")
    t_all = time.perf_counter()
    space = study.scenarios
    settings = space.settings
    if nominal is None:
        nominal = optimize_vertical(study, nominal=True)
    if not nominal.feasible:
        return RobustResult.infeasible_nominal(study, nominal, time.perf_counter() - t_all)
    if builds is None:
        builds = RobustBuilds()
    n_built = (builds.blocks_built, builds.stacks_built)
    block = builds.block(study)
    grid = build_grid(study)
    values = dict(nominal.values)
    kind = block.objective
    j_nom = OBJECTIVES[kind].from_natural(nominal.objective_value)
    first = worst_case(study, values, j_nom, grid=grid, samples=settings["search_samples"],
                       seed=settings["seed"])
    thetas = [space.center()]
    if first["score"] > 1.0 and not np.allclose(first["theta"], thetas[0]):
        thetas.append(first["theta"])
    seeded = add_scenarios(thetas, seed_scenarios)
    best_values = dict(values)
    slots: list = [block.slot_hz.copy() for _ in thetas]
    slot_rounds = [0 for _ in thetas]
    _preset_slots(study, block, thetas, slots, seed_scenarios, seed_peaks_hz)
    peaks_hz: list = [None for _ in thetas]  # each scenario's continuous peak, last round
    rounds = []
    sol = prob = None
    converged = False
    last = first
    for r in range(settings["max_rounds"] + 1):
        t0 = time.perf_counter()
        # a round that adds no scenario (peak slots moved) solves the NLP it has: the
        # scenarios and the slots are parameters
        # one stacked NLP per number of scenarios
        prob, new_nlp = builds.stacked(block, thetas)
        prob.thetas = [np.asarray(t, float) for t in thetas]
        prob.slots = [s.copy() for s in slots]
        sol = best_solve(prob, [values, nominal.values, best_values,
                                *(extra_starts if r == 0 else ())], study)
        if sol.feasible:
            best_values = dict(sol.values)
        if not sol.feasible:
            k, cname, amount = sol.worst_scenario()
            return RobustResult.infeasible(study, nominal, prob, sol, k, cname, amount, rounds,
                                           time.perf_counter() - t_all)
        values = dict(sol.values)
        moved = _place_peak_slots(study, block, prob, sol, grid, slots, slot_rounds,
                                  peaks_hz)
        last = worst_case(study, values, sol.objective, grid=grid,
                          samples=settings["search_samples"], seed=settings["seed"] + r + 1)
        rounds.append({"round": r, "scenarios": len(thetas), "objective":
                       OBJECTIVES[kind].to_natural(sol.objective), "iterations": sol.iterations,
                       "solve_s": sol.wall_s, "worst_score": last["score"],
                       "worst_quantity": last["which"], "peak_slots_moved": moved,
                       "search_evaluations": last["evaluations"], "nlp_built": new_nlp,
                       "wall_s": time.perf_counter() - t0})
        if progress:
            progress(rounds[-1])
        if last["score"] <= 1.0 and not moved:
            converged = True
            break
        if r == settings["max_rounds"]:
            break
        if last["score"] > 1.0 and not any(
                np.allclose(last["theta"], t, rtol=1e-9, atol=1e-12) for t in thetas):
            thetas.append(np.asarray(last["theta"], float))
            slots.append(block.slot_hz.copy())
            slot_rounds.append(0)
            peaks_hz.append(None)
    rows = scenario_rows(study, prob, sol, grid, nominal.values)
    return RobustResult(
        study=study, nominal=nominal, values=values, design=study.design_at(values),
        objective=kind, objective_value=OBJECTIVES[kind].to_natural(sol.objective),
        feasible=True, converged=converged, status=sol.status, rounds=tuple(rounds),
        scenarios=tuple(rows), first_search=first, last_search=last, problem=prob,
        solution=sol, wall_s=time.perf_counter() - t_all,
        constraints=scenario_constraints(study, prob, sol),
        extra={"nlp_builds": {"scenario_blocks": builds.blocks_built - n_built[0],
                              "stacks": builds.stacks_built - n_built[1]},
               "continuation": {"extra_starts": len(extra_starts), "seeded_scenarios": seeded,
                                "peak_hz": peaks_hz}})


def _preset_slots(study, block, thetas, slots, seeds, peaks_hz) -> None:
    """The last refinement round's movable peak frequencies of each seeded scenario placed
    at its expected continuous peak (``slots`` changed in place; nothing without a peak
    bound)."""
    if study.constraints.get("max_peak_transmissibility_db") is None:
        return
    for th, f in zip(seeds, peaks_hz, strict=False):
        k = next((i for i, t in enumerate(thetas)
                  if np.allclose(np.asarray(th, float), t, rtol=1e-9, atol=1e-12)), None)
        if k is None or f is None or not np.isfinite(f) or f <= 0:
            continue
        block.select(thetas[k], slots[k])
        peak_slots(block, PEAK_ROUNDS - 1, float(f))
        slots[k] = block.slot_hz.copy()


def _place_peak_slots(study, block, prob, sol, grid, slots, slot_rounds, peaks_hz) -> bool:
    """Peak refinement per scenario: movable frequencies near a continuous peak above
    its bound (at most :data:`.problem.PEAK_ROUNDS` rounds per scenario); each
    scenario's continuous peak frequency into ``peaks_hz``."""
    bound = study.constraints.get("max_peak_transmissibility_db")
    if bound is None:
        return False
    moved = False
    for k, th in enumerate(prob.thetas):
        block.select(th, slots[k])
        xk = prob.block_x(sol, k)
        peak, f_pk = continuous_peak_db(block, sol.values, block.sigma(xk), block.tube_rms(xk))
        peaks_hz[k] = float(f_pk)
        if peak > bound + PEAK_TOLERANCE_DB and slot_rounds[k] < PEAK_ROUNDS:
            peak_slots(block, slot_rounds[k], f_pk)
            slots[k] = block.slot_hz.copy()
            slot_rounds[k] += 1
            moved = True
    return moved
