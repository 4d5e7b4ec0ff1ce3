"""Robust design of a table study (six degrees of freedom): scenarios stacked, exchange.

The same layer as :mod:`.robust` and :mod:`.exchange`, on the table NLP
(:class:`.table_problem.TableProblem`): every scenario is the table study under
that scenario's payload mass, centre-of-gravity offset (``cg_offset_x_m``,
``cg_offset_y_m``), temperature, and the built spring's tolerances
(:func:`.table_scenario.table_scenario`), its own TableProblem (the leveling pressures and
the mass matrix follow the payload and the CG). :class:`TableStack` stacks them by the one
construction of both bodies (:func:`.robust.stack_scenarios`, one block per scenario): the
scaled design ``z`` shared, each scenario's closure unknowns its own, the worst case an
epigraph over the scenarios' objectives, every constraint in every scenario.

The exchange as the vertical one (:func:`.exchange.robust_optimize`): a round with a new
scenario set solves the stack from the last solution and the nominal optimum, keeping the
best feasible solution (:func:`_solve_round`); movable peak frequencies are placed where a
scenario's continuous peak of ``|T_p,aa|`` exceeds its bound
(:meth:`_Scenarios.place_peak_slots`; such a round solves the built stack again, from the
last solution, without a new scenario); then the box is searched at the new design
(:func:`.table_search.search_box`, as the vertical exchange's ``worst_case``): the corners
(at most :data:`MAX_CORNERS`) and the centre through each scenario's NLP where it is built
(its NumPy closure and the NLP's own constraint expressions, :meth:`_Scenarios.check`),
else with the NumPy scorer (:meth:`_Scenarios.score`), ``search_samples``
uniform samples with the NumPy scorer that gives the same numbers without building an NLP
(:func:`.table_search.score_table_scenario`, ~0.09 s a sample against ~0.4 s for a
scenario's NLP build), and the three best candidates refined by a bounded local
maximization (L-BFGS-B, at most 40 scorer evaluations each) of the quantity that scored
them; ``search_samples = 0``: the corners and the centre alone. The worst is added, its
NLP built then and its peak frequencies placed before its first solve. Each scenario's NLP
is built once, its movable peak frequencies present from the start (parameters), and the
stack once per scenario set (docs/robust.md, section 3, step 3 and "The table's rounds").
What the vertical exchange has besides: the scenario values as NLP parameters (here
sensitivities by central differences, :func:`table_sensitivities`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.optimization.nlp import stacked_bounds
from isodesign.optimization.problem import Problem
from isodesign.optimization.result import worst_constraint_reports
from isodesign.optimization.robust import add_scenarios, best_solve
from isodesign.optimization.robust_result import RobustFields
from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
from isodesign.optimization.table_constraints import table_constraint_reports
from isodesign.optimization.table_driver import _modes_at, optimize_table
from isodesign.optimization.table_scenario import table_scenario
from isodesign.optimization.table_search import score_table_scenario, search_box

__all__ = ["FD_STEP", "MAX_CORNERS", "TableRobustResult", "check_robust_table",
           "robust_optimize_table",
           "table_scenario", "table_sensitivities"]

#: Most corners of the box scored per round (a random subset beyond).
MAX_CORNERS = 16
#: Central-difference step of :func:`table_sensitivities`, relative to each parameter's
#: half-width.
FD_STEP = 1e-3


def table_sensitivities(study, values: dict, theta=None) -> list:
    """Design-held sensitivities of a table design's worst margin to each parameter.

    The worst margin (dB, over every point, axis and band) of the table study under a
    scenario, the design held (a built table does not re-optimize itself), by central
    differences of the table's NumPy band response
    (:func:`.yields.table_draw_response`, the yield's analysis) with a step of
    :data:`FD_STEP` times the parameter's half-width. The worst margin is the minimum over
    the point-axis-bands: where two of them tie the difference is the mean of the two
    one-sided slopes.

    Parameters
    ----------
    study : Study
        A table study with its ``[scenarios]`` box.
    values : dict
        The held design: SI values by variable name.
    theta : array, optional
        Where the derivatives are taken (default the nominal values of the parameters).

    Returns
    -------
    list of Sensitivity
        One per continuous parameter (a discrete one has no derivative): ``quantity``
        ``"objective"`` for a worst-margin objective over every point and axis (else
        ``"worst_band_margin"``),
        ``per_unit`` dB per unit of the parameter (per % of a relative deviation),
        ``effect`` over the parameter's half-width; ``binding`` False (no constraint).
    """
    from isodesign.optimization.sensitivity import Sensitivity
    from isodesign.optimization.yields import table_draw_response
    from isodesign.table.study import objective_selection

    space = study.scenarios
    th0 = np.asarray(space.nominal() if theta is None else theta, float)
    axes, points = objective_selection(study.raw["table"], study.table)
    every = len(axes) == 3 and len(points) == len(study.table.point_names)
    quantity = ("objective" if study.objective["kind"] == "worst_band_margin" and every
                else "worst_band_margin")
    out = []
    for k, p in enumerate(space.parameters):
        if p.discrete or not p.half_width > 0:
            continue
        h = FD_STEP * p.half_width
        m = []
        for sign in (1.0, -1.0):
            th = th0.copy()
            th[k] += sign * h
            m.append(float(table_draw_response(study, values, th)[0].worst_margin_db))
        d = (m[0] - m[1]) / (2.0 * h)
        pct = 0.01 if p.mode == "relative" else 1.0
        out.append(Sensitivity(quantity, p.name, d * pct, "dB",
                               "%" if p.mode == "relative" else p.unit,
                               d * p.half_width, False))
    return out


#: A peak above its bound within this relative distance of a frequency placed before for
#: the same scenario has drifted (the design moved it off its rows): it gets a comb of
#: :data:`DRIFT_COMB` around it instead of the three frequencies of a new peak.
DRIFT_RANGE = 0.08
#: The comb's frequencies relative to the drifted peak (0.5 % apart, +-2 %).
DRIFT_COMB = tuple(1.0 + 0.005 * k for k in range(-4, 5))


def _drift_combs(over, used) -> list:
    """``over`` with each drifted peak (:data:`DRIFT_RANGE`) spread into the peaks of a comb
    (:data:`DRIFT_COMB`, its excess kept; :func:`.table_driver.add_peak_frequencies` places
    three frequencies 0.5 % apart around every one, the duplicates merge): on the built-in
    robust table the peak of the heaviest scenario moved by a few per cent per round."""
    out = []
    for e, f in over:
        if any(abs(f / u - 1.0) < DRIFT_RANGE for u in used):
            out += [(e, f * r) for r in DRIFT_COMB[1::3]]  # 3 x 3 frequencies: the comb
        else:
            out.append((e, f))
    return out


class _Scenarios:
    """TableProblems of the scenarios met so far, each built once, with its movable peak
    frequencies from the start (:meth:`~.table_problem.TableProblem.set_slots`: placing
    them sets parameters, it builds nothing): the search's checks and the stacked solves
    use the same NLP of a scenario."""

    def __init__(self, study):
        from isodesign.optimization.table_problem import PEAK_SLOTS_PER_ROUND, TABLE_PEAK_ROUNDS

        self.study = study
        self.cache: dict = {}
        limit = study.constraints.get("max_peak_transmissibility_db")
        self.n_slots = (0 if limit is None or limit is False
                        else PEAK_SLOTS_PER_ROUND * TABLE_PEAK_ROUNDS)
        self.builds = 0  # scenario NLPs built (one per scenario met)

    def problem(self, theta):
        key = self.key(theta)
        if key not in self.cache:
            st = table_scenario(self.study, theta)
            # a table study: the table body, its peak rows' frequencies parameters
            self.cache[key] = Problem(st, peak_slots=self.n_slots)
            self.builds += 1
        return self.cache[key]

    @staticmethod
    def key(theta) -> tuple:
        """The cache key of a scenario."""
        return tuple(np.round(np.asarray(theta, float), 12))

    def place_peak_slots(self, thetas, stack, sol, values: dict, placed: dict) -> tuple:
        """The vertical exchange's peak refinement per scenario (``_place_peak_slots``) on
        the table: where a scenario's continuous peak of ``|T_p,aa|`` at the stacked
        solution (its own closure state, its modes) exceeds the bound by more than
        :data:`~.refine.PEAK_TOLERANCE_DB`, movable peak frequencies are placed at it
        (:func:`.table_driver.add_peak_frequencies`, until the scenario NLP's
        ``PEAK_SLOTS_PER_ROUND x TABLE_PEAK_ROUNDS`` movable frequencies are spent).

        Parameters
        ----------
        thetas : list of array
        stack : TableStack or None
            The stack ``sol`` solved (its problems in ``thetas`` order); None: scenarios
            not solved yet, measured at their NumPy closure at ``values`` (a scenario the
            search adds gets its peak frequencies before its first solve).
        sol : RobustSolution or None
        values : dict
            The design at ``sol``.
        placed : dict
            Scenario key -> frequencies placed so far (updated).

        Returns
        -------
        (bool, float)
            Whether a frequency was placed (solve again), and the largest excess (dB) left
            over a scenario whose rounds are spent (0 when none).
        """
        from isodesign.optimization.refine import PEAK_TOLERANCE_DB
        from isodesign.optimization.table_driver import add_peak_frequencies, measure_peaks
        from isodesign.optimization.table_problem import (
            PEAK_SLOTS_PER_ROUND,
            TABLE_PEAK_ROUNDS,
        )

        limit = self.study.constraints.get("max_peak_transmissibility_db")
        if limit is None or limit is False:
            return False, 0.0
        moved, left = False, 0.0
        probs = stack.probs if stack is not None else [self.problem(th) for th in thetas]
        for k, (th, pr) in enumerate(zip(thetas, probs, strict=True)):
            xk = stack.block_x(sol, k) if stack is not None else None
            # a scenario not solved yet (just added): its NumPy closure at the design
            sigma, sigma_u = ((pr.sigma(xk), pr.tube_rms(xk)) if xk is not None
                              else pr.closure(pr.study.design_at(values), values))
            d = pr.study.design_at(values)
            # the modes only bound the peak search: the faster side-by-side evaluation
            modes = _modes_at(pr, d, sigma, sigma_u, values=values, side_by_side=True)
            over = measure_peaks(pr, d, sigma, sigma_u, modes, values=values).above(
                limit, PEAK_TOLERANCE_DB)
            if not over:
                continue
            used = placed.setdefault(self.key(th), [])
            # until the scenario NLP's movable frequencies (the nominal optimizer's number,
            # PEAK_SLOTS_PER_ROUND x TABLE_PEAK_ROUNDS, present from its build) are spent
            if len(used) < PEAK_SLOTS_PER_ROUND * TABLE_PEAK_ROUNDS:
                new_pr, new = add_peak_frequencies(pr, _drift_combs(over, used), used)
                if new:
                    used += new
                    self.cache[self.key(th)] = new_pr  # the same NLP, its slots set
                    moved = True
                    continue
            left = max(left, over[0][0])
        return moved, left

    def score(self, theta, values: dict, reference: float | None) -> dict:
        """:meth:`check` where the scenario's NLP is built (its placed peak frequencies
        among its rows), else the NumPy scorer's same numbers without building it
        (:func:`.table_search.score_table_scenario`, equal to 1e-9: a corner the search
        does not add costs no NLP build)."""
        if self.key(theta) in self.cache:
            return self.check(theta, values, reference)
        return score_table_scenario(self.study, theta, values, reference,
                                    n_slots=self.n_slots)

    def check(self, theta, values: dict, reference: float | None) -> dict:
        """Objective J and violations of scenario ``theta`` at a drawn design (NumPy
        closure, the NLP's own constraint expressions)."""
        prob = self.problem(theta)
        d = prob.study.design_at(values)
        # evaluated, not solved (a round sets the modes it solves with again): the
        # scorer's side-by-side evaluation, as score_table_scenario's
        prob.set_modes(_modes_at(prob, d, side_by_side=True))
        x = prob.initial_guess(values)
        # models.distortion: the terms at this design (distortion_rows.params_at)
        _, g = prob.eval_fn(x, getattr(prob, "params_at", lambda x: prob.params())(x))
        viol = [(n, v) for n, v in prob.violations(np.asarray(g).ravel())
                if not n.startswith(("epigraph_", "bound_"))]
        margin = prob.worst_margin_db(x)
        j = float(np.asarray(prob._j_fn(x)).ravel()[0])
        if prob.objective == "worst_band_margin":
            j = -margin
        return {"j": j, "violations": viol, "max_violation": max(v for _, v in viol),
                "gap": None if reference is None else j - reference, "margin_db": margin}


class TableStack:
    """The table's scenario NLPs stacked, sharing the design: the vertical body's
    construction (:func:`.robust.stack_scenarios`, one block per scenario, each its
    :class:`.table_problem.TableProblem` compiled for that scenario) with the interface of
    :class:`.robust.RobustProblem` that :func:`.robust.best_solve` uses.

    Parameters
    ----------
    probs : sequence of TableProblem
        One per scenario, their frozen modes set.
    """

    def __init__(self, probs):
        import casadi as ca

        from isodesign.optimization.robust import block_function, stack_scenarios

        self.probs = list(probs)
        p0 = self.probs[0]
        self.nz = p0.nz
        nlp, self.j_fn = stack_scenarios([(block_function(pr, self.nz), 1) for pr in probs],
                                         self.nz, p0.scaling)
        b = stacked_bounds(self.probs, self.nz, extra_rows=1)  # t <= epsilon
        self.lbg, self.ubg, self.lbx, self.ubx = b["lbg"], b["ubg"], b["lbx"], b["ubx"]
        self.solver = ca.nlpsol("isodesign_table_robust", "ipopt", nlp, p0.ipopt_options())

    def start_from(self, prev, values: dict) -> np.ndarray:
        """``x0`` from a solution ``prev`` of this stack or of a stack of its first scenarios
        (the exchange appends scenarios): the solved scenarios' unknowns kept, an added
        scenario's from its NumPy closure at ``values``, ``t`` the worst of the objectives.

        IPOPT is started from it with the ordinary barrier parameter: warm-started with
        ``prev``'s multipliers too (:data:`.nlp.WARM_OPTIONS`) the built-in table's re-solve
        after a peak round took more iterations (docs/robust.md, section 3).

        Parameters
        ----------
        prev : RobustSolution
        values : dict
            The design at ``prev``.
        """
        nz, nw = self.nz, self.probs[0].nx - self.nz
        k_old = (prev.x.size - nz - 1) // nw
        parts, js = [prev.x[: nz + k_old * nw]], [float(prev.x[-1])]
        for pr in self.probs[k_old:]:
            xk = pr.initial_guess(values)
            js.append(float(np.asarray(pr._j_fn(xk)).ravel()[0]))
            parts.append(xk[nz:])
        return np.concatenate([*parts, [max(js)]])

    def block_x(self, sol, k: int) -> np.ndarray:
        """Scenario ``k``'s variables ``[z, w_k]`` at a solution."""
        start = self.nz + sum(pr.nx - self.nz for pr in self.probs[:k])
        return np.concatenate([sol.x[:self.nz],
                               sol.x[start: start + self.probs[k].nx - self.nz]])

    def params(self) -> np.ndarray:
        """Every scenario NLP's parameters, then the global ones (minimize ``t``)."""
        from isodesign.optimization.robust import global_params

        return np.concatenate([*[pr.params() for pr in self.probs], global_params()])

    def initial_guess(self, values: dict) -> np.ndarray:
        """``x0`` at a design: each scenario's unknowns from its NumPy closure, ``t`` the
        worst of their objectives."""
        x0s = [pr.initial_guess(values) for pr in self.probs]
        js0 = [float(np.asarray(pr._j_fn(x)).ravel()[0]) for pr, x in zip(self.probs, x0s,
                                                                           strict=True)]
        return np.concatenate([x0s[0][:self.nz], *[x[self.nz:] for x in x0s], [max(js0)]])

    def solve(self, x0: np.ndarray, p=None):
        """IPOPT on the stacked NLP from ``x0``; a :class:`.robust.RobustSolution` (every
        scenario's violations, its objective the worst scenario's). models.distortion: the
        outer fixed point over the stack (:func:`.distortion_rows.solve_stack`)."""
        if getattr(self.probs[0], "distortion", False):
            from isodesign.optimization.distortion_rows import solve_stack

            return solve_stack([(pr, lambda: None) for pr in self.probs], x0,
                               self._solve_once, self.params, self.block_x)
        return self._solve_once(x0, p)

    def _solve_once(self, x0: np.ndarray, p=None):
        """One IPOPT solve of the stacked NLP from ``x0``."""
        from isodesign.optimization.robust import RobustSolution

        t0 = time.perf_counter()
        p = self.params() if p is None else np.asarray(p, float)
        res = self.solver(x0=x0, p=p, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        stats = self.solver.stats()
        x = np.asarray(res["x"]).ravel()
        g = np.asarray(res["g"]).ravel()
        viol, row = {}, 0
        for k, pr in enumerate(self.probs):
            ng = pr.lbg.size
            viol[k] = list(pr.violations(g[row: row + ng]))
            row += ng
        js = np.asarray(self.j_fn(x, p)).ravel()
        return RobustSolution(
            x=x, g=g, values=self.probs[0].values(x[:self.nz]), objective=float(np.max(js)),
            epigraph=float(x[-1]), scenario_objectives=js, violations=viol,
            status=stats.get("return_status", "unknown"),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)), wall_s=time.perf_counter() - t0,
            params=p)


@dataclass(frozen=True, eq=False, repr=False)
class TableRobustResult(RobustFields):
    """The answer to a ``robust table`` study (:func:`robust_optimize_table`).

    The common interface is :class:`~.result.StudyResult`'s (and
    :class:`~.result.RobustStudyResult`'s). ``values`` the robust design,
    ``objective_value`` its worst case (the worst margin in dB, or the total volume in
    m^3), ``nominal`` the nominal table optimum, ``rounds`` and ``scenarios`` (each:
    ``index``, ``description``, ``theta``, ``objective``, ``nominal_objective``,
    ``margin_db``, ``worst``, ``binding``, ``active``), ``constraints`` each constraint in
    the scenario where its margin is smallest, ``first_worst_case`` the nominal optimum's
    worst case over the scored scenarios, and for an infeasible run
    ``infeasible_scenario`` (the scenario and its most violated constraint).
    """

    KIND = "robust table"

    first_worst_case: float | None = None
    first_worst_scenario: str | None = None
    last_search_score: float | None = None
    robust_at_nominal: float | None = None

    @property
    def design(self):
        """The robust spring (a :class:`~isodesign.spring.design.SpringDesign`)."""
        return self.study.design_at(self.values)

    def nominal_worst_case(self) -> float | None:
        """The nominal optimum's worst case over the box's corners and centre."""
        return self.first_worst_case

    def sensitivities(self, scenario: int | None = None) -> list:
        """Design-held sensitivities of the robust design's worst margin in a scenario of
        the final set (default: the nominal values of the parameters);
        :func:`table_sensitivities`."""
        th = None
        if scenario is not None:
            row = self.scenarios[scenario]["theta"]
            th = np.array([row[n] for n in self.study.scenarios.names], float)
        return table_sensitivities(self.study, self.values, th)

    def nominal_at_robust(self) -> float | None:
        """The robust design's objective in the nominal scenario (natural units)."""
        return self.robust_at_nominal

    def record(self) -> dict:
        """JSON-ready summary (robust.json), with the keys of the vertical robust record
        (:meth:`.robust_result.RobustResult.record`) and ``table`` True."""
        from isodesign.optimization.objectives import OBJECTIVES

        out = {"feasible": self.feasible, "converged": self.converged, "status": self.status,
               "objective": self.objective, "unit": OBJECTIVES[self.objective].unit,
               "worst_case_objective": self.objective_value,
               "worst_margin_db": self.worst_margin_db, "values": self.values,
               "nominal_values": self.nominal.values,
               "nominal_objective": self.nominal.objective_value,
               "nominal_worst_case": self.first_worst_case, "rounds": list(self.rounds),
               "scenarios": [dict(r) for r in self.scenarios],
               "parameters": [p.label() for p in self.study.scenarios.parameters],
               "settings": dict(self.study.scenarios.settings),
               "constraints": [c.display() for c in self.constraints],
               "limited_by": self.limited_by if self.feasible else [],
               "verdict": self.verdict(), "hessian": self.hessian_choice(),
               "infeasible_scenario": self.infeasible_scenario, "wall_s": self.wall_s,
               "table": True}
        if self.feasible:
            out["nominal_optimum"] = {"values": self.nominal.values,
                                      "objective": self.nominal.objective_value,
                                      "worst_case_in_box": self.first_worst_case,
                                      "worst_case_quantity": "objective",
                                      "worst_case_scenario": self.first_worst_scenario}
            out["robust_at_nominal_scenario"] = self.robust_at_nominal
            out["last_search_score"] = self.last_search_score
        out.update(self.extra)
        return out


def _natural(kind: str, j: float) -> float:
    return -j if kind == "worst_band_margin" else math.exp(j)


def check_robust_table(study) -> None:
    """Refuse, before any solve (the nominal optimum too), a robust table study this
    optimizer cannot answer: free co-design levers, the leveling loop's margin bounds.

    Parameters
    ----------
    study : Study
        With ``[table]`` and ``[scenarios]``.

    Raises
    ------
    InputError
        Naming the study key.
    """
    from isodesign.optimization.variables import refuse_free_levers
    from isodesign.table.leveling import leveling_margin_bounds

    refuse_free_levers(study, "robust design")
    from isodesign.optimization.uncertainty import cg_corner_problem

    unlevelable = cg_corner_problem(study.source, study.scenarios, study)
    if unlevelable is not None:  # no robust design holds a corner no valve can level
        raise InputError(unlevelable)
    if leveling_margin_bounds(study) != (None, None):  # not held over the scenarios yet
        raise InputError("constraints.min_leveling_gain_margin_db: the robust table optimizer "
                         "does not hold the leveling loop's margins over the scenarios; set "
                         "min_leveling_gain_margin_db and min_leveling_phase_margin_deg to "
                         "false (docs/table.md, section 12)")


def robust_optimize_table(study, *, nominal=None, extra_starts=(),
                          seed_scenarios=()) -> TableRobustResult:
    """Robust optimum of a table study with ``[scenarios]`` (see the module docstring).

    Parameters
    ----------
    study : Study
        With ``table`` and ``scenarios``.
    nominal : TableOptimizationResult, optional
        The nominal table optimum (run here by default).
    extra_starts : sequence of dict, optional
        Further designs the first round's solve starts from, besides the nominal optimum
        (a sweep point's finished neighbours' robust optima).
    seed_scenarios : sequence of array, optional
        Scenarios in the set from the first round, their peak frequencies placed at the
        nominal optimum as a scenario the search adds (a sweep point's neighbours' active
        scenarios); the answer is checked by the same search of the box.

    Returns
    -------
    TableRobustResult
    """
    if study.table is None or study.scenarios is None:
        raise InputError("robust_optimize_table: the study needs a [table] and [scenarios]")
    check_robust_table(study)
    t_all = time.perf_counter()
    space = study.scenarios
    settings = space.settings
    if nominal is None:
        nominal = optimize_table(study, analyze=False)
    kind = study.objective["kind"]
    if not nominal.feasible:
        return TableRobustResult(study, nominal, dict(nominal.values), kind, None, False, False,
                                 "nominal study infeasible", wall_s=time.perf_counter() - t_all,
                                 infeasible_scenario={"description": "the nominal scenario"},
                                 constraints=tuple(nominal.constraints))
    tol = settings["tolerance_db"] if kind == "worst_band_margin" else 1e-3
    rng = np.random.default_rng(settings["seed"])
    cands = np.vstack([space.corners(limit=MAX_CORNERS, rng=rng), space.center()[None, :]])
    sc = _Scenarios(study)
    values = dict(nominal.values)

    def search(ref, seed):
        # the corners and the centre through their NLPs where built (the exchange stacks
        # them), else, as the samples and the local maximization, with the NumPy scorer
        return search_box(study, values, ref, sc.score, cands,
                          samples=settings["search_samples"], seed=seed, tol=tol,
                          feas_tol=FEASIBILITY_TOLERANCE, n_slots=sc.n_slots)

    first = search(-nominal.objective_value if kind == "worst_band_margin"
                   else math.log(nominal.objective_value), settings["seed"])
    thetas = [space.center()]
    if first["score"] > 1.0 and not np.allclose(first["theta"], thetas[0]):
        thetas.append(np.asarray(first["theta"], float))
    seeded = add_scenarios(thetas, seed_scenarios)
    rounds, converged, sol_js, status = [], False, None, ""
    best_values = dict(values)
    placed: dict = {}  # scenario -> the movable peak frequencies placed for it
    if seeded:  # their continuous peaks at the nominal optimum, before the first solve
        sc.place_peak_slots(thetas[-seeded:], None, None, values, placed)
    last_s = first["score"]  # the score of the last search of the box
    peak_left = 0.0
    stack = sol = None
    n_stacks = 0
    for r in range(settings["max_rounds"] + 1):
        t0 = time.perf_counter()
        probs = [sc.problem(th) for th in thetas]
        for pr in probs:
            pr.set_modes(_modes_at(pr, pr.study.design_at(values), side_by_side=True))
        # the stacked NLP is built when the scenario set changes; a round that only placed
        # peak frequencies (parameters) re-solves it from the last solution
        new_set = stack is None or len(stack.probs) != len(probs)
        if new_set:
            stack = TableStack(probs)
            n_stacks += 1
        sol = _solve_round(stack, sol, values, [nominal.values, best_values,
                                                *(extra_starts if r == 0 else ())],
                           study, new_set)
        status = sol.status
        g = sol.g
        if not sol.feasible:
            k, cname, amount = sol.worst_scenario()
            th = thetas[k]
            return TableRobustResult(
                study, nominal, values, kind, None, False, False, status,
                rounds=tuple(rounds), wall_s=time.perf_counter() - t_all,
                first_worst_case=_natural(kind, first["check"]["j"]),
                constraints=_scenario_constraints(space, probs, thetas, g),
                infeasible_scenario={"description": space.describe(th),
                                     "theta": space.as_dict(th), "constraint": cname,
                                     "violation": float(amount)})
        values = dict(sol.values)
        best_values = dict(values)
        t_star = sol.epigraph
        moved, peak_left = sc.place_peak_slots(thetas, stack, sol, values, placed)
        # a round that placed peak frequencies solves again first: the box is searched at
        # a design that holds its scenarios' peaks
        found = None if moved else search(t_star, settings["seed"] + r + 1)
        s, th_w = (None, None) if found is None else (found["score"], found["theta"])
        last_s = last_s if s is None else s
        rounds.append({"round": r, "scenarios": len(thetas), "objective": _natural(kind, t_star),
                       "iterations": sol.iterations, "worst_score": s,
                       "peak_slots_moved": moved, "peak_excess_left_db": peak_left,
                       "nlp_built": new_set, **_search_record(found),
                       "wall_s": time.perf_counter() - t0})
        sol_js = t_star
        if not moved and s <= 1.0:
            converged = peak_left == 0.0  # a peak left above its bound: not held
            break
        if r == settings["max_rounds"]:
            break
        if th_w is not None and s > 1.0 and not any(np.allclose(th_w, t) for t in thetas):
            thetas.append(np.asarray(th_w, float))
            # its continuous peaks at the design, before its first solve (saves a round)
            sc.place_peak_slots(thetas[-1:], None, None, values, placed)
        elif not moved:
            break
    reports = _scenario_constraints(space, probs, thetas, g)
    rows = []
    for k, th in enumerate(thetas):
        c = sc.check(th, values, sol_js)
        c_nom = sc.check(th, nominal.values, None)
        pr, ng = probs[k], probs[k].lbg.size
        row0 = sum(p.lbg.size for p in probs[:k])
        binding = [r.name for r in table_constraint_reports(pr, g[row0: row0 + ng]) if r.active]
        worst = bool(c["j"] >= sol_js - tol)
        rows.append({"index": k, "theta": space.as_dict(th), "description": space.describe(th),
                     "objective": _natural(kind, c["j"]),
                     "nominal_objective": _natural(kind, c_nom["j"]),
                     "margin_db": float(c["margin_db"]), "worst": worst, "binding": binding,
                     "active": bool(worst or binding), "max_violation": c["max_violation"]})
    at_nominal = sc.check(space.nominal(), values, None)["j"]
    return TableRobustResult(study, nominal, values, kind, _natural(kind, sol_js), True,
                             converged, status, rounds=tuple(rounds), scenarios=tuple(rows),
                             wall_s=time.perf_counter() - t_all, constraints=reports,
                             first_worst_case=_natural(kind, first["check"]["j"]),
                             first_worst_scenario=space.describe(first["theta"]),
                             last_search_score=float(last_s),
                             extra={"nlp_builds": {"scenarios": sc.builds,
                                                   "stacks": n_stacks},
                                    "first_search": _search_record(first),
                                    "continuation": {"extra_starts": len(extra_starts),
                                                     "seeded_scenarios": seeded}},
                             robust_at_nominal=_natural(kind, at_nominal))


def _search_record(found) -> dict:
    """A round's record of its search of the box (:func:`.table_search.search_box`): how
    many candidates each method scored, and where the worst came from (None: no search,
    the round placed peak frequencies)."""
    ev = {} if found is None else found["evaluations"]
    return {"search_corners": ev.get("corners"), "search_samples": ev.get("samples"),
            "search_refinements": ev.get("refinements"),
            "search_refinement_evaluations": ev.get("refinement"),
            "search_evaluations": None if found is None else sum(ev.values())
            - ev["refinements"],
            "worst_source": None if found is None else found["source"],
            "worst_quantity": None if found is None else found["which"]}


def _solve_round(stack, prev, values: dict, starts: list, study, new_set: bool):
    """One exchange round's solve of the stacked NLP.

    A round on the last round's scenarios (their peak frequencies moved, the modes frozen
    again: parameters of the built NLP) solves it once, in this process, from the last
    solution (:meth:`TableStack.start_from`); should that end infeasible, from the cold
    starts below too. A round with a new scenario set solves, as the vertical exchange
    (:func:`.robust.best_solve`), from the last solution (the added scenario's unknowns
    from its closure) and from ``starts`` (the nominal optimum, the best robust design so
    far) in forked workers, keeping the feasible solution with the best worst case (the
    first on a tie); the first round from ``starts``.

    Returns
    -------
    RobustSolution
    """
    from isodesign.optimization.multistart import map_in_workers

    if prev is None:
        return best_solve(stack, starts, study)
    x0 = stack.start_from(prev, values)
    if not new_set:
        sol = stack.solve(x0)
        return sol if sol.feasible else best_solve(stack, [values, *starts], study)
    cold = []
    for v in starts:
        if not any(all(abs(v[k] / w[k] - 1.0) < 1e-9 for k in v) for w in [values, *cold]):
            cold.append(dict(v))

    def one(item):
        try:
            return stack.solve(x0 if item is None else stack.initial_guess(item))
        except Exception as exc:  # a start that cannot be initialized: the others
            return str(exc)

    sols = [s for s in map_in_workers(one, [None, *cold], workers=study.solver.get("workers"))
            if not isinstance(s, str)]
    if not sols:
        return best_solve(stack, [values, *starts], study)
    feas = [s for s in sols if s.feasible]
    return min(feas, key=lambda s: s.objective) if feas else min(sols,
                                                                 key=lambda s: s.max_violation)


def _scenario_constraints(space, probs, thetas, g) -> tuple:
    """The constraint table of the stacked solve ``g``: each constraint in the scenario
    where its margin is smallest."""
    per, row = [], 0
    for pr in probs:
        ng = pr.lbg.size
        per.append(table_constraint_reports(pr, g[row: row + ng]))
        row += ng
    return worst_constraint_reports(per, [space.describe(th) for th in thetas])
