"""The distributed acoustic model (tube as a lossy line, chambers with modes), verified.

The reference solution here is written independently of the package: the linear acoustic
wave equations of the low-reduced-frequency theory, ``dp/dx = -z Q``, ``dQ/dx = -y p``, with
``z`` and ``y`` from scipy's Bessel functions, solved by second-order finite differences on
a staggered grid through top chamber, tube and bottom chamber (docs/acoustics.md).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy import special

from isodesign.spring.acoustics import acoustic_network
from isodesign.spring.capillary import (
    describing_velocity,
    poiseuille_resistance,
    womersley_number,
    womersley_zeta,
)
from isodesign.spring.chamber import (
    chamber_dimensions,
    first_longitudinal_mode_hz,
    first_transverse_mode_hz,
    polytropic_index,
)
from isodesign.spring.design import SpringDesign
from isodesign.spring.equations import air_stiffness
from isodesign.spring.flow_models import resistance_function
from isodesign.spring.stiffness import complex_stiffness, stiffness_function
from isodesign.spring.transmission_line import (
    thermal_function,
    tube_series_impedance,
    tube_shunt_admittance,
    tube_two_port,
)

KAPPA = 1.4


def _g_bessel(s):
    """2 J1(z)/(z J0(z)), z = i^(3/2) s, straight from scipy (independent of the package)."""
    z = np.exp(0.75j * np.pi) * np.asarray(s, dtype=float)
    return 2.0 * special.jv(1, z) / (z * special.jv(0, z))


def _long_tube():
    """The reference spring with a 1 m capillary of 1.5 mm (issue 16's long-tube case)."""
    return SpringDesign.reference().replace(capillary_length_m=1.0, capillary_diameter_m=1.5e-3)


def _large_chamber():
    """V_t0 = 10 L, V_b0 = 40 L, a 0.3 m tube of 2 mm, heavy-table pressure."""
    return SpringDesign.reference().replace(
        volume_ratio=4.0, top_volume_m3=0.01, capillary_length_m=0.3,
        capillary_diameter_m=2e-3, piston_area_m2=0.02, pressure_pa=6e5,
    )


# --------------------------------------------------------------------------------------------
# the independent finite-difference solution
# --------------------------------------------------------------------------------------------
def _segments(d: SpringDesign, omega: float, r_end: complex):
    """(length, z, y, cells) of top chamber, tube, bottom chamber; end resistance r."""
    rho, p0, mu = d.density_kg_m3, d.pressure_pa, d.viscosity_pa_s
    n = d.process_index
    segs = []
    for v in (d.top_volume_m3, d.bottom_volume_m3):
        a = d.chamber_aspect_ratio
        diam = (4.0 * v / (math.pi * a)) ** (1.0 / 3.0)
        length = a * diam
        s = v / length
        segs.append((length, 1j * omega * rho / s, 1j * omega * s / (n * p0)))
    dc, lc = d.capillary_diameter_m, d.capillary_length_m
    ac = math.pi * dc * dc / 4.0
    shear = 0.5 * dc * math.sqrt(omega * rho / mu)
    z = 1j * omega * rho / (ac * (1.0 - _g_bessel(shear)))
    y = 1j * omega * ac / (KAPPA * p0) * (1.0 + (KAPPA - 1.0) * _g_bessel(shear * math.sqrt(0.71)))
    tube = (lc, z, y)
    return [segs[0], tube, segs[1]]


def fd_air_stiffness(d: SpringDesign, omega: float, r_end: complex = 0.0, cells: int = 600):
    """Air stiffness from the staggered-grid finite-difference solution (X = 1 m)."""
    segs = _segments(d, omega, r_end)
    hs, zs, ys = [], [], []
    for length, z, y in segs:
        hs += [length / cells] * cells
        zs += [z] * cells
        ys += [y] * cells
    hs, zs, ys = np.array(hs), np.array(zs), np.array(ys)
    m = hs.size  # pressures at cell centres 0..m-1; volume velocities at faces 0..m
    # unknowns: p (m) then Q (m+1)
    rows, cols, vals, rhs = [], [], [], []
    eq = 0

    def add(r, c, v):
        rows.append(r)
        cols.append(c)
        vals.append(v)

    # continuity in each cell: Q[i+1] - Q[i] + y h p[i] = 0
    for i in range(m):
        add(eq, m + i + 1, 1.0)
        add(eq, m + i, -1.0)
        add(eq, i, ys[i] * hs[i])
        rhs.append(0.0)
        eq += 1
    # momentum at interior faces: p[i] - p[i-1] + (z_{i-1} h_{i-1}/2 + z_i h_i/2 + r) Q[i] = 0
    junctions = {cells, 2 * cells}
    for i in range(1, m):
        add(eq, i, 1.0)
        add(eq, i - 1, -1.0)
        zz = 0.5 * (zs[i - 1] * hs[i - 1] + zs[i] * hs[i]) + (r_end if i in junctions else 0.0)
        add(eq, m + i, zz)
        rhs.append(0.0)
        eq += 1
    # piston face: Q[0] = j w A_p X; closed end: Q[m] = 0
    add(eq, m, 1.0)
    rhs.append(1j * omega * d.piston_area_m2)
    eq += 1
    add(eq, 2 * m, 1.0)
    rhs.append(0.0)
    eq += 1
    a = sp.csr_matrix((vals, (rows, cols)), shape=(eq, 2 * m + 1), dtype=complex)
    sol = spla.spsolve(a.tocsc(), np.array(rhs, dtype=complex))
    p_piston = sol[0] + 0.5 * zs[0] * hs[0] * sol[m]
    return d.piston_area_m2 * p_piston


def _model_and_fd(d, f_hz, velocity=2.0):
    """(model k_air, FD k_air) for the womersley resistance at a fixed tube velocity."""
    w = 2 * math.pi * np.asarray(f_hz, float)
    c = resistance_function("womersley", d, w)(velocity + 0.0 * w)
    k = air_stiffness(d, w, c, "womersley").to_complex()
    r_end = 0.5 * d.density_kg_m3 * d.minor_loss * describing_velocity(velocity) / (
        2.0 * d.capillary_area_m2)
    k_fd = np.array([fd_air_stiffness(d, wi, r_end) for wi in w])
    return k, k_fd


@pytest.mark.parametrize("case", [_long_tube, _large_chamber], ids=["L_c=1m", "V_b0=40L"])
def test_matches_finite_difference_wave_equation(case):
    """Complex stiffness within 1 % of the FD wave solution, 0.2 Hz to the first chamber mode."""
    d = case()
    f_mode = min(first_longitudinal_mode_hz(d, d.top_volume_m3),
                 first_longitudinal_mode_hz(d, d.bottom_volume_m3))
    f = np.geomspace(0.2, f_mode, 40)
    k, k_fd = _model_and_fd(d, f)
    err = np.abs(k - k_fd) / np.abs(k_fd)
    assert np.max(err) < 0.01, (f[np.argmax(err)], np.max(err))
    # and the lumped model does not: it misses the tube's waves by far more than 1 %
    kl = air_stiffness(d.replace(acoustics="lumped"), 2 * math.pi * f,
                       resistance_function("womersley", d, 2 * math.pi * f)(2.0 + 0 * f))
    err_l = np.abs(kl.to_complex() - k_fd) / np.abs(k_fd)
    assert np.max(err_l) > 0.05


def test_tube_resonances_in_transmissibility():
    """The tube's first acoustic resonances are where the wave equation puts them.

    Above the suspension resonance ``|T| ~ |k| / (m w^2)``; the tube's half-wave
    resonances (a 2 m tube between two large volumes: near ``n c / (2 L)``) are the
    maxima of ``|T| f^2``, the transmissibility over its mass-line asymptote.
    """
    d = SpringDesign.reference().replace(capillary_length_m=2.0, capillary_diameter_m=5e-3,
                                         volume_ratio=4.0, top_volume_m3=0.004)
    mass = 150.0
    f = np.linspace(20.0, 260.0, 481)
    k, k_fd = _model_and_fd(d, f, velocity=0.5)
    w = 2 * math.pi * f

    def peaks(kk):
        t = np.abs(kk / (kk - mass * w * w)) * f * f
        i = np.flatnonzero((t[1:-1] > t[:-2]) & (t[1:-1] > t[2:])) + 1
        return f[i]

    pm, pf = peaks(k), peaks(k_fd)
    assert len(pm) == 2 and len(pf) == 2
    np.testing.assert_allclose(pm, pf, atol=0.5)  # one grid step
    half_wave = d.speed_of_sound_m_s / (2 * d.capillary_length_m)
    np.testing.assert_allclose(pm / half_wave, [1.0, 2.0], rtol=0.03)
    # the lumped model has no resonance there
    kl = air_stiffness(d.replace(acoustics="lumped"), w,
                       resistance_function("womersley", d, w)(0.5 + 0 * w))
    assert len(peaks(kl.to_complex())) == 0


# --------------------------------------------------------------------------------------------
# limits and backends
# --------------------------------------------------------------------------------------------
def test_thermal_function_matches_bessel_both_backends():
    s = np.geomspace(2e-3, 500.0, 301)
    g = thermal_function(s).to_complex()
    np.testing.assert_allclose(g, _g_bessel(s), rtol=1e-10)
    sx = ca.SX.sym("s")
    gx = thermal_function(sx)
    fn = ca.Function("g", [sx], [gx.re, gx.im])
    got = np.array([complex(*(float(v) for v in fn(si))) for si in s])
    np.testing.assert_allclose(got, _g_bessel(s), rtol=1e-8)


def test_low_frequency_limit_is_womersley_tube_with_inertance(ref):
    """The line's series impedance is the Womersley tube: rho C_u zeta per length, inertance
    (4/3) rho L/A_c at low frequency to 1e-6; the two-port's series element is that times
    ``sinh(theta)/theta = 1 + z y L^2 / 6 + ...`` (the distributed correction)."""
    d = _long_tube()
    w = 2 * math.pi * np.array([1e-4, 1e-3])
    ch, b, c = tube_two_port(d, w)
    z = tube_series_impedance(d, w) * d.capillary_length_m
    y = tube_shunt_admittance(d, w) * d.capillary_length_m
    zeta = womersley_zeta(womersley_number(d, w))
    c_u = poiseuille_resistance(d)
    rho = d.density_kg_m3
    np.testing.assert_allclose(z.to_complex(), rho * c_u * zeta.to_complex(), rtol=1e-12)
    np.testing.assert_allclose(z.im / w, 4.0 / 3.0 * rho * d.capillary_length_m
                               / d.capillary_area_m2, rtol=1e-6)
    zy = (z * y).to_complex()
    np.testing.assert_allclose(b.to_complex(), z.to_complex() * (1 + zy / 6 + zy**2 / 120),
                               rtol=1e-9)
    # the shunt element is the tube's isothermal volume
    vol = d.capillary_area_m2 * d.capillary_length_m
    np.testing.assert_allclose(c.im / w, vol / d.pressure_pa, rtol=1e-3)
    np.testing.assert_allclose(ch.to_complex(), 1 + zy / 2, rtol=1e-9)


@pytest.mark.parametrize("flow", ["womersley", "quasi_steady"])
def test_low_frequency_stiffness_is_the_lumped_one(ref, flow):
    """At low frequency the distributed spring is Eq. 38 plus the tube's own small volume."""
    w = 2 * math.pi * np.geomspace(1e-3, 0.2, 8)
    c = resistance_function(flow, ref, w)(0.3 + 0 * w)
    k = air_stiffness(ref, w, c, flow).to_complex()
    kl = air_stiffness(ref.replace(acoustics="lumped"), w, c).to_complex()
    v_tube = ref.capillary_area_m2 * ref.capillary_length_m
    bound = 1.5 * KAPPA * v_tube / ref.total_volume_m3
    assert np.max(np.abs(k / kl - 1)) < bound


def test_casadi_equals_numpy():
    d = _large_chamber()
    fn = stiffness_function(d, flow="womersley")
    f = np.array([0.3, 3.0, 30.0, 120.0])
    x = 2e-4
    res = complex_stiffness(d, f, x, flow="womersley", warn=False)
    for i, fi in enumerate(f):
        kr, ki, u = (float(v) for v in fn(d.volume_ratio, d.top_volume_m3,
                                          d.capillary_length_m, d.capillary_diameter_m, fi, x))
        assert complex(kr, ki) == pytest.approx(res.k[i], rel=1e-7)
        assert u == pytest.approx(res.diagnostics.velocity_amplitude_m_s[i], rel=1e-7)


def test_chamber_shape_and_modes(ref):
    length, diam = chamber_dimensions(ref.replace(chamber_aspect_ratio=2.0), 1e-3)
    assert length == pytest.approx(2 * diam)
    assert math.pi * diam**2 / 4 * length == pytest.approx(1e-3)
    c = ref.speed_of_sound_m_s
    v = 0.04
    lo, di = chamber_dimensions(ref, v)
    assert first_longitudinal_mode_hz(ref, v) == pytest.approx(c / (2 * lo))
    assert first_transverse_mode_hz(ref, v) == pytest.approx(1.8412 * c / (math.pi * di))
    # the top chamber's stiffness has its pole at the blocked chamber's half-wave mode
    d = ref.replace(capillary_diameter_m=1e-4, capillary_length_m=0.5)  # tube nearly shut
    f0 = first_longitudinal_mode_hz(d, d.top_volume_m3)
    net = acoustic_network(d, 2 * math.pi * np.array([0.98 * f0, 1.02 * f0]), "womersley")
    k = net.stiffness(net.c_womersley).to_complex()
    assert k[0].real < 0 < k[1].real  # the pole of the piston-driven closed pipe


def test_heat_exchange_polytropic_index(ref):
    d = ref.replace(chamber_heat_exchange=True)
    w = 2 * math.pi * np.array([1e-6, 1e6])
    n = polytropic_index(d, d.top_volume_m3, w).to_complex()
    assert n[0].real == pytest.approx(1.0, rel=1e-3)
    assert n[1].real == pytest.approx(KAPPA, rel=1e-2)
    # in between it dissipates (a loss factor from the walls)
    nm = polytropic_index(d, d.top_volume_m3, 2 * math.pi * np.geomspace(0.01, 100, 9))
    assert np.all(nm.im > 0) and np.all((nm.re > 1) & (nm.re < KAPPA))
    with pytest.raises(Exception, match="chamber_heat_exchange"):
        ref.replace(chamber_heat_exchange=True, polytropic_index=1.2)


def test_validity_flags_transverse_mode(ref):
    d = _large_chamber()
    ft = first_transverse_mode_hz(d, d.bottom_volume_m3)
    res = complex_stiffness(d, [10.0, 1.1 * ft], 1e-4, flow="womersley", warn=False)
    ok = res.diagnostics.checks["chamber_plane_wave"]
    assert ok.tolist() == [True, False]
    assert "lumped" not in res.diagnostics.checks
    lumped = complex_stiffness(d.replace(acoustics="lumped"), [10.0], 1e-4, warn=False)
    assert "lumped" in lumped.diagnostics.checks


def test_paper_models_stay_lumped(ref):
    res = complex_stiffness(ref, 2.0, 1e-4, flow="zhao", amplitude_mode="kinematic", warn=False)
    assert res.design.acoustics == "lumped"
    assert complex_stiffness(ref, 2.0, 1e-4, warn=False).design.acoustics == "distributed"


def test_network_is_passive_for_random_inputs():
    rng = np.random.default_rng(3)
    for _ in range(30):
        d = SpringDesign.reference().replace(
            volume_ratio=float(np.exp(rng.uniform(-1, 2.3))),
            top_volume_m3=float(np.exp(rng.uniform(np.log(2e-4), np.log(0.05)))),
            capillary_length_m=float(np.exp(rng.uniform(np.log(0.01), np.log(3.0)))),
            capillary_diameter_m=float(np.exp(rng.uniform(np.log(3e-4), np.log(5e-3)))),
        )
        w = 2 * math.pi * np.geomspace(0.05, 2000, 50)
        c = resistance_function("quasi_steady", d, w)(float(np.exp(rng.uniform(-5, 4))) + 0 * w)
        k = air_stiffness(d, w, c, "quasi_steady")
        assert np.all(np.isfinite(k.re)) and np.all(k.im >= -1e-9 * np.abs(k.re))



def test_numbers_quoted_in_docs_acoustics(ref):
    """docs/acoustics.md: h = 1.7 cm and n = 1.36, 1.38 (0.2, 1 Hz) for the reference top
    chamber; 5e-6 low-frequency difference (tube volume); 0.7 % at 80 Hz."""
    d = ref.replace(chamber_heat_exchange=True)
    length, diam = chamber_dimensions(d, d.top_volume_m3)
    h = d.top_volume_m3 / (math.pi * diam * (length + 0.5 * diam))
    assert f"{100 * h:.1f}" == "1.7"
    n = polytropic_index(d, d.top_volume_m3, 2 * math.pi * np.array([0.2, 1.0]))
    assert [f"{v:.2f}" for v in n.re] == ["1.36", "1.38"]
    tube = KAPPA * ref.capillary_area_m2 * ref.capillary_length_m / ref.total_volume_m3
    assert f"{tube:.0e}" == "5e-06"
    w = 2 * math.pi * np.array([80.0])
    c = resistance_function("womersley", ref, w)(np.array([1.0]))
    k = air_stiffness(ref, w, c, "womersley").to_complex()
    kl = air_stiffness(ref.replace(acoustics="lumped"), w, c).to_complex()
    assert f"{100 * abs(k[0] / kl[0] - 1):.1f}" == "0.7"


def test_lumped_chamber_limit_quoted_in_docs_acoustics():
    """docs/acoustics.md: a chamber judged to the 80 Hz band's upper edge must stay below
    5.85 L for the lumped model (w V^(1/3) / c <= 0.98 x 0.3 at 293.15 K)."""
    from isodesign.floor.bands import third_octave_bands
    from isodesign.spring.diagnostics import LUMPED_LIMIT

    f_top = float(third_octave_bands(80.0, 80.0).upper_hz[-1])
    c = SpringDesign.reference().replace(temperature_k=293.15).speed_of_sound_m_s
    v_max = (0.98 * LUMPED_LIMIT * c / (2 * math.pi * f_top)) ** 3
    assert f"{v_max * 1e3:.2f}" == "5.85"
