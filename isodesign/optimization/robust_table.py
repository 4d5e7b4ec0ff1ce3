"""Robust design of a table study (six degrees of freedom): scenarios stacked, exchange.

The same layer as :mod:`.robust` and :mod:`.exchange`, on the table NLP
(:class:`isodesign.table.problem.TableProblem`): every scenario is the table study under
that scenario's payload mass, centre-of-gravity offset (``cg_offset_x_m``,
``cg_offset_y_m``), temperature, and the built spring's tolerances
(:class:`.uncertainty.ScenarioStudy`), its own TableProblem (the leveling pressures and
the mass matrix follow the payload and the CG); the stacked NLP shares the scaled design
``z``, each scenario keeps its closure unknowns, and the worst case is an epigraph over
the scenarios' objectives with every constraint in every scenario. The exchange method
scores the box's corners (at most :data:`MAX_CORNERS`) and centre with each scenario's
NumPy closure and the table NLP's own constraint expressions, adds the worst and repeats.

What the vertical layer has that this one has not (yet): the scenario values as NLP
parameters (here each scenario is compiled numerically, so no parametric sensitivities),
a local maximization inside the box (corners and centre only), the yield and the CLI
summary figures.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.errors import InputError
from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
from isodesign.optimization.study import study_from_dict
from isodesign.optimization.uncertainty import (
    OPERATING_PARAMETERS,
    ScenarioStudy,
    UncertaintySpace,
)
from isodesign.results import ResultDisplay
from isodesign.table.optimize import HESSIAN, _modes_at, optimize_table
from isodesign.table.problem import TableProblem

__all__ = ["MAX_CORNERS", "TableRobustResult", "robust_optimize_table", "table_scenario"]

#: Most corners of the box scored per round (a random subset beyond).
MAX_CORNERS = 16


def table_scenario(study, theta):
    """The table study under scenario ``theta`` (a study object the TableProblem takes).

    Parameters
    ----------
    study : Study
        With ``table`` and ``scenarios``.
    theta : array
        In ``study.scenarios.names`` order.

    Returns
    -------
    Study or ScenarioStudy
    """
    space = study.scenarios
    th = space.as_dict(theta)
    raw = copy.deepcopy(study.raw)
    raw.pop("scenarios", None)
    if "payload_mass_kg" in th:
        raw["payload"]["mass_kg"] = th["payload_mass_kg"]
    if "cg_offset_x_m" in th or "cg_offset_y_m" in th:
        cg = list(raw["table"]["cg_m"])
        cg[0] += th.get("cg_offset_x_m", 0.0)
        cg[1] += th.get("cg_offset_y_m", 0.0)
        raw["table"]["cg_m"] = cg
    if "temperature_k" in th:
        raw["hardware"]["temperature_k"] = th["temperature_k"]
    st = study_from_dict(raw, source=study.source, fill_defaults=False)
    tol = [p for p in space.parameters if p.name not in OPERATING_PARAMETERS]
    if not tol:
        return st
    sub = UncertaintySpace(tuple(tol), space.settings)
    return ScenarioStudy(st, sub, [th[p.name] for p in tol])


class _Scenarios:
    """TableProblems of the scenarios met so far (built once each)."""

    def __init__(self, study):
        self.study = study
        self.cache: dict = {}

    def problem(self, theta):
        key = tuple(np.round(np.asarray(theta, float), 12))
        if key not in self.cache:
            self.cache[key] = TableProblem(table_scenario(self.study, theta), hessian=HESSIAN)
        return self.cache[key]

    def check(self, theta, values: dict, reference: float | None) -> dict:
        """Objective J and violations of scenario ``theta`` at a drawn design (NumPy
        closure, the NLP's own constraint expressions)."""
        prob = self.problem(theta)
        d = prob.study.design_at(values)
        prob.set_modes(_modes_at(prob, d))
        x = prob.initial_guess(values)
        _, g = prob.eval_fn(x, prob.params())
        viol = [(n, v) for n, v in prob.violations(np.asarray(g).ravel())
                if not n.startswith(("bound_", "worst_band_margin_epigraph"))]
        j = float(np.asarray(prob._j_fn(x)).ravel()[0])
        if prob.objective == "worst_band_margin":
            j = -prob.worst_margin_db(x)
        return {"j": j, "violations": viol, "max_violation": max(v for _, v in viol),
                "gap": None if reference is None else j - reference}


def _stack(probs, study):
    """The stacked NLP of the scenarios' TableProblems sharing z."""
    import casadi as ca

    p0 = probs[0]
    nz = p0.nz
    z = ca.MX.sym("z", nz)
    t = ca.MX.sym("t")
    xs, ps, gs, js, lbg, ubg, lbx, ubx = [], [], [], [], [], [], [], []
    for k, pr in enumerate(probs):
        w = ca.MX.sym(f"w{k}", pr.nx - nz)
        p = ca.MX.sym(f"p{k}", pr.params().size)
        jk, gk = pr.eval_fn(ca.vertcat(z, w), p)
        xs.append(w)
        ps.append(p)
        gs.append(gk)
        js.append(jk)
        lbg.append(pr.lbg)
        ubg.append(pr.ubg)
        lbx.append(pr.lbx[nz:])
        ubx.append(pr.ubx[nz:])
    g = ca.vertcat(*gs, *[j - t for j in js])
    x = ca.vertcat(z, *xs, t)
    solver = ca.nlpsol("isodesign_table_robust", "ipopt",
                       {"x": x, "f": t, "g": g, "p": ca.vertcat(*ps)}, p0.ipopt_options())
    bounds = {"lbg": np.concatenate([*lbg, np.full(len(probs), -np.inf)]),
              "ubg": np.concatenate([*ubg, np.zeros(len(probs))]),
              "lbx": np.concatenate([p0.lbx[:nz], *lbx, [-300.0]]),
              "ubx": np.concatenate([p0.ubx[:nz], *ubx, [300.0]])}
    return solver, bounds


@dataclass(frozen=True, eq=False, repr=False)
class TableRobustResult(ResultDisplay):
    """Outcome of :func:`robust_optimize_table`.

    ``values`` the robust design, ``objective_value`` its worst case (the worst margin in
    dB, or the total volume in m^3), ``nominal`` the nominal table optimum, ``rounds`` and
    ``scenarios`` (each: ``description``, ``theta``, ``objective``, ``worst``), and for an
    infeasible run ``infeasible_scenario`` (the scenario and its most violated constraint).
    """

    study: Any
    nominal: Any
    values: dict
    objective: str
    objective_value: float | None
    feasible: bool
    converged: bool
    status: str
    rounds: tuple = ()
    scenarios: tuple = ()
    wall_s: float = 0.0
    infeasible_scenario: dict | None = None
    extra: dict = field(default_factory=dict)

    def raise_for_status(self) -> TableRobustResult:
        """Raise :class:`~isodesign.errors.SolverError` naming the scenario that cannot be
        met unless a robust design was found; return self (as the nominal results do)."""
        from isodesign.errors import SolverError

        if not self.feasible:
            raise SolverError(self.failure_message())
        return self

    def failure_message(self) -> str:
        """One line naming the scenario that cannot be met."""
        s = self.infeasible_scenario or {}
        return (f"no design meets every constraint in the scenario {s.get('description')} "
                f"({self.status}); most violated there: {s.get('constraint')} "
                f"({s.get('violation', 0.0):.3g} in the NLP's units)")

    def to_frame(self):
        """One row per scenario of the final set."""
        import pandas as pd

        return pd.DataFrame([{**r["theta"], "objective": r["objective"], "worst": r["worst"]}
                             for r in self.scenarios])

    def _summary_items(self):
        v = self.values
        return [("study", self.study.name), ("", "robust" if self.feasible else "NO ROBUST"),
                ("worst case", "n/a" if self.objective_value is None
                 else f"{self.objective_value:+.3f}"),
                ("design", f"N {v['volume_ratio']:.4g}, V_t0 {v['top_volume_m3'] * 1e3:.4g} L, "
                           f"L_c {v['capillary_length_m'] * 1e3:.4g} mm, D_c "
                           f"{v['capillary_diameter_m'] * 1e3:.4g} mm"),
                ("rounds", f"{len(self.rounds)}, {len(self.scenarios)} scenarios")]


def _natural(kind: str, j: float) -> float:
    return -j if kind == "worst_band_margin" else math.exp(j)


def robust_optimize_table(study, *, nominal=None) -> TableRobustResult:
    """Robust optimum of a table study with ``[scenarios]`` (see the module docstring).

    Parameters
    ----------
    study : Study
        With ``table`` and ``scenarios``.
    nominal : TableOptimizationResult, optional
        The nominal table optimum (run here by default).

    Returns
    -------
    TableRobustResult
    """
    if study.table is None or study.scenarios is None:
        raise InputError("robust_optimize_table: the study needs a [table] and [scenarios]")
    from isodesign.optimization.variables import refuse_free_levers
    from isodesign.table.leveling import leveling_margin_bounds

    refuse_free_levers(study, "robust design")
    if leveling_margin_bounds(study) != (None, None):  # not held over the scenarios yet
        raise InputError("constraints.min_leveling_gain_margin_db: the robust table optimizer "
                         "does not hold the leveling loop's margins over the scenarios; set "
                         "min_leveling_gain_margin_db and min_leveling_phase_margin_deg to "
                         "false (docs/table.md, section 12)")
    t_all = time.perf_counter()
    space = study.scenarios
    settings = space.settings
    if nominal is None:
        nominal = optimize_table(study, analyze=False)
    kind = study.objective["kind"]
    if not nominal.feasible:
        return TableRobustResult(study, nominal, dict(nominal.values), kind, None, False, False,
                                 "nominal study infeasible", wall_s=time.perf_counter() - t_all,
                                 infeasible_scenario={"description": "the nominal scenario"})
    tol = settings["tolerance_db"] if kind == "worst_band_margin" else 1e-3
    rng = np.random.default_rng(settings["seed"])
    cands = np.vstack([space.corners(limit=MAX_CORNERS, rng=rng), space.center()[None, :]])
    sc = _Scenarios(study)
    values = dict(nominal.values)

    def search(ref):
        best = (-math.inf, None, None)
        for th in cands:
            c = sc.check(th, values, ref)
            s = max(c["gap"] / tol, c["max_violation"] / FEASIBILITY_TOLERANCE)
            if s > best[0]:
                best = (s, th, c)
        return best

    first = search(-nominal.objective_value if kind == "worst_band_margin"
                   else math.log(nominal.objective_value))
    thetas = [space.center()]
    if first[0] > 1.0 and not np.allclose(first[1], thetas[0]):
        thetas.append(first[1])
    rounds, converged, sol_js, status = [], False, None, ""
    for r in range(settings["max_rounds"] + 1):
        t0 = time.perf_counter()
        probs = [sc.problem(th) for th in thetas]
        for pr in probs:
            pr.set_modes(_modes_at(pr, pr.study.design_at(values)))
        solver, b = _stack(probs, study)
        x0s = [pr.initial_guess(values) for pr in probs]
        nz = probs[0].nz
        js0 = [float(np.asarray(pr._j_fn(x)).ravel()[0]) for pr, x in zip(probs, x0s,
                                                                           strict=True)]
        x0 = np.concatenate([x0s[0][:nz], *[x[nz:] for x in x0s], [max(js0)]])
        p = np.concatenate([pr.params() for pr in probs])
        res = solver(x0=x0, p=p, **b)
        stats = solver.stats()
        status = stats.get("return_status", "unknown")
        x = np.asarray(res["x"]).ravel()
        g = np.asarray(res["g"]).ravel()
        row, worst = 0, (0, "", 0.0)
        for k, pr in enumerate(probs):
            ng = pr.lbg.size
            for n, v in pr.violations(g[row: row + ng]):
                if v > worst[2]:
                    worst = (k, n, v)
            row += ng
        if worst[2] > FEASIBILITY_TOLERANCE:
            th = thetas[worst[0]]
            return TableRobustResult(
                study, nominal, values, kind, None, False, False, status,
                rounds=tuple(rounds), wall_s=time.perf_counter() - t_all,
                infeasible_scenario={"description": space.describe(th),
                                     "theta": space.as_dict(th), "constraint": worst[1],
                                     "violation": float(worst[2])})
        values = probs[0].values(x[:nz])
        t_star = float(x[-1])
        s, th_w, _ = search(t_star)
        rounds.append({"round": r, "scenarios": len(thetas), "objective": _natural(kind, t_star),
                       "iterations": int(stats.get("iter_count", -1)), "worst_score": s,
                       "wall_s": time.perf_counter() - t0})
        sol_js = t_star
        if s <= 1.0:
            converged = True
            break
        if r == settings["max_rounds"] or any(np.allclose(th_w, t) for t in thetas):
            break
        thetas.append(np.asarray(th_w, float))
    rows = []
    for th in thetas:
        c = sc.check(th, values, sol_js)
        rows.append({"theta": space.as_dict(th), "description": space.describe(th),
                     "objective": _natural(kind, c["j"]), "worst": c["j"] >= sol_js - tol,
                     "max_violation": c["max_violation"]})
    return TableRobustResult(study, nominal, values, kind, _natural(kind, sol_js), True,
                             converged, status, rounds=tuple(rounds), scenarios=tuple(rows),
                             wall_s=time.perf_counter() - t_all)
