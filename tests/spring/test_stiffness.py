"""Tests of the spring model k*(X_p, w): isodesign.spring.stiffness, capillary, diaphragm.

Every expected value comes from outside the code under test: analytic limits of
Eq. 38, the three-parameter (Zener) isolator of docs/physics.md, section 5, the
paper's equations written out by hand with plain NumPy, published friction
laws, the Womersley asymptotes, central finite differences, and an independent
harmonic-balance table (laminar friction + K, docs/physics.md, section 3).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from isodesign.errors import InputError, ModelValidityWarning
from isodesign.spring.capillary import (
    churchill_friction_factor,
    churchill_friction_re_product,
    poiseuille_resistance,
    womersley_zeta,
)
from isodesign.spring.design import SpringDesign
from isodesign.spring.equations import driven_velocity
from isodesign.spring.flow_models import resistance
from isodesign.spring.stiffness import complex_stiffness, stiffness_function

# --------------------------------------------------------------------------------------------
# The paper's Table 1, written out here (not read from isodesign) for the hand computations
# --------------------------------------------------------------------------------------------
KAPPA = 1.4
R_GAS = 286.9
T0 = 288.1
P0 = 4.93e5
MU = 1.79e-5
K_MINOR = 1.5
V_T0 = 8.1e-4
V_B0 = 1.5e-3
L_C = 1.2e-2
D_C = 0.9e-3
A_P = 5.3e-3
N_REF = V_B0 / V_T0
RHO = P0 / (R_GAS * T0)
A_C = math.pi * D_C**2 / 4.0
K_S = KAPPA * P0 * A_P**2 / V_T0  # Eq. 40

SMOOTH_FLOWS = ("quasi_steady", "womersley", "poiseuille")
MODES = ("self_consistent", "kinematic")
DESIGN_FIELDS = ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m")

pytestmark = pytest.mark.filterwarnings("ignore::isodesign.errors.ModelValidityWarning")



def k_of(design, f, x, **kw) -> np.ndarray:
    """Complex stiffness as a plain complex array (warnings off)."""
    return complex_stiffness(design, f, x, warn=False, **kw).k


# --------------------------------------------------------------------------------------------
# Reference numbers of docs/physics.md, section 1
# --------------------------------------------------------------------------------------------
def test_reference_design_numbers(ref):
    assert ref.volume_ratio == pytest.approx(N_REF, rel=1e-15)
    assert ref.single_chamber_stiffness_n_per_m == pytest.approx(K_S, rel=1e-14)
    assert round(K_S) == 23935
    assert round(K_S / (N_REF + 1)) == 8393
    assert poiseuille_resistance(ref) == pytest.approx(
        128 * MU * L_C / (math.pi * RHO * D_C**4), rel=1e-14
    )
    assert poiseuille_resistance(ref) == pytest.approx(2.234e6, rel=2e-3)  # hand value
    assert ref.load_n / 9.80665 == pytest.approx(212, abs=0.5)  # ~212 kg, not 100 kg


# --------------------------------------------------------------------------------------------
# Analytic limits of Eq. 38 without diaphragm
# --------------------------------------------------------------------------------------------
# From Eq. 38, exactly: k/k0 - 1 = N jwt/(N+1+jwt) with k0 = k_s/(N+1), and
# k/k_s - 1 = -N/(N+1+jwt), with jwt = jw V_b0 C/(R T0 kappa). Every smooth model
# has Re C >= C_u (Churchill's f Re >= 64, Womersley's Re zeta >= 1, K >= 0; checked
# below), so |N+1+jwt| >= w s Re C >= w s C_u and |k/k_s - 1| <= N/(w s C_u): a
# rigorous tolerance at high frequency. At low frequency C -> C_u (+ the vanishing
# K and inertance terms), so |k/k0 - 1| ~ N w s C_u/(N+1); we allow 10 times that.
LIMIT_DESIGNS = {
    "reference": {},
    "N=0.5": {"volume_ratio": 0.5},
    "N=6,long tube": {"volume_ratio": 6.0, "capillary_length_m": 0.2},
    "small chamber": {"top_volume_m3": 1e-4, "capillary_diameter_m": 2e-3},
}


@pytest.mark.parametrize("changes", LIMIT_DESIGNS.values(), ids=LIMIT_DESIGNS.keys())
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("flow", SMOOTH_FLOWS)
def test_frequency_limits_without_diaphragm(ref, flow, mode, changes):
    """Eq. 38's limits k_s/(N+1) and k_s (the lumped model; the distributed one's are in
    tests/spring/test_acoustics.py)."""
    d = ref.replace(acoustics="lumped", **changes)
    n, ks = d.volume_ratio, d.single_chamber_stiffness_n_per_m
    s = d.bottom_volume_m3 / (KAPPA * R_GAS * T0)
    c_u = poiseuille_resistance(d)
    amps = np.array([1e-6, 1e-4, 1e-3])
    f_lo, f_hi = 1e-6, 1e6
    w_lo, w_hi = 2 * math.pi * f_lo, 2 * math.pi * f_hi
    k_lo = k_of(d, f_lo, amps, flow=flow, amplitude_mode=mode, diaphragm="none")
    k_hi = k_of(d, f_hi, amps, flow=flow, amplitude_mode=mode, diaphragm="none")
    tol_lo = 10 * n * w_lo * s * c_u / (n + 1)
    tol_hi = n / (w_hi * s * c_u)
    assert tol_lo < 1e-3 and tol_hi < 1e-2  # the limits are actually reached there
    assert np.all(np.abs(k_lo / (ks / (n + 1)) - 1) <= tol_lo)
    assert np.all(np.abs(k_hi / ks - 1) <= tol_hi)


@pytest.mark.parametrize("flow", SMOOTH_FLOWS)
def test_resistance_at_least_poiseuille(ref, flow):
    """Re C >= C_u for the smooth models (the premise of the limit tolerances)."""
    w = 2 * math.pi * np.geomspace(1e-3, 1e4, 60)[:, None]
    u = np.geomspace(1e-6, 1e3, 50)[None, :]
    c = resistance(flow, ref, w, u)
    assert np.all(c.re >= poiseuille_resistance(ref) * (1 - 1e-13))
    assert np.all(c.im >= 0)  # inertance, never negative


def test_reference_limits_numbers(ref):
    """docs/physics.md's numbers: 8,393 N/m and 23,935 N/m (literal model too; Eq. 38 is
    the lumped model, whose high-frequency limit is the blocked tube)."""
    lumped = ref.replace(acoustics="lumped")
    for kw in ({"flow": "zhao", "amplitude_mode": "kinematic"}, {}):
        k_lo = k_of(lumped, 1e-6, 1e-4, diaphragm="none", **kw).item()
        k_hi = k_of(lumped, 1e5, 1e-4, diaphragm="none", **kw).item()
        assert k_lo.real == pytest.approx(8393, abs=0.5)
        assert k_hi.real == pytest.approx(23935, abs=1)


# --------------------------------------------------------------------------------------------
# Eq. 38 with Eq. 41 is the Zener (three-parameter) isolator (docs/physics.md, section 5)
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [0.2, 0.5, 1.0, N_REF, 4.0, 10.0])
def test_poiseuille_equals_zener(ref, n):
    d = ref.replace(volume_ratio=n)
    f = np.geomspace(1e-3, 1e3, 301)
    w = 2 * math.pi * f
    c_u = 128 * MU * L_C / (math.pi * RHO * D_C**4)  # Eq. 41
    tau = n * V_T0 * c_u / (R_GAS * T0 * KAPPA)
    k = K_S / (n + 1)
    k1 = n * k
    c = K_S * n * tau / (n + 1) ** 2
    k_zener = k + k1 * (1j * w * c) / (k1 + 1j * w * c)
    for mode in MODES:
        got = k_of(d, f, 1e-4, flow="poiseuille", amplitude_mode=mode, diaphragm="none")
        np.testing.assert_allclose(got.real, k_zener.real, rtol=1e-12)
        np.testing.assert_allclose(got.imag, k_zener.imag, rtol=1e-12)


# --------------------------------------------------------------------------------------------
# The literal paper model against a hand computation (Eqs. 24, 36, 37, 38, 40)
# --------------------------------------------------------------------------------------------
def zhao_by_hand(f_hz: float, x_m: float) -> complex:
    """Eqs. 37, 24, 36, 38 and 40 for Table 1, written out with plain NumPy."""
    w = 2 * np.pi * f_hz
    u_max = (A_P / A_C) * x_m * w  # Eq. 37
    re_w = RHO * w * D_C**2 / MU  # kinetic Reynolds number
    a0 = (u_max / w) / D_C  # x_max / D_c
    fr_o = 4.0 / a0 * (3.27 / (re_w**0.548 - 2.04))  # Eq. 24
    c = (L_C / D_C * fr_o + K_MINOR) * 4.0 * u_max / (3.0 * np.pi * A_C)  # Eq. 36
    jwt = 1j * w * V_B0 * c / (R_GAS * T0 * KAPPA)
    return K_S * (1 + jwt) / (N_REF + 1 + jwt)  # Eq. 38 with Eq. 40


@pytest.mark.parametrize("x_m", [0.05e-3, 0.5e-3])
@pytest.mark.parametrize("f_hz", [0.5, 1.0, 2.0, 3.0, 10.0])
def test_zhao_matches_hand_computation(ref, f_hz, x_m):
    got = k_of(ref, f_hz, x_m, flow="zhao", amplitude_mode="kinematic", diaphragm="none").item()
    want = zhao_by_hand(f_hz, x_m)
    assert abs(got - want) <= 1e-12 * abs(want)


def test_zhao_pole_and_negative_loss_factor(ref):
    """Notes section 2: pole at Re_w = 3.673 (2.17 Hz); eta = -0.55 at 2.0 Hz, 0.05 mm."""
    re_pole = 2.04 ** (1 / 0.548)
    assert re_pole == pytest.approx(3.673, abs=5e-4)
    f_pole = re_pole * MU / (2 * math.pi * RHO * D_C**2)
    assert f_pole == pytest.approx(2.17, abs=0.01)
    res = complex_stiffness(
        ref, 2.0, 0.05e-3, flow="zhao", amplitude_mode="kinematic", diaphragm="none", warn=False
    )
    assert res.loss_factor.item() == pytest.approx(-0.55, abs=0.005)
    assert res.loss_factor.item() == pytest.approx(
        zhao_by_hand(2.0, 0.05e-3).imag / zhao_by_hand(2.0, 0.05e-3).real, rel=1e-12
    )
    # the friction changes sign across the pole: C -> -inf below, +inf above, so the air
    # spring goes to the blocked value k_s right at the pole
    k_at_pole = zhao_by_hand(f_pole * (1 + 1e-9), 0.05e-3)
    assert k_at_pole.real == pytest.approx(K_S, rel=1e-4)


def test_zhao_flagged_non_passive(ref):
    with pytest.warns(ModelValidityWarning, match="passive"):
        res = complex_stiffness(ref, 2.0, 0.05e-3, flow="zhao", amplitude_mode="kinematic")
    assert not res.diagnostics.checks["passive"].item()
    assert not res.valid.item()
    assert res.k.imag.item() < 0
    # and out of the correlation's stated range (Re_w 23-395, A0 <= 26.4) all over Fig. 11
    res = complex_stiffness(
        ref,
        [0.2, 2.0, 24.0],
        [0.05e-3, 0.5e-3],
        flow="zhao",
        amplitude_mode="kinematic",
        warn=False,
    )
    assert not res.diagnostics.checks["zhao_a0"].any()
    np.testing.assert_allclose(
        res.diagnostics.dimensionless_amplitude[0], [463.0, 4630.0], rtol=2e-3
    )  # independent value: A0 = 463 and 4,630
    assert not res.diagnostics.checks["zhao_re_w"][:2].any()


# --------------------------------------------------------------------------------------------
# The paper's main observation: the loss-factor peak moves down as the amplitude grows
# --------------------------------------------------------------------------------------------
TABLE2_AMPLITUDES_M = np.array([0.05, 0.06, 0.07, 0.08, 0.09, 0.10, 0.15, 0.20, 0.30, 0.40, 0.50])
TABLE2_AMPLITUDES_M = TABLE2_AMPLITUDES_M * 1e-3
F_PEAK_GRID = np.geomspace(0.2, 24.0, 1500)


def peak_frequencies(design, amps, exclude=None, **kw) -> np.ndarray:
    eta = complex_stiffness(design, F_PEAK_GRID, amps, warn=False, **kw).loss_factor
    if exclude is not None:
        eta = np.where(exclude[:, None], -np.inf, eta)
    return F_PEAK_GRID[np.argmax(eta, axis=0)]


@pytest.mark.parametrize("flow", ["quasi_steady", "womersley"])
def test_peak_frequency_falls_with_amplitude_self_consistent(ref, flow):
    fp = peak_frequencies(ref, TABLE2_AMPLITUDES_M, flow=flow)
    assert np.all(np.diff(fp) <= 0)
    assert fp[0] > 3.0 and fp[-1] < 1.3  # measured: about 4 Hz -> 1 Hz (paper, Section 2)


@pytest.mark.parametrize("diaphragm", ["viscoelastic", "none"])
def test_peak_frequency_falls_with_amplitude_zhao(ref, diaphragm):
    """Fig. 11 amplitudes; the narrow spike on the flank of the pole is excluded."""
    f_pole = 2.04 ** (1 / 0.548) * MU / (2 * math.pi * RHO * D_C**2)
    near_pole = np.abs(F_PEAK_GRID / f_pole - 1) < 0.1
    fp = peak_frequencies(
        ref,
        np.array([0.05e-3, 0.15e-3, 0.5e-3]),
        exclude=near_pole,
        flow="zhao",
        amplitude_mode="kinematic",
        diaphragm=diaphragm,
    )
    assert np.all(np.diff(fp) < 0)
    assert 2.5 < fp[0] < 3.2  # independent value: near 3 Hz at 0.05 mm
    assert 0.8 < fp[-1] < 1.1  # independent value: near 1 Hz at 0.5 mm


def test_poiseuille_peak_independent_of_air_amplitude(ref):
    fp = peak_frequencies(ref, TABLE2_AMPLITUDES_M, flow="poiseuille", diaphragm="none")
    assert np.all(fp == fp[0])


# --------------------------------------------------------------------------------------------
# Passivity
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def random_points():
    rng = np.random.default_rng(20241121)
    f = 10 ** rng.uniform(-2, 3, 3000)
    x = 10 ** rng.uniform(-7, -2, 3000)
    return f, x


@pytest.mark.parametrize("diaphragm", ["viscoelastic", "none"])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("flow", SMOOTH_FLOWS)
def test_passive_on_random_grid(ref, random_points, flow, mode, diaphragm):
    f, x = random_points
    res = complex_stiffness(
        ref, f, x, flow=flow, amplitude_mode=mode, diaphragm=diaphragm, pairwise=True, warn=False
    )
    assert np.all(np.isfinite(res.k))
    assert np.all(res.k.imag >= 0)
    assert res.diagnostics.checks["passive"].all()


def test_zhao_not_passive_somewhere_on_random_grid(ref, random_points):
    f, x = random_points
    res = complex_stiffness(
        ref,
        f,
        x,
        flow="zhao",
        amplitude_mode="kinematic",
        diaphragm="none",
        pairwise=True,
        warn=False,
    )
    bad = res.k.imag < 0
    assert bad.any()
    np.testing.assert_array_equal(res.diagnostics.checks["passive"], ~bad)


# --------------------------------------------------------------------------------------------
# CasADi face: values and derivatives
# --------------------------------------------------------------------------------------------
CASADI_POINTS = [(1.0, 0.05e-3), (3.0, 0.05e-3), (5.0, 0.5e-3), (20.0, 0.5e-3), (0.3, 1e-3)]


def _numpy_values(design, f, x, **kw) -> np.ndarray:
    res = complex_stiffness(design, f, x, warn=False, **kw)
    return np.array(
        [res.k.real.item(), res.k.imag.item(), res.diagnostics.velocity_amplitude_m_s.item()]
    )


@pytest.fixture(scope="module")
def casadi_jacobians(ref):
    """For each model: a casadi Function p, f, X -> (values, d values / d p)."""
    import casadi as ca

    out = {}
    for flow in SMOOTH_FLOWS:
        for mode in MODES:
            for dia in ("viscoelastic", "none"):
                fun = stiffness_function(ref, flow=flow, amplitude_mode=mode, diaphragm=dia)
                p = ca.MX.sym("p", 4)
                f, x = ca.MX.sym("f"), ca.MX.sym("x")
                y = ca.vertcat(*fun(p[0], p[1], p[2], p[3], f, x))
                out[flow, mode, dia] = (
                    fun,
                    ca.Function("k_and_jacobian", [p, f, x], [y, ca.jacobian(y, p)]),
                )
    return out


@pytest.mark.parametrize("dia", ["viscoelastic", "none"])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("flow", SMOOTH_FLOWS)
def test_casadi_values_equal_numpy(ref, casadi_jacobians, flow, mode, dia):
    fun, _ = casadi_jacobians[flow, mode, dia]
    p0 = [getattr(ref, k) for k in DESIGN_FIELDS]
    assert fun.name_in() == ["N", "V_t0", "L_c", "D_c", "frequency_hz", "amplitude_m"]
    assert fun.name_out() == ["k_real", "k_imag", "U"]
    for f, x in CASADI_POINTS:
        got = np.array([float(v) for v in fun(*p0, f, x)])
        want = _numpy_values(ref, f, x, flow=flow, amplitude_mode=mode, diaphragm=dia)
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=0)


@pytest.mark.parametrize("dia", ["viscoelastic", "none"])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("flow", SMOOTH_FLOWS)
def test_casadi_derivatives_match_finite_differences(ref, casadi_jacobians, flow, mode, dia):
    """d(k_real, k_imag, U)/d(N, V_t0, L_c, D_c) against central differences of NumPy.

    Compared as logarithmic sensitivities ``p dy/dp`` relative to ``|y|``: the step is
    1e-6 relative, so the truncation error is ~1e-12 and the rounding/solver noise
    ~1e-16/1e-6; 1e-6 leaves a wide margin (the observed error is ~3e-10).
    """
    _, jac = casadi_jacobians[flow, mode, dia]
    p0 = np.array([getattr(ref, k) for k in DESIGN_FIELDS])
    kw = {"flow": flow, "amplitude_mode": mode, "diaphragm": dia}
    for f, x in [(1.0, 0.05e-3), (5.0, 0.5e-3), (20.0, 0.5e-3)]:
        y, jc = (np.asarray(v) for v in jac(p0, f, x))
        y = y.ravel()
        jfd = np.empty((3, 4))
        for i, name in enumerate(DESIGN_FIELDS):
            h = 1e-6 * p0[i]
            yp = _numpy_values(ref.replace(**{name: p0[i] + h}), f, x, **kw)
            ym = _numpy_values(ref.replace(**{name: p0[i] - h}), f, x, **kw)
            jfd[:, i] = (yp - ym) / (2 * h)
        scaled_err = np.abs(jc - jfd) * p0[None, :] / np.abs(y)[:, None]
        assert np.max(scaled_err) <= 1e-6, (f, x, scaled_err)
        # the derivatives are not trivially zero (each output depends on the design)
        assert np.all(np.any(np.abs(jc) * p0[None, :] > 1e-3 * np.abs(y)[:, None], axis=1))


def test_casadi_refuses_zhao(ref):
    with pytest.raises(InputError, match="flow"):
        stiffness_function(ref, flow="zhao", amplitude_mode="kinematic")


def test_casadi_turbulent_point_is_turbulent(ref):
    """The derivative checks include the turbulent regime (0.5 mm, 5 Hz)."""
    res = complex_stiffness(ref, 5.0, 0.5e-3, warn=False)
    assert res.diagnostics.regime.item() == "turbulent"


# --------------------------------------------------------------------------------------------
# Womersley impedance: spline against Bessel functions, and asymptotes
# --------------------------------------------------------------------------------------------
def test_womersley_spline_matches_bessel():
    import casadi as ca

    a = ca.SX.sym("alpha")
    z = womersley_zeta(a)
    fun = ca.Function("zeta", [a], [z.re, z.im])
    alpha = np.geomspace(1e-3, 1e3, 30001)
    zr, zi = (np.asarray(v).ravel() for v in fun(alpha))
    exact = womersley_zeta(alpha)
    np.testing.assert_allclose(zr, exact.re, rtol=1e-8)
    np.testing.assert_allclose(zi, exact.im, rtol=1e-8)


def test_womersley_small_alpha_limit():
    alpha = np.geomspace(1e-4, 0.3, 50)
    z = womersley_zeta(alpha)
    lim = 1 + 1j * alpha**2 / 6  # Poiseuille + 4/3 of the plug inertance
    # next term is O(alpha^4)
    assert np.all(np.abs(z.re + 1j * z.im - lim) <= alpha**4 / 500 + 1e-14)


def test_womersley_large_alpha_limit():
    alpha = np.geomspace(20, 1e3, 50)
    z = womersley_zeta(alpha)
    lim = 1j * alpha**2 / 8 + alpha / (4 * math.sqrt(2)) * (1 + 1j)
    rel = np.abs(z.re + 1j * z.im - lim) / np.abs(lim)
    assert np.all(rel <= 4 / alpha**2)  # relative error falls as alpha^-2
    # the resistance grows like alpha/(4 sqrt 2) (boundary layer), not like alpha^2
    np.testing.assert_allclose(z.re / (alpha / (4 * math.sqrt(2))), 1, rtol=0.15)


def test_womersley_model_low_frequency_is_poiseuille(ref):
    c = resistance("womersley", ref, 2 * math.pi * 1e-5, 1e-9)
    assert c.re == pytest.approx(poiseuille_resistance(ref), rel=1e-9)


# --------------------------------------------------------------------------------------------
# Churchill (1977) friction factor
# --------------------------------------------------------------------------------------------
def test_churchill_laminar():
    re = np.geomspace(1e-3, 1000, 200)
    np.testing.assert_allclose(churchill_friction_re_product(re), 64.0, rtol=1e-12)
    np.testing.assert_allclose(churchill_friction_factor(re), 64.0 / re, rtol=1e-12)
    # the turbulent terms start to matter only near the transition
    re = np.geomspace(1000, 1500, 50)
    np.testing.assert_allclose(churchill_friction_re_product(re), 64.0, rtol=1e-7)


def test_churchill_blasius():
    re = np.geomspace(1e4, 1e5, 50)
    blasius = 0.3164 * re**-0.25
    np.testing.assert_allclose(churchill_friction_factor(re), blasius, rtol=0.03)


def test_churchill_smooth_across_transition():
    re = np.arange(1500.0, 4500.0, 0.1)
    f = churchill_friction_factor(re)
    # A laminar/Blasius switch at 2300 would jump by 60 % (0.0278 -> 0.0456). Here
    # neighbours 0.1 apart differ by at most twice the laminar rate |d ln f| = dRe/Re
    # (at Re = 1500: 6.7e-5), and the slope changes gradually (bounded 2nd difference).
    assert np.max(np.abs(np.diff(np.log(f)))) < 2 * 0.1 / 1500
    assert np.max(np.abs(np.diff(f, 2))) < 1e-8
    assert np.all(np.isfinite(f)) and np.all(f > 0)


@pytest.mark.parametrize("roughness", [0.0, 1e-3])
def test_churchill_slope(roughness):
    re = np.geomspace(1.001e3, 1e7, 300)
    phi, dphi = churchill_friction_re_product(re, roughness, with_slope=True)
    h = 1e-6 * re
    fd = (
        churchill_friction_re_product(re + h, roughness)
        - churchill_friction_re_product(re - h, roughness)
    ) / (2 * h)
    np.testing.assert_allclose(phi, churchill_friction_re_product(re, roughness), rtol=1e-15)
    # compare slopes scaled by Re/Phi (log-log slope), since dPhi/dRe crosses zero
    np.testing.assert_allclose(dphi * re / phi, fd * re / phi, atol=1e-6)
    _, d0 = churchill_friction_re_product(np.array([1.0, 500.0]), roughness, with_slope=True)
    np.testing.assert_array_equal(d0, 0.0)


# --------------------------------------------------------------------------------------------
# The self-consistent flow amplitude
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("acoustics", ["lumped", "distributed"])
@pytest.mark.parametrize("flow", SMOOTH_FLOWS)
def test_self_consistent_velocity_is_driven_velocity(ref, random_points, flow, acoustics):
    f, x = random_points
    d = ref.replace(acoustics=acoustics)
    res = complex_stiffness(d, f, x, flow=flow, pairwise=True, warn=False)
    d = res.design  # the paper's poiseuille is lumped by definition
    u = res.diagnostics.velocity_amplitude_m_s
    w = 2 * math.pi * f
    c = resistance(flow, ref, w, u)
    np.testing.assert_allclose(u, driven_velocity(d, w, x, c, flow), rtol=1e-10)
    np.testing.assert_allclose(res.diagnostics.driven_velocity_m_s, u, rtol=1e-10)
    if d.acoustics == "lumped":
        # written out: N (A_p/A_c) X w / |1 + N + j w s C|
        s = N_REF * V_T0 / (KAPPA * R_GAS * T0)
        by_hand = N_REF * (A_P / A_C) * x * w / np.abs(
            1 + N_REF + 1j * w * s * (c.re + 1j * c.im))
        np.testing.assert_allclose(u, by_hand, rtol=1e-10)


# Independent harmonic balance (laminar friction + K = 1.5; docs/physics.md, section 3)
NOTES_TABLE = [  # (X_p, f, U kinematic, U self-consistent)
    (0.05e-3, 0.5, 1.31, 0.85),
    (0.05e-3, 2.0, 5.23, 3.24),
    (0.05e-3, 20.0, 52.3, 6.60),
    (0.5e-3, 2.0, 52.3, 20.6),
    (0.5e-3, 20.0, 523.0, 23.3),
]


@pytest.mark.parametrize(("x", "f", "u_kin", "u_sc"), NOTES_TABLE)
def test_harmonic_balance_velocity_table(ref, x, f, u_kin, u_sc):
    kin = complex_stiffness(ref, f, x, flow="zhao", amplitude_mode="kinematic", warn=False)
    assert kin.diagnostics.velocity_amplitude_m_s.item() == pytest.approx(u_kin, rel=0.01)
    # womersley = laminar friction + K, like the notes (plus the exact unsteady inertia)
    wo = complex_stiffness(ref, f, x, flow="womersley", warn=False)
    assert wo.diagnostics.velocity_amplitude_m_s.item() == pytest.approx(u_sc, rel=0.03)
    # quasi_steady has turbulent friction where Re > 2300 (0.5 mm): lower U, within 10 %
    qs = complex_stiffness(ref, f, x, warn=False)
    assert qs.diagnostics.velocity_amplitude_m_s.item() == pytest.approx(u_sc, rel=0.10)


def test_kinematic_velocity_supersonic_flagged(ref):
    res = complex_stiffness(ref, 20.0, 0.5e-3, flow="zhao", amplitude_mode="kinematic", warn=False)
    assert res.diagnostics.velocity_amplitude_m_s.item() == pytest.approx(523, rel=2e-3)
    assert res.diagnostics.mach.item() > 1
    assert not res.diagnostics.checks["mach"].item()
    assert not res.diagnostics.checks["kinematic_consistency"].item()


# --------------------------------------------------------------------------------------------
# Property tests (hypothesis)
# --------------------------------------------------------------------------------------------
def log_uniform(lo: float, hi: float):
    return st.floats(math.log(lo), math.log(hi)).map(math.exp)


designs = st.builds(
    lambda n, v, lc, dc, p0: (n, v, lc, dc, p0),
    log_uniform(0.2, 10.0),
    log_uniform(1e-5, 1e-2),
    log_uniform(1e-3, 1.0),
    log_uniform(1e-4, 5e-3),
    log_uniform(1.2e5, 1e6),
)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    params=designs,
    freqs=st.lists(log_uniform(0.01, 1000.0), min_size=1, max_size=6),
    amps=st.lists(log_uniform(1e-7, 5e-3), min_size=1, max_size=6),
    flow=st.sampled_from(SMOOTH_FLOWS),
    mode=st.sampled_from(MODES),
    diaphragm=st.sampled_from(["viscoelastic", "none"]),
)
def test_random_valid_designs_finite_and_passive(params, freqs, amps, flow, mode, diaphragm):
    n, v, lc, dc, p0 = params
    assume(dc < lc)
    d = SpringDesign.reference().replace(
        volume_ratio=n,
        top_volume_m3=v,
        capillary_length_m=lc,
        capillary_diameter_m=dc,
        pressure_pa=p0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        res = complex_stiffness(d, freqs, amps, flow=flow, amplitude_mode=mode, diaphragm=diaphragm)
    assert np.all(np.isfinite(res.k))
    assert np.all(res.k.imag >= 0)
    # (Re k may be negative: above the air-slug resonance of a small-volume, long-tube
    # design the driven-point stiffness of chamber-slug-chamber is negative; not a bug.)
    assert np.all(np.isfinite(res.diagnostics.velocity_amplitude_m_s))
    # Without inertance (poiseuille), Re k_air >= k_s/(N+1): from Eq. 38,
    # Re k/k0 - 1 = N (w tau)^2 / |N+1+jw tau|^2 >= 0. (The air slug's inertance of the
    # other models may lower it below the static value under the slug resonance.)
    if flow == "poiseuille":
        assert np.all(res.k_air.real >= d.static_stiffness_n_per_m * (1 - 1e-12))


BAD_NUMBERS = [0.0, -1.0, -1e-9, math.nan, math.inf, -math.inf]


@given(
    field=st.sampled_from(
        [
            "volume_ratio",
            "top_volume_m3",
            "capillary_length_m",
            "capillary_diameter_m",
            "piston_area_m2",
            "temperature_k",
        ]
    ),
    bad=st.sampled_from(BAD_NUMBERS) | st.floats(max_value=0.0, allow_infinity=False),
)
def test_invalid_design_raises(field, bad):
    with pytest.raises(InputError, match=field) as exc:
        SpringDesign.reference().replace(**{field: bad})
    assert isinstance(exc.value, ValueError)


@given(
    p=st.sampled_from([math.nan, math.inf, -math.inf, 101_325.0, 0.0, -1.0])
    | st.floats(max_value=101_325.0, allow_nan=False)
)
def test_invalid_pressure_raises(p):
    with pytest.raises(InputError, match="pressure_pa"):
        SpringDesign.reference().replace(pressure_pa=p)


def test_diameter_not_below_length_raises():
    with pytest.raises(InputError, match="capillary_diameter_m"):
        SpringDesign.reference().replace(capillary_diameter_m=0.02, capillary_length_m=0.01)


@given(
    which=st.sampled_from(["frequency_hz", "amplitude_m"]),
    bad=st.sampled_from(BAD_NUMBERS) | st.floats(max_value=0.0, allow_infinity=False),
    flow=st.sampled_from(("quasi_steady", "womersley", "poiseuille", "zhao")),
)
def test_invalid_frequency_or_amplitude_raises(which, bad, flow):
    mode = "kinematic" if flow == "zhao" else "self_consistent"
    args = {"frequency_hz": [1.0, bad], "amplitude_m": 1e-4}
    if which == "amplitude_m":
        args = {"frequency_hz": 1.0, "amplitude_m": [bad, 1e-4]}
    with pytest.raises(InputError, match=which):
        complex_stiffness(SpringDesign.reference(), **args, flow=flow, amplitude_mode=mode)


@given(name=st.text(min_size=0, max_size=12))
def test_unknown_model_names_raise(name):
    assume(name not in ("quasi_steady", "womersley", "poiseuille", "zhao", "zhao_turbulent"))
    d = SpringDesign.reference()
    with pytest.raises(InputError, match="flow"):
        complex_stiffness(d, 1.0, 1e-4, flow=name)
    assume(name not in ("self_consistent", "kinematic"))
    with pytest.raises(InputError, match="amplitude_mode"):
        complex_stiffness(d, 1.0, 1e-4, amplitude_mode=name)
    assume(name not in ("viscoelastic", "none", "table") and not name.lower().endswith(".csv"))
    assume(not name.startswith("table:"))
    with pytest.raises(InputError, match="diaphragm"):
        complex_stiffness(d, 1.0, 1e-4, diaphragm=name)


def test_zhao_self_consistent_refused(ref):
    with pytest.raises(InputError, match="amplitude_mode"):
        complex_stiffness(ref, 1.0, 1e-4, flow="zhao", amplitude_mode="self_consistent")


# --------------------------------------------------------------------------------------------
# Diaphragm defaults (illustrative, as documented) and Eq. 42
# --------------------------------------------------------------------------------------------
def test_viscoelastic_defaults_as_documented(ref):
    res = complex_stiffness(ref, 1.0, [0.05e-3, 0.5e-3], warn=False)
    kd = res.k_diaphragm
    np.testing.assert_allclose(kd.real, [8030, 5010], rtol=2e-3)  # ~8 kN/m -> ~5 kN/m
    eta = kd.imag / kd.real
    assert 0.08 <= eta[0] <= 0.09 and 0.19 <= eta[1] <= 0.2
    np.testing.assert_allclose(res.k, res.k_air + res.k_diaphragm, rtol=1e-15)  # Eq. 42
