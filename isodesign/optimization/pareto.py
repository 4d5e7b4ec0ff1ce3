"""Pareto studies: epsilon-constraint sweeps with warm starts.

:func:`pareto_front` minimizes objective A subject to ``objective B <= eps``
for a sweep of ``eps`` between B's two anchors (B at A's optimum, and B's own
optimum), each NLP warm-started from the previous solution with one
parametric IPOPT solver built once (:class:`isodesign.optimization.problem.Problem` with
both objectives, parametric weights and bounds). The points are filtered for
non-dominance; the front's
hypervolume is computed in the normalized space of the two (minimized)
objectives against a reference point (see :func:`hypervolume_2d`).

Default front: worst-band margin (maximized) against total chamber volume
(minimized). That is the designer's first question once a study works: how
much compliance margin does each litre of isolator buy, within the envelope?
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.optimization.constraints import constraint_reports
from isodesign.optimization.dispatch import refuse
from isodesign.optimization.front import (
    REFERENCE_MARGIN,
    front_reference,
    hypervolume_2d,
    nondominated,
)
from isodesign.optimization.grid import DEFAULT_POINT_FREQUENCY_HZ
from isodesign.optimization.multistart import map_in_workers, run_starts, start_points
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.problem import PEAK_ROUNDS, Problem
from isodesign.optimization.recheck import recheck
from isodesign.optimization.refine import (
    PEAK_TOLERANCE_DB,
    continuous_peak_db,
    flat_tolerance,
    peak_slots,
    refine_branches,
)
from isodesign.optimization.solution import Solution
from isodesign.optimization.study import Study
from isodesign.plotting.optimization import pareto_figure
from isodesign.results import ResultDisplay

__all__ = ["DEFAULT_OBJECTIVES", "ParetoResult", "check_front", "hypervolume_2d", "nondominated",
           "pareto_front"]

DEFAULT_OBJECTIVES = ("worst_band_margin", "total_volume")
#: The front of a table study (its only one).
TABLE_OBJECTIVES = DEFAULT_OBJECTIVES
#: The entry point's name in its refusal of a robust study (the API's and the CLI's line).
PARETO_WHAT = "the Pareto front"


def _minimized(kind: str, v: np.ndarray) -> np.ndarray:
    """Natural values -> values to minimize (margins negated)."""
    return OBJECTIVES[kind].minimized(v)


@dataclass(frozen=True, eq=False, repr=False)
class ParetoResult(ResultDisplay):
    """A Pareto front.

    ``values`` has one row per point (natural units: dB, m^3, ...), ``designs``
    the design variables of each point; ``front`` marks the non-dominated ones;
    ``binding`` the constraints binding at each point (within
    :data:`~isodesign.optimization.constraints.BINDING_TOL`; empty for a point not
    solved, or for a result built without them): the plot explains the front's breaks
    with them.
    """

    objectives: tuple[str, str]
    values: np.ndarray
    designs: tuple[dict, ...]
    statuses: tuple[str, ...]
    front: np.ndarray
    reference_point: np.ndarray
    ideal_point: np.ndarray
    hypervolume: float
    wall_s: float
    settings: dict = field(default_factory=dict)
    binding: tuple[tuple[str, ...], ...] = ()

    def normalized(self, values: np.ndarray | None = None) -> np.ndarray:
        """Minimized objectives scaled so that ideal -> 0 and reference -> 1."""
        v = self.values if values is None else np.asarray(values, float)
        m = np.column_stack([_minimized(k, v[:, i]) for i, k in enumerate(self.objectives)])
        return (m - self.ideal_point) / (self.reference_point - self.ideal_point)

    def hypervolume_of(self, values: np.ndarray) -> float:
        """Hypervolume of another set of points (natural units) with this reference."""
        return hypervolume_2d(self.normalized(values), np.ones(2))

    def to_frame(self):
        """One row per point: objectives, design variables, status, on-front flag."""
        import pandas as pd

        rows = []
        for i, dvals in enumerate(self.designs):
            r = {self.objectives[0]: self.values[i, 0], self.objectives[1]: self.values[i, 1]}
            r.update(dvals)
            r["status"] = self.statuses[i]
            r["nondominated"] = bool(self.front[i])
            rows.append(r)
        df = pd.DataFrame(rows)
        df.attrs["hypervolume"] = self.hypervolume
        return df

    def _summary_items(self) -> list[tuple[str, str]]:
        """Objectives, points, front size and hypervolume (for repr and notebooks)."""
        ok = np.isfinite(self.values).all(axis=1)
        return [
            ("objectives", f"{self.objectives[0]} (optimized) vs {self.objectives[1]} (swept)"),
            ("points", f"{len(self.designs)} ({int(ok.sum())} solved)"),
            ("non-dominated", str(int(np.sum(self.front)))),
            ("hypervolume", f"{self.hypervolume:.4f} (normalized)"),
            ("wall time", f"{self.wall_s:.1f} s"),
        ]

    def plot(self, ax=None, *, annotate: int = 5):
        """The front, the pass/fail line, a few designs listed.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Drawn into; default a new figure.
        annotate : int
            Number of designs listed.

        Returns
        -------
        matplotlib.figure.Figure
            Made with an Agg canvas; the global Matplotlib backend is not touched.
        """
        return pareto_figure(self, annotate=annotate, ax=ax)


def _check_objectives(objectives) -> tuple[str, str]:
    if isinstance(objectives, str) or not isinstance(objectives, list | tuple) \
            or not all(isinstance(o, str) for o in objectives):
        raise InputError(f"objectives: need two different objective names, e.g. "
                         f"{DEFAULT_OBJECTIVES!r}, got {objectives!r:.60}")
    objs = tuple(objectives)
    if len(objs) != 2 or objs[0] == objs[1]:
        raise InputError(f"objectives: need two different objectives, got {','.join(objs)}")
    for o in objs:
        if o not in OBJECTIVES:
            raise InputError(f"objectives: unknown {o!r}; valid: {', '.join(OBJECTIVES)}")
    return objs  # type: ignore[return-value]


def check_front(study: Study, objectives) -> tuple[str, str]:
    """The front's two objectives checked against the study, before anything is solved.

    A table study has the fronts ``worst_band_margin,total_volume`` and
    ``worst_band_margin,footprint_area`` (the latter with a free layout, docs/table.md
    section 15); ``footprint_area`` is a table's only.

    Parameters
    ----------
    study : Study
    objectives : sequence of 2 str

    Returns
    -------
    tuple of 2 str

    Raises
    ------
    InputError
        Naming ``objectives``.
    """
    from isodesign.optimization.variables import LAYOUT_LEVERS

    a, b = _check_objectives(objectives)
    if study.table is None:
        if "footprint_area" in (a, b):
            raise InputError("objectives: footprint_area is the footprint of a table's "
                             "isolators (a study with a [table] and a free layout, "
                             "docs/table.md section 15); this study has no [table]")
        if "added_mass" in (a, b):
            raise InputError("objectives: added_mass is the mass of a table's inertia base "
                             "(a study with a [table] and variables.inertia_base_mass_kg free, "
                             "docs/table.md section 16); this study has no [table]")
        return a, b
    fronts = (TABLE_OBJECTIVES, ("worst_band_margin", "footprint_area"),
              ("worst_band_margin", "added_mass"))
    if (a, b) not in fronts:
        raise InputError(f"objectives: a study with a [table] has the fronts "
                         f"{' and '.join(','.join(f) for f in fronts)}, got {a},{b}")
    if b == "footprint_area" and not any(v.free for v in study.levers
                                         if v.name in LAYOUT_LEVERS):
        raise InputError("objectives: footprint_area needs a free layout "
                         "(variables.layout_length_m or layout_width_m, fixed = false; "
                         "docs/table.md section 15)")
    if b == "added_mass" and not any(v.free for v in study.levers
                                     if v.name == "inertia_base_mass_kg"):
        raise InputError("objectives: added_mass needs a free inertia base "
                         "(variables.inertia_base_mass_kg, fixed = false; docs/table.md "
                         "section 16)")
    return a, b


def pareto_front(study: Study, objectives=DEFAULT_OBJECTIVES, points: int = 20, *,
                 progress=None) -> ParetoResult:
    """Epsilon-constraint Pareto front of two objectives with warm starts.

    One parametric NLP (:class:`isodesign.optimization.problem.Problem` with both objectives)
    is built once. Anchor A is :func:`isodesign.optimization.driver.optimize` of the study
    with objective A (multi-start, peak refinement, tie-break, re-check), so the
    front starts at the reported single-objective optimum; anchor B is B
    minimized from there. The sweep minimizes A subject to ``B <= eps`` for
    ``points`` values of eps from B at A's optimum to B's optimum, in two chains
    (one from each anchor, meeting in the middle, in two forked workers when
    ``solver.workers`` and the cores available to the process are both 2 or more), each
    point warm-started from the previous one of its chain, and refines each
    point's peak grid like ``optimize`` does.

    Parameters
    ----------
    study : Study
        Constraints, models and variables of the study apply to every point.
    objectives : (str, str)
        Objective A (optimized) and B (swept as a constraint).
    points : int
        Number of epsilon values (>= 2), anchors included.
    progress : callable or None
        ``progress(done, total)`` after each start of the anchor and each sweep point.

    Returns
    -------
    ParetoResult or TableParetoResult
        A study with ``[table]`` gets the table's front (worst margin over every point,
        axis and band against total volume: :func:`.table_pareto.table_pareto_front`);
        a study with ``[scenarios]`` is refused (InputError naming ``[scenarios]``): the
        front is nominal.
    """
    if not isinstance(study, Study):
        raise InputError(f"study: expected a Study (load_study(path) or default_study()), "
                         f"got {type(study).__name__} {study!r:.40}")
    refuse(study, PARETO_WHAT, table=False)  # no robust front (docs/robust.md)
    a, b = check_front(study, objectives)
    if isinstance(points, bool) or not isinstance(points, int) or not 2 <= points <= 500:
        # the range of the command line's --points (each point is a solve)
        raise InputError(f"points: must be an integer >= 2 and <= 500, got {points!r:.40}")
    if study.table is not None:  # the table's front (docs/table.md, section 11)
        from isodesign.optimization.table_pareto import table_pareto_front

        return table_pareto_front(study, points, progress=progress, cost=b)
    t0 = time.perf_counter()
    st = study.with_changes(objective=_objective_table(study, a))
    total = points + 1
    prob = Problem(st, objectives=(a, b))
    anchor_a, lex = _anchor_a(st, prob, progress, total)
    if progress:
        progress(1, total)
    anchor_b, last = _anchor_b(prob, anchor_a, lex)
    jb_at_a = float(anchor_a.objectives[1])
    jb_min = float(anchor_b.objectives[1])
    eps = np.linspace(jb_at_a, jb_min, points)
    # two warm-started chains over the whole sweep, one from each anchor, taking every
    # other point (A's chain the points 0, 2, 4, ..., B's chain the last point and every
    # other one below it): they run in the two forked workers when the machine has the
    # cores. Each chain's first point is solved already: A's optimum, and B's
    # lexicographic end point (when verified). Then every point where the two chains
    # are on different branches is solved from the other chain's neighbours too.
    idx_a = list(range(0, points - 1, 2))
    idx_b = [points - 1] + [k for k in range(points - 2, 0, -1) if k % 2]
    chains = [(anchor_a, idx_a, anchor_a), (anchor_b, idx_b, last)]
    sols = _run_chains(prob, chains, eps, anchor_b, st.solver.get("workers"))
    branches = _other_branch(prob, sols, set(idx_a), eps, st.solver.get("workers"))
    values, designs, statuses, binding = [], [], [], []
    for k in range(points):
        sol = sols[k]
        if sol.feasible:
            values.append((OBJECTIVES[a].to_natural(sol.objectives[0]),
                           OBJECTIVES[b].to_natural(sol.objectives[1])))
        else:
            values.append((math.nan, math.nan))
        designs.append(sol.values)
        statuses.append(sol.status)
        binding.append(tuple(c.name for c in constraint_reports(prob.con_rows, sol.g)
                             if c.active) if sol.feasible else ())
    if progress:
        progress(total, total)
    v = np.array(values, float)
    mins = np.column_stack([_minimized(a, v[:, 0]), _minimized(b, v[:, 1])])
    front = nondominated(mins)
    if not np.any(front):
        raise SolverError("pareto: no feasible point on the sweep")
    ideal, ref, hv = front_reference(mins, front)
    return ParetoResult(
        objectives=(a, b), values=v, designs=tuple(designs), statuses=tuple(statuses),
        front=front, reference_point=ref, ideal_point=ideal, hypervolume=hv,
        wall_s=time.perf_counter() - t0,
        settings={"method": "epsilon-constraint, one parametric IPOPT NLP, warm starts",
                  "points": points, "reference_margin": REFERENCE_MARGIN,
                  "units": (OBJECTIVES[a].unit, OBJECTIVES[b].unit),
                  "starts": st.solver["starts"],
                  "max_total_volume_m3": st.constraints.get("max_total_volume_m3"),
                  "branches": branches},
        binding=tuple(binding),
    )


#: Band above A's value at its optimum to which A's epigraph is bounded while B alone is
#: minimized from A's optimum (the fallback when the lexicographic anchor fails; internal
#: units: dB for a dB objective, else a natural log, i.e. a factor of e^4.6 = 100). With
#: zero weight the epigraph variable is otherwise free up to its box (300): the barrier
#: pulls it far from its constraints and IPOPT wanders.
ANCHOR_B_BAND = {True: 40.0, False: math.log(100.0)}
#: Weight of A beside B (weight 1) in the lexicographic solve of anchor B, minimize
#: ``J_B + w J_A`` (internal units: dB, or a natural log). Small enough that B's minimum is
#: kept wherever the front's end is set by constraints (the weighted optimum leaves B's
#: minimum only where the front is steeper than 1 / w there: 100 dB per unit of ln V);
#: :func:`_anchor_b` verifies it either way.
LEXICOGRAPHIC_WEIGHT = 0.01
#: Band above A's value at the lexicographic point within which B alone is minimized again
#: to verify that point (internal units, like :data:`ANCHOR_B_BAND`): narrow, so that the
#: free epigraph cannot wander (14 iterations on the default study).
VERIFY_BAND = {True: 1.0, False: math.log(1.1)}


def _anchor_a(st: Study, prob: Problem, progress, total: int):
    """A's optimum as :func:`~isodesign.optimization.driver.optimize` finds it, without
    the tie-break; and the lexicographic anchor of B, solved alongside.

    The starts, then the peak refinement of each distinct branch
    (:func:`~isodesign.optimization.refine.refine_branches`) and the NumPy re-check of the
    winner; the tie-break of the flat direction is left out (the front starts at the
    NLP's best design, which the tie-break would leave by up to its tolerance), so its
    solves are not spent. While the branches are refined, B's lexicographic anchor is
    solved from the best start in the same map (:func:`_lexicographic_b`). Returns the
    winner's refined optimum (``prob``'s movable peak frequencies are the winner's) and
    that anchor's result.
    """
    a = prob.objectives[0]

    def start_progress(done, n, _out):
        if progress:
            progress(0, total)

    outs = run_starts(prob, start_points(st, prob.scaling), workers=st.solver.get("workers"),
                      progress=start_progress)
    good = {i: o for i, o in enumerate(outs) if isinstance(o, Solution) and o.feasible}
    if not good:
        sols = [o for o in outs if isinstance(o, Solution)]
        status = (min(sols, key=lambda o: o.max_violation).status if sols
                  else f"no start could be initialized: {outs[0]}")
        verb = "maximizing" if OBJECTIVES[a].maximized else "minimizing"
        raise SolverError(f"pareto: no feasible design when {verb} {a} alone ({status})")
    best = min(good.values(), key=lambda o: o.objective)
    win = refine_branches(st.with_changes(solver={"tie_break": False}), prob, good,
                          flat_tolerance(a), alongside=lambda: _lexicographic_b(prob, best))
    # B has no weight here: its epigraph variable (if any) is made tight, so that the
    # anchor's B is B's value there (the sweep's first epsilon) and the re-check holds
    best = prob.retighten(win.best)
    recheck(prob, best, st.design_at(best.values))
    return best, win.alongside


def _lexicographic_b(prob: Problem, start: Solution):
    """B's lexicographic anchor from a solution of A: ``(anchor, end point)``, or ``None``.

    ``J_B + w J_A`` minimized (:data:`LEXICOGRAPHIC_WEIGHT`) gives B's minimum with the
    best A there, which is the sweep's last point (A optimized subject to
    ``B <= min B``). It is verified by minimizing B alone from it, A's epigraph bounded to
    :data:`VERIFY_BAND` above its value there (:func:`_minimize_b`: the solve is repeated
    without the bound if the bound binds): when that does not lower B (beyond the sweep's
    1e-9 relative slack on epsilon), the lexicographic point is the anchor and the last
    point; otherwise the verified minimum is the anchor and the end point ``None`` (the
    sweep solves it). ``None`` when a solve fails.
    """
    lex = prob.solve(start.x, prob.params(weights=[LEXICOGRAPHIC_WEIGHT, 1.0]),
                     warm=start.as_start())
    if not lex.feasible:
        return None
    ver = _minimize_b(prob, lex, VERIFY_BAND)
    if not ver.feasible:
        return None
    jb = float(ver.objectives[1])
    if float(lex.objectives[1]) <= jb + 1e-9 * max(1.0, abs(jb)):
        return lex, lex
    return ver, None


def _on_grid(prob: Problem, sol: Solution) -> Solution:
    """A solution re-evaluated on the NLP's current peak grid (constraints, objectives)."""
    _, g = prob.eval_fn(sol.x, prob.params())
    g = np.asarray(g).ravel()
    return sol.replace(g=g, objectives=prob.objective_values(sol.x),
                       objective=float(prob.objective_values(sol.x)[0]),
                       violations=tuple(prob.violations(g)))


def _anchor_b(prob: Problem, anchor_a: Solution, lex=None) -> tuple[Solution, Solution | None]:
    """B's minimum, and the front's end point when the lexicographic solve gives it.

    ``lex`` is :func:`_lexicographic_b`'s result solved on the study's peak grid
    (alongside the branches); it stands when its points are feasible on the current grid
    (the winner's movable frequencies added: then B's minimum is the same, since the
    current grid only adds constraints). Else the lexicographic anchor is solved here
    from A's optimum; if that fails, B is minimized from A's optimum
    (:func:`_minimize_b`), then from the study's starts.
    """
    b = prob.objectives[1]
    if lex is not None:
        anchor_b, last = (_on_grid(prob, s) if s is not None else None for s in lex)
        if anchor_b.feasible and (last is None or last.feasible):
            return anchor_b, last
    lex = _lexicographic_b(prob, anchor_a)
    if lex is not None:
        return lex
    anchor_b = _minimize_b(prob, anchor_a, ANCHOR_B_BAND)
    if anchor_b.feasible:
        return anchor_b, None
    # from A's optimum IPOPT can stall; minimize B from the study's starts instead
    outs = run_starts(prob, start_points(prob.study, prob.scaling),
                      workers=prob.study.solver.get("workers"),
                      params=prob.params(weights=[0.0, 1.0]))
    good = [o for o in outs if isinstance(o, Solution) and o.feasible]
    if not good:
        raise SolverError(f"pareto: {'maximizing' if OBJECTIVES[b].maximized else 'minimizing'}"
                          f" {b} failed ({anchor_b.status}) from A's "
                          "optimum and from every start")
    return min(good, key=lambda o: o.objectives[1]), None


def _minimize_b(prob: Problem, start: Solution, band=None) -> Solution:
    """B minimized alone from a solution, A's epigraph bounded to a band above its value.

    ``band`` maps "A is in dB" to the band (default :data:`ANCHOR_B_BAND`). The band must
    not bind: if A's true value (epigraph made tight) reaches its bound the solve is
    repeated without it, so the result is B's minimum either way.
    """
    kind_a = prob.objectives[0]
    band = ANCHOR_B_BAND if band is None else band
    bound = float(start.objectives[0]) + band[OBJECTIVES[kind_a].db]
    sol = prob.solve(start.x, prob.params(weights=[0.0, 1.0], eps=[bound, None]),
                     warm=start.as_start())
    if sol.feasible:
        tight = prob.retighten(sol)
        if float(tight.objectives[0]) < bound - 1e-6 * max(1.0, abs(bound)):
            return sol
    # without A's bound the solve travels far from the start (A is free), where the
    # start's expansion of the distortion's terms extrapolates badly: the terms' values
    # (a cold start) lead IPOPT there (docs/random-response.md 3d)
    return prob.solve(start.x, prob.params(weights=[0.0, 1.0]))


def _chain(prob: Problem, anchor: Solution, indices: list[int], eps,
           anchor_b: Solution, first: Solution | None = None) -> dict:
    """Solve a chain of sweep points, each warm-started from the previous one.

    ``first``, when given, is the chain's first point solved already (an anchor that is
    that point's optimum): only its peak is checked. Where the peak of |T| is refined,
    round 0 of the movable peak frequencies is placed before each point around the peak
    predicted from the chain so far (the last two refined peaks extrapolated
    geometrically: the epsilon steps are equal; the anchor's own peak first), so that the
    exchange method (:func:`_refine_point`, rounds 1, 2, ...) seldom needs a re-solve.
    """
    out = {}
    refined = _peak_refined(prob)
    x = None if first is not None else _consistent(prob, anchor)
    peaks = [_peak_of(prob, anchor)[1]] if refined and first is None else []
    zs: list = []
    for n, k in enumerate(indices):
        e_k = eps[k] + 1e-9 * max(1.0, abs(eps[k]))
        if n == 0 and first is not None:
            sol = first
        else:
            if len(zs) >= 2:
                z_pred = np.clip(2.0 * zs[-1] - zs[-2], -1.0, 1.0)
                x = x.copy()
                x[: prob.nz] = z_pred
            if peaks:
                f_pred = peaks[-1] if len(peaks) < 2 else peaks[-1] ** 2 / peaks[-2]
                peak_slots(prob, 0, f_pred)
            if peaks or len(zs) >= 2:
                x = prob.initial_guess(prob.values(x))  # consistent on the moved frequencies
            sol = prob.solve(x, prob.params(weights=[1.0, 0.0], eps=[None, e_k]))
            if not sol.feasible:
                # warm start failed: retry from B's anchor (feasible for every eps >= B's min)
                sol = prob.solve(_consistent(prob, anchor_b),
                                 prob.params(weights=[1.0, 0.0], eps=[None, e_k]),
                                 warm=anchor_b.as_start())
        if sol.feasible:
            sol, f_pk = _refine_point(prob, sol, [None, e_k])
            sol = _tight(prob, sol)
            x = sol.x
            zs.append(sol.x[: prob.nz].copy())
            if refined and f_pk is not None:
                peaks.append(f_pk)
        elif x is None:  # the given first point is not feasible: start from the anchor
            x = _consistent(prob, anchor)
        out[k] = sol
    return out


def _run_chains(prob: Problem, chains, eps, anchor_b, workers) -> dict:
    """Run the sweep chains, in forked workers when ``workers`` (default 2), capped by
    the cores available to the process, is more than 1
    (:func:`~isodesign.optimization.multistart.map_in_workers`). Each chain starts from
    the NLP's current movable peak frequencies, in a worker or not."""
    chains = [c for c in chains if c[1]]
    slots = prob.slot_hz.copy() if prob is not None else None

    def run(c):
        if slots is not None and not np.array_equal(prob.slot_hz, slots):
            prob.set_slots(slots)
        return _chain(prob, c[0], c[1], eps, anchor_b, *c[2:])

    parts = map_in_workers(run, chains, workers=workers)
    sols: dict = {}
    for part in parts:
        sols.update(part)
    return sols


#: Two chains are on different branches at a point when the design one of them found
#: there and the other chain's neighbours, interpolated, differ by more than this in a
#: scaled design variable (z in [-1, 1]: the log range of the variable). On the default
#: front the same branch differs by at most 0.023 (interpolation over two steps), two
#: branches by 0.11 to 0.31.
BRANCH_DZ = 0.05


def on_other_branch(z, z_ref) -> bool:
    """True when two designs lie on different branches: a scaled design variable (z in
    [-1, 1]) differs by more than :data:`BRANCH_DZ` (the Pareto chains' test, and a sweep's
    along its lines: :mod:`isodesign.sweeps.continuation`).

    Parameters
    ----------
    z, z_ref : array_like
        Scaled designs (:meth:`~isodesign.optimization.variables.LogScaling.to_z`).

    Returns
    -------
    bool
    """
    return bool(np.max(np.abs(np.asarray(z, float) - np.asarray(z_ref, float))) > BRANCH_DZ)


def _other_branch(prob: Problem, sols: dict, in_a: set, eps, workers) -> dict:
    """Solve again, from the other chain's branch, every point where the chains differ.

    Warm-started continuation follows the branch (local optimum) it starts on. The two
    chains take alternate points, so each interior point has neighbours from the other
    chain: where the point's design differs from their interpolation by more than
    :data:`BRANCH_DZ` (the chains are on different branches there), the point is solved
    again from that interpolation (the peak slots of round 0 at the neighbours' peaks,
    interpolated geometrically) and the better of the two solutions is kept (better by
    more than A's flat tolerance, :func:`~isodesign.optimization.refine.flat_tolerance`).
    On the default study the chain from B's anchor finds more margin between 1.5 and
    3.8 L (N = 8 with a smaller top chamber, where the chain from A's anchor lowers N).
    The solves are independent: they run in the workers. Replaces points of
    ``sols`` in place; returns the points compared and those replaced.
    """
    n = len(sols)
    todo = []
    for k in range(1, n - 1):
        other = [sols[j] for j in (k - 1, k + 1) if (j in in_a) != (k in in_a)
                 and sols[j].feasible]
        if not other:
            continue
        z = np.mean([o.x[: prob.nz] for o in other], axis=0)
        if sols[k].feasible and not on_other_branch(sols[k].x[: prob.nz], z):
            continue
        todo.append((k, z, other))
    slots = prob.slot_hz.copy()

    def solve(item):
        k, z, other = item
        if not np.array_equal(prob.slot_hz, slots):
            prob.set_slots(slots)
        if _peak_refined(prob):
            peak_slots(prob, 0, math.exp(np.mean([math.log(_peak_of(prob, o)[1])
                                                  for o in other])))
        x = np.zeros(prob.nx)
        x[: prob.nz] = z
        e_k = eps[k] + 1e-9 * max(1.0, abs(eps[k]))
        try:
            x = prob.initial_guess(prob.values(x))
        except SolverError:
            return None
        sol = prob.solve(x, prob.params(weights=[1.0, 0.0], eps=[None, e_k]))
        return _tight(prob, _refine_point(prob, sol, [None, e_k])[0]) if sol.feasible else None

    outs = map_in_workers(solve, todo, workers=workers) if todo else []
    tol = flat_tolerance(prob.objectives[0])
    replaced = []
    for (k, _, _), sol in zip(todo, outs, strict=True):
        if sol is not None and sol.feasible and (
                not sols[k].feasible or float(sol.objective) < float(sols[k].objective) - tol):
            sols[k] = sol
            replaced.append(k)
    return {"compared": [t[0] for t in todo], "replaced": replaced}


def _tight(prob: Problem, sol: Solution) -> Solution:
    """A sweep point with B's epigraph variable (if any, slack below epsilon where B has
    no weight) made tight on the peak grid it was solved on, so that its B is the
    design's own value; the point as it is if that is not feasible."""
    tight = prob.retighten(sol)
    return tight if tight.feasible else sol


def _consistent(prob: Problem, sol: Solution) -> np.ndarray:
    """A start at a solution's design with every implicit unknown solved for the
    current grid (the movable peak frequencies included)."""
    return prob.initial_guess(sol.values)


def _peak_refined(prob: Problem) -> bool:
    """True when the sweep refines the peak grid (a peak bound, or the peak objective)."""
    return (prob.study.constraints.get("max_peak_transmissibility_db") is not None
            or "peak_transmissibility" in prob.objectives)


def _peak_of(prob: Problem, sol: Solution) -> tuple[float, float]:
    """Continuous peak of |T| of a solution: (dB, Hz)."""
    return continuous_peak_db(prob, sol.values, prob.sigma(sol.x), prob.tube_rms(sol.x))


def _refine_point(prob: Problem, sol: Solution, eps) -> tuple[Solution, float | None]:
    """The exchange method of :func:`isodesign.optimization.driver.optimize` for one sweep point.

    If the continuous peak of |T| exceeds the study's bound (or the sampled peak
    objective, its epigraph made tight) by more than PEAK_TOLERANCE_DB, move five of the
    NLP's movable
    peak frequencies around it and solve again (at most PEAK_ROUNDS rounds, using the
    slot rounds 1, 2, ... and 0 last: round 0 holds the chain's predicted peak). The
    frequencies stay for the next point, whose peak is usually close. Returns the point
    and the frequency of its continuous peak last measured (None when not refined).
    """
    bound = prob.study.constraints.get("max_peak_transmissibility_db")
    kinds = prob.objectives
    if not _peak_refined(prob):
        return sol, None
    f_pk = None
    for rnd in range(PEAK_ROUNDS):
        vals = sol.values
        peak_db, f_pk = _peak_of(prob, sol)
        limits = [bound] if bound is not None else []
        if "peak_transmissibility" in kinds:
            # the sampled peak itself: an objective without weight has a slack epigraph
            j = prob.retighten(sol).objectives
            limits += [OBJECTIVES[kind].to_natural(j[k]) for k, kind in enumerate(kinds)
                       if kind == "peak_transmissibility"]
        if peak_db <= min(limits) + PEAK_TOLERANCE_DB:
            break
        peak_slots(prob, (rnd + 1) % PEAK_ROUNDS, f_pk)
        new = prob.solve(prob.initial_guess(vals), prob.params(weights=[1.0, 0.0], eps=eps),
                         warm=sol.as_start())
        if not new.feasible:
            break
        sol = new
    return sol, f_pk


def _objective_table(study: Study, kind: str) -> dict:
    t = {"kind": kind}
    o = study.raw.get("objective", {})
    for k in ("frequency_hz", "band_min_hz", "band_max_hz"):
        if k in o:
            t[k] = o[k]
    if OBJECTIVES[kind].at_frequency and "frequency_hz" not in t:
        t["frequency_hz"] = DEFAULT_POINT_FREQUENCY_HZ
    return t
