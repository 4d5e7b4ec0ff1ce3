"""The outcome of an optimization: :class:`StudyResult` (the one result type of every study
kind), :class:`OptimizationResult` (the vertical kind) and its start records."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from isodesign.errors import InputError, SolverError
from isodesign.optimization.constraints import ConstraintReport
from isodesign.optimization.explain import (
    BINDING_NOTE,
    constraint_table_lines,
    constraint_table_rows,
    limiting_factors,
    limiting_summary,
)
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.variables import DESIGN_VARIABLE_UNITS, TABLE_LEVER_UNITS
from isodesign.plotting.optimization import all_bands_response, optimization_figure
from isodesign.plotting.response import draw_bands, judged_mask
from isodesign.plotting.style import OPTIMUM, START
from isodesign.results import ResultDisplay

__all__ = ["OptimizationResult", "RobustStudyResult", "StartRecord", "StudyResult",
           "worst_constraint_reports"]

#: Design variable -> (symbol, factor, unit) as the command line shows it.
_DISPLAY = {
    "volume_ratio": ("N = V_b0/V_t0", 1.0, "-"),
    "top_volume_m3": ("V_t0", 1e3, "L"),
    "capillary_length_m": ("L_c", 1e3, "mm"),
    "capillary_diameter_m": ("D_c", 1e3, "mm"),
}


class StudyResult(ResultDisplay):
    """The one result type of :func:`isodesign.optimize`: the common interface of every kind.

    Every optimization returns a subclass of this class, one per study kind
    (:attr:`kind`): :class:`OptimizationResult` (``vertical``),
    :class:`~isodesign.optimization.table_driver.TableOptimizationResult` (``table``),
    :class:`~isodesign.optimization.robust_result.RobustResult` (``robust``) and
    :class:`~isodesign.optimization.robust_table.TableRobustResult` (``robust table``).
    This class owns what they share, written once:

    * :attr:`kind`, :attr:`status` and :attr:`feasible` (fields), :attr:`success`,
      :meth:`raise_for_status`, :meth:`verdict` (one line, PASS only for a success),
      :attr:`worst_margin_db` (the verdict's margin: over every judged band, and for a
      table every point and axis, and for a robust result the worst over the final
      scenario set) and :attr:`values` (the design variables, SI);
    * the constraint table (:attr:`constraints`, :meth:`constraints_frame`,
      :meth:`constraint_lines`) with binding flags, :attr:`limited_by` and
      :meth:`limiting_summary` (the sentence naming the limit that stopped the design);
      a robust result's table holds each constraint in the scenario where its margin is
      smallest;
    * :meth:`starts_frame` (a robust result: the starts of its nominal multi-start),
      :meth:`to_frame` (design variables, objective, worst margin, constraints),
      :meth:`plot`, ``str``, ``repr`` and ``_repr_html_``;
    * :meth:`hessian_choice`: IPOPT's Hessian of the run and why.

    The kind-specific parts (a table's modes and peaks, a robust result's scenarios and
    rounds) are the subclasses' own attributes.
    """

    __slots__ = ()

    #: The study kind this class answers (one of
    #: :data:`isodesign.optimization.dispatch.KINDS`).
    KIND = ""

    def __new__(cls, *args, **kwargs):
        # the common interface holds no result: StudyResult() had no fields to show
        if not cls.KIND:
            raise InputError(f"{cls.__name__}: the common interface of isodesign.optimize's "
                             "results, not a result; get one from isodesign.optimize(study)")
        return super().__new__(cls)

    # -- hooks of the subclasses ---------------------------------------------------------------
    def _checked(self) -> bool:
        """Whether the result passed its kind's checks (re-check, exchange convergence)."""
        return True

    def _broken(self) -> tuple:
        """``(name, amount)`` of the constraints the returned design breaks."""
        return tuple(getattr(self, "violations", ()))

    def _start_values(self) -> dict:
        """The design the optimization started from (SI)."""
        return dict(getattr(self, "start_values", {}))

    def _start_objective(self):
        return getattr(self, "start_objective", None)

    def _start_worst_margin(self):
        a = getattr(self, "start_analysis", None)
        return None if a is None else float(a.worst_margin_db)

    def _start_rows(self) -> list[dict]:
        nominal = getattr(self, "nominal", None)
        return [] if nominal is None else nominal._start_rows()

    def _variable_notes(self) -> dict:
        """A note per design variable (``fixed``, a lever's bound), for :meth:`to_frame`."""
        st = self.study
        return {v.name: "fixed" for v in (*st.variables, *getattr(st, "levers", ()))
                if v.fixed}

    def _band_verdict(self) -> str:
        a = getattr(self, "analysis", None)
        if a is not None:
            return a.verdict()
        w = self.worst_margin_db
        return "worst margin n/a" if w is None else \
            f"worst margin {w:+.2f} dB on the NLP's grid"

    def _margin_basis(self) -> str:
        if getattr(self, "analysis", None) is not None:
            return "fine grid" + (", every point and axis" if self.kind == "table" else "")
        return "NLP grid"

    def _kind_items(self) -> list[tuple[str, str]]:
        return []

    def _extra_lines(self) -> list[str]:
        return []

    def _draw(self, ax) -> None:
        raise NotImplementedError

    def _figure(self):
        from isodesign.plotting.style import new_figure

        fig = new_figure(7.0, 4.0)
        self._draw(fig.add_subplot(1, 1, 1))
        return fig

    # -- the common interface ------------------------------------------------------------------
    @property
    def kind(self) -> str:
        """The study kind answered: ``vertical``, ``table``, ``robust`` or ``robust table``."""
        return self.KIND

    @property
    def robust(self) -> bool:
        """True for the answer to a study with ``[scenarios]``."""
        return self.KIND.startswith("robust")

    @property
    def success(self) -> bool:
        """True for a feasible, checked design that breaks no constraint (a PASS candidate)."""
        return bool(self.feasible and self._checked() and not self._broken())

    def failure_message(self) -> str:
        """One line: why the result is not a usable design (the status and what is broken)."""
        what = ("no feasible design" if not self.feasible
                else "the design breaks a constraint")
        broken = ", ".join(f"{n} ({v:.3g})" for n, v in self._broken()[:3])
        return f"{what} ({self.status}); most violated: {broken or 'n/a'}"

    def raise_for_status(self):
        """Raise :class:`~isodesign.errors.SolverError` unless the result is a design (feasible,
        no constraint broken); return self.

        Returns
        -------
        StudyResult
            ``self``.
        """
        if not self.feasible or self._broken():
            raise SolverError(f"{self.kind} optimization: {self.failure_message()}")
        return self

    @property
    def worst_margin_db(self) -> float | None:
        """The verdict's worst margin to the criterion (dB): the fine-grid analysis's when
        there is one, else the NLP's worst-margin objective (None for another objective
        without an analysis)."""
        a = getattr(self, "analysis", None)
        if a is not None:
            return float(a.worst_margin_db)
        if self.objective == "worst_band_margin" and self.objective_value is not None:
            return float(self.objective_value)
        return None

    def verdict(self) -> str:
        """One line: PASS only for a :attr:`success` whose bands pass; a design that breaks
        a constraint is a FAIL naming it, an infeasible run says INFEASIBLE."""
        if not self.feasible:
            return f"INFEASIBLE: {self.failure_message()}"
        band = self._band_verdict()
        broken = self._broken()
        if not broken:
            return band
        units = {"dB": " dB", "deg": " deg"}
        unit_of = {c.name: units.get(c.unit, "") for c in self.constraints}
        unit_of.setdefault("continuous_peak_transmissibility", " dB")
        text = ", ".join(f"{n} ({v:.3g}{unit_of.get(n, '')})" for n, v in broken)
        return f"FAIL: constraint broken: {text}; bands: {band}"

    @property
    def limited_by(self) -> list[str]:
        """Sentences naming the limits that stopped the design
        (:func:`~isodesign.optimization.explain.limiting_factors`)."""
        return limiting_factors(self)

    def limiting_summary(self) -> str:
        """The sentence naming what stopped the design
        (:func:`~isodesign.optimization.explain.limiting_summary`)."""
        return limiting_summary(self)

    def hessian_choice(self) -> dict:
        """IPOPT's Hessian of the run: ``{"hessian": "exact" | "limited-memory",
        "reason": str}`` (:func:`isodesign.optimization.hessian.hessian_choice`)."""
        h = getattr(self, "hessian_info", None) or getattr(getattr(self, "problem", None),
                                                           "hessian_info", None)
        if h:
            return dict(h)
        nominal = getattr(self, "nominal", None)
        if nominal is not None and nominal is not self:
            return nominal.hessian_choice()
        return {"hessian": "n/a", "reason": "not recorded"}

    def constraints_frame(self):
        """One row per constraint: value, bounds, margin, unit, binding, description (the
        command line's units: L, mm)."""
        import pandas as pd

        return pd.DataFrame([c.display() for c in self.constraints],
                            columns=["name", "value", "lower", "upper", "margin", "unit",
                                     "binding", "description"])

    def constraint_lines(self) -> list[str]:
        """The constraint table, the binding sentence and the Hessian, as text lines."""
        where = "the optimum" if self.feasible else "the best point found (not a design)"
        if self.robust:
            where += " (each in the scenario where its margin is smallest)"
        lines = constraint_table_lines(self, f"constraints at {where}")
        h = self.hessian_choice()
        lines.append(f"Hessian: {h['hessian']} ({h['reason']})")
        return lines

    def starts_frame(self):
        """One row per start of the (nominal) multi-start: ``start``, ``status``,
        ``feasible``, ``iterations``, ``wall_s`` and the objective; a vertical result also
        ``finished_s`` (when the start's solve finished, s since the optimize call began:
        where the time of a multi-start went)."""
        import pandas as pd

        return pd.DataFrame(self._start_rows())

    def starts_columns(self) -> dict:
        """The columns of :meth:`starts_frame` (name -> list), without pandas (a run's
        ``starts.csv``: :func:`isodesign.io.csvtable.columns_csv`)."""
        from isodesign.io.csvtable import records_columns

        return records_columns(self._start_rows())

    def to_frame(self):
        """Design variables (start and optimum), the objective, the worst margin, then the
        constraints (value, margin, binding).

        SI units (``unit`` column); a constraint's ``note`` gives its margin and ``BINDING``
        when it is within 0.5 % of its bound (0.022 dB for a peak). A robust result's
        ``start`` is the nominal optimum (where the exchange started) and its objective the
        worst case. ``attrs``: ``kind``, ``verdict``, ``success``, ``hessian`` and
        ``hessian_reason``.
        """
        import pandas as pd

        start = self._start_values()
        notes = self._variable_notes()
        units = {**DESIGN_VARIABLE_UNITS, **TABLE_LEVER_UNITS}
        rows = [{"quantity": k, "start": start.get(k), "optimum": v, "unit": units.get(k, ""),
                 "note": notes.get(k, "")} for k, v in self.values.items()]
        o = OBJECTIVES.get(self.objective)
        rows.append({"quantity": f"objective: {self.objective}" + (" (worst case)" if self.robust
                                                                 else ""),
                     "start": self._start_objective(), "optimum": self.objective_value,
                     "unit": "" if o is None else o.unit, "note": ""})
        rows.append({"quantity": "worst margin", "start": self._start_worst_margin(),
                     "optimum": self.worst_margin_db, "unit": "dB",
                     "note": self._margin_basis()})
        for c in self.constraints:
            rows.append({"quantity": f"constraint: {c.name}", "start": None, "optimum": c.value,
                         "unit": c.unit, "note": ("BINDING " if c.active else "")
                         + f"margin {c.margin_natural:.3g} {c.unit}"})
        df = pd.DataFrame(rows)
        h = self.hessian_choice()
        df.attrs.update(kind=self.kind, verdict=self.verdict(), success=self.success,
                        hessian=h["hessian"], hessian_reason=h["reason"])
        return df

    def _display_frame(self):
        """Start against optimum in the command line's units (L, mm); no constraints."""
        import pandas as pd

        start = self._start_values()
        notes = self._variable_notes()
        rows = []
        for n, v in self.values.items():
            sym, scale, unit = _DISPLAY.get(n, (n, 1.0, TABLE_LEVER_UNITS.get(n, "")))
            s = start.get(n)
            rows.append({"quantity": sym, "start": None if s is None else s * scale,
                         "optimum": v * scale, "unit": unit, "note": notes.get(n, "")})
        o = OBJECTIVES.get(self.objective)
        sc = getattr(o, "display_scale", 1.0)
        j0 = self._start_objective()
        rows.append({"quantity": f"objective: {self.objective}",
                     "start": None if j0 is None else j0 * sc,
                     "optimum": None if self.objective_value is None
                     else self.objective_value * sc,
                     "unit": getattr(o, "display_unit", getattr(o, "unit", "")),
                     "note": "worst case" if self.robust else "NLP grid"})
        return pd.DataFrame(rows)

    def _summary_items(self) -> list[tuple[str, str]]:
        """Kind, feasibility, verdict, objective, design, binding constraints, starts."""
        o = OBJECTIVES.get(self.objective)
        v = self.values
        val = ("n/a" if self.objective_value is None else o.format(self.objective_value)
               if o is not None else f"{self.objective_value:.6g}")
        items = [
            ("study", f"{self.study.name} ({self.kind})"),
            ("", ("feasible" if self.feasible else "NO FEASIBLE DESIGN (best point found)")
             if not self.robust else ("robust" if self.feasible else "NO ROBUST DESIGN")),
            ("verdict", self.verdict()),
            (("worst-case " if self.robust else "") + self.objective, val),
            ("design", f"N {v['volume_ratio']:.4g}, V_t0 {v['top_volume_m3'] * 1e3:.4g} L, "
                       f"L_c {v['capillary_length_m'] * 1e3:.4g} mm, "
                       f"D_c {v['capillary_diameter_m'] * 1e3:.4g} mm"),
            ("binding", ", ".join(c.name for c in self.constraints if c.active) or "none"),
        ]
        if self._broken():
            items.append(("violations" if self.feasible else "most violated",
                          ", ".join(f"{n} {a:.3g}" for n, a in self._broken()[:3])))
        items += self._kind_items()
        items.append(("Hessian", self.hessian_choice()["hessian"]))
        items.append(("wall", f"{getattr(self, 'wall_s', 0.0):.3g} s"))
        return items

    def __str__(self) -> str:
        lines = ["", *self.constraint_lines()]
        extra = self._extra_lines()
        if extra:
            lines += ["", *extra]
        return super().__str__() + "\n" + "\n".join(lines)

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
            extra.append(f"<p>{e(self.limiting_summary())}:</p><ul>"
                         + "".join(f"<li>{e(t)}</li>" for t in self.limited_by) + "</ul>")
        h = self.hessian_choice()
        extra.append(f"<p>Hessian: {e(h['hessian'])} ({e(h['reason'])})</p>")
        more = self._extra_lines()
        if more:
            extra.append("<p>" + "<br>".join(e(t) for t in more) + "</p>")
        return base[: -len("</div>")] + "".join(extra) + "</div>"

    def plot(self, ax=None):
        """The result's figure: start against optimum (a nominal result), or the objective
        in each scenario of the final set (a robust one).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw one panel into this axes. Default: a new figure.

        Returns
        -------
        matplotlib.figure.Figure
            Made with an Agg canvas; the global Matplotlib backend is not touched.

        Raises
        ------
        ValueError
            For a run without a feasible design (nothing was analysed).
        """
        if not self.feasible:
            raise ValueError(f"plot: the {self.kind} result has no feasible design to draw "
                             f"({self.status})")
        if ax is None:
            return self._figure()
        self._draw(ax)
        return ax.figure


@dataclass(frozen=True)
class StartRecord:
    """One start of the multi-start run.

    ``wall_s`` is IPOPT's time for the start, s; ``finished_s`` the instant its solve
    finished, s since the optimize call began (on ``time.perf_counter``, system-wide on
    Linux, so a forked worker's instant compares with the driver's; NaN when the start's
    initial guess failed). ``objective`` is natural (the margin in dB for ``worst_margin``).
    """

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
    finished_s: float = math.nan

    def row(self) -> dict:
        """Flat dict for a table."""
        r = {"start": self.index, "status": self.status, "success": self.success,
             "feasible": self.feasible, "iterations": self.iterations, "wall_s": self.wall_s,
             "finished_s": self.finished_s,
             "objective": self.objective, "max_violation": self.max_violation}
        r.update({f"start_{k}": v for k, v in self.start.items()})
        r.update({f"final_{k}": v for k, v in self.final.items()})
        return r


class RobustStudyResult(StudyResult):
    """What the two robust kinds (``robust``, ``robust table``) add to :class:`StudyResult`,
    written once: the worst margin and the verdict over the final scenario set, the
    exchange's convergence as the kind's check, the failure naming the scenario that cannot
    be met, :meth:`scenarios_frame`, :meth:`rounds_frame` and the scenario bars as the plot.

    A subclass has the fields ``nominal`` (the nominal optimum, the exchange's start),
    ``converged``, ``rounds``, ``scenarios`` (rows with ``index``, ``theta``,
    ``description``, ``objective``, ``nominal_objective``, ``margin_db``, ``worst``,
    ``binding``, ``active``) and ``infeasible_scenario``, and the methods
    :meth:`nominal_worst_case` and ``record()`` (robust.json).
    """

    __slots__ = ()

    def _checked(self) -> bool:
        return bool(self.converged)

    def _broken(self) -> tuple:
        return ()

    def nominal_worst_case(self) -> float | None:
        """The nominal optimum's worst case over the box (natural units); the subclass's."""
        return None

    def _start_values(self) -> dict:
        return dict(self.nominal.values)

    def _start_objective(self):
        return self.nominal_worst_case()

    def _start_worst_margin(self):
        return None

    def _margin_basis(self) -> str:
        return f"worst over the {len(self.scenarios)} scenarios of the final set"

    @property
    def worst_margin_db(self) -> float | None:
        """The worst margin to the criterion (dB) over the final scenario set (None for a
        run without a robust design)."""
        m = [r["margin_db"] for r in self.scenarios if r.get("margin_db") is not None]
        return float(min(m)) if m and self.feasible else None

    def failure_message(self) -> str:
        """One line naming the scenario that cannot be met."""
        s = self.infeasible_scenario or {}
        return (f"no design meets every constraint in the scenario {s.get('description')} "
                f"({self.status}); most violated there: {s.get('constraint')} "
                f"({s.get('violation', 0.0):.3g} in the NLP's units)")

    def raise_for_status(self):
        """Raise :class:`~isodesign.errors.SolverError` naming the scenario that cannot be
        met unless a robust design was found; return self."""
        if not self.feasible:
            raise SolverError(self.failure_message())
        return self

    def _band_verdict(self) -> str:
        w = self.worst_margin_db
        rows = [r for r in self.scenarios if r.get("margin_db") is not None]
        if w is None or not rows:
            return "worst margin n/a"
        r = min(rows, key=lambda r: r["margin_db"])
        head = "PASS" if w >= 0 else "FAIL"
        if not self.converged:
            head = "UNCONFIRMED" if w >= 0 else "FAIL"
        text = (f"{head}: {self.study.target.name} worst case over the {len(rows)} scenarios "
                f"of the final set, margin {w:+.2f} dB (scenario {r['description']})")
        if not self.converged:
            text += "; the exchange did not converge (max_rounds): the box may hold worse"
        return text

    def active_scenarios(self) -> list[dict]:
        """The scenarios that shape the robust design (worst objective or binding)."""
        return [r for r in self.scenarios if r["active"]]

    def scenarios_frame(self):
        """One row per scenario of the final set: its parameters, objective, worst margin,
        whether it sets the worst case, its binding constraints and whether it is active."""
        import pandas as pd

        return pd.DataFrame([{"scenario": r["index"], **r["theta"], "objective": r["objective"],
                              "margin_db": r.get("margin_db"), "worst": r["worst"],
                              "binding": ", ".join(r["binding"]), "active": r["active"]}
                             for r in self.scenarios])

    def rounds_frame(self):
        """One row per exchange round."""
        import pandas as pd

        return pd.DataFrame(list(self.rounds))

    def _kind_items(self) -> list[tuple[str, str]]:
        return [("rounds", f"{len(self.rounds)}, {len(self.scenarios)} scenarios, "
                           + ("converged" if self.converged else "NOT converged"))]

    def _extra_lines(self) -> list[str]:
        out = ["scenarios of the final set (active: they shape the robust design):"]
        for r in self.scenarios:
            tags = (["worst"] if r["worst"] else []) + (
                ["binding: " + ", ".join(r["binding"])] if r["binding"] else [])
            m = r.get("margin_db")
            out.append(f"  {r['description']}: objective {r['objective']:+.4g}"
                       + ("" if m is None else f", margin {m:+.2f} dB")
                       + (f" ({'; '.join(tags)})" if tags else ""))
        return out if self.scenarios else []

    def _draw(self, ax) -> None:
        from isodesign.plotting.robust import scenario_bars

        scenario_bars(self, ax=ax)


def worst_constraint_reports(per_scenario, descriptions) -> tuple:
    """The constraint table of a robust design: each constraint in the scenario where its
    margin is smallest (its description names the scenario).

    Parameters
    ----------
    per_scenario : list of list of ConstraintReport
        The constraints of the robust design in each scenario of the final set.
    descriptions : list of str
        The scenarios, in the same order.

    Returns
    -------
    tuple of ConstraintReport
        In the first scenario's order.
    """
    import dataclasses

    best: dict = {}
    for reps, desc in zip(per_scenario, descriptions, strict=True):
        for c in reps:
            if c.name not in best or c.margin < best[c.name][0].margin:
                best[c.name] = (c, desc)
    return tuple(dataclasses.replace(c, description=(c.description + "; " if c.description
                                                     else "") + f"worst in {d}")
                 for c, d in best.values())


@dataclass(frozen=True, eq=False, repr=False)
class OptimizationResult(StudyResult):
    """The answer to a ``vertical`` study (:func:`isodesign.optimization.driver.optimize_vertical`).

    The common interface (verdict, worst margin, constraint table, starts, frames, plot,
    text and HTML) is :class:`StudyResult`'s.

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

    KIND = "vertical"

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
    hessian_info: dict = field(default_factory=dict)
    #: The solves after the multi-start that made the returned design, in finish order:
    #: dicts with ``stage`` (``refinement``: the winning branch's last peak-refinement
    #: re-solve, present when it took rounds; ``tie-break``: the solve whose point was
    #: returned, present when the tie-break moved it), ``start`` (the branch's start),
    #: ``finished_s`` (s since the optimize call began, the clock of
    #: :attr:`StartRecord.finished_s`), ``objective`` (natural) and ``values`` (the
    #: design variables there, SI).
    solves: tuple[dict, ...] = ()

    def _checked(self) -> bool:
        return self.recheck_max_rel_diff is not None

    def _start_rows(self) -> list[dict]:
        return [s.row() for s in self.starts]

    def _kind_items(self) -> list[tuple[str, str]]:
        return [("starts", f"{len(self.starts)} ({self.n_reached_best} reached the best)")]

    @property
    def scope(self):
        """What the answer covers and leaves out (:class:`~isodesign.response.scope.Scope`).

        None for a run without a feasible design (nothing was analysed).
        """
        return None if self.analysis is None else self.analysis.scope

    def _extra_lines(self) -> list[str]:
        return [] if self.scope is None else list(self.scope.lines())

    def _figure(self):
        if self.analysis is None or self.start_analysis is None:
            raise ValueError("plot: the result has no band analysis (infeasible run)")
        return optimization_figure(self)

    def _draw(self, ax) -> None:
        """Start design against optimum in every band (judged ones shaded)."""
        if self.analysis is None or self.start_analysis is None:
            raise ValueError("plot: the result has no band analysis (infeasible run)")
        st = self.study
        start_all = all_bands_response(st, st.design_at(self.start_values))
        opt_all = all_bands_response(st, self.design)
        tg = st.raw["target"]
        judged = judged_mask(opt_all.bands, (tg["band_min_hz"], tg["band_max_hz"]))
        draw_bands(ax, [("payload, start design", start_all, START),
                        ("payload, optimum", opt_all, OPTIMUM)], judged=judged)
