"""A sweep of the built-in table (``table_study()``) over payload mass and CG height: the
continuation along the mass line, an interrupt (an event: the second finished point) and
its resume giving the uninterrupted table, the binding map showing each point's binding
set as its result flags it, and the report's section of that map."""

from __future__ import annotations

import json

import numpy as np
import pytest

import isodesign
from isodesign.optimization.parametric import ProblemCache
from isodesign.optimization.study import table_study
from isodesign.plotting.sweep import NO_DESIGN, binding_map, binding_map_data, map_axes
from isodesign.sweeps import points

#: Two masses x two CG heights of the table study, on a coarse grid, two starts per point.
VARY = ["payload.mass_kg=450,650", "payload.cg_height_m=0.25,0.45"]
#: The columns an interrupted and resumed sweep must share with an uninterrupted one.
SAME = ("status", "feasible", "objective_value", "volume_ratio", "top_volume_m3",
        "capillary_length_m", "capillary_diameter_m", "binding", "neighbour_starts",
        "from_neighbour", "branch_changed")


def _cheap_table():
    return table_study().with_changes(models={"points_per_band": 3, "peak_points": 20},
                                      solver={"starts": 2})


#: The NLPs the serial worker's cache built in :func:`table_line`.
_WORKER_BUILDS: list[int] = []


@pytest.fixture(scope="module")
def table_line(tmp_path_factory):
    """The uninterrupted sweep (serial: the same points and chains as a cluster's)."""
    out = tmp_path_factory.mktemp("table_line") / "whole"
    saved = getattr(points._LOCAL, "problems", None)
    points._LOCAL.problems = cache = ProblemCache()  # the serial worker's, empty
    try:
        res = isodesign.sweep(_cheap_table(), vary=VARY, output=out, scheduler="serial")
    finally:
        points._LOCAL.problems = saved
    _WORKER_BUILDS.append(cache.builds)
    return res


def _by_point(df):
    return df.set_index("point").sort_index()


@pytest.mark.slow
def test_table_points_continue_along_the_mass_line(table_line):
    df = table_line.table
    assert len(df) == 4 and set(df["question"]) == {"table"}
    assert set(df["status"]) <= {"complete", "infeasible"}, df[["status", "error"]]
    # "NLPs built" is what the (serial) worker's cache built, not the points that built one:
    # a table point may build two, its structure's and the one with movable peak frequencies
    assert table_line.nlp_builds == _WORKER_BUILDS[-1] >= 1
    # (a point solved again keeps only its last row in the table: at most the sweep's count)
    assert table_line.nlp_builds >= int(df["nlp_builds"].sum())
    continued = 0
    for h in (0.25, 0.45):
        light, heavy = (r for _, r in df[df["payload.cg_height_m"] == h]
                        .sort_values("payload.mass_kg").iterrows())
        assert light["neighbour_starts"] == 0  # a line's first point: its own starts
        if light["status"] != "complete" or not light["feasible"]:
            assert heavy["neighbour_starts"] == 0  # no design to start from
            continue
        # the heavier point's first start is the lighter one's optimum
        assert heavy["neighbour_starts"] == 1
        continued += 1
        solved = isodesign.load_study(table_line.directory / heavy["run_dir"]
                                      / "study_resolved.toml")
        start = {v.name: v.start for v in solved.variables}
        for k in ("volume_ratio", "top_volume_m3", "capillary_length_m",
                  "capillary_diameter_m"):
            assert start[k] == pytest.approx(light[k], rel=1e-9)
    assert continued >= 1
    # the point's identity is its own study (a rerun reuses every point, solves none)
    charts = sorted((table_line.directory / "charts").glob("*.png"))
    assert [c.name for c in charts] == ["binding_map.png", "worst_band_margin.png"]
    drawn = [c.stat().st_mtime_ns for c in charts]
    again = isodesign.sweep(_cheap_table(), vary=VARY, output=table_line.directory,
                            scheduler="serial")
    assert again.ran == 0 and again.reused == 4
    # nothing ran: the charts drawn after the last point are kept, not drawn again
    assert [c.stat().st_mtime_ns for c in charts] == drawn
    rec = json.loads((table_line.directory / "record.json").read_text(encoding="utf-8"))
    assert rec["charts"] == ["charts/worst_band_margin.png", "charts/binding_map.png"]
    assert rec["sweep"]["values"] == {"payload.mass_kg": [450, 650],
                                      "payload.cg_height_m": [0.25, 0.45]}


@pytest.mark.slow
def test_an_interrupted_table_sweep_resumes_to_the_uninterrupted_table(table_line, tmp_path):
    out = tmp_path / "cut"
    seen = []

    def stop_after_two(done, total, row, running):
        if row is not None:
            seen.append(row["point"])
            if len(seen) == 2:  # the event: the second point has finished
                raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        isodesign.sweep(_cheap_table(), vary=VARY, output=out, scheduler="serial",
                        progress=stop_after_two)
    rec = json.loads((out / "record.json").read_text(encoding="utf-8"))
    assert rec["run_status"] == "interrupted"
    cut = isodesign.sweeps.read_table(out)
    assert sorted(cut["point"]) == sorted(seen)
    res = isodesign.sweep(_cheap_table(), vary=VARY, output=out, scheduler="serial")
    assert res.status == "complete" and res.reused == 2 and res.ran == 2
    a, b = _by_point(table_line.table), _by_point(res.table)
    assert list(a.index) == list(b.index)
    for col in SAME:
        if a[col].dtype.kind == "f":
            np.testing.assert_allclose(b[col].to_numpy(float), a[col].to_numpy(float),
                                       rtol=1e-6, err_msg=col)
        else:
            assert list(b[col]) == list(a[col]), col


def _flags(directory, run_dir) -> set[str]:
    """The binding set a point's result flags: its binding constraints (design.json) and
    its variables at a bound."""
    d = json.loads((directory / run_dir / "design.json").read_text(encoding="utf-8"))
    names = {c["name"] for c in d["constraints"] if c.get("binding")}
    names |= {f"{k}={v['at_bound']}" for k, v in d["variables"].items() if v.get("at_bound")}
    return names


@pytest.mark.slow
def test_the_binding_map_shows_each_points_binding_flags(table_line):
    df, keys = table_line.table, list(table_line.keys)
    data = binding_map_data(df, keys)
    assert map_axes(df, keys) == ("payload.mass_kg", "payload.cg_height_m", [])
    assert len(data) == 4
    for _, r in data.iterrows():
        row = df[df["point"] == r["point"]].iloc[0]
        if r["category"] == NO_DESIGN:  # infeasible, or a constraint broken at the check
            assert not row["feasible"] or row["status"] == "infeasible"
            continue
        shown = set(r["category"].split(";")) - {"none binding"}
        assert shown == _flags(table_line.directory, row["run_dir"]), r["point"]
    # the figure's cells hold the same categories (the codes index the legend's order)
    fig = table_line.binding_map()
    mesh = next(c for c in fig.axes[0].collections if hasattr(c, "get_array"))
    codes = np.ma.filled(mesh.get_array(), -1).reshape(2, 2)  # rows: CG, columns: mass
    for _, r in data.iterrows():
        i = [0.25, 0.45].index(r["payload.cg_height_m"])
        j = [450, 650].index(r["payload.mass_kg"])
        assert fig.binding_categories[codes[i, j]] == r["category"]
    assert (table_line.directory / "charts" / "binding_map.png").is_file()


@pytest.mark.slow
def test_the_sweep_report_has_the_binding_map(table_line, tmp_path):
    out = tmp_path / "r.html"
    isodesign.report(table_line.directory, out)
    html = out.read_text(encoding="utf-8")
    assert "Where the binding set changes" in html
    assert html.count("<svg") == 2  # the design chart and the binding map
    n_sets = binding_map_data(table_line.table, list(table_line.keys))["category"].nunique()
    assert f"{n_sets} distinct sets" in html
    assert "<strong>payload.mass_kg</strong> and <strong>payload.cg_height_m</strong>" in html


def _synthetic():
    """Three masses x two CG heights x two floors; the set changes once along the mass on
    VC-A and nowhere on VC-B; one point infeasible, one changed branch."""
    import pandas as pd

    rows = []
    for floor in ("VC-A", "VC-B"):
        for h in (0.2, 0.4):
            for m in (400, 500, 600):
                b = "total_volume;peak_transmissibility" if floor == "VC-A" and m > 450 \
                    else "volume_ratio=upper"
                rows.append({"point": f"{floor}-{h}-{m}", "payload.mass_kg": m,
                             "payload.cg_height_m": h, "floor.criterion": floor,
                             "task": "optimize", "objective": "worst_band_margin",
                             "status": "complete", "feasible": (floor, h, m) != ("VC-B", 0.4,
                                                                                  600),
                             "binding": b, "branch_changed": (floor, h, m) == ("VC-A", 0.2,
                                                                               500)})
    return pd.DataFrame(rows)


def test_the_binding_map_facets_by_the_third_key_and_draws_the_boundaries():
    df = _synthetic()
    keys = ["payload.mass_kg", "payload.cg_height_m", "floor.criterion"]
    assert map_axes(df, keys) == ("payload.mass_kg", "payload.cg_height_m",
                                  ["floor.criterion"])
    data = binding_map_data(df, keys)
    assert sorted(set(data["facet"])) == ["floor.criterion=VC-A", "floor.criterion=VC-B"]
    assert data.loc[data["point"] == "VC-B-0.4-600", "category"].item() == NO_DESIGN
    fig = binding_map(df, keys)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in axes] == ["floor.criterion=VC-A", "floor.criterion=VC-B"]

    def segments(ax):
        from matplotlib.collections import LineCollection

        return [s for c in ax.collections if isinstance(c, LineCollection)
                for s in c.get_segments()]

    # VC-A: the set changes between 400 and 500 kg at both heights: two vertical edges at
    # the cells' shared edge (450 kg); VC-B: only around the infeasible corner (two edges)
    a = segments(axes[0])
    assert len(a) == 2 and all(np.allclose(s[:, 0], 450.0) for s in a)
    assert len(segments(axes[1])) == 2
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "total_volume, peak_transmissibility" in legend and NO_DESIGN in legend
    assert any(t.startswith("branch changed") for t in legend)
    dots = [ln for ln in axes[0].get_lines() if ln.get_marker() == "o"]
    assert len(dots) == 1 and list(dots[0].get_xdata()) == [500.0]
    with pytest.raises(isodesign.InputError, match="no swept key"):
        binding_map(df, keys, x="payload.spacing_m")
    with pytest.raises(isodesign.InputError, match=r"no binding sets \(task response\)"):
        binding_map(df.assign(task="response"), keys)


def test_a_table_sweeps_cg_height_moves_the_tables_cg():
    from isodesign.optimization.study import vertical_study
    from isodesign.sweeps.spec import build_points, combine, parse_vary

    base = table_study()
    pts, _ = build_points(base, combine([parse_vary("payload.cg_height_m=0.2,0.5")]))
    for p, h in zip(pts, (0.2, 0.5), strict=True):
        assert p.study.raw["table"]["cg_m"] == [0.0, 0.0, h]  # over the same x, y
        assert p.study.table.cg_height_m == pytest.approx(h)
        assert p.study.raw["payload"]["cg_height_m"] == h
        # the instrument points stay on the table top
        assert p.study.raw["table"]["instrument_points_m"] == \
            base.raw["table"]["instrument_points_m"]
    # a point that gives both must make them agree (the study's own check)
    with pytest.raises(isodesign.InputError, match="disagree"):
        build_points(base, [{"payload.cg_height_m": 0.3, "table.cg_m": [0.0, 0.0, 0.4]}])
    # a vertical study has no table: its CG height is the payload's alone
    (v,), _ = build_points(vertical_study(), [{"payload.cg_height_m": 0.5}])
    assert v.study.raw.get("table") is None and v.study.raw["payload"]["cg_height_m"] == 0.5


def test_the_binding_map_spans_the_sweeps_values_and_orders_its_panels():
    df = _synthetic()
    keys = ["payload.mass_kg", "payload.cg_height_m", "floor.criterion"]
    part = df[df["payload.mass_kg"] < 600]  # the 600 kg column not run yet
    order = {"payload.mass_kg": [400, 500, 600], "payload.cg_height_m": [0.2, 0.4],
             "floor.criterion": ["VC-B", "VC-A", "VC-C"]}
    fig = binding_map(part, keys, order=order)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    # the panels in the sweep's order, VC-C (no point yet) blank
    assert [ax.get_title() for ax in axes] == [f"floor.criterion={f}" for f in
                                               ("VC-B", "VC-A", "VC-C")]
    mesh = next(c for c in axes[0].collections if hasattr(c, "get_array"))
    arr = mesh.get_array()
    assert arr.shape == (2, 3) and arr.mask[:, 2].all() and not arr.mask[:, :2].any()
    assert axes[0].get_xlim() == (350.0, 650.0)


@pytest.mark.slow
@pytest.mark.skipif(not __import__("sys").platform.startswith("linux"),
                    reason="process groups and signals as on Linux")
def test_a_table_sweep_on_a_local_cluster_interrupted_by_sigint_resumes_to_the_same_table(
        table_line, tmp_path):
    """``isodesign sweep`` of the table on a local Dask cluster (one worker: the chains in
    order), SIGINT to its process group at the event of its first finished point (the
    point's row in place), exit 130; the same command again finishes it, and the table
    equals the uninterrupted one."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    from isodesign.io.record import study_toml

    study = tmp_path / "table.toml"
    study.write_text(study_toml(_cheap_table()), encoding="utf-8")
    out = tmp_path / "sw"
    env = dict(os.environ)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[2]) + os.pathsep + \
        env.get("PYTHONPATH", "")
    env.pop("DASK_SCHEDULER_ADDRESS", None)
    cmd = [sys.executable, "-m", "isodesign", "sweep", str(study), *(
        a for v in VARY for a in ("--vary", v)), "--workers", "1", "-o", str(out),
        "--quiet", "--no-plots"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, start_new_session=True)
    t0 = time.monotonic()
    while not any(q for q in (out / "points").glob("*/sweep_point.json")
                  if not q.parent.name.startswith(".")):  # the event: a point in place
        if proc.poll() is not None or time.monotonic() - t0 > 600:
            proc.kill()
            pytest.fail(f"no point finished (status {proc.returncode}): "
                        f"{proc.communicate()[1]}")
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    rec = json.loads((out / "record.json").read_text(encoding="utf-8"))
    if proc.returncode == 0:  # the interrupt came after the last point: nothing to resume
        pytest.skip("every point had finished before the interrupt arrived")
    assert proc.returncode == 130 and rec["run_status"] == "interrupted", err
    cut = isodesign.sweeps.read_table(out)
    assert 1 <= len(cut) < 4
    again = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
    assert again.returncode == 0, again.stderr
    res = isodesign.sweeps.read_table(out)
    cols = ["payload.mass_kg", "payload.cg_height_m"]
    a = table_line.table.set_index(cols).sort_index()
    b = res.set_index(cols).sort_index()
    assert list(a.index) == list(b.index)
    for col in SAME:
        if a[col].dtype.kind == "f":
            np.testing.assert_allclose(b[col].to_numpy(float), a[col].to_numpy(float),
                                       rtol=1e-6, err_msg=col)
        else:
            assert list(b[col]) == list(a[col]), col
