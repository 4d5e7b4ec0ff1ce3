"""Tests of the payload response: closures, band compliance, stability, python-control."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from isodesign.errors import InputError, ModelValidityWarning
from isodesign.floor import FloorSpectrum, criterion
from isodesign.floor.bands import third_octave_bands
from isodesign.numerics.cplx import Cx
from isodesign.plotting.style import save_figure
from isodesign.response import (
    LINEAR_REFERENCE_AMPLITUDE_M,
    band_response,
    harmonic_response,
    linear_transmissibility,
    stability_figures,
    step_metrics,
    to_frd,
    to_transfer_function,
)
from isodesign.response.isolator import (
    Payload,
    loaded_design,
    relative_transmissibility,
    zener_damping_ratio,
    zener_optimum,
    zener_transmissibility,
)
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    band_margin_db,
    band_mean_square,
    rayleigh_average,
    rayleigh_rule,
    response_grid,
    stroke_variance,
    velocity_margin_db,
)
from isodesign.spring.capillary import gaussian_equivalent_resistance, linear_resistance
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import ViscoelasticDiaphragm, diaphragm_model
from isodesign.spring.equations import air_stiffness
from isodesign.spring.stiffness import complex_stiffness

TWO_PI = 2.0 * math.pi


@pytest.fixture(autouse=True)
def _quiet():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        yield



@pytest.fixture(scope="module")
def payload():
    return Payload(400.0, 4)


@pytest.fixture(scope="module")
def default_response(ref, payload):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        return band_response(ref, payload, "VC-A", "VC-E")


def _stiffness(design, f, x, **kw):
    return complex_stiffness(design, f, x, pairwise=True, warn=False, **kw).k


# --------------------------------------------------------------------------------------------
# linear limit: the Zener isolator
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("mass", [40.0, 400.0, 1200.0])
def test_linear_limit_equals_zener_closed_form(ref, mass):
    p = Payload(mass, 4)
    d = loaded_design(ref, p)
    f = np.geomspace(0.05, 200.0, 400)
    t = linear_transmissibility(ref, p, f, flow="poiseuille", diaphragm="none")
    wn = math.sqrt(d.static_stiffness_n_per_m / p.mass_per_isolator_kg)
    z = zener_damping_ratio(d, p.mass_per_isolator_kg)
    tz = zener_transmissibility(d.volume_ratio, z, TWO_PI * f / wn)
    np.testing.assert_allclose(np.abs(t), tz, rtol=1e-9)
    # amplitude does not matter in that limit: the closure converges at once
    h = harmonic_response(ref, p, f[::40], [1e-6, 1e-3], flow="poiseuille", diaphragm="none")
    np.testing.assert_allclose(np.abs(h.transmissibility), tz[::40, None] * np.ones(2), rtol=1e-9)


def test_zener_optimum_through_the_whole_chain(ref, payload):
    """Capillary length set for the optimal damping: peak |T| = 1 + 2/N at r = r_peak."""
    d0 = loaded_design(ref, payload)
    z0 = zener_damping_ratio(d0, 100.0)
    tmax, r_pk, z_opt = zener_optimum(d0.volume_ratio)
    d = ref.replace(capillary_length_m=ref.capillary_length_m * z_opt / z0)
    s = stability_figures(d, payload, flow="poiseuille", diaphragm="none")
    assert s.zener_damping_ratio == pytest.approx(z_opt, rel=1e-12)
    assert s.peak_transmissibility == pytest.approx(tmax, rel=1e-10)
    fn = math.sqrt(d0.static_stiffness_n_per_m / 100.0) / TWO_PI
    assert s.natural_frequency_hz == pytest.approx(fn, rel=1e-12)
    assert s.peak_frequency_hz == pytest.approx(r_pk * fn, rel=1e-5)


# --------------------------------------------------------------------------------------------
# stiff spring: T -> 1, payload spectrum = floor
# --------------------------------------------------------------------------------------------


def test_very_stiff_spring_follows_the_floor():
    stiff = SpringDesign(
        volume_ratio=1.0,
        top_volume_m3=1e-6,
        capillary_length_m=1e-2,
        capillary_diameter_m=1e-3,
        piston_area_m2=5e-2,
        pressure_pa=5e5,
    )
    p = Payload(0.04, 4)  # k_s/(N+1) ~ 1.8e8 N/m on 10 g: f_n ~ 21 kHz
    r = band_response(stiff, p, "VC-A", "VC-A")
    t = r.transmissibility
    # |T - 1| ~ (f/f_n)^2 <= 1e-4 up to 89 Hz
    assert np.max(np.abs(t - 1.0)) < 1e-4
    np.testing.assert_allclose(r.payload_velocity_rms_m_s, r.floor_velocity_rms_m_s, rtol=1e-4)
    np.testing.assert_allclose(r.floor_velocity_rms_m_s, 50e-6, rtol=1e-12)
    np.testing.assert_allclose(r.margin_db, 0.0, atol=1e-3)


# --------------------------------------------------------------------------------------------
# random linearization: Rayleigh average and equivalent amplitude
# --------------------------------------------------------------------------------------------


def test_equivalent_amplitude_constant():
    assert EQUIVALENT_AMPLITUDE_FACTOR == pytest.approx(3.0 * math.sqrt(math.pi / 8.0), rel=1e-15)
    assert round(EQUIVALENT_AMPLITUDE_FACTOR, 3) == 1.880


def test_rayleigh_rule_exact_for_polynomials_in_amplitude():
    a, w = rayleigh_rule(16)
    assert w.sum() == pytest.approx(1.0, rel=1e-15) and np.all(w > 0)
    for p in range(32):  # E[A^p] for a Rayleigh envelope of sigma = 1: 2^(p/2) Gamma(p/2 + 1)
        # weight A^3/(2 s^4) exp(-A^2/2s^2) = Rayleigh density times A^2/(2 s^2)
        exact = 2.0 ** (p / 2) * math.gamma(p / 2 + 2)
        assert w @ a**p == pytest.approx(exact, rel=1e-13)
    # k linear in A gives exactly 1.880 sigma
    assert rayleigh_average(lambda amp: amp, 2.5) == pytest.approx(
        EQUIVALENT_AMPLITUDE_FACTOR * 2.5, rel=1e-14
    )
    with pytest.raises(InputError, match="rayleigh_nodes"):
        rayleigh_rule(1)


def test_rayleigh_average_against_direct_quadrature():
    from scipy.integrate import quad

    def k(amp):
        return 1e4 / (1.0 + (amp / 1e-4) ** 2) + 3e3j * np.tanh(amp / 5e-5)

    sigma = 7e-5

    def dens(amp):
        return amp**3 / (2 * sigma**4) * math.exp(-(amp**2) / (2 * sigma**2))

    re = quad(lambda x: k(x).real * dens(x), 0, 20 * sigma, epsabs=0, epsrel=1e-12)[0]
    im = quad(lambda x: k(x).imag * dens(x), 0, 20 * sigma, epsabs=0, epsrel=1e-12)[0]
    got = rayleigh_average(k, sigma, 24)
    assert got == pytest.approx(re + 1j * im, rel=1e-7)


def test_quadratic_damper_random_describing_function():
    """Harmonic DF 8 A c/(3 pi) -> Rayleigh average c sqrt(8/pi) sigma (notes, section 7)."""
    c = 3.7
    for sigma in (1e-6, 0.3, 2.0):
        n_r = rayleigh_average(lambda amp: 8.0 * amp * c / (3.0 * math.pi), sigma)
        assert n_r == pytest.approx(c * math.sqrt(8.0 / math.pi) * sigma, rel=1e-14)
        # the equivalent amplitude reproduces it through the harmonic DF
        assert 8.0 * EQUIVALENT_AMPLITUDE_FACTOR * sigma * c / (3.0 * math.pi) == pytest.approx(
            n_r, rel=1e-14
        )
    # and the law itself: E[v f(v)] / sigma^2 for f = c v|v|, v Gaussian
    from scipy.integrate import quad

    sigma = 0.7
    e = quad(
        lambda v: v * c * v * abs(v) * math.exp(-(v**2) / (2 * sigma**2)),
        -12 * sigma,
        12 * sigma,
        epsabs=0,
        epsrel=1e-12,
    )[0] / (sigma * math.sqrt(2 * math.pi))
    assert e / sigma**2 == pytest.approx(c * math.sqrt(8.0 / math.pi) * sigma, rel=1e-10)


# --------------------------------------------------------------------------------------------
# self-consistency of the closures
# --------------------------------------------------------------------------------------------


def test_harmonic_stroke_is_self_consistent(ref, payload):
    f = np.geomspace(0.5, 50.0, 60)
    xf = np.array([1e-7, 1e-6, 1e-5, 1e-4])
    h = harmonic_response(ref, payload, f, xf)
    fg = np.broadcast_to(f[:, None], h.stroke_m.shape)
    k = _stiffness(h.design, fg, h.stroke_m)  # independent evaluation at X_s
    t = k / (k - 100.0 * (TWO_PI * fg) ** 2)
    np.testing.assert_allclose(h.stroke_m, np.abs(t - 1.0) * xf, rtol=1e-8)
    np.testing.assert_allclose(h.transmissibility, t, rtol=1e-12)
    assert np.all(h.n_roots == 1) and h.converged
    df = h.to_frame()
    assert len(df) == f.size * xf.size
    assert {"frequency_hz", "floor_amplitude_m", "stroke_m", "transmissibility_abs"} <= set(df)
    # larger floor motion: more damping at resonance here, lower peak
    assert h.peak_transmissibility[0] > h.peak_transmissibility[-1]


@pytest.mark.parametrize("xf", [1e-13, 0.3])
def test_harmonic_roots_outside_the_scan_window(ref, payload, xf):
    """Strokes below 1 nm or above 0.1 m are bracketed by extension (spring linear there)."""
    f = np.geomspace(0.5, 50.0, 12)
    h = harmonic_response(ref, payload, f, xf)
    k = _stiffness(h.design, f[:, None], h.stroke_m)
    t = k / (k - 100.0 * (TWO_PI * f[:, None]) ** 2)
    np.testing.assert_allclose(h.stroke_m, np.abs(t - 1.0) * xf, rtol=1e-8)
    assert np.all(h.n_roots == 1)
    if xf > 0.1:  # a 0.3 m floor motion is far outside the small-signal model: flagged
        assert any("small_signal" in w for w in h.warnings)


@pytest.mark.parametrize("method", ["equivalent_amplitude", "rayleigh"])
def test_random_stroke_is_self_consistent(ref, payload, method):
    r = band_response(ref, payload, "VC-A", "VC-E", random_method=method, points_per_band=30)
    floor = FloorSpectrum.from_criterion("VC-A")
    f = r.grid.frequency_hz
    t = r.transmissibility

    def rel2(ff):  # |T - 1|^2 from the final T (interpolation-free: ff are grid points)
        idx = np.searchsorted(f, ff)
        return np.abs(t[idx] - 1.0) ** 2

    # independent quadrature: the floor's own band integration of the relative motion
    sigma = math.sqrt(
        np.sum(floor.band_rms(None, "displacement", 30, power_transmissibility=rel2) ** 2)
    )
    assert r.stroke_rms_m == pytest.approx(sigma, rel=1e-12)
    assert r.equivalent_amplitude_m == pytest.approx(EQUIVALENT_AMPLITUDE_FACTOR * sigma, rel=1e-8)
    assert r.converged and 1 <= r.iterations <= 10
    assert r.closure_slope is not None and abs(r.closure_slope) < 1
    # T really is the spring at the final linearization
    sigma_in = r.equivalent_amplitude_m / EQUIVALENT_AMPLITUDE_FACTOR
    if method == "equivalent_amplitude":
        k = _stiffness(r.design, f, r.equivalent_amplitude_m)
    else:
        k = rayleigh_average(
            lambda amp: complex_stiffness(r.design, f, amp.ravel(), warn=False).k, sigma_in
        )
    np.testing.assert_allclose(t, k / (k - 100.0 * (TWO_PI * f) ** 2), rtol=1e-12)


def test_rayleigh_and_equivalent_amplitude_agree_closely(ref, payload):
    r1 = band_response(ref, payload, "VC-A", "VC-E", random_method="equivalent_amplitude")
    r2 = band_response(ref, payload, "VC-A", "VC-E", random_method="rayleigh")
    assert r2.stroke_rms_m == pytest.approx(r1.stroke_rms_m, rel=0.02)
    np.testing.assert_allclose(r2.margin_db, r1.margin_db, atol=0.2)


def test_multiple_harmonic_roots_are_detected():
    """A strongly softening, lightly damped spring jumps near resonance."""
    d = SpringDesign.reference().replace(capillary_length_m=0.5, capillary_diameter_m=0.4e-3)
    dia = ViscoelasticDiaphragm(
        k0_n_per_m=40000,
        kinf_n_per_m=2000,
        eta0=0.01,
        etainf=0.01,
        critical_amplitude_m=1e-4,
        stiffness_frequency_exponent=0,
        loss_frequency_exponent=0,
    )
    p = Payload(400.0, 4)
    f = np.geomspace(2.0, 3.6, 60)
    kw = {"flow": "poiseuille", "diaphragm": dia}
    up = harmonic_response(d, p, f, 3e-6, **kw)
    lo = harmonic_response(d, p, f, 3e-6, branch="lower", **kw)
    multi = up.multiple_roots[:, 0]
    assert multi.sum() >= 5 and np.array_equal(multi, lo.multiple_roots[:, 0])
    assert np.all(up.stroke_m[multi] > 1.5 * lo.stroke_m[multi])
    np.testing.assert_allclose(up.stroke_m[~multi], lo.stroke_m[~multi], rtol=1e-9)
    for h in (up, lo):  # both branches are self-consistent
        fg = np.broadcast_to(f[:, None], h.stroke_m.shape)
        k = _stiffness(h.design, fg, h.stroke_m, flow="poiseuille", diaphragm=dia)
        t = k / (k - 100.0 * (TWO_PI * fg) ** 2)
        np.testing.assert_allclose(h.stroke_m, np.abs(t - 1.0) * 3e-6, rtol=1e-8)
    assert any("multiple_roots" in w for w in up.warnings)


# --------------------------------------------------------------------------------------------
# quadratures shared with the optimizer
# --------------------------------------------------------------------------------------------


def test_band_mean_square_is_the_floor_band_integration():
    floor = FloorSpectrum.from_criterion("NIST-A")  # not flat in velocity
    bands = third_octave_bands(2, 63)
    g = response_grid(floor, bands, target=criterion("VC-E"), points_per_band=40)
    one = Cx(np.ones(g.n_points), np.zeros(g.n_points))
    for q in ("velocity", "displacement", "acceleration"):
        got = np.sqrt(band_mean_square(one, g, q))
        trap = floor.band_rms(bands, q, 40, power_transmissibility=np.ones_like)
        np.testing.assert_allclose(got, trap, rtol=1e-12)  # the same trapezoid rule
        exact = floor.band_rms(bands, q)  # closed form for a band-constant floor
        np.testing.assert_allclose(got, exact, rtol=1e-12 if q == "velocity" else 1e-4)
    f = g.frequency_hz
    t = 1.0 / (1.0 + 1j * f / 3.0)
    ref = floor.band_rms_velocity(
        bands, 40, power_transmissibility=lambda ff: 1.0 / (1.0 + (ff / 3.0) ** 2)
    )
    np.testing.assert_allclose(np.sqrt(band_mean_square(Cx.from_complex(t), g)), ref, rtol=1e-12)
    np.testing.assert_allclose(g.limit_velocity_m_s, 3.12e-6)
    margin = band_margin_db(band_mean_square(one, g), g)
    np.testing.assert_allclose(margin, 20 * np.log10(3.12e-6 / g.floor_velocity_rms_m_s))
    # the RMS-velocity form used by the results agrees with the mean-square form
    np.testing.assert_allclose(velocity_margin_db(g.limit_velocity_m_s, g.floor_velocity_rms_m_s),
                               margin, rtol=1e-12)


def test_velocity_margin_db_sign_zero_and_broadcast():
    limit = np.array([2.0, 1.0, 1.0])
    # twice below the limit: +6.02 dB; at it: 0; ten times above: -20 dB
    np.testing.assert_allclose(velocity_margin_db(limit, np.array([1.0, 1.0, 10.0])),
                               [20 * math.log10(2.0), 0.0, -20.0], atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a zero velocity is an infinite margin, silently
        assert velocity_margin_db(limit, np.zeros(3)).tolist() == [math.inf] * 3
    # per-band limits against (points, axes, bands) velocities (the rigid table)
    v = np.full((2, 6, 3), 0.5)
    np.testing.assert_allclose(velocity_margin_db(limit, v),
                               np.broadcast_to(20 * np.log10(limit / 0.5), v.shape))


def test_stroke_grid_covers_a_pointwise_floor_beyond_the_bands():
    f = np.array([0.5, 2.0, 10.0, 200.0])
    floor = FloorSpectrum(f, np.array([1e-10, 4e-10, 4e-11, 1e-12]), name="measured")
    g = response_grid(floor, third_octave_bands(4, 20), points_per_band=50)
    assert g.frequency_hz[0] == 0.5 and g.frequency_hz[-1] == 200.0
    # sigma^2 with |T - 1| = 1 is the floor's displacement variance over its whole range
    ff = np.geomspace(0.5, 200.0, 200001)
    exact = np.trapezoid(floor.psd_velocity(ff) / (TWO_PI * ff) ** 2, ff)
    one = Cx(np.ones(g.n_points), np.zeros(g.n_points))
    assert float(stroke_variance(one, g)) == pytest.approx(exact, rel=1e-5)
    # end to end: default bands are the target's bands within the floor's range
    r = band_response(SpringDesign.reference(), Payload(400.0, 4), floor, "VC-C")
    assert r.bands.labels[0] == "1" and r.bands.labels[-1] == "80"  # VC-C: 1 to 80 Hz
    assert r.converged and r.stroke_rms_m > 0


def test_quadratures_on_casadi_symbols():
    import casadi as ca

    g = response_grid(FloorSpectrum.from_criterion("VC-C"), target=criterion("VC-E"))
    n = g.n_points
    re, im = ca.SX.sym("re", n), ca.SX.sym("im", n)
    t = Cx(re, im)
    fun = ca.Function(
        "q",
        [re, im],
        [
            band_mean_square(t, g),
            stroke_variance(t - 1.0, g),
            band_margin_db(band_mean_square(t, g), g),
        ],
    )
    rng = np.random.default_rng(1)
    x, y = rng.random(n), rng.random(n)
    ms, s2, mdb = fun(x, y)
    tn = Cx(x, y)
    np.testing.assert_allclose(np.asarray(ms).ravel(), band_mean_square(tn, g), rtol=1e-13)
    assert float(s2) == pytest.approx(float(stroke_variance(tn - 1.0, g)), rel=1e-13)
    np.testing.assert_allclose(
        np.asarray(mdb).ravel(), band_margin_db(band_mean_square(tn, g), g), rtol=1e-12
    )
    # with relative_transmissibility on symbols: T - 1 from a symbolic stiffness
    kr, ki = ca.SX.sym("kr", n), ca.SX.sym("ki", n)
    s2k = stroke_variance(relative_transmissibility(Cx(kr, ki), 100.0, g.omega), g)
    assert s2k.shape == (1, 1)


# --------------------------------------------------------------------------------------------
# python-control interop
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("flow", "minor_loss", "amp"),
    [("poiseuille", 1.5, 1e-6), ("quasi_steady", 0.0, 1e-6), ("quasi_steady", 1.5, 1e-18)],
)
def test_transfer_function_matches_isodesign(ref, payload, flow, minor_loss, amp):
    import control

    d = ref.replace(minor_loss=minor_loss, acoustics="lumped")  # a rational model
    f = np.geomspace(0.05, 200.0, 300)
    tf = to_transfer_function(d.replace(acoustics="distributed"), payload, flow=flow)
    t_ctl = np.asarray(control.frequency_response(tf, TWO_PI * f).complex).ravel()
    t = linear_transmissibility(d, payload, f, flow=flow, diaphragm="none", amplitude_m=amp)
    np.testing.assert_allclose(t_ctl, t, rtol=1e-10)
    # T - 1 and k(s) too
    rel = to_transfer_function(d, payload, flow=flow, output="relative")
    np.testing.assert_allclose(
        np.asarray(control.frequency_response(rel, TWO_PI * f).complex).ravel(), t - 1.0,
        rtol=1e-10,
    )  # fmt: skip
    ks = to_transfer_function(d, payload, flow=flow, output="stiffness")
    k = _stiffness(loaded_design(d, payload), f, amp, flow=flow, diaphragm="none")
    np.testing.assert_allclose(ks(1j * TWO_PI * f), k, rtol=1e-10)


def test_frd_round_trip(ref, payload):
    import control

    f = np.geomspace(0.2, 50.0, 120)
    frd = to_frd(ref, payload, f)
    assert isinstance(frd, control.FrequencyResponseData)
    t = linear_transmissibility(ref, payload, f)
    np.testing.assert_allclose(frd.omega, TWO_PI * f)
    np.testing.assert_allclose(np.asarray(frd.eval(TWO_PI * f)).ravel(), t, rtol=1e-14)
    # the FRD of the rational model equals the FRD sampled from its transfer function
    tf = to_transfer_function(ref, payload, flow="poiseuille")
    frd2 = to_frd(ref, payload, f, flow="poiseuille", diaphragm="none")
    frd3 = control.FrequencyResponseData(tf, TWO_PI * f)
    np.testing.assert_allclose(
        np.asarray(frd2.eval(TWO_PI * f)).ravel(), np.asarray(frd3.eval(TWO_PI * f)).ravel(),
        rtol=1e-10,
    )  # fmt: skip


def test_step_metrics_and_pole_damping(ref, payload):
    sm = step_metrics(ref, payload, flow="poiseuille")
    assert sm.steady_state == pytest.approx(1.0, rel=1e-12)
    assert 0 < sm.rise_time_s < sm.settling_time_s < 60
    assert sm.overshoot_percent > 0 and sm.peak > 1
    tail = sm.response[sm.time_s >= sm.settling_time_s]
    assert np.all(np.abs(tail - 1.0) <= 0.02 + 1e-9)
    s = stability_figures(ref, payload, flow="poiseuille", diaphragm="none")
    assert s.pole_damping_ratio == pytest.approx(sm.dominant_damping_ratio)
    # the dominant pair is the payload mode; close to the Zener estimate
    assert s.pole_damping_ratio == pytest.approx(s.zener_damping_ratio, rel=0.05)
    assert s.pole_frequency_hz == pytest.approx(s.natural_frequency_hz, rel=0.05)
    assert stability_figures(ref, payload).pole_damping_ratio is None  # not rational
    assert len(sm.to_frame()) == sm.time_s.size


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"flow": "womersley"}, "flow"),
        ({"flow": "zhao"}, "flow"),
        ({"flow": "nope"}, "flow"),
        ({"diaphragm": "viscoelastic"}, "diaphragm"),
        ({"output": "phase"}, "output"),
    ],
)
def test_transfer_function_rejects_non_rational_models(ref, payload, kwargs, name):
    with pytest.raises(InputError, match=rf"^{name}:.*valid"):
        to_transfer_function(ref, payload, **kwargs)


# --------------------------------------------------------------------------------------------
# compliance
# --------------------------------------------------------------------------------------------


def test_compliance_hand_check(ref, payload, default_response):
    r = default_response
    # loose target (ISO-office: 400 um/s flat above 8 Hz, 20 mm/s^2 below): passes
    loose = band_response(ref, payload, "VC-A", "ISO-office")
    assert loose.passes and loose.worst_margin_db > 0
    # VC-G (0.78 um/s) fails; on a flat floor against a flat curve the worst band is the
    # band where the band-averaged |T|^2 is largest, around the resonance peak
    g = band_response(ref, payload, "VC-A", "VC-G")
    assert not g.passes
    t2 = np.abs(g.transmissibility) ** 2
    band_avg = [np.mean(t2[g.grid.band_points[b]]) for b in range(len(g.bands))]
    assert g.worst_band_hz == g.bands.nominal_hz[int(np.argmax(band_avg))]
    f_peak = g.stability.excited_peak_frequency_hz
    i = int(np.argmin(g.margin_db))
    assert g.bands.lower_hz[i - 1] <= f_peak <= g.bands.upper_hz[i + 1]
    # margins by hand: 20 log10(limit / payload)
    np.testing.assert_allclose(g.margin_db, 20 * np.log10(0.78e-6 / g.payload_velocity_rms_m_s))
    assert g.worst_margin_db == pytest.approx(np.min(g.margin_db))
    # the same transmissibility: VC-G and VC-E differ by 12.04 dB in every band
    np.testing.assert_allclose(r.margin_db - g.margin_db, 20 * np.log10(3.12 / 0.78), rtol=1e-12)
    # the payload band RMS is the floor's band integration through |T|^2 of the spring
    # linearized at (A*, sigma_u): tube C = linear part + Gaussian-equivalent resistance
    amp = r.equivalent_amplitude_m
    floor = FloorSpectrum.from_criterion("VC-A")
    dia = diaphragm_model("viscoelastic")

    def t2_of(ff):
        w = TWO_PI * ff.ravel()
        c_lin = linear_resistance("quasi_steady", r.design, w)
        c_nl = gaussian_equivalent_resistance("quasi_steady", r.design, r.tube_velocity_rms_m_s)
        k = (air_stiffness(r.design, w, Cx(c_lin.re + c_nl, c_lin.im), "quasi_steady")
             + dia.stiffness(w, amp)).to_complex().reshape(ff.shape)
        return np.abs(k / (k - 100.0 * (TWO_PI * ff) ** 2)) ** 2

    expect = floor.band_rms_velocity(r.bands, 50, power_transmissibility=t2_of)
    np.testing.assert_allclose(r.payload_velocity_rms_m_s, expect, rtol=1e-11)
    # above resonance the payload moves less than the floor
    assert np.all(r.payload_velocity_rms_m_s[-8:] < 0.2 * r.floor_velocity_rms_m_s[-8:])
    assert r.verdict().startswith("FAIL") and "worst band 2 Hz" in r.verdict()


def test_band_response_result_api(default_response, tmp_path):
    r = default_response
    df = r.to_frame()
    assert len(df) == 20
    for col in (
        "nominal_hz",
        "label",
        "centre_hz",
        "floor_velocity_rms_m_s",
        "payload_velocity_rms_m_s",
        "payload_displacement_rms_m",
        "payload_acceleration_rms_m_s2",
        "limit_velocity_rms_m_s",
        "margin_db",
        "passes",
    ):
        assert col in df
    # displacement and acceleration are consistent with velocity within a band (0.9 %)
    c = TWO_PI * r.bands.centre_hz
    np.testing.assert_allclose(r.payload_displacement_rms_m * c, r.payload_velocity_rms_m_s,
                               rtol=0.05)  # fmt: skip
    assert r.spring_diagnostics.shape == r.grid.frequency_hz.shape
    assert isinstance(r.warnings, tuple)
    assert r.stability.excitation_amplitude_m == r.equivalent_amplitude_m
    assert r.stability.excited_peak_transmissibility < r.stability.peak_transmissibility
    sf = r.stability.to_frame()
    assert {"figure", "value", "unit", "definition"} <= set(sf)
    fig = r.plot()
    assert len(fig.axes) >= 3  # bands, |T| (dB), phase
    p = save_figure(fig, tmp_path / "r.png")
    assert p.stat().st_size > 1000


def test_stability_figures_definitions(ref):
    p = Payload(400.0, 4, spacing_m=0.8, cg_height_m=0.3)
    s = stability_figures(ref, p)
    d = loaded_design(ref, p)
    # K0: air static stiffness plus the diaphragm at 1 um and at the air spring's own
    # natural frequency sqrt(k_air/(m/n))/(2 pi) (isolator.static_stiffness)
    w_air = np.sqrt(d.static_stiffness_n_per_m / 100.0)
    kd = ViscoelasticDiaphragm().stiffness(np.array([w_air]),
                                           np.array([LINEAR_REFERENCE_AMPLITUDE_M]))
    k0 = d.static_stiffness_n_per_m + float(kd.re[0])
    assert s.static_stiffness_n_per_m == pytest.approx(k0, rel=1e-12)
    assert (TWO_PI * s.natural_frequency_hz) ** 2 * 100.0 == pytest.approx(k0, rel=1e-12)
    assert s.tilt_margin == pytest.approx(4 * k0 * 0.4**2 / (400 * 9.80665 * 0.3), rel=1e-12)
    assert s.tilt_stable is (s.tilt_margin > 1)
    assert s.excited_peak_transmissibility is None
    # derive_pressure=False keeps the design's p0 (Table 1: 4.93 bar)
    s2 = stability_figures(ref, p, derive_pressure=False)
    assert s2.pressure_pa == ref.pressure_pa and s2.natural_frequency_hz > s.natural_frequency_hz


def test_fixed_stroke_amplitude_skips_the_closure(ref, payload):
    r = band_response(ref, payload, "VC-A", "VC-E", stroke_amplitude_m=2e-5, points_per_band=10)
    assert r.iterations == 1 and r.equivalent_amplitude_m == pytest.approx(2e-5, rel=1e-14)
    f = r.grid.frequency_hz
    k = _stiffness(r.design, f, 2e-5)
    np.testing.assert_allclose(r.transmissibility, k / (k - 100.0 * (TWO_PI * f) ** 2), rtol=1e-12)


def test_floor_from_csv(ref, payload, tmp_path):
    p = tmp_path / "floor.csv"
    p.write_text(
        "# quantity: velocity; kind: band_rms; unit: um/s\nfrequency_hz,value\n"
        + "\n".join(f"{f},{v}" for f, v in [(4, 10), (5, 20), (6.3, 30), (8, 40), (10, 40)])
        + "\n"
    )
    r = band_response(ref, payload, str(p), "VC-E", points_per_band=20)
    assert list(r.bands.labels) == ["4", "5", "6.3", "8", "10"]  # target bands within floor
    np.testing.assert_allclose(r.floor_velocity_rms_m_s, [10e-6, 20e-6, 30e-6, 40e-6, 40e-6])


# --------------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------------


def test_bad_inputs_name_the_parameter(ref, payload, tmp_path):
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    bad = tmp_path / "bad.csv"
    bad.write_text("# quantity: velocity; kind: psd; unit: um/s\nfrequency_hz,value\n1,abc\n")
    cases = [
        ((ref, payload, "VC-Z", "VC-E"), {}, "floor"),
        ((ref, payload, "VC-A", "VC-Z"), {}, "target"),
        ((ref, payload, str(empty), "VC-E"), {}, "floor"),
        ((ref, payload, str(bad), "VC-E"), {}, "floor"),
        ((ref, payload, str(tmp_path / "missing.csv"), "VC-E"), {}, "floor"),
        ((ref, payload, "VC-A", "VC-E"), {"bands": (0.5, 80)}, "bands"),  # outside the floor
        ((ref, payload, "VC-A", "VC-A-legacy"), {"bands": (1, 80)}, "bands"),  # outside curve
        ((ref, payload, "VC-A-legacy", "VC-A"), {"bands": (1, 80)}, "bands"),
        ((ref, payload, "VC-A", "VC-E"), {"random_method": "mc"}, "random_method"),
        ((ref, payload, "VC-A", "VC-E"), {"flow": "laminar"}, "flow"),
        ((ref, payload, "VC-A", "VC-E"), {"diaphragm": "rubber"}, "diaphragm"),
        ((ref, payload, "VC-A", "VC-E"), {"points_per_band": 1}, "points_per_band"),
        ((ref, payload, "VC-A", "VC-E"), {"stroke_amplitude_m": -1.0}, "stroke_amplitude_m"),
        ((ref, 400.0, "VC-A", "VC-E"), {}, "payload"),
        (("ref", payload, "VC-A", "VC-E"), {}, "design"),
        ((ref, payload, 42, "VC-E"), {}, "floor"),
    ]
    for args, kw, name in cases:
        with pytest.raises(InputError, match=rf"^{name}"):
            band_response(*args, **kw)
    with pytest.raises(InputError, match="mass_kg"):
        band_response(ref, Payload(-1.0), "VC-A", "VC-E")
    with pytest.raises(InputError, match=r"^frequency_hz"):
        harmonic_response(ref, payload, [-1.0, 2.0], 1e-6)
    with pytest.raises(InputError, match=r"^floor_amplitude_m"):
        harmonic_response(ref, payload, [1.0, 2.0], 0.0)
    with pytest.raises(InputError, match=r"^branch"):
        harmonic_response(ref, payload, 1.0, 1e-6, branch="middle")
    with pytest.raises(InputError, match=r"^amplitude_m"):
        linear_transmissibility(ref, payload, 1.0, amplitude_m=0.0)


# --------------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------------


@pytest.fixture
def cli_main(monkeypatch):
    from isodesign import cli

    monkeypatch.setitem(cli.COMMANDS, "response", ("isodesign.commands.response", "band response"))
    monkeypatch.setitem(
        cli.COMMANDS, "transmissibility", ("isodesign.commands.transmissibility", "harmonic T")
    )
    return cli.main


def test_cli_response(cli_main, tmp_path, capsys):
    out = tmp_path / "bands.csv"
    assert cli_main(["response", "-o", str(out), "--spacing-m", "0.8", "--cg-height-m", "0.3"]) == 0
    text = capsys.readouterr().out
    # the default target is the built-in default study's (VC-C); peak |T| in dB (issue 14)
    assert "FAIL: VC-C exceeded" in text and "worst band 2 Hz" in text and "tilt margin" in text
    assert "scope: vertical" in text
    # without a study the closure is the study default's: with the distortion power, so
    # the command's figures are band_response's with distortion=True
    assert "random closure statistical, with the distortion power (from defaults)" in text
    r = band_response(SpringDesign.reference(), Payload(400.0, 4),
                      FloorSpectrum.from_criterion("VC-A"), "VC-C", distortion=True)
    s = r.stability
    assert (f"peak |T| {20 * math.log10(s.excited_peak_transmissibility):.2f} dB at "
            f"{s.excited_peak_frequency_hz:.4g} Hz (at A*)") in text
    assert "peak |T| 12.25 dB at 1.862 Hz (at A*)" in text  # docs/response.md's listing
    import pandas as pd

    df = pd.read_csv(out)
    assert len(df) == 20 and "margin_db" in df
    assert cli_main(["response", "--target", "ISO-office", "--points-per-band", "20"]) == 0
    assert "PASS: ISO-office met in all 20 bands" in capsys.readouterr().out


def test_cli_transmissibility(cli_main, tmp_path, capsys):
    out = tmp_path / "t.csv"
    args = ["transmissibility", "--floor-amplitude", "1,10um", "--freq", "1:4:12", "-o", str(out)]
    assert cli_main(args) == 0
    assert "peak |T|" in capsys.readouterr().out
    import pandas as pd

    assert len(pd.read_csv(out)) == 24


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["response", "--payload-kg", "-5"], "--payload-kg"),
        (["response", "--isolators", "0"], "--isolators"),
        (["response", "--floor", "VC-Z"], "floor"),
        (["response", "--target", "nope"], "target"),
        (["response", "--bands", "1-80"], "--bands"),
        (["response", "missing.toml"], "missing.toml"),
        (["transmissibility", "--freq", "0.5:50"], "--freq"),
        (["transmissibility", "--floor-amplitude", "-1"], "--floor-amplitude"),
    ],
)
def test_cli_bad_input(cli_main, capsys, argv, needle):
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1


@pytest.mark.slow
def test_cli_plots(cli_main, tmp_path):
    assert cli_main(["response", "--plot", str(tmp_path / "r.png")]) == 0
    assert cli_main(["transmissibility", "--plot", str(tmp_path / "t.png")]) == 0
    assert (tmp_path / "r.png").stat().st_size > 1000
    assert (tmp_path / "t.png").stat().st_size > 1000
