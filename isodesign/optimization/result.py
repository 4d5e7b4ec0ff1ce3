"""The outcome of an optimization: :class:`OptimizationResult` and its start records."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from isodesign.errors import SolverError
from isodesign.optimization.constraints import ConstraintReport
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.variables import DESIGN_VARIABLE_UNITS, DESIGN_VARIABLES

__all__ = ["OptimizationResult", "StartRecord"]


@dataclass(frozen=True)
class StartRecord:
    """One start of the multi-start run."""

    index: int
    start: dict
    status: str
    success: bool
    feasible: bool
    iterations: int
    wall_s: float
    objective: float
    max_violation: float
    final: dict

    def row(self) -> dict:
        """Flat dict for a table."""
        r = {"start": self.index, "status": self.status, "success": self.success,
             "feasible": self.feasible, "iterations": self.iterations, "wall_s": self.wall_s,
             "objective": self.objective, "max_violation": self.max_violation}
        r.update({f"start_{k}": v for k, v in self.start.items()})
        r.update({f"final_{k}": v for k, v in self.final.items()})
        return r


@dataclass(frozen=True, eq=False)
class OptimizationResult:
    """Outcome of :func:`isodesign.optimization.driver.optimize`.

    ``feasible`` is False when no start found a design that satisfies every
    constraint; ``design`` is then the best point found (least violation),
    reported with ``violations`` and not to be used as a design. ``peak`` records
    the exchange method on the peak grid: rounds, added frequencies, and the
    continuous peak of |T| at the optimum (dB, Hz), its limit and whether it was
    met. A feasible result (every constraint met on the NLP's grid) whose
    continuous peak stayed above its limit after the last refinement round has
    that excess (dB) in ``violations``; it is not a :attr:`success`. ``branches`` lists the starts
    whose branches were refined before the winner was chosen, with their refined
    objective values (natural units), the winner first.
    """

    study: Any
    objective: str
    feasible: bool
    status: str
    design: Any
    values: dict
    objective_value: float
    start_values: dict
    start_objective: float | None
    constraints: tuple[ConstraintReport, ...]
    starts: tuple[StartRecord, ...]
    n_reached_best: int
    violations: tuple[tuple[str, float], ...]
    flat_direction: dict | None
    recheck_max_rel_diff: float | None
    analysis: Any = None
    start_analysis: Any = None
    wall_s: float = 0.0
    settings: dict = field(default_factory=dict)
    peak: dict | None = None
    branches: tuple[tuple[int, float], ...] = ()

    @property
    def success(self) -> bool:
        """True for a feasible, re-checked optimum without a violation."""
        return (self.feasible and self.recheck_max_rel_diff is not None
                and not self.violations)

    def raise_for_status(self) -> None:
        """Raise :class:`SolverError` unless the run found a feasible optimum."""
        if not self.feasible:
            worst = ", ".join(f"{n} ({v:.3g})" for n, v in self.violations[:3])
            raise SolverError(f"no feasible design ({self.status}); most violated: {worst}")

    def to_frame(self):
        """Design variables and figures, start vs optimum (one row per quantity)."""
        import pandas as pd

        rows = []
        for n in DESIGN_VARIABLES:
            fixed = self.study.variable(n).fixed
            rows.append({"quantity": n, "start": self.start_values[n], "optimum": self.values[n],
                         "unit": DESIGN_VARIABLE_UNITS[n], "note": "fixed" if fixed else ""})
        unit = OBJECTIVES[self.objective].unit
        rows.append({"quantity": f"objective: {self.objective}", "start": self.start_objective,
                     "optimum": self.objective_value, "unit": unit, "note": ""})
        for c in self.constraints:
            rows.append({"quantity": f"constraint: {c.name}", "start": None, "optimum": c.value,
                         "unit": c.unit, "note": ("BINDING " if c.active else "")
                         + f"margin {c.margin:.3g}"})
        return pd.DataFrame(rows)

    def starts_frame(self):
        """One row per start (status, iterations, time, objective)."""
        import pandas as pd

        return pd.DataFrame([s.row() for s in self.starts])
