"""The rigid-table Monte Carlo verifier (six degrees of freedom), and the closure it checks.

Standard errors (random-phase floors, the default): with the floor's three axes on
interleaved bins the linear response has no estimation variance, and across seeds the band
RMS of the verified cases vary by at most the figure asserted in each test (printed by
``TableMonteCarloResult.standard_error_db``), well below the 0.5 dB tolerance; the stroke
RMS by under 0.5 %, against the 5 % tolerance.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.floor import FloorSpectrum
from isodesign.floor.bands import third_octave_bands
from isodesign.simulation.monte_carlo import _floor_spectrum, _norm_bands, fit_prony
from isodesign.simulation.table_monte_carlo import (
    TableMonteCarloResult,
    TableRig,
    lateral_prony,
    simulate_table_response,
)
from isodesign.spring.diaphragm import PronyDiaphragm
from isodesign.spring.stiffness import complex_stiffness

G = 9.80665
VCA = FloorSpectrum.from_criterion("VC-A")
TINY = FloorSpectrum.from_band_rms(VCA.bands, 1e-3 * VCA.band_rms_velocity(), name="VC-A/1000")
F_FIT = np.geomspace(0.89, 89.1, 60)


def _loads(xy, groups, mass):
    """Three-valve leveling by hand: one force per group; vertical force and moments."""
    a = np.zeros((3, 3))
    for i, g in enumerate(groups):
        a[:, g] += (1.0, xy[i, 0], xy[i, 1])
    return np.linalg.solve(a, [mass * G, 0.0, 0.0])[list(groups)]


def _rig(ref, *, lateral=(3.0e4, 0.15)):
    """An asymmetric 4-isolator table built by hand (positions relative to the CG)."""
    mass = 600.0
    xy = np.array([[0.62, 0.38], [-0.58, 0.42], [-0.6, -0.4], [0.6, -0.35]])
    w = _loads(xy, (0, 1, 2, 2), mass)
    rv = np.c_[xy, np.full(4, -0.35)]
    rh = np.c_[xy, np.full(4, -0.30)]
    lat, _ = lateral_prony(lateral, F_FIT)
    kg = np.zeros((6, 6))  # -W h on rx and ry: equilibrium about the CG, loads 0.35 m below
    kg[3, 3] = kg[4, 4] = -mass * G * 0.35
    return TableRig(
        mass_kg=mass, inertia_kg_m2=np.diag([60.0, 110.0, 150.0]),
        designs=tuple(ref.with_load(wi / G, 1) for wi in w), loads_n=w, r_vertical_m=rv,
        r_horizontal_m=rh, pendulum_n_per_m=w / 0.25, lateral=(lat,) * 4,
        points_m=[[0.3, 0.2, 0.4], [-0.5, -0.3, 0.1]], gravity_n_per_m=kg,
        point_names=("top", "edge"),
    )  # fmt: skip


def _linear_band_ms(rig, floor, duration, seed, bands, flow="quasi_steady"):
    """Band mean squares of the linearized table at the floor's own bins, assembled here.

    An independent 6x6 assembly: ``Z = sum_i k_i J^T J + K_g - w^2 M`` with the vertical
    complex stiffness of the frequency-domain spring model at 1 nm and the realized lateral
    element; the floor's bins and amplitudes are those the simulation draws.
    """
    def jac(r):
        x, y, z = r
        return np.array([[1, 0, 0, 0, z, -y], [0, 1, 0, -z, 0, x], [0, 0, 1, y, -x, 0]], float)

    rng = np.random.default_rng(seed)
    edges = np.append(bands.lower_hz, bands.upper_hz[-1])
    m = rig.mass_matrix
    out = np.zeros((len(rig.points_m), 3, len(bands)))
    for ia in range(3):
        k, coef = _floor_spectrum(floor, duration, rng, "random_phase",
                                  _norm_bands(floor, "random_phase"), 3, ia)  # fmt: skip
        f = k / duration
        w = 2 * math.pi * f
        z = np.zeros((f.size, 6, 6), complex) + rig.gravity_n_per_m - w[:, None, None] ** 2 * m
        for i in range(rig.isolators):
            kv = np.asarray(complex_stiffness(rig.designs[i], f, 1e-9, flow=flow,
                                              diaphragm="none").k)  # fmt: skip
            jv = jac(rig.r_vertical_m[i])[2:3]
            z += kv[:, None, None] * (jv.T @ jv)
            kl = rig.lateral[i].stiffness(w, 1e-6)
            kh = np.asarray(kl.re) + 1j * np.asarray(kl.im) + rig.pendulum_n_per_m[i]
            jh = jac(rig.r_horizontal_m[i])[:2]
            z += kh[:, None, None] * (jh.T @ jh)
        e = np.zeros(6)
        e[ia] = 1.0
        q = np.linalg.solve(z, (-(m @ e))[None, :, None] * (1j * w)[:, None, None])[..., 0]
        pos = np.searchsorted(edges, f, side="right") - 1
        a2 = 0.5 * np.abs(coef) ** 2
        for ip, r in enumerate(rig.points_m):
            v = 1j * w[:, None] * (q @ jac(r).T)
            v[:, ia] += 1.0
            for b in range(len(bands)):
                sel = pos == b
                out[ip, :, b] += (np.abs(v[sel]) ** 2 * a2[sel, None]).sum(axis=0)
    return out


@pytest.mark.filterwarnings("ignore::isodesign.errors.ModelValidityWarning")
def test_linear_limit_against_an_independent_assembly(ref):
    """A floor 1000 times below VC-A in x, y, z: the nonlinear table is linear; every point,
    axis and band against the 6x6 frequency response assembled in the test, bin by bin."""
    rig = _rig(ref)
    mc = simulate_table_response(None, rig, TINY, target="VC-E", seeds=[3], duration_s=80.0,
                                 diaphragm="none")  # fmt: skip
    expect = _linear_band_ms(rig, TINY, 80.0, 3, mc.bands)
    err = 10 * np.log10(mc.velocity_rms_m_s**2 / expect)
    # measured: 0.05 dB at most (80 Hz: the point velocity is the small difference of the
    # floor and the relative velocity; the RK4 step), 0.02 dB below 50 Hz
    assert np.max(np.abs(err)) < 0.1, np.round(err, 3)
    assert np.max(np.abs(err[..., :-2])) < 0.04
    np.testing.assert_allclose(mc.floor_velocity_rms_m_s, np.tile(TINY.band_rms_velocity(),
                                                                  (3, 1)), rtol=1e-9)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::isodesign.errors.ModelValidityWarning")
def test_linear_limit_with_womersley_flow(ref):
    """The Womersley tube (each isolator at its own p0, so its own Bessel-mode rates in the
    per-isolator arrays) against the exact laminar oscillating impedance of the
    frequency-domain model, in the linear limit (bands 4-80 Hz, one 20 s record; measured
    0.005 dB)."""
    rig = _rig(ref)
    bands = third_octave_bands(4.0, 80.0)
    mc = simulate_table_response(None, rig, TINY, bands=bands, seeds=[2], duration_s=20.0,
                                 warmup_s=20.0, flow="womersley", diaphragm="none")  # fmt: skip
    expect = _linear_band_ms(rig, TINY, 20.0, 2, mc.bands, flow="womersley")
    err = 10 * np.log10(mc.velocity_rms_m_s**2 / expect)
    assert np.max(np.abs(err)) < 0.05, np.round(err, 3)
    assert mc.time_step_s == pytest.approx(1 / 8192)


def test_step_halving_converges(ref):
    rig = _rig(ref)
    floor = FloorSpectrum.from_band_rms(VCA.bands, 4.0 * VCA.band_rms_velocity())
    bands = third_octave_bands(4.0, 80.0)
    runs = [simulate_table_response(None, rig, floor, bands=bands, seeds=[1], duration_s=20.0,
                                    diaphragm="none", time_step_s=dt, warmup_s=5.0)
            for dt in (1 / 2048, 1 / 4096, 1 / 8192)]  # fmt: skip
    d1 = np.max(np.abs(20 * np.log10(runs[1].velocity_rms_m_s / runs[0].velocity_rms_m_s)))
    d2 = np.max(np.abs(20 * np.log10(runs[2].velocity_rms_m_s / runs[1].velocity_rms_m_s)))
    assert d2 < 0.01 and d2 < d1 / 8  # fourth order: 16x per halving
    np.testing.assert_allclose(runs[2].stroke_rms_m, runs[1].stroke_rms_m, rtol=1e-5)
    # a step beyond the stability of the fastest lateral branch is refused, by name
    with pytest.raises(InputError, match=r"^time_step_s: .* relaxation rate"):
        simulate_table_response(None, rig, floor, bands=bands, seeds=[1], duration_s=20.0,
                                diaphragm="none", time_step_s=1 / 1024)


def test_lateral_prony():
    pd = PronyDiaphragm(1e4, (2e3,), (30.0,))
    assert lateral_prony(pd, F_FIT) == (pd, 0.0)
    fit, err = lateral_prony((3.0e4, 0.15), F_FIT)
    k = fit.stiffness(2 * math.pi * F_FIT, 1e-6)
    # a causal element cannot hold a constant loss factor over a constant storage stiffness
    # (Kramers-Kronig); fitted part by part: storage within 18.5 %, loss within 10.5 %
    storage, loss = np.asarray(k.re) / 3.0e4 - 1.0, np.asarray(k.im) / 4.5e3 - 1.0
    assert np.max(np.abs(storage)) < 0.185 and np.max(np.abs(loss)) < 0.105
    assert 0.15 < err < 0.2
    # the default complex weighting (the diaphragm's) would miss the loss stiffness by 60 %
    k_inf, k_i, r_i, _ = fit_prony(2 * math.pi * F_FIT, np.full(F_FIT.size, 3.0e4 * (1 + 0.15j)))
    im = PronyDiaphragm(k_inf, tuple(k_i), tuple(r_i)).stiffness(2 * math.pi * F_FIT, 1e-6).im
    assert np.max(np.abs(np.asarray(im) / 4.5e3 - 1.0)) > 0.5
    # no loss: the complex weighting
    elastic, err0 = lateral_prony((3.0e4, 0.0), F_FIT)
    assert err0 < 1e-6 and elastic.k_inf_n_per_m == pytest.approx(3.0e4, rel=1e-6)
    fit2, err2 = lateral_prony(complex(3.0e4, 4.5e3), F_FIT)
    assert err2 == pytest.approx(err) and fit2.k_inf_n_per_m == pytest.approx(fit.k_inf_n_per_m)
    _, err3 = lateral_prony(pd, F_FIT)
    assert err3 == 0.0
    with pytest.raises(InputError, match=r"^weighting:"):
        fit_prony(2 * math.pi * F_FIT, np.full(F_FIT.size, 3.0e4 + 0j), weighting="real")
    for bad in ("soft", complex(-1.0, 0.0)):
        with pytest.raises(InputError, match=r"^lateral:"):
            lateral_prony(bad, F_FIT)


def test_result_api(ref):
    rig = _rig(ref)
    mc = simulate_table_response(None, rig, "VC-A", target="VC-E", seeds=2, duration_s=60.0,
                                 diaphragm="none", warmup_s=5.0)  # fmt: skip
    assert isinstance(mc, TableMonteCarloResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        mc.duration_s = 0.0
    assert mc.velocity_rms_m_s.shape == mc.velocity_rms_se_m_s.shape == (2, 3, 20)
    assert mc.per_seed_band_ms.shape == (2, 2, 3, 20)
    assert mc.stroke_rms_m.shape == mc.tube_velocity_rms_m_s.shape == (4,)
    assert mc.horizontal_stroke_rms_m.shape == (4, 2)
    assert np.all(np.isfinite(mc.velocity_rms_se_m_s)) and mc.floor_names == ("VC-A floor",) * 3
    df = mc.to_frame()
    assert len(df) == 2 * 3 * 20 and set(df["axis"]) == {"x", "y", "z"}
    assert list(df["point"].unique()) == ["top", "edge"]
    row = df[(df.point == "edge") & (df.axis == "y")]
    np.testing.assert_array_equal(row["velocity_rms_m_s"], mc.velocity_rms_m_s[1, 1])
    assert len(mc.isolator_frame()) == 4
    r = repr(mc)
    assert r.startswith("<TableMonteCarloResult: seeds 2 x 60 s") and len(r) <= 240
    assert "velocity_rms_m_s" in str(mc)
    np.testing.assert_allclose(mc.error_db(mc.velocity_rms_m_s), 0.0, atol=1e-12)
    with pytest.raises(InputError, match=r"^closure_velocity_rms_m_s:"):
        mc.error_db(mc.velocity_rms_m_s[0])
    fig = mc.plot()
    assert len(fig.axes) == 1 and len(fig.axes[0].lines) >= 6
    # one seed: the same realization as the second seed of the pair, no standard error
    one = simulate_table_response(None, rig, "VC-A", target="VC-E", seeds=[1], duration_s=60.0,
                                  diaphragm="none", warmup_s=5.0)  # fmt: skip
    assert np.all(np.isnan(one.velocity_rms_se_m_s))
    np.testing.assert_allclose(one.per_seed_band_ms[0], mc.per_seed_band_ms[1], rtol=1e-12)


def test_floor_per_axis(ref):
    """Each axis draws its own floor: a quiet x and y leave only cross-coupled motion there."""
    rig = _rig(ref)
    quiet = FloorSpectrum.from_band_rms(VCA.bands, 1e-6 * VCA.band_rms_velocity())
    mc = simulate_table_response(None, rig, {"x": quiet, "y": quiet, "z": "VC-A"},
                                 target="VC-E", seeds=[0], duration_s=60.0, diaphragm="none",
                                 warmup_s=5.0)  # fmt: skip
    np.testing.assert_allclose(mc.floor_velocity_rms_m_s[2], VCA.band_rms_velocity(), rtol=1e-9)
    assert np.all(mc.floor_velocity_rms_m_s[:2] < 1e-5 * mc.floor_velocity_rms_m_s[2])
    # the vertical floor excites x and y at the points only through the rocking coupling
    assert np.all(mc.velocity_rms_m_s[:, 2] > mc.velocity_rms_m_s[:, 0])


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"seeds": 0}, "seeds"),
        ({"duration_s": -1.0}, "duration_s"),
        ({"duration_s": 5.0}, "duration_s"),
        ({"flow": "zhao"}, "flow"),
        ({"amplitudes": "white"}, "amplitudes"),
        ({"time_step_s": 0.01}, "time_step_s"),
        ({"floor": {"x": "VC-A", "z": "VC-A"}}, "floor"),
        ({"floor": ("VC-A", "VC-A")}, "floor"),
        ({"diaphragm": "viscoelastic", "diaphragm_amplitude_m": -1.0}, "diaphragm_amplitude_m"),
    ],
)
def test_bad_input_is_named(ref, kw, name):
    args = {"seeds": 1, "duration_s": 60.0, "diaphragm": "none", "floor": "VC-A"}
    args.update(kw)
    floor = args.pop("floor")
    with pytest.raises(InputError, match=rf"^{name}:"):
        simulate_table_response(None, _rig(ref), floor, **args)


def test_rig_validation(ref):
    rig = _rig(ref)
    with pytest.raises(InputError, match=r"^table\.loads_n:"):
        dataclasses.replace(rig, loads_n=[1.0, 2.0])
    with pytest.raises(InputError, match=r"^table\.lateral:"):
        dataclasses.replace(rig, lateral=(rig.lateral[0],))
    with pytest.raises(InputError, match=r"^table:"):
        simulate_table_response(ref, "a table", "VC-A", seeds=1, duration_s=60.0)


def _asymmetric_table(lateral_model=None):
    """An asymmetric 4-isolator table (the verification case of the closure tests)."""
    from isodesign.table import HorizontalElement, Table

    hz = HorizontalElement(pendulum_length_m=0.2, lateral_stiffness_n_per_m=2.0e4,
                           lateral_loss_factor=0.15, lateral_model=lateral_model,
                           elastic_centre_height_m=0.05)  # fmt: skip
    return Table(mass_kg=600.0, isolators_m=[[0.0, 0.0], [1.2, 0.0], [1.25, 0.85], [-0.05, 0.8]],
                 cg_m=[0.68, 0.37, 0.35], inertia_kg_m2=[[45.0, 3.0, 0.0], [3.0, 80.0, 0.0],
                                                          [0.0, 0.0, 110.0]],
                 instrument_points_m=[[0.6, 0.4, 0.5], [1.1, 0.75, 0.45]],
                 point_names=("centre", "corner"), horizontal=hz)  # fmt: skip


def test_rig_of_a_table_is_the_frequency_domain_model(ref):
    """table_rig: leveling loads and p0, the pendulum, the gravity term by hand; and the
    compiled right-hand side's stiffness equals the 6x6 assembly's static stiffness."""
    from isodesign.simulation import _table_kernel as kern
    from isodesign.simulation.table_monte_carlo import _pack, table_rig
    from isodesign.table import geometry
    from isodesign.table.assembly import static_stiffness_matrix

    table = _asymmetric_table()
    rig = table_rig(ref, table)
    w = rig.loads_n
    xy = table.isolators_m - table.cg_m[:2]
    np.testing.assert_allclose(w, _loads(xy, (0, 0, 1, 2), 600.0), rtol=1e-12)
    np.testing.assert_allclose([d.pressure_pa for d in rig.designs],
                               101325.0 + w / ref.piston_area_m2, rtol=1e-12)  # fmt: skip
    np.testing.assert_allclose(rig.pendulum_n_per_m, w / 0.2, rtol=1e-12)
    kg = np.zeros((6, 6))
    kg[3, 3] = kg[4, 4] = -600.0 * G * 0.35
    np.testing.assert_allclose(rig.gravity_n_per_m, kg, atol=1e-9)
    assert 0.15 < rig.lateral_fit_error < 0.2
    # the kernel's generalized force at a small displacement, internal states at rest and a
    # vertical diaphragm k_d: K_kernel = -M dq''/dq, against sum k g g^T + K_g
    k_d = np.array([1.1e4, 1.3e4, 0.9e4, 1.2e4])
    k_dia = [(k, np.zeros(0), np.zeros(0), 0.0) for k in k_d]
    pk = _pack(rig, "quasi_steady", k_dia, 2048.0)
    minv = np.linalg.inv(rig.mass_matrix)
    k_kernel = np.zeros((6, 6))
    for j in range(6):
        y = np.zeros(pk["n_states"])
        y[j] = 1e-9
        out = np.zeros_like(y)
        kern._table_rhs(y, out, 0.0, 0.0, 0.0, minv, rig.gravity_n_per_m, pk["P"], 0,
                        pk["n_modes"], pk["mode_gain"], pk["mode_rate"], pk["n_branch"],
                        pk["br_k"], pk["br_rate"], rig.r_vertical_m, rig.r_horizontal_m,
                        pk["kh0"], pk["n_hb"], pk["hk"], pk["hrate"], pk["off"], pk["hoff"],
                        np.zeros(4), np.zeros(6))  # fmt: skip
        k_kernel[:, j] = -(rig.mass_matrix @ out[6:12]) / 1e-9
    geo = geometry(table, w)
    expect = static_stiffness_matrix(geo, k_d, pk["kh0"])
    np.testing.assert_allclose(k_kernel, expect, rtol=1e-6, atol=1e-6 * np.abs(expect).max())


def _three_isolator_table(lateral_model):
    """An irregular 3-isolator table (one isolator per leveling valve)."""
    from isodesign.table import HorizontalElement, Table

    hz = HorizontalElement(pendulum_length_m=0.2, lateral_model=lateral_model,
                           elastic_centre_height_m=0.05)  # fmt: skip
    return Table(mass_kg=360.0, isolators_m=[[0.0, 0.0], [1.0, 0.1], [0.4, 0.9]],
                 cg_m=[0.5, 0.35, 0.3], inertia_kg_m2=[30.0, 25.0, 45.0],
                 instrument_points_m=[[0.45, 0.35, 0.45], [0.9, 0.2, 0.4]],
                 point_names=("centre", "edge"), horizontal=hz)  # fmt: skip


#: The verified cases: (id, table builder, vertical diaphragm). The lateral element is the
#: hysteretic k_lat = 20 kN/m, eta = 0.15 fitted as a Prony series once, and that realized
#: element is given to both the closure and the simulation (lateral_model=).
TABLE_CASES = [
    ("asymmetric-4-isolators", _asymmetric_table, "none"),
    ("3-isolators-prony-diaphragm", _three_isolator_table, "prony"),
]


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::isodesign.errors.ModelValidityWarning")
@pytest.mark.parametrize("case", TABLE_CASES, ids=[c[0] for c in TABLE_CASES])
def test_closure_against_monte_carlo(ref, case):
    """VC-A in x, y and z: every point, axis and band within 0.5 dB of the closure, each
    isolator's stroke RMS within 5 % (3 seeds x 160 s; the standard error stays below
    0.15 dB per band and 0.5 % on the strokes)."""
    from isodesign.simulation.monte_carlo import prony_diaphragm
    from isodesign.table.response import table_band_response

    _, build, dia = case
    lat, _ = lateral_prony((2.0e4, 0.15), F_FIT)
    table = build(lat) if build is _three_isolator_table else build(lateral_model=lat)
    if dia == "prony":  # the viscoelastic diaphragm at the closure's mean A*, in both
        a_star = 1.880 * table_band_response(ref, table, "VC-A", "VC-E").stroke_rms_m
        dia, err = prony_diaphragm("viscoelastic", F_FIT, float(np.mean(a_star)))
        assert err < 0.1
    closure = table_band_response(ref, table, "VC-A", "VC-E", diaphragm=dia)
    mc = simulate_table_response(ref, table, "VC-A", target="VC-E", seeds=3, duration_s=160.0,
                                 diaphragm=dia)  # fmt: skip
    assert mc.lateral_fit_error == 0.0  # the same realized element in both
    assert np.nanmax(mc.standard_error_db()) < 0.15
    assert np.max(mc.stroke_rms_se_m / mc.stroke_rms_m) < 0.005
    err = mc.error_db(closure.velocity_rms_m_s, closure.bands)
    assert np.max(np.abs(err)) < 0.5, np.round(err, 2)
    stroke_err = closure.stroke_rms_m / mc.stroke_rms_m - 1.0
    assert np.max(np.abs(stroke_err)) < 0.05, stroke_err
    np.testing.assert_allclose(closure.tube_velocity_rms_m_s, mc.tube_velocity_rms_m_s,
                               rtol=0.05)  # fmt: skip
    np.testing.assert_allclose(closure.horizontal_stroke_rms_m, mc.horizontal_stroke_rms_m,
                               rtol=0.05)  # fmt: skip


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::isodesign.errors.ModelValidityWarning")
def test_default_warmup_outlasts_the_slowest_mode(ref):
    """A point near the node of the y-rx pair (0.35 m above the CG of the symmetric study
    table: its y velocity 70-90 dB below the floor above 16 Hz): a start-up transient left
    in the record would leak into those bands (more than 4 dB after the 1-DOF verifier's
    20 s warm-up). The default warm-up, 14 decay times of the slowest mode of the linearized
    table, leaves e^-14 of it; the point's y band RMS then matches the independent linear
    assembly to 0.08 dB up to 40 Hz (above, RK4's step error on a velocity 90 dB below the
    floor's)."""
    from isodesign.simulation.table_monte_carlo import table_rig
    from isodesign.table import HorizontalElement, Table

    lat, _ = lateral_prony((1.0e4, 0.1), F_FIT)
    table = Table.symmetric(600.0, 1.2, 0.8, 0.35, size_m=(1.5, 1.0, 0.7),
                            instrument_points_m=[[0.0, 0.0, 0.7]],
                            horizontal=HorizontalElement(pendulum_length_m=0.15,
                                                         lateral_model=lat))  # fmt: skip
    rig = table_rig(ref, table)
    mc = simulate_table_response(None, rig, TINY, target="VC-E", seeds=[0], duration_s=60.0,
                                 diaphragm="none")  # fmt: skip
    assert mc.transient_left == pytest.approx(math.exp(-14.0), rel=1e-6)
    assert 30.0 < mc.warmup_s < 60.0
    expect = _linear_band_ms(rig, TINY, 60.0, 0, mc.bands)
    err = 10 * np.log10(mc.velocity_rms_m_s**2 / expect)
    isolation = 20 * np.log10(mc.velocity_rms_m_s[0, 1] / mc.floor_velocity_rms_m_s[1])
    assert np.min(isolation) < -85.0  # the node: far below the floor
    assert np.max(np.abs(err[..., :-3])) < 0.08, np.round(err, 3)
    short = simulate_table_response(None, rig, TINY, target="VC-E", seeds=[0], duration_s=60.0,
                                    diaphragm="none", warmup_s=20.0)  # fmt: skip
    leak = 10 * np.log10(short.velocity_rms_m_s**2 / expect)
    assert np.max(leak[0, 1, :-3]) > 4.0 and short.transient_left > 1e-3


def distortion_case(ref):
    """The asymmetric 4-isolator table (its CG 0.08 m in x and 0.04 m in y off the
    isolators' centroid), VC-A in z and half of it in x and y, no diaphragm; the closure
    without and with the distortion power, and the Monte Carlo (3 seeds x 160 s)."""
    from isodesign.table.floor import table_floor
    from isodesign.table.response import table_band_response

    vca = FloorSpectrum.from_criterion("VC-A")
    half = FloorSpectrum.from_band_rms(vca.bands, 0.5 * vca.band_rms_velocity(), name="VC-A/2")
    fl = table_floor(x=half, y=half, z=vca)
    lat, _ = lateral_prony((2.0e4, 0.15), F_FIT)
    table = _asymmetric_table(lateral_model=lat)
    plain = table_band_response(ref, table, fl, "VC-E", diaphragm="none")
    dist = table_band_response(ref, table, fl, "VC-E", diaphragm="none", distortion=True)
    mc = simulate_table_response(ref, table, fl, target="VC-E", seeds=3, duration_s=160.0,
                                 diaphragm="none")  # fmt: skip
    return plain, dist, mc


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::isodesign.errors.ModelValidityWarning")
def test_table_distortion_against_monte_carlo(ref):
    """The distortion (non-Gaussian, docs/random-response.md 3c) brings every isolator's
    stroke and tube velocity RMS closer to the simulation (the closure alone is 1-2 % low),
    to within 1 %, and keeps every band of both points and axes within 0.3 dB (with it
    within 0.25 dB: the Gaussian residual's overstatement of the centre's z bands at 5-8 Hz,
    +0.27 dB, is gone); each isolator's predicted kurtosis is within 0.1 of the simulated."""
    plain, dist, mc = distortion_case(ref)
    assert np.nanmax(mc.standard_error_db()) < 0.15
    assert np.max(mc.stroke_rms_se_m / mc.stroke_rms_m) < 0.005
    e0 = plain.stroke_rms_m / mc.stroke_rms_m - 1.0
    e1 = dist.stroke_rms_m / mc.stroke_rms_m - 1.0
    assert np.all(np.abs(e1) < np.abs(e0) - 0.002), (e0, e1)
    assert np.max(np.abs(e1)) < 0.01
    u0 = plain.tube_velocity_rms_m_s / mc.tube_velocity_rms_m_s - 1.0
    u1 = dist.tube_velocity_rms_m_s / mc.tube_velocity_rms_m_s - 1.0
    assert np.all(np.abs(u1) < np.abs(u0) - 0.003), (u0, u1)
    b0 = mc.error_db(plain.velocity_rms_m_s, plain.bands)
    b1 = mc.error_db(dist.velocity_rms_m_s, dist.bands)
    assert np.max(np.abs(b0)) < 0.3 and np.max(np.abs(b1)) < 0.25
    # each isolator's predicted tube velocity kurtosis (section 3c) against the simulated one
    assert plain.distortion_kurtosis is None
    np.testing.assert_allclose(dist.distortion_kurtosis, mc.tube_velocity_kurtosis, atol=0.1)
