"""The ``optimize`` task's vertical and table points: their NLPs, starts and rows.

A sweep worker builds one NLP per structure (:func:`problem_cache`) and solves every point
it is given on it; a vertical point continues from its finished neighbours' optima with its
checkpoints and preset peak frequencies, a table point from its neighbour's optimum as its
first start (docs/sweep.md, section 7). The robust points (:mod:`.robust_points`) solve
their nominal optima here too. :mod:`.tasks` runs them as its ``optimize`` task.
"""

from __future__ import annotations

import dataclasses
import threading

from isodesign.sweeps.continuation import PEAK_MASS_EXPONENT

__all__ = ["PEAK_MASS_EXPONENT", "payload_varies", "problem_cache", "table_continuation_study"]


def _variables(values: dict) -> dict:
    from isodesign.optimization.variables import DESIGN_VARIABLES

    out = {k: float(values[k]) for k in DESIGN_VARIABLES}
    out["total_volume_m3"] = out["top_volume_m3"] * (1.0 + out["volume_ratio"])
    return out


def _analysis_fields(analysis) -> dict:
    import math

    if analysis is None:
        return {}
    s = analysis.stability
    pk = s.excited_peak_transmissibility
    return {"worst_band_margin_db": float(analysis.worst_margin_db),
            "worst_band_hz": float(analysis.worst_band_hz),
            "passes": bool(analysis.passes),
            "natural_frequency_hz": float(s.natural_frequency_hz),
            "peak_transmissibility_db": 20.0 * math.log10(pk) if pk else None}


_LOCAL = threading.local()


def problem_cache():
    """This thread's built NLPs (:class:`~isodesign.optimization.parametric.ProblemCache`).

    A sweep worker builds one NLP per structure and solves every point it is given on it;
    a worker process runs one task at a time (one thread), so the cache is the process's.

    Returns
    -------
    ProblemCache
    """
    from isodesign.optimization.parametric import ProblemCache

    cache = getattr(_LOCAL, "problems", None)
    if cache is None:
        cache = _LOCAL.problems = ProblemCache()
    return cache


def _optimize_vertical(study, options: dict, nominal: bool = False):
    """The vertical optimum on this worker's NLP, from the study's starts and the finished
    neighbours' optima; the row's continuation fields (docs/sweep.md, section 7). With
    ``nominal``, the nominal optimum of a study with ``[scenarios]`` (a robust point's, its
    neighbours the rows of their nominal optima), on the NLP of the study without them."""
    from isodesign.optimization.driver import optimize_vertical
    from isodesign.optimization.objectives import OBJECTIVES
    from isodesign.optimization.refine import flat_tolerance
    from isodesign.sweeps.continuation import jumped, needs_own_starts, neighbour_starts

    cache = problem_cache()
    before = cache.builds
    # a robust point's nominal: the study without [scenarios] (the ranges do not reach it)
    prob = cache.get(dataclasses.replace(study, scenarios=None) if nominal else study)
    given = list(options.get("_neighbours") or ())
    pairs = [(i, v) for i, r in enumerate(given) for v in neighbour_starts([r])]
    # between checkpoints a point is solved from its predecessor's optimum alone, and
    # again with its own starts when its answer jumped (docs/sweep.md, section 7)
    own, since = needs_own_starts(given, bool(options.get("_resolved", False)),
                                  int(study.solver["starts"]))
    extra = tuple(v for _, v in pairs)
    # the point's own peak grid: a solve of its own starts runs on it, as a cold optimize
    # of the point does (the preset frequencies change the NLP, and with them the branch
    # a start reaches); between checkpoints the neighbour's predicted peak is preset
    slots0 = prob.slot_hz.copy()
    preset = None if own else _preset_peak_slots(study, prob, given)
    result = optimize_vertical(study, problem=prob, extra_starts=extra, own_starts=own,
                               nominal=nominal)
    rerun = False
    if not own:
        row = {"feasible": result.feasible, "binding": _vertical_row(result)["binding"]}
        if result.violations or jumped(row, next(r for r in given if r)):
            own, since, rerun = True, 0, True
            prob.set_slots(slots0)
            result = optimize_vertical(study, problem=prob, extra_starts=extra, nominal=nominal)
    n_own = len(result.starts) - len(pairs)
    best, changed = None, False
    if result.feasible:
        sign = -1.0 if OBJECTIVES[result.objective].maximized else 1.0
        best = min((r for r in result.starts if r.feasible), key=lambda r: sign * r.objective,
                   default=None)
        # the answer left the branch the continuation followed: no neighbour's start reached
        # the best start's objective (within the tie-break's flat tolerance)
        obj = OBJECTIVES[result.objective]
        tol = flat_tolerance(result.objective)
        nbs = result.starts[n_own:]
        changed = bool(nbs) and best is not None and all(
            not r.feasible or obj.from_natural(r.objective) > obj.from_natural(best.objective)
            + tol for r in nbs)
    return result, {
        "nlp_built": cache.builds > before, "nlp_builds": cache.builds - before,
        "nlp_builds_worker": cache.builds,
        "neighbour_starts": len(pairs),
        "from_neighbour": bool(best is not None and best.index >= n_own),
        # which of the given neighbours' optima the best start was (-1: the point's own)
        "best_neighbour": (pairs[best.index - n_own][0]
                           if best is not None and best.index >= n_own else -1),
        "branch_changed": changed,
        "own_starts": own, "own_starts_rerun": rerun, "since_own_starts": since,
        "continuous_peak_hz": (result.peak or {}).get("peak_frequency_hz"),
        "payload_kg": float(study.payload.mass_kg), "preset_peak_hz": preset,
        "resolved": bool(options.get("_resolved", False))}


def _preset_peak_slots(study, prob, given) -> float | None:
    """Place the last refinement round's five movable peak frequencies around the
    continuous peak predicted from the predecessor's (``continuous_peak_hz`` of its row),
    as the exchange method would place them (:func:`.refine.peak_slots`), so that the
    point's solves bound |T| there from the start and its refinement seldom needs a
    re-solve. Returns the predicted peak frequency (Hz), or None (no peak refinement, no
    neighbour's peak)."""
    from isodesign.optimization.problem import PEAK_ROUNDS
    from isodesign.optimization.refine import _peak_refined, peak_slots

    nb = next((r for r in given if r), None)
    f_nb, m_nb = (nb or {}).get("continuous_peak_hz"), (nb or {}).get("payload_kg")
    if not f_nb or not m_nb or not _peak_refined(study, prob):
        return None
    f = float(f_nb) * (float(m_nb) / float(study.payload.mass_kg)) ** PEAK_MASS_EXPONENT
    peak_slots(prob, PEAK_ROUNDS - 1, f)
    return f


#: Study tables whose keys never move a table's payload (its mass, CG, inertia, supply).
_PAYLOAD_FREE_TABLES = ("floor", "target", "constraints", "variables", "solver")


def payload_varies(changes: dict) -> bool:
    """Whether a sweep point's changes may move a table study's payload: its table NLP then
    takes the payload as parameters (one NLP for every payload), else it folds the payload's
    numbers (the solves as fast as a fresh build's; docs/sweep.md section 7).

    Parameters
    ----------
    changes : dict
        The point's study changes (dotted keys).

    Returns
    -------
    bool
        False when every key is in a floor, target, constraints, variables or solver table.
    """
    return not all(str(k).split(".")[0] in _PAYLOAD_FREE_TABLES for k in changes)


def table_continuation_study(study, neighbours):
    """The study a table point is solved as: its first start its neighbour's optimum.

    The table's NLP takes its starts from the study (:func:`~isodesign.optimization.
    multistart.start_points`: the study's start, then ``solver.starts - 1`` Latin-hypercube
    starts drawn in the variables' boxes, independent of the start). So a table point
    continues from a finished neighbour by starting its free design variables at the
    neighbour's optimum in place of the study's start; its Latin-hypercube starts are
    unchanged. The point's identity (hash, run directory) stays its own study's.

    Parameters
    ----------
    study : Study
        The point's table study.
    neighbours : sequence of dict or None
        Finished neighbours' rows; the first feasible one is used.

    Returns
    -------
    (Study, dict or None)
        The study to solve and the neighbour's values it starts from (None: no feasible
        neighbour, the point's own study).
    """
    from isodesign.sweeps.continuation import neighbour_starts

    free = {v.name: v for v in study.variables if v.free}
    for vals in neighbour_starts(neighbours):
        start = {k: min(max(v, free[k].lower), free[k].upper)
                 for k, v in vals.items() if k in free}
        if start:
            return study.with_changes(variables={k: {"start": v} for k, v in start.items()}), \
                start
    return study, None


def _optimize_table(study, options: dict):
    """The table optimum, its first start the finished neighbour's optimum (continuation
    along the line; :func:`table_continuation_study`), and the row's continuation fields.

    On this worker's table NLP of the point's structure
    (:class:`~isodesign.optimization.table_parametric.TableParametricProblem`: the floor,
    the target's limits, the start, the payload's mass, CG position and principal inertia
    and the constraints' bounds are parameters; the layout, the levers and which
    constraints are on are the structure: docs/sweep.md, section 7)."""
    from isodesign.optimization.dispatch import optimize
    from isodesign.optimization.refine import flat_tolerance

    given = list(options.get("_neighbours") or ())
    if options.get("_resolved"):  # the branch pass: the later neighbour's branch first
        given = given[::-1]
    solve, start = table_continuation_study(study, given)
    cache = problem_cache()
    before = cache.builds
    # its study_resolved.toml: the study solved, with that start
    result = optimize(solve, problem=cache.get(solve, payload=options.get("_payload", True)))
    changed = from_nb = False
    recs = [r for r in result.starts if r[2]]  # (index, status, feasible, iter, wall, J)
    if start is not None and recs:
        best_j = min(r[5] for r in recs)
        first = next((r for r in recs if r[0] == 0), None)
        tol = flat_tolerance(result.objective)
        from_nb = first is not None and first[5] <= best_j + 1e-4
        # the answer left the branch the continuation followed: the neighbour's start did
        # not reach the best start's objective (within the tie-break's flat tolerance)
        changed = first is None or first[5] > best_j + tol
    return result, {"nlp_built": cache.builds > before, "nlp_builds": cache.builds - before,
                    "nlp_builds_worker": cache.builds,
                    "neighbour_starts": int(start is not None),
                    "from_neighbour": bool(from_nb),
                    "best_neighbour": 0 if from_nb else -1,
                    "branch_changed": bool(changed),
                    "resolved": bool(options.get("_resolved", False))}, solve


def _at_bounds(result) -> list[str]:
    from isodesign.io.record import variables_at_bounds

    return [f"{n}={side}" for n, side in variables_at_bounds(result).items()]


def _vertical_row(result) -> dict:
    binding = [c.name for c in result.constraints if c.active] + _at_bounds(result)
    row = {"feasible": bool(result.feasible), "objective": result.objective,
           "objective_value": float(result.objective_value), "solver_status": result.status,
           **_variables(result.values), "binding": ";".join(binding),
           "n_reached_best": int(result.n_reached_best), "starts": len(result.starts)}
    if result.feasible:
        row.update(_analysis_fields(result.analysis))
    else:
        row["binding"] = "violated: " + ";".join(n for n, _ in result.violations[:3])
    return row


def _table_row(result) -> dict:
    """The row of a table optimum: its objective, design, and the table's analysis (worst
    margin over points, axes and bands; the z mode; the peak of |T| over every axis)."""
    # (name, worst violation) pairs, or constraint reports with ``active`` and ``margin``
    cons = [(c[0], c[1], False) if isinstance(c, tuple) else
            (c.name, max(-float(c.margin), 0.0), bool(c.active)) for c in result.constraints]
    binding = [n for n, _, active in cons if active]
    row = {"feasible": bool(result.feasible), "objective": result.objective,
           "objective_value": float(result.objective_value), "solver_status": result.status,
           **_variables(result.values), "binding": ";".join(binding + _at_bounds(result)),
           "n_reached_best": int(result.n_reached_best), "starts": len(result.starts)}
    if not result.feasible:
        viol = [(n, v) for n, v, _ in cons if v > 1e-6]
        row["binding"] = "violated: " + ";".join(n for n, _ in viol[:3])
        return row
    a = result.analysis
    if a is not None:
        point, axis, band, _ = a.worst
        z = [f for f, n in zip(result.modes.frequency_hz, result.modes.names, strict=True)
             if n == "z"] if result.modes is not None else []
        row.update({"worst_band_margin_db": float(a.worst_margin_db),
                    "worst_band_hz": float(band), "worst_point": str(point),
                    "worst_axis": str(axis), "passes": bool(a.passes),
                    "natural_frequency_hz": float(z[0]) if z else None,
                    "peak_transmissibility_db": float(a.peak_transmissibility_db().max())})
    return row
