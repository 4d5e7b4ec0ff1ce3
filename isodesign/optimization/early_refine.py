"""The multi-start with each branch refined as soon as its start finishes (pipelined).

:func:`starts_and_branches` runs the starts and the branches' peak refinements
(:func:`.refine._refine_one`) in one pool of forked workers
(:func:`.multistart.run_starts_pipelined`): after each start finishes, the starts
finished so far are grouped into branches as :func:`.refine.refine_branches` groups them
(by sampled objective J, best first; a start within :data:`.refine.BRANCH_TOLERANCE` of a
branch's first start belongs to it), and each branch's first start not yet refined is
refined in the next free worker, before the starts not yet begun. A start that coincides
with a better one already refined is not refined; one that finishes after a worse start
of its branch was refined is (it is the branch's first start now), so the branches at the
end are exactly those of :func:`.refine.refine_branches`, refined from the same points:
the answer does not depend on the order in which the starts finish.
:func:`select_branch` then applies the rule of :func:`.refine.refine_branches` to these
refinements: the same branches' order, the same test of a branch joining a better one (on
the objectives of the re-solves it made, recorded in the worker), the same choice and
tie-break of the winner. See ``docs/optimization.md`` sections 8 and 13.
"""

from __future__ import annotations

import numpy as np

from isodesign.errors import SolverError
from isodesign.optimization.multistart import run_starts_pipelined
from isodesign.optimization.refine import (
    BRANCH_TOLERANCE,
    Refined,
    _peak_refined,
    _rank_branches,
    _refine_one,
)

__all__ = ["branch_starts", "select_branch", "starts_and_branches"]


class _Recording:
    """The NLP, with the objective J of every feasible solve recorded (the re-solves of a
    refinement, in order): all else is passed to the NLP."""

    def __init__(self, prob):
        self._prob = prob
        self.objectives: list[float] = []

    def __getattr__(self, name):
        return getattr(self._prob, name)

    def solve(self, *args, **kwargs):
        sol = self._prob.solve(*args, **kwargs)
        if sol.feasible:  # an infeasible re-solve ends the refinement before its join test
            self.objectives.append(float(sol.objective))
        return sol


def starts_and_branches(study, prob, starts, tol_j: float, *, progress=None):
    """The starts and, pipelined with them, the refinement of every new branch.

    Parameters
    ----------
    study : Study
        Gives ``solver.workers`` and the peak bound.
    prob : Problem
        The built NLP (its movable peak frequencies: the study's).
    starts : list of dict
        The starts' design-variable values (SI).
    tol_j : float
        The tie-break's tolerance on J (:func:`.refine.flat_tolerance`).
    progress : callable, optional
        ``progress(done, total, result)`` after each start.

    Returns
    -------
    (list, dict) or None
        The starts' results in start order (as :func:`.multistart.run_starts`) and
        ``{start: (Refined or SolverError, re-solve objectives J)}`` of the starts refined;
        ``None`` when nothing is refined (no peak bound, peak objective absent) or the starts
        would not run in forked local workers: the caller runs the starts and
        :func:`.refine.refine_branches` one after the other.
    """
    if not _peak_refined(study, prob):
        return None

    def after(i, payload):
        sol, known = payload
        rec = _Recording(prob)
        try:
            r = _refine_one(study, rec, i, sol, tol_j, known=known)
        except SolverError as exc:
            r = exc
        return r, rec.objectives

    def choose(finished):
        # each branch with the sampled J of the better branches known now: its refinement
        # stops where it joins one of them (select_branch checks it against them all)
        good = {i: s for i, s in finished.items() if not isinstance(s, str) and s.feasible}
        reps = branch_starts(good)
        return [(i, (good[i], [good[b].objective for b in reps[:k]]))
                for k, i in enumerate(reps)]

    return run_starts_pipelined(prob, starts, after, choose=choose,
                                workers=study.solver.get("workers"), progress=progress)


def branch_starts(sols: dict) -> list[int]:
    """The first start of each distinct branch, best sampled objective first: the grouping
    of :func:`.refine.refine_branches` (ties in start order).

    Parameters
    ----------
    sols : dict
        Start index -> feasible Solution.

    Returns
    -------
    list of int
    """
    out: list[int] = []
    for i in sorted(sols, key=lambda i: (sols[i].objective, i)):
        if not any(abs(sols[i].objective - sols[b].objective) <= BRANCH_TOLERANCE for b in out):
            out.append(i)
    return out


def _joined(objectives, known) -> int | None:
    """Index in ``known`` of the first branch a re-solve landed on (within
    :data:`.refine.BRANCH_TOLERANCE`), in re-solve order; ``None`` if none did."""
    for j in objectives:
        hits = [k for k, v in enumerate(known) if abs(j - v) <= BRANCH_TOLERANCE]
        if hits:
            return hits[0]
    return None


def select_branch(study, prob, sols: dict, refined: dict, tol_j: float) -> Refined:
    """The winning branch among pipelined refinements, by :func:`.refine.refine_branches`' rule.

    Parameters
    ----------
    study : Study
        Gives ``solver.tie_break``.
    prob : Problem
        The NLP (this process's copy: its movable frequencies are the study's); left on
        the winner's.
    sols : dict
        Start index -> feasible Solution.
    refined : dict
        Start index -> (Refined or SolverError, re-solve objectives J), of
        :func:`starts_and_branches`, for the feasible starts refined.
    tol_j : float
        The tie-break's tolerance on J (:func:`.refine.flat_tolerance`), as in
        :func:`starts_and_branches`; also that of a branch refined again here.

    Returns
    -------
    Refined
        As :func:`.refine.refine_branches`: the winner, tie-broken, with ``branches``.

    Raises
    ------
    SolverError
        When the refinement failed on every branch (the first failure).

    Notes
    -----
    In :func:`.refine.refine_branches` branch ``k`` stops at its first re-solve that lands
    within :data:`.refine.BRANCH_TOLERANCE` of a better branch's sampled objective. A
    refinement here ran with the better branches known when it began (a subset, up to
    starts superseded since), from the same point on the same grid, so its re-solves up to
    its stop are the same solves: the recorded objectives say where it would have stopped,
    and such a branch is treated as joined exactly as there. One that stopped at a branch
    that is not a better one in the end is refined again in full here.
    """
    branches = branch_starts(sols)
    missing = [i for i in branches if i not in refined]
    if missing:
        raise ValueError(f"select_branch: branches {missing} were not refined")
    slots0 = prob.slot_hz.copy()

    def result(i, known):
        # branch i's refinement as refine_branches' refine(k, known) would end: joined
        # (the index in known), or its Refined / SolverError
        r, objectives = refined[i]
        m = _joined(objectives, known)
        if m is not None:
            return m
        if isinstance(r, Refined) and r.peak.get("merged_with") is not None:
            # stopped at a branch that is no better one here (it was superseded or fell
            # out): refined again, in full as refine_branches would, in this process
            if not np.array_equal(prob.slot_hz, slots0):
                prob.set_slots(slots0)
            try:
                r = _refine_one(study, prob, i, sols[i], tol_j, known=known)
            except SolverError as exc:
                return exc
            return r.peak["merged_with"] if r.peak.get("merged_with") is not None else r
        return r

    done: list[Refined] = []
    merged: list[tuple[int, Refined]] = []
    error = None
    for k, i in enumerate(branches):
        r = result(i, [sols[b].objective for b in branches[:k]])
        if isinstance(r, int):
            target = next((d for d in done if d.start == branches[r]), None)
            if target is None:
                r = result(i, [sols[d.start].objective for d in done])
                target = done[r] if isinstance(r, int) else None
            if target is not None:
                merged.append((i, target))
                continue
        if isinstance(r, SolverError):
            error = error or r
        else:
            done.append(r)
    return _rank_branches(study, prob, done, merged, tol_j, error)
