"""The branch pass run while the chains go (isodesign.sweeps.runner._resolve_next) asks for
the same re-solves, with the same neighbours, as the pass run after them (_branch_pass)."""

from __future__ import annotations

from types import SimpleNamespace

from isodesign.sweeps.runner import _branch_pass, _resolve_next

ORDER = [[0, 1, 2, 3, 4], [5, 6, 7]]


def _pts():
    return [SimpleNamespace(study_hash=f"h{i}") for i in range(8)]


def _row(i, changed=False, best=-1):
    return {"point": f"p{i}", "question": "vertical", "feasible": True, "status": "complete",
            "branch_changed": changed, "best_neighbour": best}


#: the chain rows: points 2, 4 and 7 left the branch their predecessor led to
CHANGED = {2, 4, 7}
#: a re-solved point's answer: 1 (its later neighbour's branch) for 1, else its own
LATER = {1}


def _resolved_row(a):
    return {**_row(a, best=1 if a in LATER else -1), "resolved": True, "again": a}


def test_the_overlapped_branch_pass_asks_for_what_the_pass_after_the_chains_does():
    pts = _pts()
    ran = {p.study_hash for p in pts}
    # after the chains: _branch_pass
    rows = {f"h{i}": _row(i, i in CHANGED) for i in range(8)}
    after = []

    def solve(items):
        for a, nb, again in items:
            assert again
            after.append((a, [r and r["point"] for r in nb]))
            rows[f"h{a}"] = _resolved_row(a)

    _branch_pass(pts, rows, ORDER, "optimize", solve, ran)
    # as the chains go: each arriving row may ask for its predecessor's re-solve, whose
    # row may ask for the next one back
    rows2: dict = {}
    where = {i: (c, k) for c, ch in enumerate(ORDER) for k, i in enumerate(ch)}
    tried: set = set()
    during, queue = [], []
    for k in range(5):  # the two chains' rows arrive interleaved
        for ch in ORDER:
            if k < len(ch):
                i = ch[k]
                rows2[f"h{i}"] = _row(i, i in CHANGED)
                queue += _resolve_next(pts, rows2, ORDER, where, i, rows2[f"h{i}"], True,
                                       ran, tried)
    while queue:
        a, nb = queue.pop(0)
        during.append((a, [r and r["point"] for r in nb]))
        rows2[f"h{a}"] = _resolved_row(a)
        queue += _resolve_next(pts, rows2, ORDER, where, a, rows2[f"h{a}"], False, ran, tried)
    assert sorted(after) == sorted(during)
    # 2 -> 1 (from 0 and 2), 1 took 2's branch -> 0 (from nothing and 1), 4 -> 3, 7 -> 6
    assert sorted(a for a, _ in during) == [0, 1, 3, 6]
    assert rows == rows2


def test_no_re_solve_of_a_point_not_run_now_or_not_vertical():
    pts = _pts()
    where = {i: (c, k) for c, ch in enumerate(ORDER) for k, i in enumerate(ch)}
    rows = {f"h{i}": _row(i, i in CHANGED) for i in range(8)}
    ran = {p.study_hash for p in pts} - {"h1"}  # point 1 finished in an earlier run
    assert _resolve_next(pts, rows, ORDER, where, 2, rows["h2"], True, ran, set()) == []
    rows["h3"]["question"] = "table"
    ran = {p.study_hash for p in pts}
    assert _resolve_next(pts, rows, ORDER, where, 4, rows["h4"], True, ran, set()) == []
    # a chain's first point has no predecessor
    assert _resolve_next(pts, rows, ORDER, where, 5, _row(5, True), True, ran, set()) == []
