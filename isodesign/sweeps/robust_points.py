"""The ``optimize`` task's robust points: a study with ``[scenarios]`` in a sweep.

A robust point (vertical or table) is solved on its worker's NLPs and continued from its
finished neighbours (docs/sweep.md, section 7): its nominal multi-start as a vertical or
table point's, from the neighbours' nominal optima (the robust row's ``nominal_row``); its
exchange's first solve also from their robust optima, its scenario set seeded with their
active scenarios (``scenario_units``: unit coordinates in the box, so a corner stays a
corner when the ranges are swept) and, on the vertical body, those scenarios' peak
frequencies placed where the neighbours' continuous peaks predict them. The answer is
checked by the same search of the box as a cold solve's.
"""

from __future__ import annotations

import dataclasses
import json

from isodesign.sweeps import points

__all__ = ["optimize_robust", "optimize_robust_table", "robust_row"]


def _nominal_row(result, extra: dict) -> str:
    """A robust point's nominal optimum as the row a vertical or table point would have
    (JSON, the robust row's ``nominal_row``): what its neighbours' nominal solves continue
    from (:func:`_neighbour_nominals`)."""
    row = (points._vertical_row(result) if result.kind == "vertical"
           else points._table_row(result))
    keep = {k: row.get(k) for k in ("feasible", "binding", *points._variables(result.values))}
    keep["status"] = "complete" if result.feasible else "infeasible"
    return json.dumps({**keep, **{k: v for k, v in extra.items()
                                  if isinstance(v, bool | int | float | str | None)}})


def _neighbour_nominals(given) -> list:
    """The neighbours' nominal optima as rows (``nominal_row`` of a robust row; None where a
    neighbour has none)."""
    out = []
    for r in given:
        try:
            out.append(json.loads(r["nominal_row"]) if r and r.get("nominal_row") else None)
        except (TypeError, ValueError):
            out.append(None)
    return out


def _robust_continuation(result, nominal_row: str, nominal_extra: dict, given) -> dict:
    """The continuation fields of a robust row (docs/sweep.md, section 7)."""
    from isodesign.sweeps.continuation import scenario_units

    cont = (result.extra or {}).get("continuation") or {}
    return {"nominal_row": nominal_row,
            "scenario_units": scenario_units(result) if result.feasible else "",
            "neighbour_starts": int(cont.get("extra_starts", 0)),
            "seeded_scenarios": int(cont.get("seeded_scenarios", 0)),
            "nominal_from_neighbour": bool(nominal_extra.get("from_neighbour", False)),
            "own_starts": bool(nominal_extra.get("own_starts", True)),
            "neighbours_given": sum(1 for r in given if r)}


def optimize_robust(study, options: dict):
    """The robust optimum of a vertical study with ``[scenarios]`` on this worker's NLPs:
    its nominal NLP (:meth:`~isodesign.optimization.parametric.ProblemCache.get`: the
    ranges are not part of it) and its scenario block and stacked NLPs
    (:class:`~isodesign.optimization.robust.RobustBuilds`: the scenario values are
    parameters), so points that differ in their ``[scenarios]`` ranges alone (a swept
    tolerance) build nothing after the first (docs/sweep.md, "Sweeping a tolerance").
    Continued from the finished neighbours (docs/sweep.md, section 7): the nominal
    multi-start as a vertical point's, from their nominal optima; the exchange's first
    solve also from their robust optima, its scenario set seeded with their active
    scenarios.

    Parameters
    ----------
    study : Study
        The point's vertical study with ``[scenarios]``.
    options : dict
        The task's options; ``_neighbours``: the finished neighbours' rows.

    Returns
    -------
    (RobustResult, dict)
        The robust optimum and the row's build and continuation fields.
    """
    from isodesign.optimization.exchange import robust_optimize
    from isodesign.sweeps.continuation import robust_seeds

    cache = points.problem_cache()
    before = cache.builds
    given = list(options.get("_neighbours") or ())
    nominal, nom_extra = points._optimize_vertical(
        study, {"_neighbours": _neighbour_nominals(given)}, nominal=True)
    starts, thetas, peaks = robust_seeds(given, study.scenarios, study.payload.mass_kg)
    result = robust_optimize(study, nominal=nominal, builds=cache.robust(),
                             extra_starts=tuple(starts), seed_scenarios=tuple(thetas),
                             seed_peaks_hz=tuple(peaks))
    return result, {"nlp_built": cache.builds > before, "nlp_builds": cache.builds - before,
                    "nlp_builds_worker": cache.builds,
                    **_robust_continuation(result, _nominal_row(nominal, nom_extra),
                                           nom_extra, given)}


def optimize_robust_table(study, options: dict):
    """The robust table optimum (:func:`~isodesign.optimization.robust_table.
    robust_optimize_table`, what :func:`isodesign.optimize` answers), every NLP built for
    the point (each table scenario compiles its payload and CG: docs/robust.md, section 7);
    the row counts them (its nominal table NLP, scenario NLPs and stacks: ``robust.json``).
    Continued from the finished neighbours as a vertical robust point (docs/sweep.md,
    section 7): the nominal from their nominal optima
    (:func:`~isodesign.sweeps.points.table_continuation_study`),
    the exchange from their robust optima and active scenarios.

    Parameters
    ----------
    study : Study
        The point's table study with ``[scenarios]``.
    options : dict
        The task's options; ``_neighbours``: the finished neighbours' rows.

    Returns
    -------
    (TableRobustResult, dict, Study)
        The robust optimum, the row's build and continuation fields, and the study solved
        (its starts the neighbour's nominal optimum), as a table point returns it.
    """
    from isodesign.optimization.robust_table import check_robust_table, robust_optimize_table
    from isodesign.optimization.table_driver import optimize_table
    from isodesign.sweeps.continuation import robust_seeds

    check_robust_table(study)
    cache = points.problem_cache()
    before = cache.builds
    given = list(options.get("_neighbours") or ())
    solve, start = points.table_continuation_study(study, _neighbour_nominals(given))
    # its nominal optimum on a table NLP of this worker's (payload folded), that of the
    # study without [scenarios] (the ranges do not reach it)
    nominal = optimize_table(solve, analyze=False, problem=cache.get(
        dataclasses.replace(solve, scenarios=None), payload=False))
    starts, thetas, _ = robust_seeds(given, study.scenarios)
    result = robust_optimize_table(solve, nominal=nominal, extra_starts=tuple(starts),
                                   seed_scenarios=tuple(thetas))
    n = (result.extra or {}).get("nlp_builds") or {}
    builds = cache.builds - before + int(n.get("scenarios", 0)) + int(n.get("stacks", 0))
    recs = [r for r in nominal.starts if r[2]]  # (index, status, feasible, iter, wall, J)
    from_nb = bool(start is not None and recs and any(
        r[0] == 0 and r[5] <= min(q[5] for q in recs) + 1e-4 for r in recs))
    nom_extra = {"from_neighbour": from_nb, "own_starts": True}
    return result, {"nlp_built": builds > 0, "nlp_builds": builds,
                    "nlp_builds_worker": cache.builds,
                    **_robust_continuation(result, _nominal_row(nominal, nom_extra),
                                           nom_extra, given)}, solve


def robust_row(result) -> dict:
    """The row of a robust optimum (vertical or table).

    Parameters
    ----------
    result : RobustResult or TableRobustResult

    Returns
    -------
    dict
        The worst case over the scenarios as ``objective_value``, the nominal optimum's
        objective beside it, the design, the binding constraints (or the violated one),
        rounds and scenarios.
    """
    binding = sorted({b for r in result.scenarios for b in (r.get("binding") or ())})
    row = {"feasible": bool(result.feasible), "objective": result.objective,
           "objective_value": (None if result.objective_value is None
                               else float(result.objective_value)),
           "solver_status": result.status, **points._variables(result.values),
           "binding": ";".join(binding), "converged": bool(result.converged),
           "rounds": len(result.rounds), "scenarios": len(result.scenarios),
           "nominal_objective_value": float(result.nominal.objective_value)}
    if not result.feasible:
        s = result.infeasible_scenario or {}
        row["binding"] = f"violated: {s.get('constraint')} in {s.get('description')}"
    elif result.objective == "worst_band_margin":
        row["worst_band_margin_db"] = float(result.objective_value)
    return row
