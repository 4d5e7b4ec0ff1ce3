"""One NumPy re-check of the optimum for every body (docs/optimization.md, "The NumPy
re-check"): :func:`isodesign.optimization.recheck.recheck_rows` compares each constraint row
the registry re-checks, on the NumPy analysis's quantities, with the NLP's value and with its
bounds, for the vertical optimum (``vertical_study()``), the built-in table
(``table_study()``) and a table with free isolator positions (its layout and load rows on the
table leveled by the analysis's statics); a row whose NumPy value breaks its bound is a
violation and the verdict is no PASS. Free positions: IPOPT's trial steps with a negative
group load print no CasADi NaN warning (the safeguarded mass of the vertical mode's row).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from isodesign.errors import SolverError
from isodesign.optimization.constraint_registry import (
    TABLE_ROWS,
    VERTICAL_ROWS,
    Constraint,
    constraint_rows_of,
)
from isodesign.optimization.recheck import RECHECK_RTOL, RECHECK_VIOLATION_TOL, recheck_rows
from isodesign.optimization.study import table_study, vertical_study

#: The pentagon footprint of the free-positions case (tests/table/test_position_lever.py).
POLY = [[-0.75, -0.5], [0.6, -0.5], [0.75, 0.2], [0.3, 0.5], [-0.75, 0.5]]


def _free_positions():
    """The built-in table (table_study()) with its isolators free in a pentagon, 0.5 m
    apart, one start."""
    return table_study().with_changes(
        solver={"starts": 1}, constraints={"min_isolator_distance_m": 0.5},
        variables={"isolator_positions_m": {"fixed": False, "polygon_m": POLY}})


def test_recheck_rows_reports_violations_and_refuses_disagreement():
    rows = [Constraint("total_volume", np.array([0.5]), -math.inf, 0.0, 1, key="v",
                       kind="total_volume"),
            Constraint("layout", np.array([0.2, -0.01]), 0.0, math.inf, 2, key="fp",
                       kind="layout")]
    con = [("v", 0, 1), ("fp", 1, 2), ("epigraph_x", 3, 1)]
    g = np.array([0.5, 0.2, -0.01, 7.0])
    rc = recheck_rows(rows, con, g)
    assert rc.max_difference == 0.0
    # the NumPy values break both bounds: each a violation under its name (a given row's key)
    assert dict(rc.violations) == pytest.approx({"total_volume": 0.5, "fp": 0.01})
    assert rc.unchecked == ("epigraph_x",)
    # inside the bounds within the tolerance: no violation
    ok = [dataclasses.replace(rows[0], expr=np.array([0.5 * RECHECK_VIOLATION_TOL]))]
    assert recheck_rows(ok, [("v", 0, 1)], ok[0].expr).violations == ()
    # the NLP's row and the NumPy value disagree: a bug, never a design
    with pytest.raises(SolverError, match="disagrees with the NumPy analysis's constraint rows"):
        recheck_rows(rows, con, g + np.array([10 * RECHECK_RTOL, 0, 0, 0]))


def test_vertical_optimum_rechecked_row_by_row():
    from isodesign.optimization.driver import optimize_vertical
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.recheck import recheck_design

    st = vertical_study().with_changes(solver={"starts": 1})
    prob = Problem(st)
    r = optimize_vertical(st, analyze=False, problem=prob)
    assert r.success and r.recheck_max_rel_diff <= RECHECK_RTOL
    # the optimum, solved again from itself (the same NLP), re-checked through the one function
    sol = prob.solve(prob.initial_guess(r.values))
    rc = recheck_design(prob, sol, st.design_at(sol.values))
    kinds = {kind for _, kind, _, _ in rc.rows}
    assert {"total_volume", "tilt_margin", "natural_frequency", "peak_transmissibility",
            "damping_ratio"} <= kinds <= set(VERTICAL_ROWS)
    assert rc.violations == () and rc.max_difference <= RECHECK_RTOL
    assert all(d <= RECHECK_RTOL and v <= RECHECK_VIOLATION_TOL for _, _, d, v in rc.rows)


def test_table_optimum_rechecked_row_by_row_and_a_broken_row_is_no_pass():
    from isodesign.optimization.table_constraints import table_quantities
    from isodesign.optimization.table_driver import optimize_table
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(solver={"starts": 1})
    prob = TableProblem(st)
    r = optimize_table(st, workers=1, analyze=False, problem=prob)
    rc = r.recheck_rows
    kinds = {kind for _, kind, _, _ in rc.rows}
    assert {"total_volume", "natural_frequency", "tilt_margin_rows",
            "peak_transmissibility", "mach"} <= kinds
    assert rc.max_difference <= 1e-6 and rc.violations == ()
    assert r.verdict() == r._band_verdict()  # no row broken: the bands' verdict
    # the same optimum judged by rows whose bound it breaks (a volume bound 10 % below
    # its volume): the NumPy row is a violation, and the verdict is a FAIL naming it
    v = r.design.total_volume_m3
    tight = st.with_changes(constraints={"max_total_volume_m3": 0.9 * v})
    rows = constraint_rows_of(tight, table_quantities(prob, r.values), TABLE_ROWS)
    # the NLP's rows at the optimum's design (its closure solved afresh: the volume row
    # depends on the design alone)
    prob_g = np.asarray(prob.eval_fn(prob.initial_guess(r.values), prob.params())[1],
                        float).ravel()
    broken = recheck_rows(rows, [c for c in prob.con_rows if c[0] == "max_total_volume_m3"],
                          prob_g, tol=1e-3)
    assert dict(broken.violations)["total_volume"] == pytest.approx(-math.log(0.9), rel=1e-3)
    bad = dataclasses.replace(r, violations=r.violations + broken.violations)
    assert not bad.success and bad.verdict().startswith("FAIL: constraint broken: total_volume")


@pytest.mark.slow
def test_free_positions_rechecked_and_no_nan_warning(capfd):
    """The free positions' footprint, spacing, group-load and supply rows are re-checked on
    the table leveled by the analysis's statics; the solve prints no CasADi NaN warning
    (before the safeguarded mass it printed a dozen, 'NaN detected ... row 93')."""
    from isodesign.optimization.table_driver import optimize_table

    capfd.readouterr()
    r = optimize_table(_free_positions(), workers=1, analyze=False)
    err = capfd.readouterr().err
    assert "NaN" not in err, err[:400]
    assert r.success
    rows = {key: (kind, d, v) for key, kind, d, v in r.recheck_rows.rows}
    for key, kind in (("footprint_polygon_m", "layout"), ("isolator_distance_m2", "layout"),
                      ("group_load_kn", "loads"), ("supply_pressure_pa", "loads")):
        assert rows[key][0] == kind
        assert rows[key][1] <= 1e-6 and rows[key][2] <= RECHECK_VIOLATION_TOL
    assert r.recheck_rows.violations == ()


def test_position_rows_numpy_equal_the_nlp_rows_at_a_layout():
    """At a moved layout (not an optimum) the NumPy rows (statics.level of the moved table)
    equal the NLP's closed-form rows."""
    from isodesign.optimization.lever_nlp import position_rows_numpy
    from isodesign.optimization.table_problem import TableProblem
    from isodesign.table.model import table_model

    st = _free_positions()
    prob = TableProblem(st)
    values = {v.name: v.start for v in st.variables}
    xy = st.table.isolators_m
    for i in range(xy.shape[0]):  # 3 cm towards the centre, and a little apart in y
        values[f"isolator_{i + 1}_x_m"] = 0.97 * float(xy[i, 0])
        values[f"isolator_{i + 1}_y_m"] = 0.95 * float(xy[i, 1]) + 0.01 * i
    x = prob.initial_guess(values)
    g = np.asarray(prob.eval_fn(x, prob.params())[1], float).ravel()
    table = st.table_at(values)
    lv = table_model(st.design_at(values), table).leveling
    rows = position_rows_numpy(prob, table, lv)
    assert {r[0] for r in rows} == {"footprint_polygon_m", "isolator_distance_m2",
                                    "group_load_kn", "supply_pressure_pa"}
    where = {key: (row, n) for key, row, n in prob.con_rows}
    for key, v, lo, hi in rows:
        row, n = where[key]
        np.testing.assert_allclose(v, g[row: row + n], rtol=1e-9, atol=1e-12, err_msg=key)
        assert (lo, hi) == (float(prob.lbg[row]), float(prob.ubg[row]))


def test_safe_load_is_exact_above_its_floor_and_smooth_below():
    import casadi as ca

    from isodesign.optimization.lever_nlp import safe_load

    floor = 2.0
    m = np.array([-50.0, -1.0, 0.0, 1.0, 2.0, 3.0, 100.0])
    v = safe_load(m, floor)
    assert np.all(np.isfinite(v)) and np.all(v > 0)
    np.testing.assert_array_equal(v[m >= floor], m[m >= floor])  # the exact mass
    s = ca.SX.sym("m")
    f = ca.Function("f", [s], [safe_load(s, floor), ca.jacobian(safe_load(s, floor), s)])
    for mi in m:
        val, der = (float(a) for a in f(mi))
        assert val == pytest.approx(float(safe_load(np.array(mi), floor)), rel=1e-15)
        assert math.isfinite(der) and der > 0
    # C1 at the floor: value and slope from both sides
    lo, hi = f(floor - 1e-9), f(floor + 1e-9)
    assert float(lo[0]) == pytest.approx(float(hi[0]), abs=1e-8)
    assert float(lo[1]) == pytest.approx(float(hi[1]), abs=1e-8)


def test_rows_are_finite_where_a_group_load_is_negative():
    """A layout inside the pentagon whose leveling leaves group 2 with a negative load (an
    IPOPT trial step): every row of the free-positions NLP is finite (the exact loads gave
    NaN in 421 rows, the vertical mode's first); the group-load row still sees the exact,
    negative load."""
    from isodesign.optimization.table_problem import TableProblem
    from isodesign.table.statics import group_loads_at

    st = _free_positions()
    prob = TableProblem(st)
    x = prob.initial_guess({v.name: v.start for v in st.variables})
    xy = [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [0.2, 0.45]]
    loads = group_loads_at(st.table, xy)
    assert loads[1] < 0
    ls, nzs = prob.lever_scaling, len(prob.scaling.names)
    for i, (a, b) in enumerate(xy):
        for name, val in ((f"isolator_{i + 1}_x_m", a), (f"isolator_{i + 1}_y_m", b)):
            j = ls.names.index(name)
            x[nzs + j] = (val - ls.center[j]) / ls.half[j]
    g = np.asarray(prob.eval_fn(x, prob.params())[1], float).ravel()
    assert np.all(np.isfinite(g))
    row, n = next((r, m) for k, r, m in prob.con_rows if k == "group_load_kn")
    np.testing.assert_allclose(g[row: row + n], np.asarray(loads) / 1e3, rtol=1e-12)


def test_stretched_layout_rows_rechecked_on_the_stretched_table():
    """Free layout levers (the rectangle stretched about the CG): the footprint and distance
    rows on the NumPy path are the stretched table's own, equal to the NLP's at a stretch."""
    from isodesign.optimization.table_constraints import table_quantities
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(
        variables={"layout_length_m": {"fixed": False}, "layout_width_m": {"fixed": False}},
        constraints={"footprint_m": [[-0.8, -0.6], [0.8, 0.6]], "min_isolator_distance_m": 0.5})
    prob = TableProblem(st)
    values = {v.name: v.start for v in st.variables}
    values.update(layout_length_m=1.3, layout_width_m=0.9)
    x = prob.initial_guess(values)
    g = np.asarray(prob.eval_fn(x, prob.params())[1], float).ravel()
    rows = constraint_rows_of(st, table_quantities(prob, values), TABLE_ROWS)
    rc = recheck_rows(rows, prob.con_rows, g)
    kinds = {key: kind for key, kind, _, _ in rc.rows}
    assert kinds["footprint_m"] == kinds["min_isolator_distance_m"] == "layout"
    assert rc.max_difference <= 1e-9 and rc.violations == ()


def test_free_slab_rows_rechecked_with_the_slabs_terms():
    """A free inertia base at a mass other than its start: the vertical mode, tilt and peak
    rows on the NumPy path equal the NLP's (the tilt rows with the slab's terms); its load
    and supply rows are listed as not re-checked."""
    from isodesign.optimization.table_constraints import table_quantities
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(variables={"inertia_base_mass_kg": {"fixed": False}},
                                    constraints={"max_isolator_load_n": 2500.0})
    prob = TableProblem(st)
    values = {v.name: v.start for v in st.variables} | {"inertia_base_mass_kg": 250.0}
    x = prob.initial_guess(values)
    g = np.asarray(prob.eval_fn(x, prob.params())[1], float).ravel()
    rc = recheck_rows(constraint_rows_of(st, table_quantities(prob, values), TABLE_ROWS),
                      prob.con_rows, g)
    kinds = {kind for _, kind, _, _ in rc.rows}
    assert {"natural_frequency", "tilt_margin_rows", "peak_transmissibility"} <= kinds
    assert rc.max_difference <= 1e-9
    assert {"isolator_load_n", "supply_pressure_pa"} <= set(rc.unchecked)
