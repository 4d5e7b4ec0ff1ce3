"""The branches' peak refinement pipelined with the starts (``early_refine``): the same
winner as the starts followed by ``refine_branches``, each refinement's instant reported."""

from __future__ import annotations

import math

import pytest

from isodesign.errors import SolverError
from isodesign.optimization import early_refine, refine
from isodesign.optimization.driver import optimize
from isodesign.optimization.multistart import run_starts, runs_in_parallel, start_points
from isodesign.optimization.problem import Problem
from isodesign.optimization.study import vertical_study

#: A coarse peak grid with more than one branch among 4 starts (as tests/test_refine.py).
STUDY = {"models": {"points_per_band": 3, "peak_points": 30}, "solver": {"starts": 4}}


def test_a_refinement_that_lands_on_a_better_branch_joins_it_as_in_refine_branches():
    """A refinement made without the stop of ``refine_peak(known=...)`` is judged on its
    recorded re-solve objectives: the first that lands on a better branch's sampled J
    makes it join that branch (listed with its refined J, never a candidate)."""

    class Sol:
        def __init__(self, j):
            self.objective = j

    st = vertical_study().with_changes(solver={"tie_break": False})
    prob = Problem(st)

    class R:
        def __init__(self, start, j):
            self.start, self.best, self.final = start, Sol(j), Sol(j)
            self.flat, self.peak, self.slot_hz = None, {"rounds": 1}, prob.slot_hz.copy()

    sols = {0: Sol(1.0), 1: Sol(2.0), 2: Sol(3.0)}
    # start 1 re-solves to 1.5 then to start 0's sampled J: it joins branch 0 there, even
    # though its last re-solve (0.5) would beat branch 0's refined 1.2
    refined = {0: (R(0, 1.2), [1.2]), 1: (R(1, 0.5), [1.5, 1.0 + 1e-7, 0.5]),
               2: (SolverError("re-solve failed"), [])}
    win = early_refine.select_branch(st, prob, sols, refined, 0.01)
    assert win.start == 0 and win.best.objective == 1.2
    assert win.branches == ((0, 1.2), (1, 1.2))
    assert early_refine._joined([1.5, 2.0], [1.0, 2.0]) == 1
    assert early_refine._joined([1.5], [1.0, 2.0]) is None
    with pytest.raises(SolverError, match="re-solve failed"):
        early_refine.select_branch(st, prob, {2: sols[2]}, refined, 0.01)


def test_pipelined_branches_choose_as_refine_branches():
    """The starts and their branches' refinements in one pool choose the same branch, with
    the same refined optima, as the starts followed by refine_branches."""
    st = vertical_study().with_changes(**STUDY)
    prob = Problem(st)
    starts = start_points(st, prob.scaling)
    if not runs_in_parallel(st.solver["workers"], len(starts)):
        pytest.skip("one core or no fork here: the driver takes the one-after-the-other path")
    slots0 = prob.slot_hz.copy()
    tol = refine.flat_tolerance(prob.objective)
    results, early = early_refine.starts_and_branches(st, prob, starts, tol)
    good = {i: s for i, s in enumerate(results) if not isinstance(s, str) and s.feasible}
    assert set(early) <= set(good) and early
    assert set(early_refine.branch_starts(good)) <= set(early)  # every branch refined
    piped = early_refine.select_branch(st, prob, good, early, tol)
    prob.set_slots(slots0)
    ref = refine.refine_branches(st, prob, run_starts_good(prob, starts), tol)
    assert piped.best.objective == pytest.approx(ref.best.objective, abs=1e-6)
    assert piped.final.objective == pytest.approx(ref.final.objective, abs=1e-6)
    assert sorted(round(j, 4) for _, j in piped.branches) == \
        sorted(round(j, 4) for _, j in ref.branches)
    for k, v in ref.final.values.items():
        assert piped.final.values[k] == pytest.approx(v, rel=1e-4), k


def run_starts_good(prob, starts):
    sols = run_starts(prob, starts, workers=1)
    return {i: s for i, s in enumerate(sols) if not isinstance(s, str) and s.feasible}


def test_every_pipelined_refinement_is_a_timed_solve():
    """The result's solves hold each branch's refinement with its finish instant, after its
    start's, and the winner's tie-break last."""
    res = optimize(vertical_study().with_changes(**STUDY), analyze=False)
    assert res.feasible
    fin = {s.index: s.finished_s for s in res.starts}
    refs = [s for s in res.solves if s["stage"] == "refinement"]
    assert refs and {s["start"] for s in refs} <= set(fin)
    for s in refs:
        assert fin[s["start"]] < s["finished_s"] <= res.wall_s
    at = [s["finished_s"] for s in res.solves]
    assert at == sorted(at) and all(math.isfinite(t) for t in at)
    # early_refine's rule: a start is refined as its branch's first start (best sampled J)
    # among the starts finished by then, so no better start of its branch finished before
    # it; a better one finishing later is refined again and stands for the branch at the
    # end. Every refined start belongs to one of the result's branches.
    from isodesign.optimization.objectives import OBJECTIVES
    from isodesign.optimization.refine import BRANCH_TOLERANCE

    to_j = OBJECTIVES[res.objective].from_natural
    j = {s.index: to_j(s.objective) for s in res.starts if s.feasible}
    reps = [i for i, _ in res.branches]
    for i in {s["start"] for s in refs}:
        same = [k for k in j if abs(j[k] - j[i]) <= BRANCH_TOLERANCE]
        assert not [k for k in same if fin[k] < fin[i] and j[k] < j[i] - 1e-12]
        assert set(same) & set(reps)  # refined: a branch's start, or superseded in it
