"""Pareto front of a table study: worst margin (three axes, every point) against a cost.

The cost is the total volume (default) or, with a free layout, the isolators' footprint
area ``L W`` (docs/table.md, section 15), or, with a free inertia base, its mass (section 16).

Epsilon constraint on the :class:`~.table_problem.TableProblem` with both
objectives: anchor A is :func:`~.table_driver.optimize_table` (multi-start, mode
refresh, re-check); anchor B minimizes the total volume from it; between them the worst
margin is maximized subject to ``ln V <= eps`` for ``points`` values of eps, each solve
warm-started from the previous one (from anchor B when that one stalls; docs/table.md,
section 11). A point whose leveling loop misses a margin bound (python-control at its
design; the gain-margin rows frozen at anchor A's design hold along the front) says so in
its status and is not on the front (section 12).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.optimization.front import REFERENCE_MARGIN, front_reference, nondominated
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.refine import PEAK_TOLERANCE_DB
from isodesign.optimization.table_constraints import CONTINUOUS_PEAK as PEAK_VIOLATION
from isodesign.results import ResultDisplay

__all__ = ["TableParetoResult", "table_pareto_front"]

#: The frame's column of a cost other than the total volume.
_COST_COLUMNS = {"footprint_area": "footprint_area_m2", "added_mass": "added_mass_kg"}


@dataclass(frozen=True, eq=False, repr=False)
class TableParetoResult(ResultDisplay):
    """Points of a table study's Pareto front (worst margin against a cost).

    Attributes
    ----------
    worst_margin_db : ndarray
        Worst margin over points, axes and bands (NLP grid), per point; NaN if infeasible.
    total_volume_m3 : ndarray
        Per point (whatever the cost).
    designs : tuple of dict
    statuses : tuple of str
    front : ndarray of bool
        Non-dominated points.
    study : Study
    wall_s : float
    peak_excess_db : ndarray or None
        Continuous peak of |T| (from half the lowest mode) minus the peak bound, per point
        after its refinement (NaN: no bound, or no feasible point); a point above
        :data:`~isodesign.optimization.refine.PEAK_TOLERANCE_DB` says so in its status.
    reference_point, ideal_point : ndarray (2,)
        The hypervolume's reference and ideal points, both objectives minimized (margin
        negated, dB; volume, m^3), as a vertical front's
        (:func:`isodesign.optimization.front.front_reference`).
    hypervolume : float
        The front's normalized hypervolume (ideal point -> 0, reference point -> 1).
    settings : dict
        Method, points, reference margin, units, starts of anchor A.
    cost : str
        Objective B: ``total_volume``, ``footprint_area`` or ``added_mass``.
    cost_value : ndarray or None
        Objective B per point in its natural unit (m^3, m^2 or kg; None: the total volume).
    """

    worst_margin_db: np.ndarray
    total_volume_m3: np.ndarray
    designs: tuple
    statuses: tuple
    front: np.ndarray
    study: Any
    wall_s: float
    peak_excess_db: Any = None
    reference_point: np.ndarray | None = None
    ideal_point: np.ndarray | None = None
    hypervolume: float = math.nan
    settings: dict = field(default_factory=dict)
    cost: str = "total_volume"
    cost_value: Any = None

    @property
    def objectives(self) -> tuple[str, str]:
        """The two objectives, as a vertical front names them (A maximized, B minimized)."""
        return ("worst_band_margin", self.cost)

    @property
    def costs(self) -> np.ndarray:
        """Objective B per point, natural unit (the total volume unless ``cost`` says)."""
        return self.total_volume_m3 if self.cost_value is None else self.cost_value

    @property
    def values(self) -> np.ndarray:
        """``(n, 2)``: worst margin (dB) and the cost (m^3, m^2 or kg) per point, as a vertical
        front's ``values`` (NaN where a point failed)."""
        return np.column_stack([self.worst_margin_db, self.costs])

    def to_frame(self):
        """One row per point: margin, volume, design, status, non-dominated."""
        import pandas as pd

        df = pd.DataFrame(list(self.designs))
        df.insert(0, "total_volume_m3", self.total_volume_m3)
        if self.cost in _COST_COLUMNS:
            df.insert(0, _COST_COLUMNS[self.cost], self.costs)
        df.insert(0, "worst_margin_db", self.worst_margin_db)
        df["status"] = list(self.statuses)
        if self.peak_excess_db is not None:
            df["continuous_peak_excess_db"] = self.peak_excess_db
        df["nondominated"] = self.front
        df.attrs["hypervolume"] = self.hypervolume
        return df

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("objectives", f"{self.objectives[0]} (optimized) vs {self.objectives[1]} "
                               "(swept)"),
                ("points", str(len(self.designs))), ("non-dominated", str(int(self.front.sum()))),
                ("hypervolume", f"{self.hypervolume:.4f} (normalized)"),
                ("wall", f"{self.wall_s:.3g} s")]

    def plot(self, ax=None):
        """Worst margin against the cost (total volume in L, or footprint area in m^2), the
        non-dominated points joined.

        Parameters
        ----------
        ax : matplotlib Axes, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.style import new_figure

        if ax is None:
            ax = new_figure(6.0, 4.0).subplots()
        area = self.cost == "footprint_area"
        v, m = self.costs * (1.0 if self.cost != "total_volume" else 1e3), self.worst_margin_db
        ax.plot(v[self.front], m[self.front], "C0-o", ms=4, label="non-dominated")
        ax.plot(v[~self.front], m[~self.front], "x", color="0.5", label="dominated")
        ax.axhline(0.0, color="C3", lw=0.8)
        mass = self.cost == "added_mass"
        ax.set_xlabel("footprint of the isolators, length x width (m^2)" if area else
                      "added mass: the inertia base under the payload (kg)" if mass else
                      "total volume per isolator V_t0 (1 + N) (L)")
        ax.set_ylabel("worst margin, 3 axes, every point (dB)")
        ax.set_title(f"table study {self.study.name!r}: margin against "
                     f"{'footprint' if area else 'added mass' if mass else 'volume'}",
                     fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        return ax.figure


def _own_margin(prob, sol) -> float:
    """The worst margin of a solution at its own NLP parameters (models.distortion: the
    expansion it was solved with, not the last point's)."""
    getattr(prob, "use_solution", lambda s: None)(sol)
    return prob.worst_margin_db(sol.x)


def table_pareto_front(study, points: int = 10, *, progress=None,
                       cost: str = "total_volume") -> TableParetoResult:
    """Worst margin (maximized) against a cost (minimized) of a table study.

    Parameters
    ----------
    study : Study
        With a ``[table]``.
    points : int
        Epsilon values (>= 2), anchors included.
    progress : callable, optional
        ``progress(done, total)`` after each point.
    cost : {'total_volume', 'footprint_area', 'added_mass'}
        Objective B: the total volume per isolator, the isolators' footprint ``L W``
        (a free layout, docs/table.md section 15) or the inertia base's mass (a free
        slab, section 16).

    Returns
    -------
    TableParetoResult

    Raises
    ------
    SolverError
        No feasible design at anchor A.
    """
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.table_driver import optimize_table

    if isinstance(points, bool) or not isinstance(points, int) or points < 2:
        raise InputError(f"points: must be an integer >= 2, got {points!r}")
    if cost not in ("total_volume", "footprint_area", "added_mass"):
        raise InputError(f"cost: a table's front is against total_volume, footprint_area or "
                         f"added_mass, got {cost!r}")
    t0 = time.perf_counter()
    st = study.with_changes(objective={"kind": "worst_band_margin"})
    prob = Problem(st, objectives=("worst_band_margin", cost))
    res_a = optimize_table(st, problem=prob, analyze=False)
    if not res_a.feasible:
        raise SolverError(f"pareto: no feasible design when maximizing the worst margin "
                          f"({res_a.status})")
    used = list(res_a.peak["added_frequencies_hz"])
    if used:  # the continuous peak refinement's frequencies hold along the front too
        prob = prob.with_peak_slots()
        prob.set_slots(used + [float(prob.grid.frequency_hz[0])] * (prob.n_slots - len(used)))
    anchor_a = prob.solve(prob.initial_guess(res_a.values))
    state = {"prob": prob, "used": used}
    anchor_b, _ = _peak_refined(st, state, anchor_a.x, prob.params(weights=[0.0, 1.0]))
    if not anchor_b.feasible:
        raise SolverError(f"pareto: minimizing the {cost.replace('_', ' ')} failed "
                          f"({anchor_b.status})")
    eps = np.linspace(float(anchor_a.objectives[1]), float(anchor_b.objectives[1]), points)
    sols, excess, x = [], [], anchor_a.x
    for k, e in enumerate(eps):
        params = state["prob"].params(eps=[None, e + 1e-9])
        if k == 0:
            sol, ex = _peak_refined(st, state, anchor_a.x, params, first=anchor_a)
        else:
            sol, ex = _peak_refined(st, state, x, params)
        if not sol.feasible:  # the chain stalled: from the other anchor
            sol, ex = _peak_refined(st, state, anchor_b.x,
                                    state["prob"].params(eps=[None, e + 1e-9]))
        if sol.feasible:
            x = sol.x
        sols.append(sol)
        excess.append(ex)
        if progress:
            progress(k + 1, points)
    prob = state["prob"]
    margin = np.array([_own_margin(prob, s) if s.feasible else math.nan for s in sols])
    to_nat = OBJECTIVES[cost].to_natural  # exp of a log cost; the added mass in kg
    costs = np.array([to_nat(s.objectives[1]) if s.feasible else math.nan for s in sols])
    vol = costs if cost == "total_volume" else np.array(
        [st.design_at(s.values).total_volume_m3 if s.feasible else math.nan for s in sols])
    # a point whose continuous peak stays above the bound meets the constraints on the
    # NLP's frequencies only: neither on the front nor dominating a point of it; nor one
    # whose leveling loop misses a margin bound (python-control at the point's design)
    loop_miss = [_loop_misses(st, s) for s in sols]
    ok = np.isfinite(margin) & np.array([(ex is None or ex <= PEAK_TOLERANCE_DB) and not lm
                                         for ex, lm in zip(excess, loop_miss, strict=True)])
    mins = np.column_stack([-margin, costs])  # both minimized, as a vertical front's
    mins[~ok] = np.nan
    front = nondominated(mins)
    ideal, ref, hv = front_reference(mins, front) if front.any() else (None, None, math.nan)
    statuses = tuple((s.status if ex is None or ex <= PEAK_TOLERANCE_DB else
                      f"{s.status}; {PEAK_VIOLATION} +{ex:.3g} dB")
                     + "".join(f"; {n} -{v:.3g} {'dB' if 'gain' in n else 'deg'}"
                               for n, v in lm)
                     for s, ex, lm in zip(sols, excess, loop_miss, strict=True))
    return TableParetoResult(worst_margin_db=margin, total_volume_m3=vol,
                             designs=tuple(s.values for s in sols), statuses=statuses,
                             front=front, study=st, wall_s=time.perf_counter() - t0,
                             peak_excess_db=np.array([math.nan if ex is None else ex
                                                      for ex in excess]),
                             reference_point=ref, ideal_point=ideal, hypervolume=hv,
                             settings={"method": "epsilon-constraint on the table NLP, "
                                                 "warm starts",
                                       "points": points, "reference_margin": REFERENCE_MARGIN,
                                       "units": ("dB", OBJECTIVES[cost].unit),
                                       "starts": st.solver["starts"]},
                             cost=cost, cost_value=None if cost == "total_volume" else costs)


def _loop_misses(study, sol) -> tuple:
    """The leveling loop's margins below their bounds at a feasible point: ``(name, dB or
    deg)`` (none without bounds; docs/table.md, section 12)."""
    from isodesign.optimization.table_driver import _leveling_misses, leveling_check
    from isodesign.table.leveling import leveling_margin_bounds

    if not sol.feasible or leveling_margin_bounds(study) == (None, None):
        return ()
    return _leveling_misses(*leveling_check(study, study.design_at(sol.values), sol.values))


def _peak_refined(study, state, x0, params, first=None):
    """Solve from ``x0`` with ``params`` and refine the continuous peak of |T| (as
    :func:`~.table_driver.optimize_table` does): ``(solution, excess dB or None)``.

    ``state`` holds the NLP (built again with movable frequencies when needed) and the
    frequencies placed so far, shared by every point of the front.
    """
    from isodesign.optimization.table_driver import (
        MAX_PEAK_ROUNDS,
        _modes_at,
        add_peak_frequencies,
        measure_peaks,
        solve_round,
    )

    limit = study.constraints.get("max_peak_transmissibility_db")
    sol = first if first is not None else state["prob"].solve(x0, params)
    if limit is None or limit is False:
        return sol, None
    excess = None
    for k in range(MAX_PEAK_ROUNDS + 1):
        if not sol.feasible:
            return sol, None
        prob = state["prob"]
        d = study.design_at(sol.values)
        sigma, sigma_u = prob.sigma(sol.x), prob.tube_rms(sol.x)
        pk = measure_peaks(prob, d, sigma, sigma_u,
                           _modes_at(prob, d, sigma, sigma_u, values=sol.values),
                           values=sol.values)  # a co-designed table's levers
        excess = pk.max_db - limit
        over = pk.above(limit, PEAK_TOLERANCE_DB)
        if not over or k == MAX_PEAK_ROUNDS:
            break
        w = params[: len(prob.objectives)]
        eps = params[len(prob.objectives) + 1: 2 * len(prob.objectives) + 1]
        prob, new = add_peak_frequencies(prob, over, state["used"])
        if not new:
            break  # every movable frequency taken: the excess stays reported
        state["prob"], state["used"] = prob, state["used"] + new
        params = prob.params(weights=w, eps=[None if e >= 1e19 else e for e in eps])
        sol = solve_round(prob, sol, params)
    return sol, excess
