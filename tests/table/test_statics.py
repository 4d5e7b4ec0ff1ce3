"""Three-valve leveling: group pressures by hand, and the errors that name their key."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.spring.gas import P_ATM
from isodesign.table.layout import HorizontalElement, Table, box_inertia, default_leveling_groups
from isodesign.table.statics import level

A_P = 5.3e-3
RECT = [(0.0, 0.0), (1.2, 0.0), (1.2, 0.8), (0.0, 0.8)]


def _table(cg, **kw):
    return Table(600.0, RECT, cg, [60.0, 80.0, 100.0], **kw)


def test_off_centre_cg_against_hand_equilibrium():
    # groups: {1, 2} on one valve (y = 0), 3 and 4 alone. By hand, with W = m g, L = 1.2,
    # B = 0.8 and the CG at (0.4, 0.3): y-moments give P3 + P4 = W cy / B, the vertical
    # force 2 P_A + P3 + P4 = W, x-moments L P_A + L P3 = W cx.
    cx, cy = 0.4, 0.3
    t = _table((cx, cy, 0.35))
    w = t.weight_n
    p_a = w * (1.0 - cy / 0.8) / 2.0
    p3 = w * cx / 1.2 - p_a
    p4 = w * cy / 0.8 - p3
    lv = level(t, A_P)
    np.testing.assert_allclose(lv.load_n, [p_a, p_a, p3, p4], rtol=1e-12)
    np.testing.assert_allclose(lv.pressure_pa, P_ATM + np.array([p_a, p_a, p3, p4]) / A_P,
                               rtol=1e-12)
    # equilibrium: force and both moments about the CG
    assert lv.load_n.sum() == pytest.approx(w, rel=1e-12)
    np.testing.assert_allclose(lv.load_n @ (t.isolators_m - [cx, cy]), 0.0, atol=1e-9 * w)
    assert list(lv.group_of) == [0, 0, 1, 2]


def test_three_isolators_one_valve_each():
    t = Table(300.0, [(0, 0), (1, 0), (0.5, 0.9)], (0.5, 0.3, 0.2), [20, 30, 40])
    lv = level(t, A_P)
    assert t.leveling_groups == ((0,), (1,), (2,))
    xy = t.isolators_m
    a = np.vstack([np.ones(3), xy[:, 0], xy[:, 1]])
    np.testing.assert_allclose(a @ lv.load_n, t.weight_n * np.array([1.0, 0.5, 0.3]), rtol=1e-12)


def test_symmetric_table_shares_the_load_equally():
    lv = level(Table.symmetric(600.0, 1.2, 0.8, 0.35), A_P)
    np.testing.assert_allclose(lv.load_n, 600.0 * 9.80665 / 4, rtol=1e-13)


def test_cg_outside_the_support_polygon_names_cg_m():
    with pytest.raises(InputError, match=r"^cg_m: .*outside the support polygon"):
        level(_table((1.5, 0.3, 0.35)), A_P)


def test_a_group_without_load_names_leveling_groups():
    # inside the rectangle but outside the triangle of the group centroids
    with pytest.raises(InputError, match=r"^leveling_groups: group 3 \(isolators \[4\]\)"):
        level(_table((1.15, 0.05, 0.35)), A_P)


def test_p0_above_the_supply_names_supply_pressure_pa():
    t = Table(3000.0, RECT, (0.6, 0.4, 0.3), [300, 400, 500])
    with pytest.raises(InputError, match=r"^supply_pressure_pa: isolator \d needs p0"):
        level(t, A_P)
    assert level(Table(3000.0, RECT, (0.6, 0.4, 0.3), [300, 400, 500],
                       supply_pressure_pa=2.0e6), A_P).pressure_pa.max() < 2.0e6


def test_collinear_groups_are_not_statically_determinate():
    xy = [(0, 0), (1, 0), (2, 0), (1, 1), (1, -1)]  # group centroids all on y = 0
    t = Table(100.0, xy, (1.0, 0.0, 0.2), [10, 10, 10], leveling_groups=[[0], [1, 3, 4], [2]])
    with pytest.raises(InputError, match=r"^leveling_groups: .*collinear"):
        level(t, A_P)


@pytest.mark.parametrize("kw, key", [
    (dict(isolators_m=[(0, 0), (1, 0)]), "isolators_m"),
    (dict(cg_m=(0.1, 0.2)), "cg_m"),
    (dict(inertia_kg_m2=[1.0, 1.0, 5.0]), "inertia_kg_m2"),
    (dict(inertia_kg_m2=[-1.0, 1.0, 1.0]), "inertia_kg_m2"),
    (dict(leveling_groups=[[0, 1], [2]]), "leveling_groups"),
    (dict(leveling_groups=[[0, 1], [2], [2, 3]]), "leveling_groups"),
    (dict(instrument_points_m=[(0, 0)]), "instrument_points_m"),
    (dict(mass_kg=-1.0), "mass_kg"),
    (dict(supply_pressure_pa=5e4), "supply_pressure_pa"),
])  # fmt: skip
def test_bad_layout_names_the_key(kw, key):
    base = dict(mass_kg=600.0, isolators_m=RECT, cg_m=(0.6, 0.4, 0.3),
                inertia_kg_m2=[60.0, 80.0, 100.0])
    base.update(kw)
    with pytest.raises(InputError, match=rf"^{key}: "):
        Table(**base)


def test_horizontal_element_needs_some_stiffness():
    with pytest.raises(InputError, match=r"^horizontal: "):
        HorizontalElement(pendulum_length_m=None, lateral_stiffness_n_per_m=0.0)
    with pytest.raises(InputError, match=r"^pendulum_length_m: "):
        HorizontalElement(pendulum_length_m=-0.1)


def test_default_groups_and_box_inertia():
    assert default_leveling_groups(np.array(RECT)) == ((0, 1), (2,), (3,))
    six = [(np.cos(a), np.sin(a)) for a in np.linspace(0, 2 * np.pi, 7)[:-1]]
    groups = default_leveling_groups(np.array(six))
    assert sorted(i for g in groups for i in g) == list(range(6))
    assert all(len(g) == 2 for g in groups)
    np.testing.assert_allclose(np.diag(box_inertia(12.0, (1.0, 2.0, 3.0))),
                               [13.0, 10.0, 5.0])


def test_payload_terms_are_the_statics_and_rigid_body_of_another_payload():
    """payload_terms (the table NLP's parametric payload, docs/sweep.md section 7) against
    the point's own table solved by level(), its mass matrix and its gravity term."""
    import casadi as ca

    from isodesign.optimization.study import table_study
    from isodesign.table.assembly import geometry
    from isodesign.table.statics import level, payload_terms

    base = table_study()
    t0 = base.table
    area = base.hardware["piston_area_m2"]
    lv0 = level(t0, area)
    for ch in ({"payload.mass_kg": 720.0}, {"table.cg_m": [0.0, 0.0, 0.52]},
               {"payload.mass_kg": 455.0, "table.cg_m": [0.0, 0.0, 0.2]}):
        t = base.with_changes(ch).table
        lv = level(t, area)
        terms = payload_terms(t0, t.mass_kg, t.cg_height_m, np.diag(t.inertia_kg_m2))
        np.testing.assert_allclose(terms.load_scale * lv0.load_n, lv.load_n, rtol=1e-12)
        p_atm = lv0.pressure_pa - lv0.load_n / area
        np.testing.assert_allclose(p_atm + terms.load_scale * (lv0.pressure_pa - p_atm),
                                   lv.pressure_pa, rtol=1e-12)
        np.testing.assert_allclose(np.diag(t0.mass_matrix) + np.asarray(terms.d_mass, float),
                                   np.diag(t.mass_matrix), rtol=1e-12)
        kg0, kg = geometry(t0, lv0.load_n).gravity, geometry(t, lv.load_n).gravity
        np.testing.assert_allclose(kg0[3, 3] + terms.d_gravity, kg[3, 3], rtol=1e-12)
        np.testing.assert_allclose(kg0[4, 4] + terms.d_gravity, kg[4, 4], rtol=1e-12)
        assert terms.weight_height == pytest.approx(t.weight_n * t.cg_height_m, rel=1e-12)
        assert terms.dh == pytest.approx(t.cg_height_m - t0.cg_height_m, abs=1e-15)
    # on CasADi symbols: the same numbers
    m, h = ca.SX.sym("m"), ca.SX.sym("h")
    ii = ca.SX.sym("i", 3)
    sym = payload_terms(t0, m, h, [ii[0], ii[1], ii[2]])
    f = ca.Function("f", [m, h, ii], [sym.load_scale, sym.d_gravity, sym.weight_height])
    num = payload_terms(t0, 700.0, 0.4, [90.0, 160.0, 190.0])
    got = [float(v) for v in f(700.0, 0.4, [90.0, 160.0, 190.0])]
    assert got == pytest.approx([num.load_scale, num.d_gravity, num.weight_height], rel=1e-14)
