"""A sweep's "NLPs built" is the number of NLPs its workers built (their
:class:`~isodesign.optimization.parametric.ProblemCache` s' count, summed over workers and
points), not the number of points that built one: in the printed line, the record, the
table and the :class:`~isodesign.sweeps.runner.SweepResult` (``docs/sweep.md``, section 7).
On the vertical study (``vertical_study()``), serial: one worker, this thread's cache."""

from __future__ import annotations

import pytest

import isodesign
from isodesign.commands.sweep import summary
from isodesign.io.rundir import read_run_record
from isodesign.optimization.parametric import ProblemCache
from isodesign.optimization.study import vertical_study
from isodesign.sweeps import points


def _cheap():
    return vertical_study().with_changes(models={"points_per_band": 3, "peak_points": 10},
                                         solver={"starts": 1, "tie_break": False})


@pytest.fixture
def fresh_cache(monkeypatch):
    """The serial worker's cache, empty (another test's NLPs are not this sweep's)."""
    cache = ProblemCache()
    monkeypatch.setattr(points._LOCAL, "problems", cache, raising=False)
    return cache


def _said(res, cache, n):
    assert cache.builds == n  # what the worker built
    assert res.nlp_builds == n
    assert read_run_record(res.directory)["nlp_builds"] == n
    # per point: the NLPs it built (a point solved again by the branch pass keeps only its
    # last row, which may have built none: at most the sweep's count)
    assert 1 <= int(res.table["nlp_builds"].sum()) <= n
    assert dict(res._summary_items())["NLPs built"].startswith(f"{n} for ")
    assert f"NLPs built: {n} for " in summary(res)


def test_points_of_two_structures_report_two_nlps(fresh_cache, tmp_path):
    # the grid's shape is the NLP's structure: two grids, two NLPs
    res = isodesign.sweep(_cheap(), ["models.points_per_band=3,4"], output=tmp_path / "s",
                          scheduler="serial", charts=False)
    assert len(res.table) == 2
    _said(res, fresh_cache, 2)


def test_points_of_one_structure_report_one_nlp_per_worker(fresh_cache, tmp_path):
    res = isodesign.sweep(_cheap(), ["payload.mass_kg=500,700"], output=tmp_path / "s",
                          scheduler="serial", charts=False)
    assert len(res.table) == 2
    _said(res, fresh_cache, 1)


def test_a_point_that_builds_two_nlps_counts_two(fresh_cache, tmp_path, monkeypatch):
    # a table point whose refinement needs the movable peak frequencies builds a second NLP
    # and its cache counts both (ProblemCache._table's on_build); here the vertical point's
    # cache counts one more NLP with its first, so the point built two: the sweep says 2,
    # not the one point that built any
    get = ProblemCache.get

    def twice(self, study, *args, **kwargs):
        if self.builds == 0:
            self.builds += 1
        return get(self, study, *args, **kwargs)

    monkeypatch.setattr(ProblemCache, "get", twice)
    res = isodesign.sweep(_cheap(), ["payload.mass_kg=500"], output=tmp_path / "s",
                          scheduler="serial", charts=False)
    assert len(res.table) == 1 and res.ran == 1
    _said(res, fresh_cache, 2)
    assert res.table["nlp_builds"].tolist() == [2] and res.table["nlp_built"].tolist() == [True]
