"""Staged starts of a co-designed table with free per-group springs (docs/table.md, section
13, "Starts"): a continuation in the lever set.

The per-group spring levers (``<variable>_group<k>``, section 15) add four variables per
group to the NLP. The multi-start runs first on the **tied** problem, the same study with
its free group levers removed (every leveling group then takes the shared spring, the
study's own ``group_springs`` and fixed group levers kept), whose optimum is a feasible
point of the full problem; the full NLP is then solved from the best tied optima, each
group lever starting at its shared variable's value. The full NLP's feasible set holds the
tied one, so each warm solve ends at least as well as the tied optimum it starts from.
The tied multi-start only places that start: it is solved without the distortion power
(``models.distortion = false``: one IPOPT solve per start instead of its outer fixed
point's rounds, which on the default study's tied starts ran to their cap of eight without
converging on two of three), and the full NLP, the study's own models, converges from it.
"""

from __future__ import annotations

import copy
import math

from isodesign.optimization.variables import GROUP_SPRING_LEVERS, group_lever

__all__ = ["TIED_MAX_ITER", "TIED_TOL", "WARM_SOLVES", "free_group_levers", "solve_tied",
           "tied_study", "untie_values"]

#: Full-NLP solves warm-started from the tied multi-start: its best distinct optima.
WARM_SOLVES = 1

#: IPOPT's ``tol`` of the tied multi-start at least (it only places the full NLP's starts,
#: which converge to the study's own ``solver.tol``).
TIED_TOL = 1e-6
#: IPOPT's iteration cap of a tied start (the study's ``max_iter`` if lower). The tied stage
#: only places the full NLP's start: on the default study two of its three starts converge
#: in 57 and 53 iterations and the third wanders for 135 to an optimum 1.2 dB worse, the
#: longest solve of the stage on two workers; cut at 80 it ends as
#: ``Maximum_Iterations_Exceeded`` and the stage picks the same start (docs/table.md, 13).
TIED_MAX_ITER = 80


def free_group_levers(study) -> list:
    """The study's free per-group spring levers.

    Parameters
    ----------
    study : Study
        Any study (one without levers has none).

    Returns
    -------
    list of VariableSpec
        The free ``<variable>_group<k>`` levers, in the study's order.
    """
    return [v for v in getattr(study, "levers", ()) if v.free and v.name in GROUP_SPRING_LEVERS]


def tied_study(study):
    """The study with its free per-group spring levers removed (each of those groups takes
    the shared spring), or None when none is free or one starts away from its shared
    variable's start (the study's start, a sweep point's neighbour's optimum, is then no
    point of the tied problem).

    Parameters
    ----------
    study : Study

    Returns
    -------
    Study or None
    """
    free = free_group_levers(study)
    starts = {v.name: v.start for v in study.variables}
    if not free or any(not math.isclose(v.start, starts[group_lever(v.name)[1]], rel_tol=1e-12)
                       for v in free):
        return None  # no free group spring, or the study's start is not a tied point
    from isodesign.optimization.study import study_from_dict

    raw = copy.deepcopy(study.raw)
    for v in free:
        raw["variables"].pop(v.name, None)
    raw["solver"]["tol"] = max(float(raw["solver"]["tol"]), TIED_TOL)
    # and only places it: a start still iterating after TIED_MAX_ITER is cut (its last
    # point a candidate if feasible)
    raw["solver"]["max_iter"] = min(int(raw["solver"]["max_iter"]), TIED_MAX_ITER)
    # the tied stage places the full NLP's start: without the distortion's outer rounds
    raw.setdefault("models", {})["distortion"] = False
    return study_from_dict(raw, source=study.source, fill_defaults=False)


def untie_values(study, values: dict) -> dict:
    """A start of the full problem from a tied optimum's ``values``: each free group lever
    at its shared variable's value (clipped into the lever's bounds).

    Parameters
    ----------
    study : Study
        The full study (free group levers).
    values : dict
        Design values of the tied study's solution (SI).

    Returns
    -------
    dict
    """
    out = dict(values)
    for v in free_group_levers(study):
        base = group_lever(v.name)[1]
        out[v.name] = min(max(float(values[base]), v.lower), v.upper)
    return out


def solve_tied(study, rprob, rstarts: list, prob, *, workers=None, progress=None,
               rounds=None) -> tuple | None:
    """The tied multi-start and the full NLP's solves from its best distinct feasible optima
    (:data:`WARM_SOLVES`; distinct: farther apart than
    :data:`~.refine.BRANCH_TOLERANCE` in J).

    With forked workers the tied starts are pipelined
    (:func:`~.multistart.run_starts_pipelined`): as soon as a tied start ends as the best
    feasible tied optimum so far, the full NLP ``prob`` is solved from it in the next free
    worker, beside the tied starts still running. The solves kept are those from the
    optima the stage chooses at its end, exactly as without workers (a solve depends on
    its start alone); the others are dropped.

    Parameters
    ----------
    study : Study
        The full study.
    rprob : Problem
        The tied study's NLP (its modes set).
    rstarts : list of dict
        Its starts.
    prob : Problem
        The full NLP (its modes set).
    workers : int, optional
    progress : callable, optional
        ``progress(done, total, result)`` after each tied start.
    rounds : int, optional
        The full solves' round cap of the distortion's outer fixed point.

    Returns
    -------
    (list, list, list) or None
        The tied starts' results (start order), the full NLP's starts, and their solves
        (``None``: not solved yet); None when no tied start is feasible.
    """
    from isodesign.optimization.multistart import (
        _solve_start,
        run_starts,
        run_starts_pipelined,
    )
    from isodesign.optimization.refine import BRANCH_TOLERANCE

    def after(i, sol):  # in a worker: the full NLP from a tied optimum
        return _solve_start(prob, None, untie_values(study, sol.values), rounds)

    def choose(finished):  # the best feasible tied optimum so far (ties: the first start)
        feas = [(s.objective, i) for i, s in sorted(finished.items())
                if not isinstance(s, str) and s.feasible]
        return [(min(feas)[1], finished[min(feas)[1]])] if feas else []

    piped = run_starts_pipelined(rprob, rstarts, after, choose=choose, workers=workers,
                                 progress=progress)
    outs, followed = piped if piped is not None else \
        (run_starts(rprob, rstarts, workers=workers, progress=progress), {})
    feas = [(i, o) for i, o in enumerate(outs) if not isinstance(o, str) and o.feasible]
    warm: list = []
    for i, sol in sorted(feas, key=lambda t: t[1].objective):
        if len(warm) < WARM_SOLVES and all(abs(sol.objective - o.objective) > BRANCH_TOLERANCE
                                           for _, o in warm):
            warm.append((i, sol))
    if not warm:
        return None
    return outs, [untie_values(study, sol.values) for _, sol in warm], \
        [followed.get(i) for i, _ in warm]
