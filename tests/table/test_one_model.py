"""One model: a study without ``[table]`` is the symmetric table its ``[payload]`` describes
(docs/table.md, section 14), and that table's analysis is the vertical analysis."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import table_study, vertical_study
from isodesign.response.isolator import Payload
from isodesign.response.linearization import equivalent_amplitude, rayleigh_rule
from isodesign.table.layout import Table
from isodesign.table.statics import level
from isodesign.table.symmetric import (
    payload_table,
    study_floor_axes,
    study_table,
    symmetric_layout,
)

A_P = 5.3e-3


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6, 7, 8, 12])
def test_symmetric_layout_is_centred_aligned_and_spaced(n):
    s = 0.9
    xy = symmetric_layout(n, s)
    assert xy.shape == (n, 2)
    np.testing.assert_allclose(xy.mean(axis=0), 0.0, atol=1e-15)
    # principal axes of the support along x and y
    assert abs(np.sum(xy[:, 0] * xy[:, 1])) < 1e-12
    # mirror-symmetric about the y axis: the set of positions maps onto itself
    mirrored = xy * np.array([-1.0, 1.0])
    d = np.linalg.norm(mirrored[:, None] - xy[None], axis=-1)
    assert np.all(d.min(axis=1) < 1e-12)
    if n > 1:
        dist = np.linalg.norm(xy[:, None] - xy[None], axis=-1)[np.triu_indices(n, 1)]
        assert dist.min() == pytest.approx(s, rel=1e-12)


@pytest.mark.parametrize("n", [3, 4, 5, 6, 8, 12])
def test_payload_table_levels_every_isolator_at_the_vertical_p0(ref, n):
    p = Payload(700.0, n, 1.1, 0.4)
    t = payload_table(p, piston_area_m2=ref.piston_area_m2)
    assert t.n_isolators == n and t.mass_kg == 700.0 and t.cg_height_m == 0.4
    np.testing.assert_allclose(t.cg_m[:2], t.isolators_m.mean(axis=0), atol=1e-15)
    # inertia: a homogeneous box over the isolators' span and twice the CG height
    span = np.ptp(t.isolators_m, axis=0)
    np.testing.assert_allclose(np.diag(t.inertia_kg_m2),
                               [700 * (span[1] ** 2 + 0.8 ** 2) / 12,
                                700 * (span[0] ** 2 + 0.8 ** 2) / 12,
                                700 * (span[0] ** 2 + span[1] ** 2) / 12], rtol=1e-12)
    lv = level(t, ref.piston_area_m2)
    p0 = ref.with_load(700.0, n).pressure_pa
    np.testing.assert_allclose(lv.pressure_pa, p0, rtol=1e-13)
    np.testing.assert_allclose(lv.load_n, 700.0 * p.g_m_s2 / n, rtol=1e-13)


def test_payload_table_of_four_is_the_square_table():
    t = payload_table(Payload(600.0, 4, 1.2, 0.35))
    sq = Table.symmetric(600.0, 1.2, 1.2, 0.35)
    np.testing.assert_allclose(t.isolators_m, sq.isolators_m)
    np.testing.assert_allclose(t.inertia_kg_m2, sq.inertia_kg_m2)
    np.testing.assert_allclose(t.cg_m, sq.cg_m)


def test_payload_table_raises_the_supply_for_a_heavy_payload():
    # 4,000 kg on 4 isolators of 5.3e-3 m^2 needs p0 of about 19.5 bar abs: the vertical
    # study has no supply pressure, so the symmetric table's supply follows its p0
    t = payload_table(Payload(4000.0, 4, 1.2, 0.35), piston_area_m2=A_P)
    lv = level(t, A_P)
    assert lv.pressure_pa.max() <= t.supply_pressure_pa


@pytest.mark.parametrize("n", [1, 2, 65])
def test_payload_table_refuses_what_no_table_is(n):
    with pytest.raises(InputError, match=r"payload\.isolators"):
        payload_table(Payload(600.0, n, 1.2, 0.35))


def test_payload_without_geometry_takes_the_documented_defaults():
    t = payload_table(Payload(600.0, 4))
    np.testing.assert_allclose(np.ptp(t.isolators_m, axis=0), [1.2, 1.2])
    assert t.cg_height_m == 0.35


def test_study_table_is_the_table_or_the_payloads():
    st = vertical_study()
    t = study_table(st)
    assert t.n_isolators == st.payload.isolators
    assert t.cg_height_m == st.payload.cg_height_m
    fl = study_floor_axes(st)
    assert fl.x is None and fl.y is None and fl.z is st.floor
    ts = table_study()
    assert study_table(ts) is ts.table
    assert study_floor_axes(ts) is ts.floor_axes


# ---------------------------------------------------------------------------
# equivalence: the symmetric table's analysis is the vertical analysis, to 1e-6 dB
# ---------------------------------------------------------------------------
TOL_DB = 1e-6


def _db(a, b):
    return float(np.max(np.abs(20.0 * np.log10(np.abs(np.asarray(a) / np.asarray(b))))))


def _both(study, values=None, **models):
    """The vertical analysis of ``study`` at ``values`` and its symmetric table's."""
    import warnings

    from isodesign.response.random_input import band_response
    from isodesign.table.response import table_band_response

    d = study.start_design() if values is None else study.design_at(values)
    m = study.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"],
          "diaphragm": m["diaphragm"], "random_method": m["random_method"], **models}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        b = band_response(d, study.payload, study.floor, study.target, bands=study.bands,
                          derive_pressure=False, warn=False, **kw)
        t = table_band_response(d, study_table(study), study_floor_axes(study), study.target,
                                bands=study.bands, warn=False, **kw)
    return b, t


def _assert_same(b, t):
    """Band by band at the instrument point, |T| at the closure and linear, each isolator's
    stroke and tube-velocity RMS, the verdict."""
    assert _db(t.velocity_rms_m_s[0, 2], b.payload_velocity_rms_m_s) < TOL_DB
    # a vertical floor moves no point horizontally
    assert np.max(t.velocity_rms_m_s[0, :2]) < 1e-9 * np.max(t.velocity_rms_m_s[0, 2])
    np.testing.assert_array_equal(t.limit_velocity_rms_m_s, b.limit_velocity_rms_m_s)
    np.testing.assert_allclose(t.margin_db[0, 2], b.margin_db, rtol=0, atol=TOL_DB)
    assert _db(t.transmissibility[:, 0, 2, 2], b.transmissibility) < TOL_DB
    np.testing.assert_allclose(t.transmissibility[:, 0, 2, 2], b.transmissibility, rtol=1e-7)
    assert _db(t.transmissibility_linear[:, 0, 2, 2], b.transmissibility_linear) < TOL_DB
    assert _db(t.stroke_rms_m, b.stroke_rms_m) < TOL_DB
    if b.tube_velocity_rms_m_s is None:
        assert np.all(np.isnan(t.tube_velocity_rms_m_s))
    else:
        assert _db(t.tube_velocity_rms_m_s, b.tube_velocity_rms_m_s) < TOL_DB
    assert t.passes == bool(np.all(b.band_passes))
    k = b.spring_diagnostics.k  # (f,), or (f, nodes) of the Rayleigh average
    k = k if k.ndim == 1 else k @ rayleigh_rule()[1]
    np.testing.assert_allclose(t.k_vertical, np.broadcast_to(k, t.k_vertical.shape), rtol=1e-7)


@pytest.mark.parametrize("change", [
    {},
    {"payload": {"mass_kg": 900.0}},
    {"payload": {"isolators": 3}},
    {"payload": {"isolators": 6, "mass_kg": 1200.0}},
    {"payload": {"isolators": 8, "mass_kg": 1500.0, "spacing_m": 0.7}},
    {"payload": {"cg_height_m": 0.9}},
    {"floor": {"criterion": "VC-B"}, "target": {"criterion": "VC-D"}},
    {"models": {"acoustics": "lumped"}},
    {"models": {"flow": "quasi_steady"}},
    {"models": {"flow": "poiseuille"}},
    {"models": {"random_method": "equivalent_amplitude"}},
    {"models": {"random_method": "equivalent_amplitude", "amplitude_mode": "kinematic",
                "flow": "quasi_steady"}},
], ids=["default", "mass", "n3", "n6", "n8", "cg", "floor", "lumped", "quasi_steady",
        "poiseuille", "equivalent_amplitude", "kinematic"])  # fmt: skip
def test_symmetric_table_is_the_vertical_analysis(change):
    st = vertical_study().with_changes(**change) if change else vertical_study()
    b, t = _both(st)
    _assert_same(b, t)


@pytest.mark.parametrize("flow, method, mode", [
    ("zhao", "equivalent_amplitude", "kinematic"),
    ("zhao_turbulent", "equivalent_amplitude", "kinematic"),
    ("quasi_steady", "rayleigh", "self_consistent"),
])  # fmt: skip
def test_the_papers_flow_laws_and_the_rayleigh_closure_by_name(flow, method, mode):
    """The paper's flow laws (lumped by definition, harmonic closures only) and the
    Rayleigh average: the table's closure per isolator is the vertical one."""
    b, t = _both(vertical_study(), flow=flow, random_method=method, amplitude_mode=mode)
    _assert_same(b, t)


def test_cg_height_spacing_and_instrument_point_do_not_change_the_vertical_answer():
    """The derivation (docs/table.md, section 14): under a vertical floor the CG height, the
    spacing and the point's place change nothing in z."""
    import warnings

    from isodesign.table.response import table_band_response

    st = vertical_study()
    d = st.start_design()
    out = []
    for h, s, pt in ((0.35, 1.2, None), (1.5, 0.6, [[0.4, -0.3, 1.1]])):
        table = payload_table(Payload(600.0, 4, s, h), instrument_points_m=pt)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out.append(table_band_response(d, table, study_floor_axes(st), st.target,
                                           bands=st.bands, flow="womersley", warn=False))
    assert _db(out[0].velocity_rms_m_s[0, 2], out[1].velocity_rms_m_s[0, 2]) < TOL_DB


def test_where_the_reduction_fails_a_horizontal_floor_and_an_off_centre_cg():
    """A horizontal floor rocks the table and changes each isolator's closure; an off-centre
    CG loads the isolators unequally: neither is the vertical answer."""
    import dataclasses
    import warnings

    from isodesign.table.floor import table_floor
    from isodesign.table.response import table_band_response

    st = vertical_study()
    b, _ = _both(st)
    d = st.start_design()
    t0 = study_table(st)
    off = dataclasses.replace(t0, cg_m=(0.25, 0.1, t0.cg_height_m))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hor = table_band_response(d, t0, table_floor(st.floor), st.target, bands=st.bands,
                                  flow="womersley", warn=False)
        asym = table_band_response(d, off, study_floor_axes(st), st.target, bands=st.bands,
                                   flow="womersley", warn=False)
    assert _db(hor.velocity_rms_m_s[0, 2], b.payload_velocity_rms_m_s) > 1e-3
    assert _db(asym.velocity_rms_m_s[0, 2], b.payload_velocity_rms_m_s) > 1e-3
    assert np.ptp(asym.stroke_rms_m) > 1e-3 * asym.stroke_rms_m.max()


def test_linear_transmissibility_and_the_z_mode_are_the_one_dof(ref):
    """|T| in the linear regime on a wide grid and the z mode (the root of
    ``Re k(w) = (m/n) w^2``, damping ``Im k / (2 Re k)``) of the symmetric table against the
    vertical model's."""
    import math

    from scipy.optimize import brentq

    from isodesign.response.model import linear_transmissibility, spring_model
    from isodesign.table.model import table_model
    from isodesign.table.modes import table_modes

    p = Payload(600.0, 4, 1.2, 0.35)
    f = np.geomspace(0.1, 200.0, 400)
    model = table_model(ref, payload_table(p, piston_area_m2=ref.piston_area_m2))
    t = model.linear_outputs(f).points[:, 0, 2, 2]
    assert _db(t, linear_transmissibility(ref, p, f)) < TOL_DB
    modes = table_modes(model)
    j = int(np.argmax(modes.energy_fraction[:, 2]))
    assert modes.energy_fraction[j, 2] > 1 - 1e-12
    sm = spring_model(ref, p, "quasi_steady", "self_consistent", "viscoelastic", True)

    def k(w):
        return complex(sm.k(np.array([w / (2 * math.pi)]), 1e-6)[0])

    w = brentq(lambda w: k(w).real - sm.mass * w * w, 0.5, 100.0, xtol=1e-14, rtol=1e-14)
    assert modes.frequency_hz[j] == pytest.approx(w / (2 * math.pi), rel=1e-8)
    assert modes.damping_ratio[j] == pytest.approx(k(w).imag / (2 * k(w).real), rel=1e-6)


def test_harmonic_floor_motion_is_the_vertical_harmonic_response(ref):
    """A harmonic vertical floor: each isolator's stroke amplitude closed on its own is the
    1-DOF's (response.harmonic)."""
    from isodesign.response.harmonic import harmonic_response
    from isodesign.table.harmonic import table_harmonic_response

    p = Payload(600.0, 4, 1.2, 0.35)
    f = np.geomspace(0.5, 30.0, 25)
    v = harmonic_response(ref, p, f, 2e-4, warn=False)
    t = table_harmonic_response(ref, payload_table(p, piston_area_m2=ref.piston_area_m2),
                                f, 2e-4, "z")
    assert _db(t.transmissibility[:, 0, 2], v.transmissibility.reshape(-1)) < TOL_DB
    assert _db(t.stroke_amplitude_m, v.stroke_m.reshape(-1, 1)) < TOL_DB


@pytest.mark.slow
def test_at_the_vertical_studys_optimum():
    """The vertical (default) study optimized: its analysis at the optimum and the start
    through the symmetric table, to 1e-6 dB."""
    import isodesign

    st = vertical_study()
    res = isodesign.optimize(st)
    b, t = _both(st, res.values, distortion=st.models["distortion"])  # the study's closure
    _assert_same(b, t)
    assert _db(t.velocity_rms_m_s[0, 2], res.analysis.payload_velocity_rms_m_s) < TOL_DB


def test_the_z_reduction_inside_the_table_path_is_the_full_solve(ref):
    """A z-reducible table under a vertical floor: the z DOF alone gives the 6-DOF solve's
    strokes; an asymmetric table is never reduced."""
    from isodesign.table.model import table_model

    f = np.geomspace(0.5, 80.0, 60)
    w = 2 * np.pi * f
    for n in (3, 4, 6):
        model = table_model(ref, payload_table(Payload(600.0, n, 1.0, 0.5),
                                               piston_area_m2=ref.piston_area_m2))
        assert model.z_reducible
        ks = model.vertical_stiffness(f, 1e-6)
        full = model.outputs(ks, w, strokes_only=True).strokes[:, :, 2]
        red = model.outputs(ks, w, strokes_only=True, axes=(2,))
        assert not np.any(red.body[:, [0, 1, 3, 4, 5]])
        np.testing.assert_allclose(red.strokes[:, :, 2], full, rtol=1e-12, atol=1e-15)
    asym = Table(700.0, [(0.0, 0.0), (1.2, 0.0), (1.2, 0.8), (0.0, 0.8)], (0.5, 0.45, 0.4),
                 [70.0, 90.0, 130.0])
    assert not table_model(ref, asym).z_reducible


# ---------------------------------------------------------------------------
# one analysis path: analyze(study, values) through the table model
# ---------------------------------------------------------------------------
def _vertical(study, values=None, **over):
    import warnings

    from isodesign.response.random_input import band_response

    m = study.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"],
          "diaphragm": m["diaphragm"], "random_method": m["random_method"], **over}
    vals = values or {v.name: v.start for v in study.variables}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return band_response(study.design_at(vals), study.payload, study.floor, study.target,
                             bands=study.bands, derive_pressure=False, warn=False, **kw)


def _assert_same_band_response(a, b):
    assert type(a) is type(b)
    for name in ("payload_velocity_rms_m_s", "payload_displacement_rms_m",
                 "payload_acceleration_rms_m_s2", "transmissibility",
                 "transmissibility_linear"):
        assert _db(getattr(a, name), getattr(b, name)) < TOL_DB, name
    assert _db(a.stroke_rms_m, b.stroke_rms_m) < TOL_DB
    if b.tube_velocity_rms_m_s is None:
        assert a.tube_velocity_rms_m_s is None
    else:
        assert _db(a.tube_velocity_rms_m_s, b.tube_velocity_rms_m_s) < TOL_DB
    assert a.verdict() == b.verdict()
    assert a.stability.natural_frequency_hz == pytest.approx(b.stability.natural_frequency_hz,
                                                             rel=1e-12)
    assert a.stability.excited_peak_transmissibility == pytest.approx(
        b.stability.excited_peak_transmissibility, rel=1e-7)
    assert a.warnings == b.warnings and a.converged and b.converged


@pytest.mark.parametrize("change", [
    {},
    {"payload": {"isolators": 6, "mass_kg": 1200.0}},
    {"payload": {"isolators": 2}},
    {"payload": {"isolators": 100, "mass_kg": 20000.0}},
    {"models": {"random_method": "equivalent_amplitude"}},
    {"models": {"acoustics": "lumped", "flow": "quasi_steady"}},
], ids=["default", "n6", "n2", "n100", "equivalent_amplitude", "lumped"])  # fmt: skip
def test_analyze_a_vertical_study_is_the_vertical_analysis(change):
    from isodesign.optimization.analyze import analyze

    # the plain closure (models.distortion = false): its route through the symmetric table
    # against the 1-DOF one (with the distortion, analyze is band_response's own route)
    plain = vertical_study().with_changes({"models.distortion": False})
    st = plain.with_changes(**change) if change else plain
    a, b = analyze(st), _vertical(st)
    _assert_same_band_response(a, b)
    assert a.iterations == b.iterations and a.closure_slope == b.closure_slope


def test_vertical_band_response_takes_band_responses_arguments(ref):
    """The Rayleigh closure, all bands, and a design at its own p0 that no leveling gives
    (the z DOF alone at that p0)."""
    import warnings

    from isodesign.optimization.analyze import vertical_band_response
    from isodesign.response.random_input import band_response

    p = Payload(600.0, 4, 1.2, 0.35)
    d = ref.with_load(600.0, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for kw in ({"random_method": "rayleigh"}, {"bands": None},
                   {"derive_pressure": False}):
            design = d.replace(pressure_pa=3.0e5) if kw.get("derive_pressure") is False else d
            _assert_same_band_response(
                vertical_band_response(design, p, "VC-A", "VC-C", flow="quasi_steady",
                                       **{"bands": (4, 80), **kw}),
                band_response(design, p, "VC-A", "VC-C", flow="quasi_steady",
                              **{"bands": (4, 80), **kw}))


def test_analyze_a_scenario_of_a_vertical_study():
    """Under a scenario (payload mass, a tolerance): the symmetric table of the scenario's
    payload, the same answer as the 1-DOF analysis of the scenario's study."""
    from isodesign.optimization.analyze import analyze
    from isodesign.optimization.uncertainty import ScenarioStudy

    st = vertical_study().with_changes({"models.distortion": False}, scenarios={  # plain
        "payload_mass_kg": {"min": 480.0, "max": 720.0},
        "capillary_diameter_m": {"relative": 0.05}})
    theta = [700.0, -0.04] if st.scenarios.names[0] == "payload_mass_kg" else [-0.04, 700.0]
    a = analyze(st, None, theta)
    b = _vertical(ScenarioStudy(st, st.scenarios, theta))
    _assert_same_band_response(a, b)
    with pytest.raises(InputError, match="scenario"):
        analyze(vertical_study(), None, [1.0])


def test_analyze_a_table_study_is_the_tables_analysis():
    from isodesign.optimization.analyze import analyze
    from isodesign.table.response import TableBandResponse

    st = table_study().with_changes(models={"points_per_band": 4})
    r = analyze(st, points_per_band=8)
    assert isinstance(r, TableBandResponse)
    assert r.velocity_rms_m_s.shape[1] == 3 and r.grid.floor.x is not None


@pytest.mark.parametrize("method", ["statistical", "equivalent_amplitude"])
def test_the_six_dof_closure_without_the_reduction_is_the_vertical_closure(method):
    """The closures per isolator solved on the whole table (no z reduction): the same state
    as the 1-DOF closure, to 1e-6 dB."""
    from isodesign.table.closure import TableDescribing, solve_describing_closure
    from isodesign.table.floor import table_grid
    from isodesign.table.model import study_table_model
    from isodesign.table.response import TableStatistical, solve_table_closure

    st = vertical_study()
    b = _vertical(st, random_method=method)
    model = study_table_model(st, st.start_design())
    grid = table_grid(study_floor_axes(st), st.bands, target=st.target, points_per_band=50)
    if method == "statistical":
        sigma, sigma_u, _ = solve_table_closure(TableStatistical(model, grid), reduce=False)
        assert _db(sigma_u, b.tube_velocity_rms_m_s) < TOL_DB
    else:
        sigma, _ = solve_describing_closure(TableDescribing(model, grid, method), reduce=False)
    # the band response's stroke is recomputed from T at the state; A* is the state's
    assert _db(equivalent_amplitude(sigma), b.equivalent_amplitude_m) < TOL_DB


@pytest.mark.parametrize("n", [3, 4, 5, 6, 8])
def test_the_tilt_margin_is_the_symmetric_tables_rocking_margin_for_two_rows(ref, n):
    """The 1-DOF tilt margin ``n K0 (s/2)^2 / (m g h)`` puts every isolator s/2 from the
    tilt axis: exactly the two rows of an even layout (its weak direction). An odd layout
    (the regular polygon) has ``sum b_i^2 = n R^2 / 2`` about its weak axis, R its
    circumradius: the table's margin is that fraction of the 1-DOF figure
    (docs/table.md, section 14)."""
    import math

    from isodesign.response.stability import stability_figures
    from isodesign.table.model import table_model
    from isodesign.table.modes import rocking_stability

    p = Payload(600.0, n, 0.9, 0.35)
    t = payload_table(p, piston_area_m2=ref.piston_area_m2)
    rs = rocking_stability(table_model(ref, t), frequency_hz=None)
    tilt = stability_figures(ref, p).tilt_margin
    if n % 2 == 0:
        assert rs.margin[0] == pytest.approx(tilt, rel=1e-9)
    else:
        r = 0.9 / (2 * math.sin(math.pi / n))
        assert rs.margin[0] == pytest.approx(tilt * (n * r * r / 2) / (n * 0.45 ** 2),
                                             rel=1e-9)
        # the triangle: 2/3 of the 1-DOF figure (optimistic); the pentagon: 1.45x
        assert (rs.margin[0] < tilt) == (n == 3)


def test_the_numpy_evaluation_of_a_design_closes_on_the_symmetric_table():
    """evaluate_design (the re-check's and yield's per-draw NumPy path) solves its closure on
    the study's symmetric table: the same sigma and sigma_u as the 1-DOF closure, to 1e-9,
    under a scenario too."""
    from isodesign.optimization.grid import build_grid
    from isodesign.optimization.recheck import evaluate_design
    from isodesign.optimization.uncertainty import ScenarioStudy
    from isodesign.response.random_input import solve_stroke_rms

    st = vertical_study().with_changes({"models.distortion": False}, scenarios={  # plain
        "payload_mass_kg": {"min": 480.0, "max": 720.0},
        "ambient_pressure_pa": {"min": 9.0e4, "max": 1.02e5}})
    vals = {v.name: v.start for v in st.variables}
    grid = build_grid(st)
    th = {"payload_mass_kg": 700.0, "ambient_pressure_pa": 9.2e4}
    for study in (st, ScenarioStudy(st, st.scenarios, [th[n] for n in st.scenarios.names])):
        ev = evaluate_design(study, vals, grid=grid)
        m = study.models
        sigma, info = solve_stroke_rms(study.design_at(vals), study.payload, grid.response,
                                       flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                                       diaphragm=m["diaphragm"], random_method="statistical")
        assert ev["sigma"] == pytest.approx(sigma, rel=1e-9)
        assert ev["tube_rms"] == pytest.approx(info["tube_velocity_rms_m_s"], rel=1e-9)
