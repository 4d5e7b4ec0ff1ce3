"""When the solves of an optimize call finished (``finished_s`` of the start records, the
refinement's and the tie-break's solves): non-negative, within the call's wall time and
ordered as the solves ran, in this process and in forked workers."""

from __future__ import annotations

import math
import os
import time

import pytest

from isodesign.optimization.study import vertical_study


def _small(workers: int):
    """The vertical study, coarse grids, 2 starts."""
    return vertical_study().with_changes(models={"points_per_band": 3, "peak_points": 20},
                                         solver={"starts": 2, "workers": workers})


@pytest.fixture
def two_cores(monkeypatch):
    """Two cores available to the process, whatever the machine (forked workers)."""
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)


def test_forked_worker_clock_compares_with_the_parent(two_cores):
    """perf_counter is system-wide: a forked worker's reading lies between the parent's
    readings before and after the map (what makes finished_s of parallel starts valid)."""
    from isodesign.optimization.multistart import map_in_workers, runs_in_parallel

    assert runs_in_parallel(2, 2)
    t0 = time.perf_counter()
    stamps = map_in_workers(lambda _: (os.getpid(), time.perf_counter()), range(2), workers=2)
    t1 = time.perf_counter()
    assert any(pid != os.getpid() for pid, _ in stamps)
    assert all(t0 <= t <= t1 for _, t in stamps)


@pytest.mark.parametrize("workers", [1, 2])
def test_finish_times_are_ordered_within_the_call(workers, two_cores):
    import isodesign
    from isodesign.io.csvtable import columns_csv

    r = isodesign.optimize(_small(workers), analyze=False)
    assert r.feasible
    done = [s for s in r.starts if not s.status.startswith("initial guess failed")]
    assert len(done) == 2
    for s in done:
        # a solve finishes after it has lasted its IPOPT time, and before the call returns
        assert math.isfinite(s.finished_s)
        assert s.wall_s <= s.finished_s <= r.wall_s
    if workers == 1:  # one after the other: the second solve ran after the first finished
        a, b = done
        assert b.finished_s >= a.finished_s + b.wall_s
    fin = {s.index: s.finished_s for s in done}
    last_start = max(fin.values())
    prev = min(fin.values())
    # in finish order: a branch's refinement after its own start (with 2 workers the
    # branches are refined beside the other starts, docs/optimization.md section 8), the
    # tie-break after every start and refinement
    for row in r.solves:
        assert row["stage"] in ("refinement", "tie-break")
        assert prev <= row["finished_s"] <= r.wall_s
        prev = row["finished_s"]
        assert math.isfinite(row["objective"])
        assert row["finished_s"] >= (fin[row["start"]] if row["stage"] == "refinement"
                                     else last_start)
    tie = [row for row in r.solves if row["stage"] == "tie-break"]
    assert not tie or tie == list(r.solves[-len(tie):])
    if r.solves:
        # the winning start's last solve found the returned design
        mine = [row for row in r.solves if row["start"] == r.branches[0][0]]
        assert mine[-1]["objective"] == pytest.approx(r.objective_value, abs=1e-9)
    # in the starts table and the run's starts.csv, beside wall_s
    df = r.starts_frame()
    assert list(df["finished_s"]) == [s.finished_s for s in r.starts]
    header = columns_csv(r.starts_columns()).splitlines()[0].split(",")
    assert "finished_s" in header and header.index("finished_s") == header.index("wall_s") + 1
