"""The outcome of a robust optimization: :class:`RobustResult`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.optimization.constraints import constraint_reports
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.result import RobustStudyResult, worst_constraint_reports
from isodesign.optimization.scenario_check import scenario_check
from isodesign.optimization.sensitivity import design_sensitivities, reoptimized_sensitivities

__all__ = ["RobustResult", "scenario_constraints", "scenario_rows"]


def scenario_rows(study, prob, sol, grid, nominal_values=None) -> list[dict]:
    """One row per scenario of the final set: its values, objective, binding constraints.

    Parameters
    ----------
    study : Study
    prob : RobustProblem
    sol : RobustSolution
    grid : Grid
    nominal_values : dict, optional
        The nominal optimum; its objective in each scenario is added
        (``nominal_objective``).

    Returns
    -------
    list of dict
        ``index``, ``theta`` ({parameter: value}), ``description``, ``objective``
        (natural), ``margin_db`` (the worst target band's margin there, dB), ``worst``
        (the objective sets the worst case there, within the tolerance), ``binding``
        (constraints binding in that scenario), ``active`` (worst or binding: the
        scenarios that shape the design).
    """
    space = study.scenarios
    obj = OBJECTIVES[prob.block.objective]
    tol = space.settings["tolerance_db"] if obj.db else 1e-3
    rows = []
    for k, th in enumerate(prob.thetas):
        reps = constraint_reports(prob.block.con_rows, prob.block_g(sol, k))
        binding = [c.name for c in reps if c.active]
        # the epigraph variable of a scenario that does not set the worst case is slack in
        # the stacked NLP: its objective is evaluated afresh (NumPy analysis)
        chk = scenario_check(study, sol.values, th, grid=grid)
        j = obj.from_natural(chk["objective"])
        worst = j >= sol.objective - tol
        nom = None if nominal_values is None else scenario_check(
            study, nominal_values, th, grid=grid)["objective"]
        rows.append({"index": k, "theta": space.as_dict(th), "description": space.describe(th),
                     "objective": obj.to_natural(j), "nominal_objective": nom,
                     "margin_db": float(chk["criterion_margin_db"]),
                     "worst": bool(worst), "binding": binding, "active": bool(worst or binding)})
    return rows


def scenario_constraints(study, prob, sol) -> tuple:
    """The robust design's constraint table: each constraint in the scenario of the final
    set where its margin is smallest (:func:`.result.worst_constraint_reports`).

    Parameters
    ----------
    study : Study
        With ``scenarios`` (their descriptions).
    prob : RobustProblem
        The stacked NLP of the final scenario set.
    sol : RobustSolution
        Its solution (each scenario's constraint rows).

    Returns
    -------
    tuple of ConstraintReport
    """
    per = [constraint_reports(prob.block.con_rows, prob.block_g(sol, k))
           for k in range(len(prob.thetas))]
    return worst_constraint_reports(per, [study.scenarios.describe(th) for th in prob.thetas])


@dataclass(frozen=True, eq=False, repr=False)
class RobustFields(RobustStudyResult):
    """The fields both robust answers carry, declared once (:class:`RobustResult`,
    :class:`~.robust_table.TableRobustResult`): the study, the nominal optimum, the robust
    design's ``values``, the objective's kind and worst case, feasibility, convergence and
    solver status, then the exchange's ``rounds`` and final ``scenarios``, the wall time,
    the scenario that cannot be met (``infeasible_scenario``), further record entries
    (``extra``) and the constraint table (each constraint in the scenario where its margin
    is smallest)."""

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
    constraints: tuple = ()


@dataclass(frozen=True, eq=False, repr=False)
class RobustResult(RobustFields):
    """The answer to a ``robust`` study (:func:`isodesign.optimization.exchange.robust_optimize`).

    The common interface is :class:`~.result.StudyResult`'s (and
    :class:`~.result.RobustStudyResult`'s): ``constraints`` holds each constraint in the
    scenario where its margin is smallest (:func:`scenario_constraints`).

    ``values`` is the robust (drawn) design, ``objective_value`` its stated worst case
    over the scenario box (natural units), ``nominal`` the nominal optimum
    (:class:`~.result.OptimizationResult`), ``rounds`` the exchange rounds (scenarios,
    objective, worst excess found by the search), ``scenarios`` the final scenario set
    (:func:`scenario_rows`; ``active`` ones shape the design), ``first_search`` the
    worst case of the *nominal* optimum over the box, ``last_search`` the final
    search (its ``score`` <= 1: nothing in the box exceeds the tolerances).
    An infeasible result names the scenario that cannot be met
    (``infeasible_scenario``).
    """

    KIND = "robust"

    #: the robust spring (a :class:`~isodesign.spring.design.SpringDesign`)
    design: Any = None
    first_search: dict | None = None
    last_search: dict | None = None
    problem: Any = None
    solution: Any = None

    # -- construction of failures ---------------------------------------------------------
    @classmethod
    def infeasible_nominal(cls, study, nominal, wall_s):
        """The nominal study itself has no feasible design."""
        return cls(study=study, nominal=nominal, values=dict(nominal.values),
                   design=nominal.design, objective=nominal.objective, objective_value=None,
                   feasible=False, converged=False, status="nominal study infeasible",
                   wall_s=wall_s, constraints=tuple(nominal.constraints),
                   infeasible_scenario={
                       "description": "the nominal scenario",
                       "constraint": ", ".join(n for n, _ in nominal.violations[:3]),
                       "violation": float(max((v for _, v in nominal.violations),
                                              default=0.0))})

    @classmethod
    def infeasible(cls, study, nominal, prob, sol, k, cname, amount, rounds, wall_s):
        """No design meets every constraint in scenario ``k``."""
        th = prob.thetas[k]
        return cls(study=study, nominal=nominal, values=dict(sol.values),
                   design=study.design_at(sol.values), objective=prob.block.objective,
                   objective_value=None, feasible=False, converged=False, status=sol.status,
                   rounds=tuple(rounds), problem=prob, solution=sol, wall_s=wall_s,
                   constraints=scenario_constraints(study, prob, sol),
                   infeasible_scenario={"index": k, "theta": study.scenarios.as_dict(th),
                                        "description": study.scenarios.describe(th),
                                        "constraint": cname, "violation": float(amount)})

    def nominal_at_robust(self) -> float:
        """The robust design's objective in the nominal scenario (natural units)."""
        return scenario_check(self.study, self.values, self.study.scenarios.nominal())[
            "objective"]

    def nominal_worst_case(self) -> float | None:
        """The nominal optimum's worst case over the box, as the first search found it."""
        if self.first_search is None:
            return None
        return self.first_search["check"]["objective"]

    def sensitivities(self, scenario: int | None = None):
        """Design-held sensitivities at the robust design in a scenario (default: the
        nominal values of the parameters); see :func:`.sensitivity.design_sensitivities`."""
        b = self.problem.block
        if scenario is None:
            th = self.study.scenarios.nominal()
            b.select(th, b.base_slot_hz)
            x = b.initial_guess(self.values)
            return design_sensitivities(b, x, th)
        th = self.problem.thetas[scenario]
        b.select(th, self.problem.slots[scenario])
        return design_sensitivities(b, self.problem.block_x(self.solution, scenario), th,
                                    self.problem.slots[scenario])

    def reoptimized_sensitivities(self) -> dict:
        """lam_p of the final robust solve (:func:`.sensitivity.reoptimized_sensitivities`)."""
        return reoptimized_sensitivities(self.problem, self.solution)

    def record(self) -> dict:
        """JSON-ready summary (robust.json)."""
        o = OBJECTIVES[self.objective]

        def clean(x):
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items()}
            if isinstance(x, list | tuple):
                return [clean(v) for v in x]
            if isinstance(x, np.ndarray):
                return [clean(v) for v in x.tolist()]
            if isinstance(x, np.floating | np.integer | np.bool_):
                return x.item()
            return x

        out = {"feasible": self.feasible, "converged": self.converged, "status": self.status,
               "objective": self.objective, "unit": o.unit,
               "worst_case_objective": self.objective_value, "values": self.values,
               "parameters": [p.label() for p in self.study.scenarios.parameters],
               "settings": self.study.scenarios.settings, "rounds": list(self.rounds),
               "scenarios": list(self.scenarios), "wall_s": self.wall_s,
               "infeasible_scenario": self.infeasible_scenario}
        if self.feasible:
            out["nominal_optimum"] = {"values": self.nominal.values,
                                      "objective": self.nominal.objective_value,
                                      "worst_case_in_box": self.nominal_worst_case(),
                                      "worst_case_quantity": self.first_search["which"],
                                      "worst_case_scenario": self.study.scenarios.describe(
                                          self.first_search["theta"])}
            out["robust_at_nominal_scenario"] = self.nominal_at_robust()
            out["last_search_score"] = self.last_search["score"]
        out.update(self.extra)
        return clean(out)
