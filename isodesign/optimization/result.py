"""The outcome of an optimization: :class:`OptimizationResult` and its start records."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from isodesign.errors import SolverError
from isodesign.optimization.constraints import ConstraintReport
from isodesign.optimization.explain import (
    BINDING_NOTE,
    constraint_table_lines,
    constraint_table_rows,
    limiting_factors,
    limiting_summary,
)
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.variables import DESIGN_VARIABLE_UNITS, DESIGN_VARIABLES
from isodesign.plotting.optimization import all_bands_response, optimization_figure
from isodesign.plotting.response import draw_bands, judged_mask
from isodesign.plotting.style import OPTIMUM, START
from isodesign.results import ResultDisplay

__all__ = ["OptimizationResult", "StartRecord"]

#: Design variable -> (symbol, factor, unit) as the command line shows it.
_DISPLAY = {
    "volume_ratio": ("N = V_b0/V_t0", 1.0, "-"),
    "top_volume_m3": ("V_t0", 1e3, "L"),
    "capillary_length_m": ("L_c", 1e3, "mm"),
    "capillary_diameter_m": ("D_c", 1e3, "mm"),
}


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

    @property
    def scope(self):
        """What the answer covers and leaves out (:class:`~isodesign.response.scope.Scope`).

        None for a run without a feasible design (nothing was analysed).
        """
        return None if self.analysis is None else self.analysis.scope

    @property
    def limited_by(self) -> list[str]:
        """Sentences saying which limits stopped the design
        (:func:`~isodesign.optimization.explain.limiting_factors`)."""
        return limiting_factors(self)

    def to_frame(self):
        """Design variables and figures, start vs optimum (one row per quantity).

        SI units (``unit`` column); a constraint's ``note`` gives its margin (distance to
        the nearest bound) in the same unit, and ``BINDING`` when it is within 0.5 % of
        its bound. Constraints have no start value (``start`` is None).
        """
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
                         + f"margin {c.margin_natural:.3g} {c.unit}"})
        return pd.DataFrame(rows)

    def starts_frame(self):
        """One row per start (status, iterations, time, objective)."""
        import pandas as pd

        return pd.DataFrame([s.row() for s in self.starts])

    def _display_frame(self):
        """Start against optimum in the command line's units (L, mm); no constraints."""
        import pandas as pd

        rows = []
        for n in DESIGN_VARIABLES:
            sym, scale, unit = _DISPLAY[n]
            fixed = self.study.variable(n).fixed
            rows.append({"quantity": sym, "start": self.start_values[n] * scale,
                         "optimum": self.values[n] * scale, "unit": unit,
                         "note": "fixed" if fixed else ""})
        tv0 = self.start_values["top_volume_m3"] * (1.0 + self.start_values["volume_ratio"])
        tv1 = self.values["top_volume_m3"] * (1.0 + self.values["volume_ratio"])
        rows.append({"quantity": "total volume", "start": tv0 * 1e3, "optimum": tv1 * 1e3,
                     "unit": "L", "note": "per isolator"})
        o = OBJECTIVES[self.objective]
        sc = getattr(o, "display_scale", 1.0)
        rows.append({"quantity": f"objective: {self.objective}",
                     "start": None if self.start_objective is None else self.start_objective * sc,
                     "optimum": self.objective_value * sc,
                     "unit": getattr(o, "display_unit", o.unit), "note": "NLP grid"})
        return pd.DataFrame(rows)

    def _extra_lines(self) -> list[str]:
        lines = ["", *constraint_table_lines(self, "constraints")]
        if self.scope is not None:
            lines += ["", *self.scope.lines()]
        return lines

    def __str__(self) -> str:
        return super().__str__() + "\n" + "\n".join(self._extra_lines())

    def _repr_html_(self) -> str:
        import html

        e = html.escape
        base = super()._repr_html_()
        head = ["", "constraint", "value", "bound", "margin", "unit"]
        rows = "".join("<tr>" + "".join(f"<td>{e(x)}</td>" for x in r) + "</tr>"
                       for r in constraint_table_rows(self))
        extra = [f"<p><strong>constraints</strong> ({e(BINDING_NOTE)})</p><table><tr>"
                 + "".join(f"<th>{e(h)}</th>" for h in head) + f"</tr>{rows}</table>"]
        if self.feasible:
            extra.append(f"<p>{e(limiting_summary(self))}:</p><ul>"
                         + "".join(f"<li>{e(t)}</li>" for t in self.limited_by) + "</ul>")
        if self.scope is not None:
            extra.append("<p>" + "<br>".join(e(t) for t in self.scope.lines()) + "</p>")
        return base[: -len("</div>")] + "".join(extra) + "</div>"

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


