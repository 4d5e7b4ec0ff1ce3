"""Continuation along a sweep's lines: which points are neighbours, in which order they run.

A sweep's points lie on *lines*: the points that differ only in the line key (the swept
key with numbers and the most values: ``payload.mass_kg`` in ``payload x floor``), sorted
by it. Each line is cut into at most as many *chains* as there are workers per line; a
chain's points run in order on one worker, each starting from its own starts and from its
predecessor's optimum (:func:`neighbour_starts`). A point whose answer is on another
branch than the one its predecessor's optimum led to (the sweep task's ``branch_changed``:
:func:`isodesign.optimization.pareto.on_other_branch`, the test of the Pareto chains) has
its predecessor solved again from its optimum too, and so on backwards while the answer
moves to that branch (:mod:`isodesign.sweeps.runner`). See ``docs/sweep.md``.
"""

from __future__ import annotations

import json
import math
import numbers

import numpy as np

__all__ = ["PEAK_MASS_EXPONENT", "Line", "chains", "line_key", "lines", "neighbour_starts",
           "robust_seeds", "scenario_units"]


def _number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


def line_key(tables: list[dict], keys: list[str]) -> str | None:
    """The key the lines run along: numeric, the most distinct values (None: no line).

    Parameters
    ----------
    tables : list of dict
        The points' changes (dotted key -> value).
    keys : list of str
        The swept keys, in the order given.

    Returns
    -------
    str or None
    """
    best, n_best = None, 1
    for k in keys:
        vals = [t.get(k) for t in tables]
        if not vals or not all(_number(v) for v in vals):
            continue
        n = len(set(vals))
        if n > n_best:
            best, n_best = k, n
    return best


class Line(list):
    """Indices of points on one line, sorted along the line key."""


def lines(tables: list[dict], keys: list[str]) -> list[Line]:
    """The points grouped into lines (each sorted along :func:`line_key`).

    Parameters
    ----------
    tables : list of dict
    keys : list of str

    Returns
    -------
    list of Line
        Every point index exactly once; without a line key, one line per point.
    """
    lk = line_key(tables, keys)
    if lk is None:
        return [Line([i]) for i in range(len(tables))]
    groups: dict[str, Line] = {}
    for i, t in enumerate(tables):
        rest = json.dumps({k: v for k, v in t.items() if k != lk}, sort_keys=True, default=str)
        groups.setdefault(rest, Line()).append(i)
    out = []
    for g in groups.values():
        out.append(Line(sorted(g, key=lambda i: tables[i][lk])))
    return out


def chains(tables: list[dict], keys: list[str], workers: int) -> list[list[int]]:
    """The lines cut into chains, so that every worker has one while lines last.

    Parameters
    ----------
    tables : list of dict
    keys : list of str
    workers : int

    Returns
    -------
    list of list of int
        Chains of point indices; a chain runs in order, each point after its predecessor.
        Fewer lines than workers: each line is cut into ``ceil(workers / lines)`` pieces
        of consecutive points.
    """
    ls = lines(tables, keys)
    if not ls:
        return []
    pieces = max(1, math.ceil(max(workers, 1) / len(ls)))
    out = []
    for ln in ls:
        n = min(pieces, len(ln))
        size = math.ceil(len(ln) / n)
        out += [list(ln[i: i + size]) for i in range(0, len(ln), size)]
    return out


def neighbour_starts(rows) -> list[dict]:
    """The design values of the feasible neighbours' optima (rows of the sweep table).

    Parameters
    ----------
    rows : iterable of dict or None

    Returns
    -------
    list of dict
        Design-variable values (SI) of each feasible neighbour, in order.
    """
    from isodesign.optimization.variables import DESIGN_VARIABLES

    out = []
    for r in rows:
        if not r or not r.get("feasible") or r.get("status") not in ("complete",):
            continue
        try:
            out.append({k: float(r[k]) for k in DESIGN_VARIABLES})
        except (KeyError, TypeError, ValueError):
            continue
    return out


#: The exponent of the payload mass in the continuous peak's predicted frequency,
#: ``f = f_neighbour (m_neighbour / m)^PEAK_MASS_EXPONENT`` (the optimum's peak moves
#: as m^-0.3 to m^-0.45 along the vertical study's mass line, docs/sweep.md section 7).
PEAK_MASS_EXPONENT = 0.4


def scenario_units(result) -> str:
    """The row field ``scenario_units`` of a robust optimum: the unit coordinates
    (:meth:`~isodesign.optimization.uncertainty.UncertaintySpace.to_unit`) of the final
    set's active scenarios (those that set the worst case or bind a constraint), as JSON.

    Parameters
    ----------
    result : RobustResult or TableRobustResult
        A feasible robust optimum (its ``scenarios`` rows).

    Returns
    -------
    str
        ``{"names": [parameter, ...], "units": [[u1, u2, ...], ...], "peak_hz": [...],
        "payload_kg": m}`` as JSON: the names in the box's order (``units`` empty: no
        active scenario), each active scenario's continuous peak frequency at the optimum
        (None where the peak is not refined) and the point's payload mass.
    """
    space = result.study.scenarios
    peaks = ((result.extra or {}).get("continuation") or {}).get("peak_hz") or []
    units, peak_hz = [], []
    for r in result.scenarios or ():
        if r.get("active"):
            th = [r["theta"][n] for n in space.names]
            units.append([round(float(x), 12) for x in space.to_unit(th)])
            k = int(r.get("index", -1))
            peak_hz.append(peaks[k] if 0 <= k < len(peaks) else None)
    return json.dumps({"names": list(space.names), "units": units, "peak_hz": peak_hz,
                       "payload_kg": float(result.study.payload.mass_kg)})


def robust_seeds(rows, space, mass_kg: float | None = None) -> tuple[list[dict], list, list]:
    """What a robust point takes from its finished neighbours (docs/sweep.md, section 7).

    Parameters
    ----------
    rows : iterable of dict or None
        The neighbours' rows (robust optima, with their ``scenario_units``).
    space : UncertaintySpace
        The point's own ``[scenarios]`` box.
    mass_kg : float, optional
        The point's payload mass: a neighbour's peak frequency is scaled to it as
        ``f (m_neighbour / m)^PEAK_MASS_EXPONENT``.

    Returns
    -------
    (list of dict, list of ndarray, list of float or None)
        The feasible neighbours' robust optima (further starts of the exchange's first
        solve), their active scenarios placed at the same unit coordinates in the point's
        box (a corner stays a corner when the ranges are swept; a discrete parameter
        takes its nearest listed value), without repeats: the exchange starts with them in
        its set; and each one's expected continuous peak frequency (Hz, None: unknown).
    """
    rows = [r for r in rows if r]
    starts = neighbour_starts(rows)
    thetas, peaks = [], []
    for r in rows:
        if not r.get("feasible") or r.get("status") != "complete":
            continue
        try:
            carried = json.loads(r.get("scenario_units") or "{}")
        except (TypeError, ValueError):
            continue
        if not isinstance(carried, dict) or list(carried.get("names") or ()) != list(
                space.names):
            continue  # another set of uncertain parameters: no scenario to carry
        f_nb = list(carried.get("peak_hz") or ())
        m_nb = carried.get("payload_kg")
        for i, u in enumerate(carried.get("units") or ()):
            th = space.from_unit(u)
            if any(np.allclose(th, t, rtol=1e-12, atol=0.0) for t in thetas):
                continue
            f = f_nb[i] if i < len(f_nb) else None
            if f is not None and m_nb and mass_kg:
                f = float(f) * (float(m_nb) / float(mass_kg)) ** PEAK_MASS_EXPONENT
            thetas.append(th)
            peaks.append(f)
    return starts, thetas, peaks


#: A vertical ``optimize`` point whose predecessor's optimum it starts from solves its
#: own starts too at least every ``OWN_STARTS_EVERY``-th point along its chain (the
#: checkpoints: docs/sweep.md, section 7), besides the points :func:`needs_own_starts` names.
OWN_STARTS_EVERY = 3


def binding_set(row) -> frozenset:
    """The binding constraints and variables at a bound of a row (its ``binding`` column)."""
    text = (row or {}).get("binding") or ""
    return frozenset(b for b in str(text).split(";") if b)


def needs_own_starts(neighbours, resolve: bool = False, starts: int = 1) -> tuple[bool, int]:
    """Whether a continued vertical point solves its own starts before it is solved.

    Parameters
    ----------
    neighbours : sequence of dict or None
        The finished neighbours' rows given to the point (its predecessor first).
    resolve : bool
        The branch pass's second solve (always with its own starts).
    starts : int
        The study's ``solver.starts``: a study that asks for more than one start per point
        solves them at every point.

    Returns
    -------
    (bool, int)
        Whether the point's own starts are solved, and the points since the last one
        along the chain that solved them (0: this one). The own starts are solved at a
        point with no feasible neighbour, at a second solve, at every point of a study
        with more than one start (``solver.starts``), after a predecessor that
        changed branch or had to solve its own starts again (:func:`jumped`), and at
        every :data:`OWN_STARTS_EVERY`-th point.
    """
    nb = next((r for r in neighbours if r), None) if neighbours else None
    if resolve or starts > 1 or not neighbour_starts([nb]):
        return True, 0
    since = int(nb.get("since_own_starts") or 0) + 1
    if since >= OWN_STARTS_EVERY or nb.get("branch_changed") or nb.get("own_starts_rerun"):
        return True, 0
    return False, since


def jumped(row: dict, neighbour: dict | None) -> bool:
    """The jump check of a point solved from its predecessor's optimum alone.

    True when its answer is not a feasible optimum (``row["feasible"]``; the caller adds a
    result with violations) or its binding set (the ``binding`` column: binding
    constraints, variables at a bound) differs from the predecessor's: the optimum moved to
    another face of the feasible set, where another branch may begin, and the point is
    solved again with its own starts.
    """
    if not row.get("feasible"):
        return True
    return binding_set(row) != binding_set(neighbour)
