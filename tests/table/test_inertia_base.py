"""The inertia base (docs/table.md, section 16): a slab under the payload, its mass a lever;
the combined body's mass, CG and inertia, the loads and pressures that follow, the NLP's
symbolic path against the analysis."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import table_study
from isodesign.spring.gas import P_ATM
from isodesign.table.inertia_base import InertiaBase, slab_body, with_base_mass
from isodesign.table.layout import box_inertia
from isodesign.table.statics import level

FREE = {"inertia_base_mass_kg": {"fixed": False}}


def test_the_combined_body_against_two_boxes_by_hand():
    """table_study() (600 kg, box 1.5 x 1.0 x 0.7 m, CG 0.35 m) on a 400 kg concrete slab of
    1.5 x 1.0 m hung at the support plane: t = 400 / (2400 * 1.5) m, the combined CG and the
    inertia of two boxes, each about its own CG and moved to the combined CG by hand."""
    st = table_study().with_changes({"table.inertia_base": {"mass_kg": 400.0}})
    t = st.table
    mp, ms, hp = 600.0, 400.0, 0.35
    th = 400.0 / (2400.0 * 1.5 * 1.0)
    zs = -th / 2
    h = (mp * hp + ms * zs) / (mp + ms)
    ip = box_inertia(mp, (1.5, 1.0, 0.7))
    islab = box_inertia(ms, (1.5, 1.0, th))
    par = np.diag([1.0, 1.0, 0.0])
    want = ip + mp * (hp - h) ** 2 * par + islab + ms * (zs - h) ** 2 * par
    assert t.mass_kg == pytest.approx(1000.0)
    assert t.cg_m == pytest.approx([0.0, 0.0, h], abs=1e-15)
    np.testing.assert_allclose(t.inertia_kg_m2, want, rtol=1e-13)
    assert t.inertia_base.thickness_m() == pytest.approx(th)
    # the instrument points stay in the table frame; without a slab the payload is back
    np.testing.assert_array_equal(t.instrument_points_m, table_study().table.instrument_points_m)
    back = with_base_mass(t, 0.0)
    np.testing.assert_allclose(back.inertia_kg_m2, table_study().table.inertia_kg_m2,
                               rtol=1e-13, atol=1e-12)
    assert back.cg_m == pytest.approx(table_study().table.cg_m, abs=1e-15)


def test_slab_body_on_symbols_equals_numpy():
    b = InertiaBase(density_kg_m3=2700.0, size_m=(1.2, 0.9), top_height_m=0.05)
    x = ca.SX.sym("m")
    f = ca.Function("f", [x], list(slab_body(900.0, 0.4, x, b)[:2]) + list(
        slab_body(900.0, 0.4, x, b)[2]))
    got = [float(v) for v in f(350.0)]
    m, h, di = slab_body(900.0, 0.4, 350.0, b)
    assert got == pytest.approx([m, h, *di], rel=1e-15)


def test_loads_and_pressures_scale_with_the_weight():
    """The slab centred under the CG keeps the load shares: each load and gauge pressure
    scales by m / m_payload (the leveling's equations are homogeneous in the weight)."""
    st = table_study()
    area = st.hardware["piston_area_m2"]
    l0 = level(st.table, area)
    lv = level(with_base_mass(st.table, 300.0), area)
    np.testing.assert_allclose(lv.load_n, l0.load_n * 900.0 / 600.0, rtol=1e-13)
    np.testing.assert_allclose(lv.pressure_pa - P_ATM, (l0.pressure_pa - P_ATM) * 1.5,
                               rtol=1e-13)


def test_a_slab_that_puts_the_cg_at_the_support_plane_decouples_rocking():
    """Physics: with the elastic centres at the support plane, a CG at that plane decouples
    horizontal translation from rocking (and removes the overturning term). The slab that
    does it, m_s = sqrt(2 rho A m_p h_p) (its top at the plane), leaves an x mode with no ry;
    without it the x mode rocks (a 12 bar supply carries the 1830 kg)."""
    from isodesign.table.model import table_model
    from isodesign.table.modes import table_modes

    st = table_study().with_changes({"table.supply_pressure_pa": 1.3e6})
    ms = float(np.sqrt(2 * 2400.0 * 1.5 * 1.0 * 600.0 * 0.35))
    t = with_base_mass(st.table, ms)
    assert t.cg_height_m == pytest.approx(0.0, abs=1e-12)
    d = st.start_design()

    def x_mode_rocking(table):
        m = table_modes(table_model(d, table))
        j = int(np.argmax(m.energy_fraction[:, 0]))
        return m.energy_fraction[j, 4]

    assert x_mode_rocking(t) < 1e-9
    assert x_mode_rocking(st.table) > 1e-3


def test_the_nlp_with_a_free_slab_equals_the_nlp_of_the_fixed_table():
    """At a slab of 450 kg (and the elastic centre free at 0.1 m), the NLP's symbolic path
    gives the closure, the margins and the rows of the NLP built on the table with them
    fixed; the tilt rows are the same rows times the fixed scale's ratio W h / (W_0 h_0)."""
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(constraints={"min_tilt_margin": 1.5,
                                                 "min_natural_frequency_hz": 1.0})
    free = st.with_changes(variables={**FREE, "elastic_centre_height_m": {"fixed": False}})
    lev = {"inertia_base_mass_kg": 450.0, "elastic_centre_height_m": 0.1}
    fixed = free.with_levers_fixed(lev)
    assert fixed.table.mass_kg == pytest.approx(1050.0)
    p1, p2 = TableProblem(free), TableProblem(fixed)
    vals = {v.name: v.start for v in free.variables}
    x1, x2 = p1.initial_guess({**vals, **lev}), p2.initial_guess(vals)
    np.testing.assert_allclose(np.asarray(p1._all_margins_fn(x1)).ravel(),
                               np.asarray(p2._all_margins_fn(x2)).ravel(), atol=1e-9)
    g1 = np.asarray(p1.eval_fn(x1, p1.params())[1]).ravel()
    g2 = np.asarray(p2.eval_fn(x2, p2.params())[1]).ravel()
    ratio = fixed.table.weight_n * fixed.table.cg_height_m / (600.0 * 9.80665 * 0.35)
    rows2 = {n: (r, m) for n, r, m in p2.con_rows}
    assert [n for n, _, _ in p1.con_rows if n not in rows2] == ["supply_pressure_pa"]
    for name, row, m in p1.con_rows:
        if name not in rows2:
            continue
        a, b = g1[row: row + m], g2[rows2[name][0]: rows2[name][0] + m]
        if name == "min_tilt_margin":
            b = b * np.array([ratio, ratio, ratio ** 2])
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9, err_msg=name)
    np.testing.assert_allclose(g1[: p1.n_eq], g2[: p2.n_eq], atol=1e-9)


def test_the_nlps_derivative_in_the_slab_mass_equals_finite_differences_of_the_analysis():
    """The total derivative of every band margin in the slab's mass (the closure implicit,
    from the NLP's exact Jacobians) against central differences of the NumPy analysis
    (table_band_response on the table with the slab, +-5 kg): within 0.1 %."""
    from isodesign.optimization.table_problem import TableProblem
    from isodesign.table.response import table_band_response

    st = table_study().with_changes({"models.distortion": False},  # plain closure
                                    variables=FREE)
    p = TableProblem(st)
    vals = {v.name: v.start for v in st.variables}
    x = p.initial_guess({**vals, "inertia_base_mass_kg": 300.0})
    xs = ca.MX.sym("x", p.nx)
    i = len(p.scaling.names) + p.lever_scaling.names.index("inertia_base_mass_kg")
    g = p.eval_fn(xs, p.params())[1][: p.n_eq]
    jac = ca.Function("j", [xs], [ca.jacobian(g, xs), ca.jacobian(p._all_margins_fn(xs), xs)])
    jg, jm = (np.asarray(a) for a in jac(x))
    cl = list(range(p.nz, p.nz + 2 * p.n))
    dm = (jm[:, i] - jm[:, cl] @ np.linalg.solve(jg[:, cl], jg[:, i])) / p.lever_scaling.half[
        p.lever_scaling.names.index("inertia_base_mass_kg")]
    m = st.models

    def margins(ms):
        r = table_band_response(st.design_at(vals), st.table_at({"inertia_base_mass_kg": ms}),
                                st.floor_axes, st.target, bands=st.bands,
                                points_per_band=m["points_per_band"], flow=m["flow"],
                                amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"],
                                warn=False, strict=False)
        return r.margin_db.ravel()

    np.testing.assert_allclose(np.asarray(p._all_margins_fn(x)).ravel(), margins(300.0),
                               atol=1e-9)
    fd = (margins(305.0) - margins(295.0)) / 10.0
    assert np.max(np.abs(dm - fd)) < 1e-3 * np.max(np.abs(fd))


@pytest.mark.parametrize("changes, words", [
    ({"table.inertia_base": {"density_kg_m3": 0.0}},
     r"table\.inertia_base\.density_kg_m3: must be in \[10, 25000\]"),
    ({"table.inertia_base": {"density_kg_m3": "2400"}},
     r"table\.inertia_base\.density_kg_m3: expected a number"),
    ({"table.inertia_base": {"size_m": [1.5]}}, r"table\.inertia_base\.size_m: expected"),
    ({"table.inertia_base": {"size_m": [1500.0, 1000.0]}},
     r"table\.inertia_base\.size_m: each side must be in \[0\.05, 40\] m"),
    ({"table.inertia_base": {"mass_kg": -1.0}}, r"table\.inertia_base\.mass_kg: must be >= 0"),
    ({"table.inertia_base": {"top_height_m": 350.0}}, r"table\.inertia_base\.top_height_m"),
    ({"table.inertia_base": {"thickness_m": 0.1}}, r"unknown key 'thickness_m' in "
                                                   r"\[table\.inertia_base\]"),
    ({"table.inertia_base": {"mass_kg": 1e6}},
     r"table\.inertia_base\.mass_kg = 1e\+06 kg is outside \[0, 30000\] kg"),
    ({"table.inertia_base": 5.0}, r"\[table\.inertia_base\] must be a table"),
    ({"table.inertia_base": {"size_m": [1.5, "1.0"]}},
     r"table\.inertia_base\.size_m: expected a number"),
    ({"variables.inertia_base_mass_kg": {"fixed": False, "upper": 1e6}},
     r"variables\.inertia_base_mass_kg\.upper = 1e\+06 kg is outside \[0, 30000\] kg"),
    ({"variables.inertia_base_mass_kg": {"fixed": False, "lower": -5.0}},
     r"variables\.inertia_base_mass_kg\.lower = -5 kg is outside"),
    ({"variables.inertia_base_mass_kg": {"fixed": False, "lower": 500.0, "upper": 100.0}},
     r"variables\.inertia_base_mass_kg: need 0 <= lower < upper"),
    ({"variables.inertia_base_mass_kg": {"fixed": False, "start": 2000.0}},
     r"variables\.inertia_base_mass_kg\.start \(2000\) must lie in \[lower, upper\] = "
     r"\[0, 697\.079\] kg"),
    ({"variables.inertia_base_mass_kg": {"fixed": False, "upper": 900.0}},
     r"variables\.inertia_base_mass_kg\.upper = 900 kg is above 697\.08 kg, the heaviest slab "
     r"the supply carries"),
    ({"variables.inertia_base_mass_kg": {"start": 300.0}},
     r"variables\.inertia_base_mass_kg\.start \(300 kg\) differs from the fixed slab's "
     r"table\.inertia_base\.mass_kg \(0 kg\)"),
    ({"variables.inertia_base_mass_kg": {"fixed": "no"}},
     r"variables\.inertia_base_mass_kg\.fixed: expected true or false"),
    ({"variables.inertia_base_mass_kg": {"start": True}},
     r"variables\.inertia_base_mass_kg\.start: expected a finite number"),
])
def test_bad_inertia_base_keys_name_the_key_and_its_range(changes, words):
    with pytest.raises(InputError, match=words):
        table_study().with_changes(changes)


def test_the_lever_is_fixed_at_no_slab_by_default_and_free_up_to_what_the_supply_carries():
    """Default bounds: 0 to twice the payload or the heaviest slab the supply carries if
    lighter: the built-in table's p0 (2.78 bar gauge at 600 kg, every group alike) reaches
    the 6 bar gauge supply at 600 x 6 / 2.78... = 1297 kg, a slab of 697 kg; with a supply
    margin, less."""
    st = table_study()
    spec = {v.name: v for v in st.levers}["inertia_base_mass_kg"]
    assert spec.fixed and spec.start == 0.0
    assert st.table.mass_kg == 600.0 and st.table.inertia_base.size_m == (1.5, 1.0)
    free = st.with_changes(variables=FREE)
    spec = {v.name: v for v in free.levers}["inertia_base_mass_kg"]
    lv = level(st.table, st.hardware["piston_area_m2"])
    gauge = float(lv.group_pressure_pa.max()) - P_ATM
    cap = 600.0 * (st.table.supply_pressure_pa - P_ATM) / gauge - 600.0
    assert (spec.lower, spec.fixed) == (0.0, False)
    assert spec.upper == pytest.approx(cap, rel=1e-12) and spec.upper == pytest.approx(697.08,
                                                                                     abs=0.01)
    lv = level(free.table_at({"inertia_base_mass_kg": spec.upper}),
               st.hardware["piston_area_m2"])
    assert float(lv.group_pressure_pa.max()) == pytest.approx(st.table.supply_pressure_pa)
    margin = st.with_changes(variables=FREE, constraints={"supply_margin_pa": 1e5})
    spec = {v.name: v for v in margin.levers}["inertia_base_mass_kg"]
    assert spec.upper == pytest.approx(600.0 * 5e5 / gauge - 600.0, rel=1e-12)
    with pytest.raises(InputError, match=r"values\['inertia_base_mass_kg'\]: expected a finite"):
        st.with_changes(variables=FREE).table_at({"inertia_base_mass_kg": float("nan")})


def test_a_vertical_study_refuses_the_slab_naming_the_key():
    from isodesign.optimization.study import vertical_study

    with pytest.raises(InputError, match=r"variables\.inertia_base_mass_kg is a lever of a "
                                         r"table study"):
        vertical_study().with_changes(variables=FREE)


def test_a_free_slab_with_leveling_loop_bounds_is_refused_naming_the_key():
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(variables=FREE, constraints={
        "min_leveling_gain_margin_db": 6.0})
    with pytest.raises(InputError, match=r"constraints\.min_leveling_gain_margin_db: .*"
                                         r"variables\.inertia_base_mass_kg"):
        TableProblem(st)


def test_with_a_free_slab_the_loads_and_the_supply_are_rows_of_the_nlp():
    """The rows equal the leveling of the table with the slab (loads in kN, gauge p0 in
    bar), the supply always (a physical limit), the load range when the study sets it; the
    reports read the optimum's leveling from them."""
    from isodesign.optimization.table_problem import TableProblem
    from isodesign.table.statics import leveling_of_rows

    st = table_study().with_changes(variables=FREE, constraints={
        "max_isolator_load_n": 2500.0, "supply_margin_pa": 5.0e4})
    p = TableProblem(st)
    vals = {v.name: v.start for v in st.variables}
    x = p.initial_guess({**vals, "inertia_base_mass_kg": 250.0})
    g = np.asarray(p.eval_fn(x, p.params())[1]).ravel()
    rows = {n: (r, m) for n, r, m in p.con_rows}
    lv = level(st.table_at({"inertia_base_mass_kg": 250.0}), st.hardware["piston_area_m2"])
    r, m = rows["isolator_load_n"]
    np.testing.assert_allclose(g[r: r + m] * 1e3, lv.load_n, rtol=1e-13)
    assert p.ubg[r] == pytest.approx(2.5)
    r, m = rows["supply_pressure_pa"]
    np.testing.assert_allclose(g[r: r + m] * 1e5 + P_ATM, lv.group_pressure_pa, rtol=1e-13)
    assert p.ubg[r] * 1e5 + P_ATM == pytest.approx(st.table.supply_pressure_pa - 5.0e4)
    back = leveling_of_rows(p, g)
    np.testing.assert_allclose(back.load_n, lv.load_n, rtol=1e-12)
    np.testing.assert_allclose(back.pressure_pa, lv.pressure_pa, rtol=1e-12)
    # without a free slab no such rows (the read-time check holds them)
    assert "supply_pressure_pa" not in [n for n, _, _ in TableProblem(table_study()).con_rows]


@pytest.mark.parametrize("cons, words", [
    ({"max_isolator_load_n": 1000.0}, r"constraints\.max_isolator_load_n: the heaviest "
                                      r"isolator carries 1471 N with the lightest inertia base"),
    ({"min_isolator_load_n": 5000.0}, r"constraints\.min_isolator_load_n: the lightest "
                                      r"isolator carries 3180 N with the heaviest inertia base"),
])
def test_load_constraints_no_slab_in_its_bounds_meets_are_refused_naming_the_key(cons, words):
    with pytest.raises(InputError, match=words):
        table_study().with_changes(variables=FREE, constraints=cons)
    # a range some slab meets is taken (the NLP holds it)
    table_study().with_changes(variables=FREE, constraints={"min_isolator_load_n": 2000.0})


@pytest.mark.slow
def test_a_load_bound_stops_the_slab_and_says_so():
    """The built-in table with the slab free (one start): its optimum takes 318 kg; with
    max_isolator_load_n = 2000 N the slab stops where the heaviest isolator carries 2000 N
    (the loads scale with the weight: 2000 / 1471 x 600 kg - 600 kg = 216 kg), the row is
    binding and the sentence names the key."""
    from isodesign.optimization.explain import limiting_factors
    from isodesign.optimization.table_driver import optimize_table

    st = table_study().with_changes(variables=FREE, solver={"starts": 1},
                                    constraints={"max_isolator_load_n": 2000.0})
    r = optimize_table(st, workers=1)
    assert r.success
    w0 = float(level(table_study().table, st.hardware["piston_area_m2"]).load_n.max())
    assert r.values["inertia_base_mass_kg"] == pytest.approx(2000.0 / w0 * 600.0 - 600.0,
                                                             rel=1e-5)
    c = {x.name: x for x in r.constraints}["isolator_load"]
    assert c.active and c.value == pytest.approx(2000.0, rel=1e-6)
    assert any("constraints.min/max_isolator_load_n" in s for s in limiting_factors(r))


def test_the_added_mass_objective_is_the_slabs_mass():
    """The cost of the added-mass front: the slab's mass (kg through the registry; tonnes
    inside the NLP, linear: 0 kg is a design); refused without a free slab and for a
    vertical study (one line naming objectives)."""
    from isodesign.optimization.objectives import OBJECTIVES
    from isodesign.optimization.pareto import check_front, pareto_front
    from isodesign.optimization.study import vertical_study
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(variables=FREE)
    p = TableProblem(st, objectives=("worst_band_margin", "added_mass"))
    x = p.initial_guess({**{v.name: v.start for v in st.variables},
                         "inertia_base_mass_kg": 420.0})
    j = np.asarray(p._j_fn(x)).ravel()
    assert OBJECTIVES["added_mass"].to_natural(j[1]) == pytest.approx(420.0, rel=1e-12)
    assert OBJECTIVES["added_mass"].from_natural(420.0) == pytest.approx(j[1])
    assert check_front(st, ("worst_band_margin", "added_mass")) == ("worst_band_margin",
                                                                    "added_mass")
    with pytest.raises(InputError, match=r"objectives: added_mass needs a free inertia base "
                                         r"\(variables\.inertia_base_mass_kg"):
        TableProblem(table_study(), objectives=("worst_band_margin", "added_mass"))
    with pytest.raises(InputError, match=r"objectives: added_mass needs a free inertia base"):
        pareto_front(table_study(), ("worst_band_margin", "added_mass"), 3)
    with pytest.raises(InputError, match=r"objectives: added_mass is the mass of a table's "
                                         r"inertia base.*this study has no \[table\]"):
        pareto_front(vertical_study(), ("worst_band_margin", "added_mass"), 3)
    with pytest.raises(InputError, match=r"added_mass: expected a mass >= 0 kg"):
        OBJECTIVES["added_mass"].from_natural(-1.0)


def test_the_command_line_refuses_an_added_mass_front_without_a_free_slab(tmp_path, capsys):
    from isodesign.cli import main

    out = tmp_path / "p"
    assert main(["pareto", "--builtin", "table", "--objectives",
                 "worst_band_margin,added_mass", "--points", "3", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "variables.inertia_base_mass_kg" in err[0]
    assert not out.exists()


@pytest.mark.slow
def test_a_pareto_front_of_the_margin_against_the_added_mass():
    """The built-in table, the slab free (one start, 4 points): anchor A the margin's
    optimum (a slab of 318 kg, +4.18 dB), the last point no slab; every point's cost its own
    slab's mass, the margin falling with it, and no slab-free point better than the springs
    alone can be (-4.48 dB, their optimum; the chain's warm-started points are local optima
    and may stop below it, docs/table.md section 16)."""
    from isodesign.optimization.pareto import pareto_front

    st = table_study().with_changes(variables=FREE, solver={"starts": 1})
    res = pareto_front(st, ("worst_band_margin", "added_mass"), 4)
    assert res.cost == "added_mass"
    ok = np.isfinite(res.worst_margin_db)
    assert ok.all() and res.front.all()
    np.testing.assert_allclose(res.costs, [d["inertia_base_mass_kg"] for d in res.designs],
                               rtol=1e-9, atol=1e-6)
    assert res.costs[0] == pytest.approx(317.7, abs=1.0)
    assert res.costs[-1] == pytest.approx(0.0, abs=1e-3)
    assert res.worst_margin_db[0] == pytest.approx(4.18, abs=0.05)
    assert res.worst_margin_db[-1] <= -4.48 + 0.05
    assert np.all(np.diff(res.worst_margin_db) < 0)
    df = res.to_frame()
    assert "added_mass_kg" in df
    assert res.plot().axes[0].get_xlabel().startswith("added mass")


@pytest.mark.slow
def test_slab_sensitivity_against_a_finite_difference_of_the_reoptimized_design():
    """The slab capped at 150 kg (its optimum is 318 kg): it stops on the cap, and the bound
    multiplier's exact sensitivity (dB per kg of the cap) agrees with the re-optimized design
    with the cap raised by 5 kg within 5 % (a forward difference of a curved optimum)."""
    from isodesign.optimization.table_driver import optimize_table

    def capped(upper):
        return table_study().with_changes(solver={"starts": 1}, variables={
            "inertia_base_mass_kg": {"fixed": False, "upper": upper}})

    r = optimize_table(capped(150.0), workers=1, analyze=False)
    assert r.success
    s = {x["name"]: x for x in r.lever_sensitivity}["inertia_base_mass_kg"]
    assert s["at_bound"] == "upper" and r.values["inertia_base_mass_kg"] == pytest.approx(150.0)
    up = optimize_table(capped(155.0), workers=1, analyze=False)
    fd = (up.objective_value - r.objective_value) / 5.0
    assert fd > 0
    assert s["db_per_unit"] == pytest.approx(fd, rel=0.05)


def test_a_table_without_a_slabs_plan_size_has_no_slab_until_one_is_declared():
    """box_m in millimetres (a unit slip the study warns about) is no slab's plan size: the
    table has no slab (the lever fixed at 0 is taken), and freeing it asks for size_m."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = table_study().with_changes({"table.box_m": [1500.0, 1000.0, 700.0]})
        assert st.table.inertia_base is None and st.table.mass_kg == 600.0
        with pytest.raises(InputError, match=r"variables\.inertia_base_mass_kg: the table has "
                                             r"no \[table\.inertia_base\].*give "
                                             r"table\.inertia_base\.size_m"):
            st.with_changes(variables=FREE)
        ok = st.with_changes(variables=FREE, table={"inertia_base": {"size_m": [1.5, 1.0]}})
    assert ok.table.inertia_base.size_m == (1.5, 1.0)


def test_rocking_rows_hold_the_live_mass_matrix_at_a_slab_other_than_the_start():
    """The rocking-frequency rows with a free slab: a frozen mode's Rayleigh quotient
    ``phi^H K' phi / phi^H M(m_s) phi`` with the combined body's mass at the lever, so at
    450 kg (the NLP built at the start's 0 kg, the mode frozen at 450 kg) each active row
    gives the NumPy modes' ``(2 pi f)^2`` of the table with that slab (``Re mu = w^2`` at
    the converged mode); the start's frozen mass would be off by the inertia's ratio."""
    from isodesign.optimization.table_driver import _modes_at
    from isodesign.optimization.table_problem import ROCKING_ENERGY_FRACTION, TableProblem

    f_lo = 0.3
    st = table_study().with_changes({"models.distortion": False}, variables=FREE,
                                    constraints={"min_rocking_frequency_hz": f_lo})
    p = TableProblem(st)
    vals = {v.name: v.start for v in st.variables}
    lev = {**vals, "inertia_base_mass_kg": 450.0}
    assert p.table.inertia_base.mass_kg == 0.0
    modes = _modes_at(p, st.design_at(vals), values={"inertia_base_mass_kg": 450.0})
    p.set_modes(modes)
    x = p.initial_guess(lev)
    g = np.asarray(p.eval_fn(x, p.params())[1]).ravel()
    row, _m = next((r, k) for n, r, k in p.con_rows if n == "min_rocking_frequency_hz")
    rock = [j for j in range(6) if np.isfinite(modes.frequency_hz[j])
            and modes.energy_fraction[j, 3:5].sum() >= ROCKING_ENERGY_FRACTION]
    assert len(rock) >= 2
    w2 = (2 * np.pi * f_lo) ** 2
    for j in rock:  # the row: (q_r / q_m - w_lo^2) / w_lo^2
        f = np.sqrt((g[row + j] + 1.0) * w2) / (2 * np.pi)
        assert f == pytest.approx(modes.frequency_hz[j], rel=1e-6)
    # the start table's (frozen) mass would answer another table: at least 5 % off
    frozen = p.geo.mass
    for j in rock:
        phi = modes.shapes[:, j]
        live = np.real(np.vdot(phi, st.table_at({"inertia_base_mass_kg": 450.0}).mass_matrix
                               @ phi))
        assert abs(live / np.real(np.vdot(phi, frozen @ phi)) - 1.0) > 0.05
