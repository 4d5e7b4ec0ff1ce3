"""The layout as design variables (docs/table.md, section 15): the isolators' extent along
x and y, the layout stretched about the CG, the footprint and the minimum distance."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.optimization.study import load_study, table_study, vertical_study
from isodesign.optimization.variables import LAYOUT_LEVER_RANGE, LAYOUT_LEVERS
from isodesign.table.assembly import dynamic_stiffness, geometry
from isodesign.table.layout import layout_extent, stretch_layout
from isodesign.table.lever_geometry import lever_directions, lever_stiffness, vertical_vectors
from isodesign.table.statics import level, tilt_margin_rows

LAYOUT = {"layout_length_m": {"fixed": False}, "layout_width_m": {"fixed": False}}


def _held_out(held_out_toml, **changes):
    """The held-out-like five-isolator table (off-centre CG), with ``changes``."""
    import pathlib
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        p = pathlib.Path(tmp) / "five.toml"
        p.write_text(held_out_toml)
        st = load_study(p)
    return st.with_changes(**changes) if changes else st


def test_layout_levers_are_fixed_at_the_isolators_extent_by_default():
    st = table_study()
    spec = {v.name: v for v in st.levers}
    assert layout_extent(st.table) == pytest.approx((1.2, 0.8))
    assert spec["layout_length_m"].fixed and spec["layout_length_m"].start == pytest.approx(1.2)
    assert spec["layout_width_m"].fixed and spec["layout_width_m"].start == pytest.approx(0.8)
    free = st.with_changes(variables=LAYOUT)
    spec = {v.name: v for v in free.levers}
    lo, hi = LAYOUT_LEVER_RANGE
    assert (spec["layout_length_m"].lower, spec["layout_length_m"].upper) == pytest.approx(
        (lo * 1.2, hi * 1.2))
    assert "layout_length_m" in str(free)


@pytest.mark.parametrize("changes, key", [
    ({"variables": {"layout_length_m": {"fixed": False, "lower": 1.5, "upper": 1.0}}},
     "variables.layout_length_m"),
    ({"variables": {"layout_width_m": {"fixed": False, "start": 2.0}}},
     "variables.layout_width_m.start"),
    ({"variables": {"layout_width_m": {"fixed": False, "lower": -1.0}}},
     "variables.layout_width_m"),
    ({"constraints": {"footprint_m": [0.0, 1.0]}}, "constraints.footprint_m"),
    ({"constraints": {"footprint_m": [[1.0, -1.0], [0.0, 1.0]]}}, "constraints.footprint_m"),
    ({"constraints": {"footprint_m": "big"}}, "constraints.footprint_m"),
    ({"constraints": {"min_isolator_distance_m": -0.1}}, "constraints.min_isolator_distance_m"),
    ({"constraints": {"min_isolator_distance_m": 1e3}}, "constraints.min_isolator_distance_m"),
    # TOML booleans are not coordinates; a footprint or an extent in mm typed as m
    ({"constraints": {"footprint_m": [[False, False], [True, True]]}},
     "constraints.footprint_m"),
    ({"constraints": {"footprint_m": [[-750, -500], [750, 500]]}},
     "constraints.footprint_m: a coordinate of 750 m"),
    ({"variables": {"layout_length_m": {"start": 1500.0}}},
     "variables.layout_length_m.start = 1500 m"),
    ({"variables": {"layout_width_m": {"fixed": False, "upper": 1200.0}}},
     "variables.layout_width_m.upper = 1200 m"),
    # a fixed lever's own bounds must hold it (as a design variable's); a 1 mm layout; a
    # pendulum in cm
    ({"variables": {"layout_length_m": {"lower": 2.0, "upper": 3.0}}},
     "variables.layout_length_m.start (1.2) is fixed outside its own bounds"),
    ({"variables": {"layout_length_m": {"fixed": False, "lower": 0.001}}},
     "variables.layout_length_m.lower = 0.001 m is outside the plausible extent"),
    ({"variables": {"pendulum_length_m": {"fixed": False, "upper": 150.0}}},
     "variables.pendulum_length_m.upper = 150 is outside the plausible range"),
    # a margin above the supply itself; loads no variable moves: refused by the study
    ({"constraints": {"supply_margin_pa": 9.0e5}},
     "constraints.supply_margin_pa (900000 Pa) must be below table.supply_pressure_pa"),
    ({"constraints": {"max_isolator_load_n": 1.0}},
     "constraints.max_isolator_load_n: isolator 1 (from 1) needs 1471 N"),
])
def test_bad_layout_keys_name_the_key(changes, key):
    with pytest.raises(InputError, match=re.escape(key)):
        table_study().with_changes(**changes)


@pytest.mark.parametrize("constraints, key", [
    ({"footprint_m": [[-0.1, -0.1], [0.1, 0.1]]}, "constraints.footprint_m: no layout_length_m"),
    ({"footprint_m": [[1.0, 1.0], [2.0, 2.0]]}, "constraints.footprint_m: no layout_length_m"),
    ({"min_isolator_distance_m": 5.0}, "constraints.min_isolator_distance_m = 5 m"),
    ({"footprint_m": [[-0.75, -0.5], [0.75, 0.5]], "min_isolator_distance_m": 1.2},
     "constraints.min_isolator_distance_m = 1.2 m"),
])
def test_a_free_layout_that_cannot_meet_its_constraints_is_refused_naming_the_key(
        constraints, key):
    """The footprint must hold the stretched layout for some lever value inside its bounds,
    and the largest such stretch must keep the isolators min_isolator_distance_m apart."""
    with pytest.raises(InputError, match=re.escape(key)):
        table_study().with_changes(variables=LAYOUT, constraints=constraints)
    # the same keys, reachable: accepted (the built-in table's 1.5 x 1.0 m top, 0.5 m)
    table_study().with_changes(variables=LAYOUT, constraints={
        "footprint_m": [[-0.75, -0.5], [0.75, 0.5]], "min_isolator_distance_m": 0.5})


def test_a_vertical_study_refuses_the_layout_keys():
    with pytest.raises(InputError, match=r"variables\.layout_length_m"):
        vertical_study().with_changes(variables={"layout_length_m": {"fixed": False}})
    with pytest.raises(InputError, match=r"constraints\.footprint_m"):
        vertical_study().with_changes(constraints={"footprint_m": [[0, 0], [1, 1]]})
    with pytest.raises(InputError, match=r"constraints\.min_isolator_distance_m"):
        vertical_study().with_changes(constraints={"min_isolator_distance_m": 0.3})


def test_the_stretch_keeps_the_loads_the_cg_and_the_groups(held_out_toml):
    """An off-centre CG on five isolators: stretched about the CG, every isolator's load and
    p0 stay (the leveling's moment equations are homogeneous in the offsets)."""
    st = _held_out(held_out_toml)
    t = st.table
    t2 = stretch_layout(t, 2.0, 0.9)
    assert layout_extent(t2) == pytest.approx((2.0, 0.9), rel=1e-12)
    a_p = st.hardware["piston_area_m2"]
    np.testing.assert_allclose(level(t2, a_p).load_n, level(t, a_p).load_n, rtol=1e-12)
    np.testing.assert_allclose(level(t2, a_p).pressure_pa, level(t, a_p).pressure_pa,
                               rtol=1e-12)
    assert t2.leveling_groups == t.leveling_groups
    np.testing.assert_array_equal(t2.cg_m, t.cg_m)
    off, off2 = t.isolators_m - t.cg_m[:2], t2.isolators_m - t.cg_m[:2]
    np.testing.assert_allclose(off2, off * [2.0 / 1.6, 0.9 / 1.05], rtol=1e-12)


def test_lever_stiffness_equals_the_rebuilt_geometry(held_out_toml):
    """The polynomial in (elastic-centre shift, s_x - 1, s_y - 1) is exact, strokes too."""
    st = _held_out(held_out_toml)
    t = st.table
    lv = level(t, st.hardware["piston_area_m2"])
    t2 = stretch_layout(dataclasses.replace(t, horizontal=dataclasses.replace(
        t.horizontal, elastic_centre_height_m=0.25)), 2.1, 0.8)
    geo, geo2 = geometry(t, lv.load_n), geometry(t2, lv.load_n)
    w = np.array([3.0, 25.0, 140.0])
    kv = [Cx(np.array([1e5, 2e5, 3e5]) * (1 + 0.1 * i), np.array([1e4, 3e4, 2e4]))
          for i in range(5)]
    kh = [t.horizontal.stiffness(w, ld) for ld in lv.load_n]
    c = lever_directions(geo, t)
    ex, ey = layout_extent(t)
    terms = [(0.25, c["elastic_centre_height_m"]), (2.1 / ex - 1, c["layout_length_m"]),
             (0.8 / ey - 1, c["layout_width_m"])]
    d1, b1 = lever_stiffness(geo, terms, kv, kh, w)
    d2, b2 = dynamic_stiffness(geo2, kv, kh, w)
    for a, b in ((d1.re, d2.re), (d1.im, d2.im), (b1.re, b2.re), (b1.im, b2.im)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
    np.testing.assert_allclose(np.array(vertical_vectors(geo, terms), float), geo2.gz,
                               atol=1e-14)
    np.testing.assert_allclose(geo2.gravity, geo.gravity, atol=1e-9 * np.abs(geo.gravity).max())


def test_tilt_rows_scale_with_the_stretch(held_out_toml):
    st = _held_out(held_out_toml)
    t = st.table
    t2 = stretch_layout(t, 2.0, 0.9)
    ex, ey = layout_extent(t)
    k = [1.1e5, 0.9e5, 1.3e5, 1.0e5, 1.2e5]
    wh = t.weight_n * t.cg_height_m
    r1 = tilt_margin_rows(k, t.vertical_points_m, wh, 0.5, (2.0 / ex, 0.9 / ey))
    r2 = tilt_margin_rows(k, t2.vertical_points_m, wh, 0.5)
    np.testing.assert_allclose(r1, r2, rtol=1e-12)


def test_the_nlp_with_a_free_layout_equals_the_nlp_of_the_stretched_table(held_out_toml):
    """At layout values V (with the elastic centre free too), the NLP's symbolic path gives
    the closure, the margins and the constraint rows of the NLP built on the table with V
    fixed (the table the NumPy re-check and the analysis use)."""
    from isodesign.optimization.table_problem import TableProblem

    st = _held_out(held_out_toml, constraints={"min_tilt_margin": 1.5})
    free = st.with_changes(variables={**LAYOUT, "elastic_centre_height_m": {"fixed": False}})
    lev = {"layout_length_m": 1.9, "layout_width_m": 0.85, "elastic_centre_height_m": 0.2}
    fixed = free.with_levers_fixed(lev)
    assert fixed.table.isolators_m[0] == pytest.approx(free.table_at(lev).isolators_m[0])
    p1, p2 = TableProblem(free), TableProblem(fixed)
    vals = {v.name: v.start for v in free.variables}
    x1, x2 = p1.initial_guess({**vals, **lev}), p2.initial_guess(vals)
    assert p1.values(x1)["layout_length_m"] == pytest.approx(1.9)
    np.testing.assert_allclose(p1.sigma(x1), p2.sigma(x2), rtol=1e-10)
    np.testing.assert_allclose(np.asarray(p1._all_margins_fn(x1)).ravel(),
                               np.asarray(p2._all_margins_fn(x2)).ravel(), atol=1e-9)
    g1 = np.asarray(p1.eval_fn(x1, p1.params())[1]).ravel()
    g2 = np.asarray(p2.eval_fn(x2, p2.params())[1]).ravel()
    np.testing.assert_allclose(g1, g2, rtol=1e-9, atol=1e-9)
    assert "min_tilt_margin" in [r[0] for r in p1.con_rows]


def test_footprint_and_distance_rows(held_out_toml):
    """The rows against the stretched table's positions computed in NumPy."""
    from isodesign.optimization.table_problem import TableProblem

    fp = [[-1.2, -0.7], [1.1, 0.75]]
    st = _held_out(held_out_toml, variables=LAYOUT,
                   constraints={"footprint_m": fp, "min_isolator_distance_m": 0.4})
    p = TableProblem(st)
    lev = {"layout_length_m": 1.9, "layout_width_m": 1.2}
    x = p.initial_guess({**{v.name: v.start for v in st.variables}, **lev})
    g = np.asarray(p.eval_fn(x, p.params())[1]).ravel()
    rows = {name: (row, m) for name, row, m in p.con_rows}
    xy = st.table_at(lev).isolators_m
    row, m = rows["footprint_m"]
    want = np.column_stack([xy[:, 0] - fp[0][0], fp[1][0] - xy[:, 0], xy[:, 1] - fp[0][1],
                            fp[1][1] - xy[:, 1]]).ravel()
    np.testing.assert_allclose(g[row: row + m], want, atol=1e-12)
    row, m = rows["min_isolator_distance_m"]
    d = [np.hypot(*(xy[i] - xy[j])) for i in range(5) for j in range(i + 1, 5)]
    np.testing.assert_allclose(np.exp(g[row: row + m]), d, rtol=1e-12)
    assert p.lbg[row] == pytest.approx(np.log(0.4))
    from isodesign.optimization.table_constraints import table_constraint_reports

    rep = {r.name: r for r in table_constraint_reports(p, g)}
    assert rep["footprint"].value == pytest.approx(want.min())
    assert rep["isolator_distance"].value == pytest.approx(min(d))
    assert rep["isolator_distance"].lower == pytest.approx(0.4)


def test_a_fixed_layout_outside_the_footprint_is_refused_naming_the_key(held_out_toml):
    from isodesign.optimization.table_problem import TableProblem

    # refused where the study is read (every entry point), before any problem is built
    with pytest.raises(InputError, match=r"constraints\.footprint_m: isolator 1"):
        TableProblem(_held_out(held_out_toml,
                               constraints={"footprint_m": [[-0.5, -0.6], [0.9, 0.6]]}))
    with pytest.raises(InputError, match=r"constraints\.min_isolator_distance_m: isolators 3 "
                                         r"and 5"):
        TableProblem(_held_out(held_out_toml, constraints={"min_isolator_distance_m": 0.9}))


def test_with_levers_fixed_writes_the_stretched_layout():
    st = table_study().with_changes(variables=LAYOUT)
    fixed = st.with_levers_fixed({"layout_length_m": 1.4, "layout_width_m": 0.6})
    np.testing.assert_allclose(fixed.table.isolators_m, [[-0.7, -0.3], [0.7, -0.3],
                                                         [0.7, 0.3], [-0.7, 0.3]], atol=1e-12)
    assert fixed.payload.spacing_m == pytest.approx(0.6)
    assert all(v.fixed for v in fixed.levers)
    assert fixed.table_at(None) is fixed.table
    assert [n for n in LAYOUT_LEVERS if n in fixed.raw["variables"]] == list(LAYOUT_LEVERS)


def test_layout_levers_declared_but_fixed_build_todays_nlp_exactly():
    """A symmetric layout with its levers declared but fixed: the NLP is today's, bit for bit
    (the same rows at the same point), alone and with a horizontal lever free."""
    from isodesign.optimization.table_problem import TableProblem

    st = table_study()
    fixed = {n: {"fixed": True} for n in LAYOUT_LEVERS}
    for extra in ({}, {"pendulum_length_m": {"fixed": False}}):
        p0 = TableProblem(st.with_changes(variables=extra) if extra else st)
        p1 = TableProblem(st.with_changes(variables={**fixed, **extra}))
        assert p1.nx == p0.nx and p1.con_rows == p0.con_rows
        vals = {v.name: v.start for v in st.variables}
        x0 = p0.initial_guess(vals)
        x1 = p1.initial_guess(vals)
        np.testing.assert_array_equal(x1, x0)
        np.testing.assert_array_equal(np.asarray(p1.eval_fn(x1, p1.params())[1]),
                                      np.asarray(p0.eval_fn(x0, p0.params())[1]))


def test_load_range_and_supply_margin_are_checked_naming_the_key(held_out_toml):
    """No variable moves the loads: a load or p0 outside the study's range is refused naming
    the key; inside it, the constraint table reports the worst isolator and group."""
    from isodesign.optimization.table_constraints import table_constraint_reports
    from isodesign.optimization.table_problem import TableProblem

    st = _held_out(held_out_toml)
    lv = level(st.table, st.hardware["piston_area_m2"])
    lo, hi = float(lv.load_n.min()), float(lv.load_n.max())
    with pytest.raises(InputError, match=r"constraints\.max_isolator_load_n: isolator \d"):
        TableProblem(st.with_changes(constraints={"max_isolator_load_n": hi - 1.0}))
    with pytest.raises(InputError, match=r"constraints\.min_isolator_load_n: isolator \d"):
        TableProblem(st.with_changes(constraints={"min_isolator_load_n": lo + 1.0}))
    gap = st.table.supply_pressure_pa - float(lv.group_pressure_pa.max())
    with pytest.raises(InputError, match=r"constraints\.supply_margin_pa: group \d"):
        TableProblem(st.with_changes(constraints={"supply_margin_pa": gap + 1.0}))
    with pytest.raises(InputError, match=r"constraints\.min_isolator_load_n .* must be below"):
        st.with_changes(constraints={"min_isolator_load_n": 3000.0,
                                     "max_isolator_load_n": 2000.0})
    ok = st.with_changes(constraints={"min_isolator_load_n": lo - 10.0,
                                      "max_isolator_load_n": hi + 5.0,
                                      "supply_margin_pa": gap - 1000.0})
    p = TableProblem(ok)
    x = p.initial_guess({v.name: v.start for v in ok.variables})
    g = np.asarray(p.eval_fn(x, p.params())[1]).ravel()
    rep = {r.name: r for r in table_constraint_reports(p, g)}
    assert rep["isolator_load"].value == pytest.approx(hi)  # 5 N from its bound: the worst
    assert rep["isolator_load"].upper == pytest.approx(hi + 5.0)
    assert rep["supply_pressure"].value == pytest.approx(float(lv.group_pressure_pa.max()))
    assert rep["supply_pressure"].upper == pytest.approx(float(lv.group_pressure_pa.max())
                                                         + 1000.0)


@pytest.mark.slow
def test_layout_sensitivity_against_a_finite_difference_of_the_reoptimized_design():
    """The built-in table (one start) with the layout's width free in [0.8, 1.2] m: the
    width stops on its upper bound, and the bound multiplier's exact sensitivity (1.42 dB
    per m) agrees with the re-optimized design with the bound raised by 1 cm (1.46 dB/m)
    within 5 % (a forward difference of a curved optimal value)."""
    from isodesign.optimization.table_driver import optimize_table

    st = table_study().with_changes(solver={"starts": 1})

    def width(upper):
        return st.with_changes(variables={"layout_width_m": {"fixed": False, "lower": 0.8,
                                                             "upper": upper}})

    r = optimize_table(width(1.2), workers=1, analyze=False)
    assert r.success
    s = {x["name"]: x for x in r.lever_sensitivity}["layout_width_m"]
    assert s["at_bound"] == "upper" and r.values["layout_width_m"] == pytest.approx(1.2)
    up = optimize_table(width(1.21), workers=1, analyze=False)
    fd = (up.objective_value - r.objective_value) / 0.01
    assert fd > 0
    assert s["db_per_unit"] == pytest.approx(fd, rel=0.05)
    assert s["db_per_unit"] == pytest.approx(1.42, abs=0.05)


def test_the_footprint_area_objective_is_the_stretched_layouts_area():
    """The cost of the footprint front: ln (L W) of the layout levers; refused without a free
    layout and for a vertical study (one line naming the key)."""
    from isodesign.optimization.pareto import pareto_front
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(variables=LAYOUT)
    p = TableProblem(st, objectives=("worst_band_margin", "footprint_area"))
    lev = {"layout_length_m": 1.4, "layout_width_m": 0.7}
    x = p.initial_guess({**{v.name: v.start for v in st.variables}, **lev})
    j = np.asarray(p._j_fn(x)).ravel()
    assert np.exp(j[1]) == pytest.approx(1.4 * 0.7, rel=1e-12)
    with pytest.raises(InputError, match=r"footprint_area needs a free layout.*"
                                         r"variables\.layout_length_m"):
        TableProblem(table_study(), objectives=("worst_band_margin", "footprint_area"))
    # the key the caller typed: objectives (objective.kind is a study file's key)
    with pytest.raises(InputError, match=r"objectives: footprint_area is the footprint of a "
                                         r"table's isolators.*this study has no \[table\]"):
        pareto_front(vertical_study(), ("worst_band_margin", "footprint_area"), 3)
    with pytest.raises(InputError, match=r"objectives: a study with a \[table\] has the "
                                         r"fronts"):
        pareto_front(st, ("worst_band_margin", "rms_velocity"), 3)


@pytest.mark.slow
def test_a_pareto_front_of_the_margin_against_the_footprint_area(tmp_path):
    """The table's epsilon-constraint front with the footprint area as the cost (the
    machinery of the volume front): anchor A the margin's optimum, anchor B the smallest
    footprint the constraints allow (0.6 x 0.5 m: the length on its 0.5 x 1.2 m bound, the
    width on the 0.5 m minimum distance), every point's area from its own layout levers, the
    non-dominated points' margin falling with the area."""
    from isodesign.optimization.pareto import pareto_front

    st = table_study().with_changes(variables=LAYOUT, solver={"starts": 1},
                                    constraints={"min_isolator_distance_m": 0.5})
    res = pareto_front(st, ("worst_band_margin", "footprint_area"), 3)
    assert res.objectives == ("worst_band_margin", "footprint_area")
    assert res.cost == "footprint_area"
    ok = np.isfinite(res.worst_margin_db)
    assert ok.sum() >= 2
    area = np.array([d["layout_length_m"] * d["layout_width_m"] for d in res.designs])
    np.testing.assert_allclose(res.costs[ok], area[ok], rtol=1e-9)
    assert np.nanmin(res.costs) == pytest.approx(0.6 * 0.5, rel=1e-4)
    front = np.flatnonzero(res.front)
    order = front[np.argsort(res.costs[front])]
    assert np.all(np.diff(res.worst_margin_db[order]) >= -1e-6)
    df = res.to_frame()
    assert "footprint_area_m2" in df and "total_volume_m3" in df
    assert res.plot().axes[0].get_xlabel().startswith("footprint")


def test_the_command_line_refuses_a_footprint_front_without_a_free_layout(tmp_path, capsys):
    from isodesign.cli import main

    out = tmp_path / "p"
    assert main(["pareto", "--builtin", "table", "--objectives",
                 "worst_band_margin,footprint_area", "--points", "3", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "variables.layout_length_m" in err[0]
    assert not out.exists()
    assert main(["pareto", "--builtin", "table", "--objectives",
                 "worst_band_margin,rms_velocity", "--points", "3", "-o", str(out)]) == 2
    assert "worst_band_margin,footprint_area" in capsys.readouterr().err


@pytest.mark.parametrize("call, words", [
    (lambda st: st.with_levers_fixed([1.4]), "values: expected a dict"),
    (lambda st: st.with_levers_fixed({"layout_length_m": 1.4}),
     "values: the free lever layout_width_m has no value"),
    (lambda st: st.with_levers_fixed({"layout_length_m": "1.4", "layout_width_m": 0.8}),
     "values['layout_length_m']: expected a finite number"),
    (lambda st: st.table_at({"layout_width_m": float("nan")}),
     "values['layout_width_m']: expected a finite number"),
    (lambda st: st.table_at([1.4, 0.8]), "values: expected a dict"),
])
def test_lever_values_of_the_api_are_checked_naming_the_lever(call, words):
    """Study.with_levers_fixed and Study.table_at: a list raised AttributeError, a missing
    free lever KeyError; a NaN layout built a NaN table and a string was taken as a number."""
    with pytest.raises(InputError) as exc:
        call(table_study().with_changes(variables=LAYOUT))
    assert words in str(exc.value)
