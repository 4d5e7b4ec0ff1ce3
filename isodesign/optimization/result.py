"""The outcome of an optimization: :class:`OptimizationResult` and its start records."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from isodesign.errors import SolverError
from isodesign.optimization.constraints import ConstraintReport
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.variables import DESIGN_VARIABLE_UNITS, DESIGN_VARIABLES
from isodesign.plotting.optimization import all_bands_response, optimization_figure
from isodesign.plotting.response import draw_bands, judged_mask
from isodesign.plotting.style import OPTIMUM, START
from isodesign.results import ResultDisplay

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


@dataclass(frozen=True, eq=False, repr=False)
class OptimizationResult(ResultDisplay):
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

    def _summary_items(self) -> list[tuple[str, str]]:
        """Feasibility, objective, design and binding constraints (for repr and notebooks)."""
        o = OBJECTIVES.get(self.objective)
        v = self.values
        items = [
            ("study", self.study.name),
            ("", "feasible" if self.feasible else "NO FEASIBLE DESIGN (best point found)"),
            (self.objective, o.format(self.objective_value) if o is not None
             else f"{self.objective_value:.6g}"),
            ("design", f"N {v['volume_ratio']:.4g}, V_t0 {v['top_volume_m3'] * 1e3:.4g} L, "
                       f"L_c {v['capillary_length_m'] * 1e3:.4g} mm, "
                       f"D_c {v['capillary_diameter_m'] * 1e3:.4g} mm"),
            ("binding", ", ".join(c.name for c in self.constraints if c.active) or "none"),
        ]
        if self.analysis is not None:
            a = self.analysis
            items.insert(2, ("verdict", f"{'PASS' if a.passes else 'FAIL'} (worst band "
                                        f"{a.worst_band_label} Hz {a.worst_margin_db:+.2f} dB)"))
        if not self.feasible:
            items.append(("most violated", ", ".join(n for n, _ in self.violations[:3])))
        items.append(("starts", f"{len(self.starts)} ({self.n_reached_best} reached the best)"))
        return items

    def plot(self, ax=None):
        """Start design against optimum: bands (all, judged ones shaded) and |T| (dB, phase).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw the band panel only (start and optimum in every band), into this axes.
            Default: a new figure with the bands and the transmissibility.

        Returns
        -------
        matplotlib.figure.Figure
            Made with an Agg canvas; the global Matplotlib backend is not touched.

        Raises
        ------
        ValueError
            For a run without a feasible design (nothing was analysed).
        """
        if ax is None:
            return optimization_figure(self)
        if self.analysis is None or self.start_analysis is None:
            raise ValueError("plot: the result has no band analysis (infeasible run)")
        st = self.study
        start_all = all_bands_response(st, st.design_at(self.start_values))
        opt_all = all_bands_response(st, self.design)
        tg = st.raw["target"]
        judged = judged_mask(opt_all.bands, (tg["band_min_hz"], tg["band_max_hz"]))
        draw_bands(ax, [("payload, start design", start_all, START),
                        ("payload, optimum", opt_all, OPTIMUM)], judged=judged)
        return ax.figure


