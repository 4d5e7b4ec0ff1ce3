"""Continuation along a sweep's lines: one NLP per worker, neighbours' optima as starts,
points that change branch marked (isodesign.sweeps.continuation, docs/sweep.md)."""

from __future__ import annotations

import json

import pytest

import isodesign
from isodesign.io.rundir import read_run_record
from isodesign.optimization.driver import optimize_vertical
from isodesign.optimization.study import vertical_study
from isodesign.sweeps.continuation import chains, line_key, lines

PRODUCT = [{"payload.mass_kg": m, "floor.criterion": f} for m in (300, 500, 700)
           for f in ("VC-A", "VC-B")]
KEYS = ["payload.mass_kg", "floor.criterion"]


def test_lines_run_along_the_numeric_key_with_most_values():
    assert line_key(PRODUCT, KEYS) == "payload.mass_kg"
    ls = lines(PRODUCT, KEYS)
    assert [list(ln) for ln in ls] == [[0, 2, 4], [1, 3, 5]]
    # a line per worker; one line on two workers: two chains of consecutive points
    assert chains(PRODUCT, KEYS, 2) == [[0, 2, 4], [1, 3, 5]]
    one = [{"payload.mass_kg": m} for m in (900, 300, 500, 700)]
    assert chains(one, ["payload.mass_kg"], 2) == [[1, 2], [3, 0]]
    assert chains(one, ["payload.mass_kg"], 1) == [[1, 2, 3, 0]]
    # no numeric key: no line, every point on its own
    crit = [{"floor.criterion": c} for c in ("VC-A", "VC-B")]
    assert line_key(crit, ["floor.criterion"]) is None
    assert chains(crit, ["floor.criterion"], 2) == [[0], [1]]


@pytest.fixture(scope="module")
def line_sweep(tmp_path_factory):
    st = vertical_study().with_changes(models={"points_per_band": 3, "peak_points": 10},
                                       solver={"starts": 1, "tie_break": False})
    out = tmp_path_factory.mktemp("continuation") / "s"
    res = isodesign.sweep(st, ["payload.mass_kg=400:1200:5", "floor.criterion=VC-A,VC-B"],
                          output=out, scheduler="serial", charts=False)
    return st, res


def test_one_nlp_serves_every_point_and_the_record_says_so(line_sweep):
    _, res = line_sweep
    df = res.table
    assert len(df) == 10 and set(df["status"]) == {"complete"}
    assert res.nlp_builds == 1  # one process, one structure
    assert read_run_record(res.directory)["nlp_builds"] == 1
    assert "NLPs built" in repr(res) or "NLPs built" in str(res._summary_items())
    # every point but each line's first started from its predecessor's optimum too
    first = df.groupby("floor.criterion")["payload.mass_kg"].transform("min")
    inner = df[df["payload.mass_kg"] > first]
    assert (inner["neighbour_starts"] >= 1).all()
    assert "branch_changed" in df and "resolved" in df and "from_neighbour" in df
    # a point says whether its answer left the branch its neighbours' optima led to; a
    # line's first point (no neighbour unless solved again) did not
    assert df["branch_changed"].isin([True, False]).all()
    assert not df.loc[(df["neighbour_starts"] == 0), "branch_changed"].any()
    # the best start of a point is its own (-1) or one of its neighbours'
    assert (df["from_neighbour"] == (df["best_neighbour"] >= 0)).all()


def test_continued_points_are_no_worse_than_a_cold_start(line_sweep):
    st, res = line_sweep
    df = res.table
    for _, r in df.iloc[[1, 4, 9]].iterrows():
        cold = optimize_vertical(st.with_changes(json.loads(r["changes"])), analyze=False)
        assert r["objective_value"] >= cold.objective_value - 1e-6


def test_the_command_says_how_many_nlps_it_built(tmp_path, cheap_study, monkeypatch):
    import contextlib
    import io
    import threading

    from isodesign.cli import main
    from isodesign.sweeps import points

    # a fresh process's NLP cache (another test in this process may have built one of the
    # two structures already)
    monkeypatch.setattr(points, "_LOCAL", threading.local())

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        status = main(["sweep", str(cheap_study), "--vary", "payload.mass_kg=500,700",
                       "--vary", "payload.isolators=4,6", "-o", str(tmp_path / "s"),
                       "--scheduler", "serial", "--quiet"])
    assert status == 0
    # two isolator counts: two structures, one NLP each, in this one process
    assert "4 run now, 0 reused, 0 failed; 2 NLPs built;" in out.getvalue()


def test_builtin_table_and_a_study_file_together_are_refused(tmp_path, cheap_study):
    import contextlib
    import io

    from isodesign.cli import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        status = main(["sweep", str(cheap_study), "--builtin", "table", "--vary",
                       "payload.mass_kg=500", "-o", str(tmp_path / "s")])
    assert status == 2 and "--builtin: give STUDY.toml or --builtin, not both" in err.getvalue()
    assert not (tmp_path / "s").exists()
