"""Optimize a table study in three axes: multi-start, mode refresh, re-check, analysis.

:func:`optimize_table` runs the :class:`~isodesign.optimization.table_problem.TableProblem` from the
study's start and Latin-hypercube starts (the vertical optimizer's
:func:`~isodesign.optimization.multistart.run_starts`; with free per-group springs staged,
:func:`_tied_starts`: the starts of the tied study, then the full NLP from its best
optimum, docs/table.md section 13), keeps the best feasible start, and then:

1. **Mode refresh.** The damping constraint holds on the modes below 5 Hz with shapes and
   frequencies frozen at the last nonlinear-eigenproblem solution. The modes are solved
   again at the optimum (springs linearized at its closure); while one of them misses the
   damping bound and the frozen shapes or frequencies moved (shape correlation < 0.999 or
   frequency by > 0.1 %), the NLP is solved again from the optimum with the new modes (at
   most three rounds).
2. **Continuous peak refinement.** The peak of ``|T_p,aa|`` of every point and axis is
   measured between the NLP's frequencies, on a fine grid from half the lowest modal
   frequency (:mod:`isodesign.table.peaks`); a peak above ``max_peak_transmissibility_db``
   puts movable frequencies around it into the NLP, which is solved again (rounds while its
   movable frequencies last, at most :data:`PEAK_ROUNDS_CAP_FACTOR` x
   :data:`~isodesign.optimization.table_problem.TABLE_PEAK_ROUNDS`, the mode refresh repeated
   after each). A peak still above the bound is a violation (:data:`PEAK_VIOLATION`): the
   result is not a success and its verdict is no PASS.
   **Leveling loop rounds.** With a bound on the leveling loop's gain margin, while the
   exact margin (python-control) misses it, or the frozen-pole rows bind while the margin
   exceeds the bound, the loop's poles are frozen at the current design and the NLP is
   solved again (at most :data:`LOOP_ROUNDS`). After the last round a gain or phase margin
   below its bound is a violation (:data:`LEVELING_VIOLATIONS`).
3. **Re-check** (:func:`recheck_table`). The NumPy closure
   (:func:`~isodesign.table.response.solve_table_closure`) at the optimum on the NLP's grid
   must give the NLP's stroke RMS values to 1e-6 and its worst margin to 1e-6 dB, and
   every constraint row the registry re-checks its NLP value to 1e-6
   (:func:`~isodesign.optimization.recheck.recheck_rows`, the vertical driver's one
   re-check), else :class:`~isodesign.errors.SolverError`; a row whose NumPy value breaks
   its bound by more than :data:`~isodesign.optimization.recheck.RECHECK_VIOLATION_TOL` is
   a violation (no PASS).
4. **Constraint table.** The constraints at the returned design with margins and binding
   flags (:mod:`isodesign.optimization.table_constraints`), for the sentence naming what stopped it
   (:mod:`isodesign.optimization.explain`).
5. **Analysis.** The band response on the fine grid (50 points per band), the modes and
   the rocking stability of the optimum and of the start.

Derivatives: the gradient and the constraint Jacobian are exact (CasADi AD); the Hessian of
the Lagrangian is chosen by :func:`isodesign.optimization.hessian.hessian_choice` (for a
table: IPOPT's limited-memory quasi-Newton approximation, :data:`HESSIAN`; the exact Hessian
through the mapped 6x6 solve gives the same optimum at about three times the cost,
docs/optimization.md, "The Hessian"), and stated in the result.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.optimization.distortion_rows import capped
from isodesign.optimization.multistart import run_starts, start_points
from isodesign.optimization.peak_rounds import (  # noqa: F401  (re-exported)
    MAX_PEAK_ROUNDS,
    PEAK_ROUNDS_CAP_FACTOR,
    solve_round,
)
from isodesign.optimization.refine import BRANCH_TOLERANCE, PEAK_TOLERANCE_DB
from isodesign.optimization.result import StudyResult
from isodesign.optimization.table_analysis import _analyze, band_response_and_modes
from isodesign.optimization.table_constraints import (
    CONTINUOUS_PEAK,
    LEVELING_GAIN_MARGIN,
    LEVELING_PHASE_MARGIN,
    table_constraint_reports,
)
from isodesign.optimization.table_problem import add_peak_frequencies
from isodesign.table.layout import is_position_lever
from isodesign.table.peaks import closure_springs, continuous_peaks, peak_search_band

__all__ = ["HESSIAN", "LEVELING_VIOLATIONS", "PEAK_VIOLATION", "TableOptimizationResult",
           "add_peak_frequencies", "band_response_and_modes", "closure_springs",
           "leveling_check", "measure_peaks",
           "optimize_table", "recheck_table"]

#: IPOPT's Hessian of the table NLP (``exact`` or ``limited-memory``): what
#: :func:`~isodesign.optimization.hessian.hessian_choice` gives a table study.
HESSIAN = "limited-memory"
#: Agreement required of the NumPy re-check (relative on sigma, dB on the margin).
RECHECK_TOL = 1e-6
_MODE_ROUNDS = 3
#: NLP solves with the leveling loop's gain-margin rows frozen again at the new design.
LOOP_ROUNDS = 8
#: A loop margin counts as missed when below its bound by more than this (dB, deg).
LOOP_TOLERANCE = 0.01
#: Frozen loop rows that bind at a design whose exact gain margin exceeds the bound by more
#: than this (dB) are frozen again there (the first-order rows held the design back).
LOOP_SLACK_DB = 0.03
#: Name of the violation a result carries when its continuous peak of |T| stays above
#: ``constraints.max_peak_transmissibility_db`` after the last refinement round (the
#: vertical optimizer's :data:`isodesign.optimization.driver.PEAK_VIOLATION`).
PEAK_VIOLATION = CONTINUOUS_PEAK
#: Names of the violations of the leveling loop's margins (below their bounds at the
#: returned design, python-control's margins: :func:`leveling_check`).
LEVELING_VIOLATIONS = (LEVELING_GAIN_MARGIN, LEVELING_PHASE_MARGIN)
_VIOLATION_UNITS = {PEAK_VIOLATION: " dB", LEVELING_GAIN_MARGIN: " dB",
                    LEVELING_PHASE_MARGIN: " deg"}


@dataclass(frozen=True, eq=False, repr=False)
class TableOptimizationResult(StudyResult):
    """The answer to a ``table`` study: the optimum, its checks and its analysis.

    The common interface (verdict, worst margin, constraint table, starts, frames, plot,
    text and HTML) is :class:`~isodesign.optimization.result.StudyResult`'s; the modes,
    the rocking stability, the continuous peaks and the leveling loop are this kind's.

    Attributes
    ----------
    study : Study
    feasible : bool
    status : str
        IPOPT's status of the final solve.
    values : dict
        Design-variable values (SI).
    design : SpringDesign
    objective : str
    objective_value : float
        Worst margin (dB) or total volume (m^3) at the optimum (the NLP's grid).
    start_objective : float or None
    starts : tuple
        ``(index, status, feasible, iterations, wall_s, objective)`` per start.
    n_reached_best : int
    constraints : tuple of ConstraintReport
        The constraint table at the returned design: value, bounds, margin and binding flag
        of each constraint (:func:`~.table_constraints.table_constraint_reports`).
    nlp_violations : tuple
        ``(name, worst violation)`` per NLP constraint group (NLP units).
    violations : tuple
        ``(name, amount)`` of every constraint the returned design breaks: for an infeasible
        run the NLP's violated groups; for a feasible one the continuous peak of |T| above
        its limit after the last refinement round (:data:`PEAK_VIOLATION`, dB), the exact
        modes' damping or rocking-frequency misses, and the leveling loop's gain or phase
        margin below its bound (:data:`LEVELING_VIOLATIONS`, the shortfall in dB or deg),
        and every re-checked row whose NumPy value breaks its bound
        (:attr:`recheck_rows`, :func:`recheck_table`).
        A result with violations is not a
        :attr:`success` and its :meth:`verdict` is never PASS.
    peak : dict
        The continuous peak refinement's record: ``rounds``, ``added_frequencies_hz``,
        ``limit_db``, ``met``, ``excess_db``, ``peaks`` (:class:`TablePeaks` of the returned
        design, from below its lowest mode), ``resolve_failed``.
    mode_rounds : int
        NLP solves after the first (mode refreshes).
    recheck_sigma_rel, recheck_margin_db : float
        NumPy re-check differences.
    analysis, start_analysis : TableBandResponse or None
        Fine-grid band responses.
    modes, start_modes : TableModes or None
        At the closure state of each design.
    stability : RockingStability or None
    leveling : LevelingLoop or None
        The returned design's leveling loop (the study's ``[table.leveling]`` valves, or
        the defaults), whose margins the constraint table holds.
    leveling_gain_hint_kg_s_per_m : float or None
        When the loop misses a margin bound: the largest valve gain whose loop on the
        returned springs meets both (:func:`~isodesign.table.leveling_loop.max_valve_gain`;
        None: none down to a thousandth of the study's, or no miss).
    wall_s : float
    hessian : str
    distortion_outer_rounds : int
        ``models.distortion``: the outer fixed point's rounds of the returned solve
        (docs/random-response.md 3d; 0 without it).
    """

    KIND = "table"

    study: Any
    feasible: bool
    status: str
    values: dict
    design: Any
    objective: str
    objective_value: float
    start_objective: float | None
    starts: tuple
    n_reached_best: int
    constraints: tuple
    mode_rounds: int
    recheck_sigma_rel: float
    recheck_margin_db: float
    analysis: Any = None
    start_analysis: Any = None
    modes: Any = None
    start_modes: Any = None
    stability: Any = None
    wall_s: float = 0.0
    hessian: str = HESSIAN
    nlp_violations: tuple = ()
    violations: tuple = ()
    peak: Any = None
    leveling: Any = None
    leveling_gain_hint_kg_s_per_m: float | None = None
    #: Per free lever of a co-designed table: its value, bounds, active bound and the
    #: worst margin's exact sensitivity to that bound, dB per SI unit
    #: (:meth:`~isodesign.optimization.table_problem.TableProblem.lever_sensitivities`).
    lever_sensitivity: tuple = ()
    hessian_info: dict = field(default_factory=dict)
    distortion_outer_rounds: int = 0
    #: The NumPy re-check of the returned design's constraint rows
    #: (:class:`~isodesign.optimization.recheck.RowRecheck`; None for an infeasible run).
    recheck_rows: Any = None

    def _start_values(self) -> dict:
        return {v.name: v.start for v in (*self.study.variables, *self.study.levers)}

    def _start_rows(self) -> list[dict]:
        keys = ("start", "status", "feasible", "iterations", "wall_s", "objective_nlp")
        return [dict(zip(keys, r, strict=True)) for r in self.starts]

    def _variable_notes(self) -> dict:
        return {**super()._variable_notes(), **self.lever_notes()}

    def lever_notes(self) -> dict:
        """Per free lever, one phrase: its active bound and the worst margin's exact
        sensitivity to it (``at upper bound 0.6 m: +9.1 dB per m``), or ``inside its
        bounds``."""
        from isodesign.optimization.variables import TABLE_LEVER_UNITS

        out = {}
        for s in self.lever_sensitivity:
            unit = TABLE_LEVER_UNITS.get(s["name"], "m")  # an isolator's x or y: m
            if s["at_bound"] == "binding":  # a footprint edge or the spacing (free positions)
                out[s["name"]] = f"{s['binding']}: {s['db_per_unit']:+.3g} dB per m"
            elif s["at_bound"] is None:
                out[s["name"]] = "inside its bounds (sensitivity 0)"
            else:
                out[s["name"]] = (f"at {s['at_bound']} bound {s[s['at_bound']]:g} {unit}: "
                                  f"{s['db_per_unit']:+.3g} dB per {unit} of the bound")
        return out

    def _kind_items(self) -> list[tuple[str, str]]:
        items = [("starts at best", f"{self.n_reached_best} of {len(self.starts)}")]
        if self.lever_sensitivity:
            items.append(("levers", "; ".join(
                f"{k} {self.values[k]:.4g} ({v})" if k in self.values else f"{k} ({v})"
                for k, v in self.lever_notes().items())))
        return items

    def _figure(self):
        from isodesign.table.plots import table_bands_figure

        if self.analysis is None:
            return super()._figure()
        return table_bands_figure(self.analysis)

    def _draw(self, ax) -> None:
        """The worst margin per band over every point and axis, start against optimum
        (the NLP's grid when the result has no fine-grid analysis: its stored analyses)."""
        from isodesign.plotting.style import OPTIMUM, START

        if self.analysis is None:
            raise ValueError("plot: the table result has no band analysis (analyze=False)")
        for label, a, style in (("start design", self.start_analysis, START),
                                ("optimum", self.analysis, OPTIMUM)):
            if a is None:
                continue
            worst = a.margin_db.reshape(-1, a.margin_db.shape[-1]).min(axis=0)
            ax.semilogx(a.bands.centre_hz, worst, **{**style, "marker": "o"},
                        label=f"{label} (worst {float(worst.min()):+.2f} dB)")
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_xlabel("band centre (Hz)")
        ax.set_ylabel("worst margin over points and axes (dB)")
        ax.set_title(self.verdict()[:80], fontsize=8)
        ax.legend(fontsize=7)


def optimize_table(study, *, workers=None, analyze: bool = True, progress=None,
                   problem=None) -> TableOptimizationResult:
    """Optimize the isolators of a table study in three axes.

    Parameters
    ----------
    study : Study
        With a ``[table]``.
    workers : int, optional
        Worker processes for the starts (default the study's ``solver.workers``).
    analyze : bool
        Run the fine-grid analyses of the optimum and the start (default).
    progress : callable, optional
        ``progress(done, total, result)`` after each start.
    problem : TableProblem, optional
        A prebuilt NLP of the study.

    Returns
    -------
    TableOptimizationResult

    Raises
    ------
    SolverError
        The NLP's optimum and the NumPy closure disagree (a bug, never a silently wrong
        design), or no start could be initialized.
    """
    from isodesign.optimization.problem import Problem

    if getattr(study, "table", None) is None:
        raise InputError("study: has no [table]; use isodesign.optimize")
    _refuse_levers_with_loop_bounds(study)
    t0 = time.perf_counter()
    prob = problem if problem is not None else Problem(study)
    choice = prob.hessian_info  # a prebuilt NLP with another Hessian states it as such
    starts = _lever_starts(study, prob, start_points(study, prob.scaling))
    d0 = study.design_at(starts[0])
    modes0 = _modes_at(prob, d0)
    prob.set_modes(modes0)
    workers = workers or study.solver.get("workers")
    tied = _tied_starts(study, workers, progress, prob)
    pre = [] if tied is None else tied[0]
    if tied is None:
        outs = run_starts(prob, starts, workers=workers, progress=progress)
    else:  # the full solves from the tied optima not already solved in a worker
        todo = [s for s, done in zip(tied[1], tied[2], strict=True) if done is None]
        ran = iter(run_starts(prob, todo, workers=workers, progress=progress,
                              rounds=capped(prob, 1).get("rounds")) if todo else ())
        outs = [done if done is not None else next(ran) for done in tied[2]]
    if tied is not None and not any(not isinstance(o, str) and o.feasible for o in outs):
        pre, outs = [*pre, *_records(outs, "warm from the tied optimum: ", len(pre))], \
            run_starts(prob, starts, workers=workers, progress=progress)  # as before
    recs, good = list(pre), {}
    for i, out in enumerate(outs, len(pre)):
        if isinstance(out, str):
            recs.append((i, out, False, 0, 0.0, math.nan))
            continue
        recs.append((i, out.status, out.feasible, out.iterations, out.wall_s, out.objective))
        if out.feasible:
            good[i] = out
    cand = [o for o in outs if not isinstance(o, str)]
    if not cand:
        raise SolverError("table optimization: no start could be initialized")
    best = min(good.values(), key=lambda s: s.objective) if good else \
        min(cand, key=lambda s: s.max_violation)
    n_best = sum(1 for s in good.values() if abs(s.objective - best.objective) <= 1e-4)
    j_first = best.objective
    prob, best, modes, rounds, peak = _refine(prob, study, best)
    prob, best, modes, rounds, peak = _other_branches(prob, study, good, j_first, best, modes,
                                                      rounds, peak)
    d = study.design_at(best.values)
    sig_rel = margin_db = math.nan
    getattr(prob, "use_solution", lambda sol: None)(best)  # models.distortion's terms
    checked = None
    if best.feasible:
        checked, sig_rel, margin_db = recheck_table(prob, best)
    j0 = None
    try:
        x00 = prob.initial_guess(starts[0])
        j0 = _natural(prob, x00, float(np.asarray(prob._j_fn(x00)).ravel()[0]))
    except SolverError:
        pass
    analysis = start_analysis = stab = None
    nlp_modes = modes
    if analyze:
        analysis, modes, stab = _analyze(study, d, best.values)
        start_analysis, modes0, _ = _analyze(study, d0, starts[0])
        if best.feasible:  # the continuous peak at the analysis' closure too: the larger
            pk = measure_peaks(prob, d, analysis.stroke_rms_m, analysis.tube_velocity_rms_m_s,
                               modes, values=best.values)
            if peak["peaks"] is None or pk.max_db > peak["peaks"].max_db:
                peak["peaks"] = pk
    else:
        from isodesign.table.modes import rocking_stability

        stab = rocking_stability(_model(study, d, best.values))
    loop, gm_min, pm_min = leveling_check(study, d, best.values)
    violations = _violations(study, prob, best, nlp_modes, peak)
    if checked is not None:  # rows whose NumPy value breaks a bound: no PASS
        violations += checked.violations
    gain_hint = None
    if best.feasible:
        misses = _leveling_misses(loop, gm_min, pm_min)
        violations += misses
        if misses:  # what the valves would need on these springs
            from isodesign.table.leveling_loop import max_valve_gain

            gain_hint = max_valve_gain(loop.plant.model, loop.plant.system, gm_min, pm_min)
    reports = table_constraint_reports(prob, best.g, modes=nlp_modes, stability=stab,
                                       peaks=peak["peaks"], leveling=(loop, gm_min, pm_min))
    lever_sens = prob.lever_sensitivities(best.x, best) if best.feasible else ()
    return TableOptimizationResult(
        study=study, feasible=bool(best.feasible), status=best.status, values=best.values,
        design=d, objective=prob.objective,
        objective_value=_natural(prob, best.x, best.objective), start_objective=j0,
        starts=tuple(recs), n_reached_best=n_best, constraints=tuple(reports),
        mode_rounds=rounds, recheck_sigma_rel=sig_rel, recheck_margin_db=margin_db,
        recheck_rows=checked,
        analysis=analysis, start_analysis=start_analysis, modes=modes, start_modes=modes0,
        stability=stab, wall_s=time.perf_counter() - t0, hessian=prob.hessian,
        nlp_violations=tuple(best.violations), violations=violations, peak=peak,
        leveling=loop, leveling_gain_hint_kg_s_per_m=gain_hint, lever_sensitivity=lever_sens,
        hessian_info=choice, distortion_outer_rounds=int(best.outer_rounds),
    )


def recheck_table(prob, best) -> tuple:
    """The NumPy re-check of a table optimum: every constraint row the registry re-checks
    (:func:`~isodesign.optimization.recheck.recheck_rows` on
    :func:`~isodesign.optimization.table_constraints.table_quantities`, the one re-check of
    both bodies), the closure (stroke and tube-velocity RMS) and the worst-margin
    objective at the NumPy closure.

    Parameters
    ----------
    prob : TableProblem
        The NLP of ``best`` (its slots where the refinement left them).
    best : Solution
        A feasible optimum.

    Returns
    -------
    checked : RowRecheck
        The rows' re-check, :attr:`~.recheck.RowRecheck.max_difference` including the
        closure's relative difference and the margin's (dB).
    sigma_rel : float
        ``|sigma_np / sigma_nlp - 1|``, worst over the isolators (and ``sigma_u``).
    margin_db : float
        The worst margin's difference at the NumPy closure, dB.

    Raises
    ------
    SolverError
        The NLP's optimum and the NumPy analysis disagree by more than
        :data:`RECHECK_TOL` (a bug, never a silently wrong design).
    """
    from isodesign.optimization.constraint_registry import TABLE_ROWS, constraint_rows_of
    from isodesign.optimization.recheck import recheck_rows
    from isodesign.optimization.table_constraints import table_quantities

    study = prob.study
    d = study.design_at(best.values)
    sigma, sigma_u = prob.closure(d, best.values)
    sig_rel = float(max(np.max(np.abs(sigma / prob.sigma(best.x) - 1)),
                        np.max(np.abs(sigma_u / prob.tube_rms(best.x) - 1))))
    x = best.x.copy()
    x[prob.nz: prob.nz + prob.n] = np.log(sigma)
    x[prob.nz + prob.n: prob.nz + 2 * prob.n] = np.log(sigma_u)
    margin_db = abs(prob.worst_margin_db(x) - prob.worst_margin_db(best.x))
    if sig_rel > RECHECK_TOL or margin_db > RECHECK_TOL:
        raise SolverError(f"table optimization: the NLP and the NumPy closure disagree at "
                          f"the optimum (sigma {sig_rel:.3g} relative, worst margin "
                          f"{margin_db:.3g} dB)")
    rows = constraint_rows_of(study, table_quantities(prob, best.values), TABLE_ROWS)
    checked = recheck_rows(rows, prob.con_rows, best.g, tol=RECHECK_TOL,
                           what="table optimization")
    return checked.merged(max(sig_rel, margin_db)), sig_rel, margin_db


def leveling_check(study, d, values=None) -> tuple:
    """The leveling loop of design ``d`` and the bounds on its margins.

    The loop of the study's valves (``[table.leveling]``, or the defaults; a free valve gain
    chosen by :func:`~isodesign.table.leveling_loop.study_valves`) around the table on the
    design's springs, by python-control (:func:`~isodesign.table.leveling_loop.
    leveling_loop`: what ``isodesign stability`` prints for the design), and the bounds of
    :func:`~isodesign.table.leveling.leveling_margin_bounds`.

    Parameters
    ----------
    study : Study
        With a ``[table]``.
    d : SpringDesign
    values : dict, optional
        The design's values, with a co-designed table's levers (the table at them).

    Returns
    -------
    (LevelingLoop, float or None, float or None)
        The loop, the gain-margin bound (dB) and the phase-margin bound (deg); None: the
        margin is reported, not enforced.
    """
    from isodesign.table.leveling import leveling_margin_bounds
    from isodesign.table.leveling_loop import leveling_loop, study_valves

    gm_min, pm_min = leveling_margin_bounds(study)
    return (leveling_loop(_model(study, d, values), study_valves(study, d)), gm_min,
            pm_min)


def _refuse_levers_with_loop_bounds(study) -> None:
    """Refuse free co-design levers together with bounds on the leveling loop's margins.

    The NLP's frozen-pole gain-margin rows (docs/table.md, section 12) are built on the
    table's fixed horizontal element: with a lever free they would hold the bound on
    another table than the one optimized, so the combination is refused by its keys.
    """
    from isodesign.table.leveling import leveling_margin_bounds

    free = [v.name for v in getattr(study, "levers", ()) if v.free]
    if free and leveling_margin_bounds(study) != (None, None):
        raise InputError(f"variables.{free[0]}.fixed: the leveling loop's margin bounds "
                         "(constraints.min_leveling_gain_margin_db, "
                         "min_leveling_phase_margin_deg) are not yet held with free co-design "
                         "levers; fix the levers, or set both margin keys to false "
                         "(docs/table.md, sections 12 and 13)")


def _leveling_misses(loop, gm_min, pm_min) -> tuple:
    """``(name, shortfall)`` of the loop's margins below their bounds (dB, deg)."""
    out = []
    gm, pm = loop.worst_gain_margin_db, loop.worst_phase_margin_deg
    if gm_min is not None and not gm >= gm_min - LOOP_TOLERANCE:
        out.append((LEVELING_GAIN_MARGIN, float(gm_min - gm)))
    if pm_min is not None and not pm >= pm_min - LOOP_TOLERANCE:
        out.append((LEVELING_PHASE_MARGIN, float(pm_min - pm)))
    return tuple(out)


def _lever_starts(study, prob, starts: list) -> list:
    """The starts of a co-designed table: the study's starts (levers at their starts),
    then the Latin-hypercube starts again with the free levers drawn in their own
    hypercube (each lever's range cut into ``n`` strata, one start in each at a random
    place, seeded by ``solver.seed``, 2 % inside the bounds): the levers make the worst
    margin multimodal (four free levers from four starts reach four local optima).
    Unchanged when every lever is fixed."""
    n = len(starts) - 1
    if not prob.n_levers or n <= 0:
        return starts
    ls = prob.lever_scaling
    rng = np.random.default_rng([int(study.solver["seed"]), 24])
    d = len(ls.names)
    strata = np.column_stack([rng.permutation(n) for _ in range(d)])
    z = 2.0 * (strata + rng.random((n, d))) / n - 1.0
    out = [dict(s) for s in starts]
    from isodesign.optimization.lever_nlp import draw_positions

    # free positions: feasible layouts drawn in the footprint (a box's draw may not carry
    # the CG), docs/table.md section 15
    pos = draw_positions(study, n, [int(study.solver["seed"]), 24, 1])
    for j, (s, zi) in enumerate(zip(starts[1:], z, strict=True)):
        out.append({**s, **{k: v for k, v in ls.to_values(0.98 * zi).items()
                            if not is_position_lever(k)}, **(pos[j] if j < len(pos) else {})})
    return out


def _tied_starts(study, workers, progress, prob):
    """The staged starts of a study with free per-group springs (docs/table.md, section 13,
    "Staged starts"): :func:`.lever_continuation.solve_tied` on the tied study
    (:func:`.lever_continuation.tied_study`), its full solves from the tied optimum with one
    round of the distortion's fixed point. Returns ``(records of the tied solves, starts of
    the full NLP, their solves or None)``, or None (no free group lever, a single start, or
    no feasible tied optimum: the full multi-start runs as before)."""
    from isodesign.optimization.lever_continuation import solve_tied, tied_study
    from isodesign.optimization.problem import Problem

    reduced = tied_study(study)
    if reduced is None or study.solver["starts"] < 2:
        return None
    rprob = Problem(reduced)
    rstarts = start_points(reduced, rprob.scaling)  # the levers at their starts
    rprob.set_modes(_modes_at(rprob, reduced.design_at(rstarts[0])))
    out = solve_tied(study, rprob, rstarts, prob, workers=workers, progress=progress,
                     rounds=capped(prob, 1).get("rounds"))
    if out is None:
        return None
    for k, sol in enumerate(d for d in out[2] if d is not None):
        if progress:  # as run_starts reports the full NLP's solves
            progress(k + 1, len(out[2]), sol)
    return _records(out[0], "tied groups: "), out[1], out[2]


def _records(outs, prefix: str, first: int = 0) -> list:
    """The starts' records ``(index, status, feasible, iterations, wall_s, J)``, each
    status prefixed."""
    recs = []
    for i, out in enumerate(outs, first):
        if isinstance(out, str):
            recs.append((i, f"{prefix}{out}", False, 0, 0.0, math.nan))
        else:
            recs.append((i, f"{prefix}{out.status}", out.feasible, out.iterations, out.wall_s,
                         out.objective))
    return recs


def _violations(study, prob, best, modes, peak) -> tuple:
    """What the returned design breaks (see :attr:`TableOptimizationResult.violations`)."""
    if not best.feasible:
        return tuple((n, v) for n, v in best.violations if v > 1e-6)
    out = []
    limit = peak["limit_db"]
    pk = peak["peaks"]
    if limit is not None and pk is not None:
        excess = pk.max_db - limit
        peak["excess_db"] = excess
        peak["met"] = bool(excess <= PEAK_TOLERANCE_DB)
        if not peak["met"]:
            out.append((PEAK_VIOLATION, float(excess)))
    if modes is not None:
        out += _mode_misses(study, modes)
    return tuple(out)


def _other_branches(prob, study, good, j_first, best, modes, rounds, peak):
    """Refine the other branches that could still win.

    The refinement can only lower a branch's objective, so a distinct branch whose optimum
    before it (J) is better than the refined winner's J may win after its own; each such
    branch is refined in turn (the movable frequencies placed so far kept, the frozen modes
    set at its point) and the best refined one that meets its peak bound is kept. A winner
    whose own refinement left its peak above the bound yields to any branch that meets it:
    then every branch is refined in order of J until one does.
    ``j_first`` is the refined branch's J before its refinement.
    """
    if not best.feasible or not peak["rounds"]:
        return prob, best, modes, rounds, peak
    # a winner whose refinement left its peak above the bound (its rounds spent, or a
    # re-solve failed) is no winner: every other branch is refined, in order, until one
    # meets the bound, and one that does wins whatever its objective
    met = peak["met"] is not False
    seen = [j_first, best.objective]
    for sol in sorted(good.values(), key=lambda o: o.objective):
        if met and sol.objective >= best.objective - BRANCH_TOLERANCE:
            break
        if any(abs(sol.objective - j) <= BRANCH_TOLERANCE for j in seen):
            continue
        seen.append(sol.objective)
        held = _nlp_state(prob)  # the winner's: restored if this branch loses
        try:
            prob.set_modes(_modes_at(prob, study.design_at(sol.values), prob.sigma(sol.x),
                                     prob.tube_rms(sol.x), values=sol.values))
        except InputError:
            continue
        prob.clear_loop()  # the winner's frozen poles are not this branch's
        slots = list(peak["added_frequencies_hz"])
        out = _refine(prob, study, sol, slots=slots)
        prob = out[0]
        cand, cpeak = out[1], out[4]
        if cand.feasible and cpeak["met"] is not False and (not met
                                                            or cand.objective < best.objective):
            best, modes, rounds, peak, met = cand, out[2], out[3], cpeak, True
            peak["added_frequencies_hz"] = list(slots)  # every frequency the NLP now holds
        else:
            # the NLP as the winner was solved: its frozen modes, peak frequencies and loop
            # poles (its rows, best.g, are of those; the re-check and the result read them).
            # Left at the losing branch's, the re-check compared the winner's rows at 9
            # frequencies with the NumPy rows at the branch's 21 (a 2.2 difference in
            # ln |T|^2, the co-design script's all_and_layout case with the distortion)
            prob = _restore_nlp_state(held)
    return prob, best, modes, rounds, peak


def _nlp_state(prob) -> tuple:
    """What a table refinement changes in its NLP's parameters: the frozen modes, the
    movable peak frequencies, the frozen loop poles (:func:`_restore_nlp_state`)."""
    return (prob, prob.mode_params.copy(), prob.slot_hz.copy(), prob.loop_params.copy(),
            getattr(prob, "loop_system", None))


def _restore_nlp_state(held):
    """The NLP of :func:`_nlp_state` with those parameters again; returns it."""
    prob, mode_params, slot_hz, loop_params, loop_system = held
    prob.mode_params = mode_params.copy()
    if not np.array_equal(prob.slot_hz, slot_hz):
        prob.set_slots(slot_hz)
    prob.loop_params = loop_params.copy()
    if loop_system is not None:
        prob.loop_system = loop_system
    return prob


def _mode_misses(study, modes) -> list[tuple[str, float]]:
    """The exact modes' misses of the damping and rocking-frequency bounds: ``(name, amount)``
    (amount: the damping deficit, or the distance to the frequency bound in Hz)."""
    c = study.constraints
    zmin = c.get("min_damping_ratio") or 0.0
    f_lo = c.get("min_rocking_frequency_hz") or 0.0
    f_hi = c.get("max_rocking_frequency_hz") or np.inf
    f = modes.frequency_hz
    out = []
    low = np.isfinite(f) & (f < 5.0)
    if zmin and np.any(low):
        z = float(np.min(modes.damping_ratio[low]))
        if z < zmin * (1 - 1e-3):
            out.append(("min_damping_ratio", zmin - z))
    rock = np.isfinite(f) & (modes.energy_fraction[:, 3:5].sum(axis=1) >= 0.3)
    if np.any(rock):
        fr = f[rock]
        if f_lo and float(fr.min()) < f_lo * (1 - 1e-3):
            out.append(("min_rocking_frequency_hz", f_lo - float(fr.min())))
        if np.isfinite(f_hi) and float(fr.max()) > f_hi * (1 + 1e-3):
            out.append(("max_rocking_frequency_hz", float(fr.max()) - f_hi))
    return out


def measure_peaks(prob, d, sigma, sigma_u, modes, values=None):
    """The continuous peak of |T| of design ``d`` at a closure state (a :class:`TablePeaks`).

    Parameters
    ----------
    prob : TableProblem
        Its study's models and the top of its peak rows.
    d : SpringDesign
    sigma, sigma_u : ndarray (n,)
        The closure's RMS values.
    modes : TableModes
        The design's modes (the fine grid starts at a fraction of the lowest).
    values : dict, optional
        The design's lever values (a co-designed table; default their starts).
    """
    lo, hi = peak_search_band(modes, prob._peak_cut_hz())
    return continuous_peaks(_model(prob.study, d, values), sigma,
                            _with_gain(prob, d, sigma_u, values), lo, hi)


def _refine(prob, study, best, slots=None):
    """Mode refresh and continuous peak refinement of the multi-start's best solution.

    Returns ``(prob, best, modes, mode_rounds, peak)``: the NLP last solved (built again
    with movable peak frequencies if the refinement needed them) and ``peak`` the
    refinement's record.
    """
    limit = study.constraints.get("max_peak_transmissibility_db")
    if limit is False:
        limit = None
    peak = {"rounds": 0, "added_frequencies_hz": [], "limit_db": limit,
            "tolerance_db": PEAK_TOLERANCE_DB,
            "max_rounds": MAX_PEAK_ROUNDS,
            "peaks": None, "met": None, "excess_db": None, "resolve_failed": None,
            "leveling_rounds": 0}
    rounds = 0
    modes = None
    slots = [] if slots is None else slots  # the frequencies placed so far (extended)
    # the last design whose outer fixed point (models.distortion) converged, with the NLP and
    # the frequencies it was solved with: a refinement round takes one round of that fixed
    # point (capped), which converges once, when the peaks are held (docs/table.md, 13)
    settled = (prob, prob.slot_hz.copy(), len(slots), best)
    stop = False
    while True:
        if not best.feasible:
            break
        if not best.outer_pending:
            settled = (prob, prob.slot_hz.copy(), len(slots), best)
        sigma, sigma_u = prob.sigma(best.x), prob.tube_rms(best.x)
        modes = _modes_at(prob, study.design_at(best.values), sigma, sigma_u,
                          values=best.values)
        if rounds < _MODE_ROUNDS and _mode_misses(study, modes) and _modes_moved(prob, modes):
            prob.set_modes(modes)  # the frozen modes moved: solve again with the exact ones
            sol = prob.solve(best.x, warm=best.as_start())
            rounds += 1
            if not sol.feasible:
                peak["resolve_failed"] = f"mode refresh: {sol.status}"
                break
            best = sol
            continue
        if _loop_refresh_needed(prob, study, best, peak):
            prob.set_loop(study.design_at(best.values))  # freeze the poles at this design
            sol = prob.solve(best.x, warm=best.as_start())
            peak["leveling_rounds"] += 1
            if not sol.feasible:  # keep the last feasible design; its margin is a violation
                peak["resolve_failed"] = f"leveling loop: {sol.status}"
                break
            best = sol
            continue
        pk = measure_peaks(prob, study.design_at(best.values), sigma, sigma_u, modes,
                           values=best.values)
        peak["peaks"] = pk
        over = [] if limit is None else pk.above(limit, PEAK_TOLERANCE_DB)
        if limit is not None:
            peak["met"] = not over
            peak["excess_db"] = pk.max_db - limit
        new = []
        if not (stop or not over or peak["rounds"] >= MAX_PEAK_ROUNDS):
            # the NLP best was solved with (a failed re-solve returns to it: best's g are its
            # rows)
            held = (prob, prob.slot_hz.copy())
            prob, new = add_peak_frequencies(prob, over, slots)
        if not new:  # the peaks held, the rounds or the movable frequencies spent
            if not best.outer_pending:
                break
            # the fixed point, converged: the same NLP with the expansion at best, warm from
            # best's multipliers (the refinement's rounds above start cold from best's
            # design: warm, they take another path, which on the coarse default study of
            # test_default_sensitivity ended 0.025 dB above the peak bound; docs/table.md 13)
            sol = prob.solve(best.x, warm=best)
            if sol.feasible:
                best = sol
                continue  # its peaks measured again
            peak["resolve_failed"] = f"distortion fixed point: {sol.status}"
            prob, slot_hz, n_kept, best = settled  # the last converged design, its NLP
            prob.set_slots(slot_hz)
            del slots[n_kept:]
            break
        slots += new
        peak["added_frequencies_hz"] += new
        peak["rounds"] += 1
        sol = solve_round(prob, best, **capped(prob, 1))
        if not sol.feasible:  # keep the last feasible design; its peak stays a violation
            peak["resolve_failed"] = f"peak refinement: {sol.status}"
            prob = held[0]
            prob.set_slots(held[1])
            del slots[len(slots) - len(new):]  # the frequencies the NLP holds
            stop = True  # no more frequencies; a pending fixed point still converges
            continue
        best = sol
    if best.outer_pending:  # an infeasible design's fixed point converged too (its violations)
        best = prob.solve(best.x, warm=best)
    return prob, best, modes, rounds, peak


def _loop_refresh_needed(prob, study, best, peak) -> bool:
    """Whether the leveling loop's gain-margin rows should be frozen again and the NLP solved:
    the study bounds the gain margin, rounds are left, and the exact margin at ``best``
    misses its bound, or the frozen rows bind while the exact margin exceeds the bound by
    more than :data:`LOOP_SLACK_DB` (the first-order rows held the design back)."""
    if not getattr(prob, "n_loop", 0) or peak["leveling_rounds"] >= LOOP_ROUNDS:
        return False
    loop, gm_min, _ = leveling_check(study, study.design_at(best.values), best.values)
    gm = loop.worst_gain_margin_db
    if gm < gm_min - LOOP_TOLERANCE:
        return True
    rows = [(r, m) for n, r, m in prob.con_rows if n == "min_leveling_gain_margin_db"]
    active = bool(rows and np.any(prob.loop_params[:: 2 + prob.n_states ** 2] > 0)
                  and np.max(best.g[rows[0][0]: rows[0][0] + rows[0][1]]) > -1e-4)
    return bool(active and gm > gm_min + LOOP_SLACK_DB)


def _natural(prob, x, j: float) -> float:
    if prob.objective == "worst_band_margin":
        return prob.worst_margin_db(x)
    return math.exp(j)


def _model(study, d, values=None):
    from isodesign.table.model import table_model

    m = study.models
    return table_model(d, study.table_at(values), flow=m["flow"],
                       amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])


def _modes_at(prob, d, sigma=None, sigma_u=None, values=None, side_by_side=False):
    """The modes at the closure's springs; ``side_by_side``: :func:`table_modes`'s (the
    nominal NLP's frozen modes keep the mode-by-mode evaluation: the same to rounding,
    docs/table.md section 6; the robust exchange takes the faster one)."""
    from isodesign.table.modes import table_modes

    if sigma is None:
        sigma, sigma_u = prob.closure(d, values)
    model = _model(prob.study, d, values)
    sigma_u = _with_gain(prob, d, sigma_u, values)
    return table_modes(model, vertical=closure_springs(model, sigma, sigma_u),
                       side_by_side=side_by_side)


def _with_gain(prob, d, sigma_u, values=None):
    """``sigma_u`` at which the NLP's springs are linearized: with ``models.distortion``
    times the minor loss's gain ratio of the NumPy terms (its y_k,
    optimization.distortion_rows; exact for womersley, none for poiseuille)."""
    if getattr(prob, "distortion", False) and prob.flow != "poiseuille":
        n = prob.n
        return np.asarray(sigma_u, float) * prob.distortion_terms(d, values)[2 * n:3 * n]
    return sigma_u


def _modes_moved(prob, modes) -> bool:
    old = prob.mode_params.reshape(-1, 14)[:6]
    m = prob.geo.mass
    for j in range(6):
        f = modes.frequency_hz[j]
        active = bool(np.isfinite(f) and f < 5.0)
        if active != bool(old[j, 0]):
            return True
        if not active:
            continue
        if abs(2 * math.pi * f / old[j, 1] - 1) > 1e-3:
            return True
        phi0 = old[j, 2:8] + 1j * old[j, 8:14]
        phi = modes.shapes[:, j]
        corr = abs(np.vdot(phi0, m @ phi)) ** 2 / (np.real(np.vdot(phi0, m @ phi0))
                                                   * np.real(np.vdot(phi, m @ phi)))
        if corr < 0.999:
            return True
    return False
