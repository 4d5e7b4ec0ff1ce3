"""The driver: :func:`optimize` a study (multi-start, refinement, re-check, analysis).

Trust
-----
* Multi-start: space-filling starts (Latin hypercube in the scaled log space)
  plus the study's start; the report says how many reached the best design.
* The winning start is chosen after the peak refinement of the best start of each
  distinct branch; the winner alone is tie-broken (:func:`.refine.refine_branches`).
* Re-check: the optimum is re-evaluated with the NumPy analysis path (its own
  solvers for U and sigma); objective and constraints must agree to 1e-6
  relative (an objective in dB to 1e-6 dB), else
  :class:`~isodesign.errors.SolverError` (:mod:`.recheck`).
* Failure is explicit: infeasible, iteration limit and restoration failure are
  reported with IPOPT's status, the most violated constraints and the best
  point found.
"""

from __future__ import annotations

import math
import time

from isodesign.errors import InputError, SolverError
from isodesign.optimization.analyze import vertical_band_response
from isodesign.optimization.constraints import constraint_reports
from isodesign.optimization.early_refine import select_branch, starts_and_branches
from isodesign.optimization.multistart import run_starts, start_points
from isodesign.optimization.nlp import CONSTRAINT_VIOLATION_TOL, IPOPT_OPTIONS
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.problem import Problem
from isodesign.optimization.recheck import RECHECK_RTOL, recheck_design
from isodesign.optimization.refine import (
    FLAT_TOLERANCE_DB,
    FLAT_TOLERANCE_REL,
    flat_tolerance,
    refine_branches,
)
from isodesign.optimization.result import OptimizationResult, StartRecord
from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
from isodesign.optimization.study import Study

__all__ = ["PEAK_VIOLATION", "optimize", "optimize_vertical", "solver_settings"]

#: Name of the violation a feasible result carries when the peak refinement ended with
#: the continuous peak of |T| above its limit (amount: the excess, dB).
PEAK_VIOLATION = "continuous_peak_transmissibility"


def optimize_vertical(study, *, progress=None, problem: Problem | None = None,
                      analyze: bool = True, nominal: bool = False,
                      extra_starts: tuple = (), own_starts: bool = True) -> OptimizationResult:
    """The vertical nominal optimum: multi-start IPOPT, tie-break, peak refinement, re-check.

    The internal solve of the one-degree-of-freedom payload. The public entry point is
    :func:`isodesign.optimize` (:mod:`.dispatch`), which sends a study with a ``[table]``
    or ``[scenarios]`` to the optimizer of its question; this one refuses a table study,
    and a study with ``[scenarios]`` unless ``nominal`` says that its nominal optimum is
    what is wanted (the robust exchange's starting point).

    Parameters
    ----------
    study : Study
        Without ``[table]``.
    progress : callable or None
        ``progress(done, total, solution)`` after each start (for a progress bar).
    problem : Problem, optional
        A prebuilt NLP of this study whose first objective is the study's (a Pareto
        study passes its two-objective NLP); built here by default.
    analyze : bool
        Run the fine-grid band responses of the optimum and of the start (default).
    nominal : bool
        A study with ``[scenarios]``: optimize its nominal scenario (default: refused).
    extra_starts : tuple of dict
        Further starts (design-variable values, SI) after the study's own: a sweep's
        continuation passes its finished neighbours' optima (``docs/sweep.md``).
    own_starts : bool
        Solve the study's own starts (default). False (with ``extra_starts``): solve the
        extra starts alone, the study's start still the result's start design (a sweep's
        continuation between its checkpoints, ``docs/sweep.md`` section 7).

    Returns
    -------
    OptimizationResult
        Check ``.feasible`` (or call ``.raise_for_status()``). A feasible result
        whose continuous peak of |T| is still above its limit after the last
        refinement round carries the excess (dB) in ``violations``
        (:data:`PEAK_VIOLATION`) and is not a ``success``. Raises
        :class:`SolverError` when the NLP's optimum and the NumPy analysis
        disagree (a bug, never a silently wrong design).
    """
    if not isinstance(study, Study):
        raise InputError(f"study: expected a Study (load_study(path) or default_study()), "
                         f"got {type(study).__name__} {study!r:.40}")
    if getattr(study, "table", None) is not None:
        raise InputError("[table]: the vertical optimizer does not answer a table study; "
                         "use isodesign.optimize (six degrees of freedom)")
    if getattr(study, "scenarios", None) is not None and not nominal:
        raise InputError("[scenarios]: the vertical nominal optimizer does not answer a robust "
                         "study; use isodesign.optimize (robust design)")
    # the instants of the result (StartRecord.finished_s, solves) are time.perf_counter()
    # readings less this one: on Linux perf_counter is CLOCK_MONOTONIC, one clock for the
    # whole system, so the instants stamped in the forked workers (Solution.finished_at)
    # compare with the driver's
    t_all = time.perf_counter()
    prob = problem if problem is not None else Problem(study)
    own = start_points(study, prob.scaling)
    start0 = own[0]  # the study's start: the result's start design either way
    if not own_starts and not extra_starts:
        raise InputError("own_starts=False needs extra_starts")
    starts = (own if own_starts else []) + [dict(v) for v in extra_starts]
    tol_j = flat_tolerance(prob.objective)
    # each new branch refined as soon as its start finishes, in the starts' pool
    # (docs/optimization.md section 8); else the starts, then refine_branches
    piped = starts_and_branches(study, prob, starts, tol_j, progress=progress)
    if piped is None:
        results = run_starts(prob, starts, workers=study.solver.get("workers"),
                             progress=progress)
        early = None
    else:
        results, early = piped
    records, sols = _start_records(prob, starts, results, t_all)
    good = {i: sols[i] for i, r in enumerate(records) if r.feasible and sols[i] is not None}
    if not good:
        return _infeasible_result(study, prob, start0, records, sols, t_all)
    obj = OBJECTIVES[prob.objective]
    if early is None:
        win = refine_branches(study, prob, good, tol_j)
    else:
        win = select_branch(study, prob, good, early, tol_j)
    j_win = good[win.start].objective
    n_best = sum(1 for s in good.values() if abs(s.objective - j_win) <= tol_j)
    final = win.final
    d = study.design_at(final.values)
    checked = recheck_design(prob, final, d)  # every row re-checked (recheck.recheck_rows)
    diff = checked.max_difference
    analysis, start_analysis = _analyses(study, prob, d, start0) if analyze else (None, None)
    j0 = None
    try:
        x00 = prob.initial_guess(start0)
        j0 = obj.to_natural(float(prob.objective_values(x00)[0]))
    except SolverError:
        pass
    # a continuous peak still above its limit after the last refinement round: the
    # design meets the bound on the NLP's grid only, which the result must say
    violations = ()
    if win.peak.get("met") is False:
        violations = ((PEAK_VIOLATION, win.peak["excess_db"]),)
    violations += checked.violations  # rows whose NumPy value breaks a bound: no PASS
    return OptimizationResult(
        study=study, objective=prob.objective, feasible=True, status=final.status, design=d,
        values=final.values, objective_value=obj.to_natural(final.objective),
        start_values=start0, start_objective=j0,
        constraints=tuple(constraint_reports(prob.con_rows, final.g)), starts=tuple(records),
        n_reached_best=n_best, violations=violations, flat_direction=win.flat,
        recheck_max_rel_diff=diff, analysis=analysis, start_analysis=start_analysis,
        peak=win.peak, wall_s=time.perf_counter() - t_all,
        settings={**solver_settings(study), **({"distortion_outer_rounds": final.outer_rounds}
                                                if final.outer_rounds else {})},
        branches=tuple((i, obj.to_natural(j)) for i, j in win.branches),
        hessian_info=prob.hessian_info, solves=_solves(win, obj, t_all, early),
    )


def _solves(win, obj, t_all, early=None) -> tuple[dict, ...]:
    """The refinement and tie-break solves with their finish instants
    (:attr:`.result.OptimizationResult.solves`): every branch's refinement when they were
    pipelined with the starts (``early``: start -> (Refined or error, objectives)), in
    finish order, else the winner's; then the winner's tie-break."""
    out = []
    for i, (r, _) in sorted((early or {}).items()):
        if isinstance(r, SolverError) or not r.peak.get("rounds") or r.best is win.best:
            continue
        out.append({"stage": "refinement", "start": i,
                    "finished_s": r.best.finished_at - t_all,
                    "objective": obj.to_natural(r.best.objective),
                    "values": dict(r.best.values)})
    if win.peak.get("rounds"):
        out.append({"stage": "refinement", "start": win.start,
                    "finished_s": win.best.finished_at - t_all,
                    "objective": obj.to_natural(win.best.objective),
                    "values": dict(win.best.values)})
    if win.final is not win.best:
        out.append({"stage": "tie-break", "start": win.start,
                    "finished_s": win.final.finished_at - t_all,
                    "objective": obj.to_natural(win.final.objective),
                    "values": dict(win.final.values)})
    return tuple(sorted(out, key=lambda x: x["finished_s"]))


#: The former name of :func:`optimize_vertical` (same guards: a table or robust study is
#: refused, never answered with the vertical nominal optimum).
optimize = optimize_vertical


def _start_records(prob, starts, results, t_all: float = math.nan
                   ) -> tuple[list[StartRecord], list]:
    """One record per start; the solutions (None where the initial guess failed).
    ``t_all``: the optimize call's start on ``time.perf_counter`` (``finished_s``)."""
    records: list[StartRecord] = []
    sols = []
    to_nat = OBJECTIVES[prob.objective].to_natural
    for i, (vals, out) in enumerate(zip(starts, results, strict=True)):
        if isinstance(out, str):
            records.append(StartRecord(i, vals, out, False, False,
                                       0, 0.0, math.nan, math.inf, {}))
            sols.append(None)
            continue
        records.append(StartRecord(i, vals, out.status, out.success, out.feasible,
                                   out.iterations, out.wall_s, to_nat(out.objective),
                                   out.max_violation, out.values,
                                   finished_s=out.finished_at - t_all))
        sols.append(out)
    return records, sols


def _infeasible_result(study, prob, start_vals, records, sols, t_all) -> OptimizationResult:
    """The best point found when no start is feasible (least violation)."""
    cand = [i for i, s in enumerate(sols) if s is not None]
    if not cand:
        raise SolverError("no start could be initialized (see the start records)")
    # least violation, preferring starts whose implicit equations are solved (a start
    # stopped by the iteration limit may leave them unsolved: not a physical point)
    ib = min(cand, key=lambda i: (sols[i].equation_residual > FEASIBILITY_TOLERANCE,
                                  sols[i].max_violation))
    sol = sols[ib]
    return OptimizationResult(
        study=study, objective=prob.objective, feasible=False, status=sol.status,
        design=study.design_at(sol.values), values=sol.values,
        objective_value=OBJECTIVES[prob.objective].to_natural(sol.objective),
        start_values=start_vals, start_objective=None,
        constraints=tuple(constraint_reports(prob.con_rows, sol.g)), starts=tuple(records),
        n_reached_best=0, violations=sol.violated(),
        flat_direction=None, recheck_max_rel_diff=None,
        wall_s=time.perf_counter() - t_all, settings=solver_settings(study),
        hessian_info=prob.hessian_info,
    )


def _analyses(study, prob, d, start_vals):
    """Fine-grid band responses of the optimum and of the start design, through the study's
    symmetric table (:func:`~.analyze.vertical_band_response`, :func:`~.analyze.analyze`'s
    answer for a study without ``[table]``)."""
    kw = {"flow": study.models["flow"], "amplitude_mode": study.models["amplitude_mode"],
          "diaphragm": prob.dia, "random_method": study.models["random_method"],
          "distortion": bool(study.models.get("distortion", False))}
    analysis = vertical_band_response(d, study.payload, study.floor, study.target,
                                      bands=study.bands, derive_pressure=False, warn=False, **kw)
    start_analysis = vertical_band_response(study.design_at(start_vals), study.payload,
                                            study.floor, study.target, bands=study.bands,
                                            derive_pressure=False, warn=False, **kw)
    return analysis, start_analysis


def solver_settings(study) -> dict:
    """The solver settings a run records.

    Parameters
    ----------
    study : Study
        Its ``solver`` table gives the iteration limit, tolerance, number of
        starts and seed.

    Returns
    -------
    dict
        ``solver`` (a description), ``options`` (IPOPT's ``max_iter``, ``tol``,
        ``constr_viol_tol`` and the fixed :data:`~.nlp.IPOPT_OPTIONS`, without
        the ``ipopt.`` prefix), ``starts``, ``seed``, ``recheck_rtol`` (agreement
        required of the NumPy re-check: relative, absolute in dB for a dB
        objective) and ``flat_tolerance_db`` / ``flat_tolerance_rel`` (the
        tie-break's objective tolerances). Written to
        ``record.json`` so that a run can be replayed.
    """
    return {
        "solver": "ipopt (CasADi nlpsol; the Hessian by hessian.hessian_choice)",
        "options": {"max_iter": study.solver["max_iter"], "tol": study.solver["tol"],
                    "constr_viol_tol": CONSTRAINT_VIOLATION_TOL,
                    **{k.removeprefix("ipopt."): v for k, v in IPOPT_OPTIONS.items()}},
        "starts": study.solver["starts"],
        "seed": study.solver["seed"],
        "recheck_rtol": RECHECK_RTOL,
        "flat_tolerance_db": FLAT_TOLERANCE_DB,
        "flat_tolerance_rel": FLAT_TOLERANCE_REL,
    }
