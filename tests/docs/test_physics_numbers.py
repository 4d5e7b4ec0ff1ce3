"""Every number quoted in docs/physics.md, recomputed from the code (or by quadrature).

If one of these fails, the page and the code disagree: fix the page (or the code), never the
tolerance.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, optimize, special

from isodesign.response.isolator import tilt_margin, zener_optimum, zener_transmissibility
from isodesign.spring.amplitude import solve_velocity_amplitude
from isodesign.spring.capillary import (
    QUASI_STEADY_WOMERSLEY_LIMIT,
    ZHAO_RANGES,
    kinetic_reynolds,
    poiseuille_resistance,
    womersley_number,
    womersley_zeta,
)
from isodesign.spring.equations import kinematic_velocity
from isodesign.spring.stiffness import complex_stiffness

PAGE = (Path(__file__).parents[2] / "docs" / "physics.md").read_text(encoding="utf-8")


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in " ".join(PAGE.split()), text


def test_section_1_reference_spring(ref):
    quoted(f"k_s = n p0 A_p^2 / V_t0 = {ref.single_chamber_stiffness_n_per_m:,.0f} N/m")
    quoted(f"N = V_b0/V_t0 = {ref.volume_ratio:.3f}")
    quoted(f"k_s/(N+1) = {ref.static_stiffness_n_per_m:,.0f} N/m")
    quoted(f"= {poiseuille_resistance(ref):.3e} Pa s/kg".replace("e+06", "e6"))
    quoted(f"rho = p0/(R T0) = {ref.density_kg_m3:.2f} kg/m^3")
    quoted(f"p0 = {ref.pressure_pa:.2e} Pa".replace("e+05", "e5"))
    quoted(f"A_p (p0 - p_atm) = {ref.load_n:,.0f} N")
    assert round(ref.load_n / 9.80665) == 212
    quoted("about\n212 kg")


def test_section_2_zhao_pole_and_sign(ref):
    per_w = kinetic_reynolds(ref, 1.0)
    quoted(f"Re_w = {per_w:.3f} w")
    lo, hi = kinetic_reynolds(ref, 2 * math.pi * 0.2), kinetic_reynolds(ref, 2 * math.pi * 24)
    quoted(f"{lo:.2f} to {hi:.1f} over 0.2 to 24 Hz")
    pole = 2.04 ** (1 / 0.548)
    quoted(f"Re_w = 2.04^(1/0.548) = {pole:.3f}")
    quoted(f"that is at\n{pole / per_w / (2 * math.pi):.2f} Hz")
    assert ZHAO_RANGES["laminar"] == (23.0, 395.0, 0.0, 26.4)
    assert ZHAO_RANGES["turbulent"] == (81.0, 540.0, 53.4, 113.5)
    etas = []
    for f in (1.9, 2.0, 2.1):
        r = complex_stiffness(
            ref, f, 5e-5, flow="zhao", amplitude_mode="kinematic", diaphragm="none", warn=False
        )
        etas.append(r.loss_factor.item())
        assert not r.diagnostics.checks["passive"].item()
    e1, e2, e3 = etas
    quoted(f"at 0.05 mm is {e1:.2f} at 1.9 Hz, {e2:.2f} at 2.0 Hz and {e3:.2f} at 2.1 Hz")


def test_section_3_kinematic_against_driven_velocity(ref):
    w, x = 2 * math.pi * 20.0, 5e-4
    quoted(f"it gives {kinematic_velocity(ref, w, x):.0f} m/s at 0.5 mm and 20 Hz")
    u = [
        solve_velocity_amplitude(flow, ref, np.array([w]), np.array([x])).velocity[0]
        for flow in ("quasi_steady", "womersley")
    ]
    assert 21.0 <= min(u) and max(u) <= 23.5
    quoted("about 21-23 m/s")
    # low frequency: U -> N Q / (N + 1)
    w0 = 2 * math.pi * 1e-3
    u0 = solve_velocity_amplitude("poiseuille", ref, np.array([w0]), np.array([1e-4])).velocity[0]
    q0 = kinematic_velocity(ref, w0, 1e-4)
    assert u0 == pytest.approx(q0 * ref.volume_ratio / (1 + ref.volume_ratio), rel=1e-5)


def test_section_4_womersley(ref):
    a4, a24 = womersley_number(ref, 2 * math.pi * 4), womersley_number(ref, 2 * math.pi * 24)
    quoted(f"`alpha = {a4:.2f}` at 4 Hz and `{a24:.2f}` at 24 Hz")
    quoted(f"`alpha = {QUASI_STEADY_WOMERSLEY_LIMIT}`")
    # the limits, and the quasi-steady model's departure at the flag limit
    for a in (1e-2, 5e-2):
        z = womersley_zeta(np.array([a])).to_complex()[0]
        assert z == pytest.approx(1 + 1j * a * a / 6, rel=1e-6)
    big = 300.0
    z = womersley_zeta(np.array([big])).to_complex()[0]
    assert z == pytest.approx(1j * big**2 / 8 + big * (1 + 1j) / (4 * math.sqrt(2)), rel=1e-3)
    departures = []
    for a in (3.0, QUASI_STEADY_WOMERSLEY_LIMIT, 4.0):
        zq = 1 + 1j * a * a / 6
        zx = womersley_zeta(np.array([a])).to_complex()[0]
        departures.append(abs(zq - zx) / abs(zx))
    quoted(
        f"{departures[0]:.1%} at `alpha = 3`, {departures[1]:.1%} at 3.4,\n{departures[2]:.1%} at 4"
        .replace("%", " %")
    )
    assert departures[1] <= 0.05 < departures[2]


def test_section_5_zener_optimum_numerically(ref):
    n = ref.volume_ratio
    t_max, r_star, z_opt = 1 + 2 / n, math.sqrt(2 * (n + 1) / (n + 2)), n * math.sqrt(
        2 * (n + 2)
    ) / (4 * (n + 1))
    quoted(f"`T_max = {t_max:.3f}` at\n`r* = {r_star:.3f}` with `zeta_opt = {z_opt:.3f}`")
    r = np.linspace(0.2, 3.0, 20001)

    def peak(z):
        return float(np.max(zener_transmissibility(n, z, r)))

    res = optimize.minimize_scalar(peak, bounds=(0.05, 2.0), method="bounded",
                                   options={"xatol": 1e-7})
    assert res.x == pytest.approx(z_opt, rel=1e-3)
    assert res.fun == pytest.approx(t_max, rel=1e-6)
    # the fixed point: every damping passes through it
    for z in (0.05, 0.3, 3.0):
        assert zener_transmissibility(n, z, r_star) == pytest.approx(t_max, rel=1e-12)
    assert zener_optimum(n)[2] == pytest.approx(z_opt, rel=1e-12)


def test_section_7_describing_functions():
    # harmonic: |u|u -> 8A/(3 pi)
    n_df = integrate.quad(lambda t: abs(math.sin(t)) ** 3, 0, 2 * math.pi)[0] / math.pi
    assert n_df == pytest.approx(8 / (3 * math.pi), rel=1e-10)
    # Blasius: the describing velocity against the exact first harmonic
    approx = (8 / (3 * math.pi)) ** 0.75
    exact = 2 / math.pi * integrate.quad(lambda t: math.sin(t) ** 2.75, 0, math.pi)[0]
    quoted(f"`(8/(3 pi))^0.75 = {approx:.3f}`")
    apart = f"{abs(approx / exact - 1):.1%}".replace("%", " %")
    quoted(f"`(2/pi) integral_0^pi sin^2.75 = {exact:.3f}` ({apart} apart)")
    # random: E[|u|^3] / sigma^2 for sigma = 1, and A*
    n_r = integrate.quad(lambda u: abs(u) ** 3 * np.exp(-u * u / 2) / math.sqrt(2 * math.pi),
                         -np.inf, np.inf)[0]
    assert n_r == pytest.approx(math.sqrt(8 / math.pi), rel=1e-10)
    a_star = 3 * math.sqrt(math.pi / 8)
    assert 8 * a_star / (3 * math.pi) == pytest.approx(n_r, rel=1e-12)
    quoted(f"`A* = 3 sqrt(pi/8) sigma = {a_star:.3f} sigma`")


@pytest.mark.parametrize("p", [1.0, 1.75, 2.0, 3.0])
def test_section_7_rayleigh_identity(p):
    """``E[u f(u)]/sigma^2`` equals the Rayleigh average of the harmonic gain, any f."""
    sigma = 0.7

    def f(u):
        return abs(u) ** (p - 1) * u

    def n_df(a):
        return integrate.quad(lambda t: f(a * math.sin(t)) * math.sin(t), 0, 2 * math.pi)[0] / (
            math.pi * a
        )

    gauss = integrate.quad(
        lambda u: u * f(u) * math.exp(-u * u / (2 * sigma**2)), -np.inf, np.inf
    )[0] / (math.sqrt(2 * math.pi) * sigma**3)
    rayleigh = integrate.quad(
        lambda a: n_df(a) * a**3 / (2 * sigma**4) * math.exp(-a * a / (2 * sigma**2)), 0, 12
    )[0]
    assert rayleigh == pytest.approx(gauss, rel=1e-7)
    if p == 3.0:  # cubic stiffness: N_DF = 3A^2/4, N_R = 3 sigma^2 -> A* = 2 sigma
        assert gauss == pytest.approx(3 * sigma**2, rel=1e-9)
        assert math.sqrt(gauss * 4 / 3) == pytest.approx(2 * sigma, rel=1e-9)


def test_section_8_tilt_margin_is_the_moment_ratio(ref):
    from isodesign.response.isolator import Payload

    payload = Payload(mass_kg=400.0, isolators=4, spacing_m=0.8, cg_height_m=0.3)
    k = 9000.0
    expected = 4 * k * 0.4**2 / (400.0 * 9.80665 * 0.3)
    assert float(tilt_margin(k, payload)) == pytest.approx(expected, rel=1e-12)


def test_page_cites_no_outside_notes():
    assert not re.search(r"physics notes|physics-notes", PAGE, re.I)


def test_bessel_form_of_f():
    """``F = 1 - 2 J1/(z J0) = -J2/J0`` (the form the code evaluates)."""
    z = np.exp(0.75j * np.pi) * np.array([0.3, 2.0, 9.0])
    lhs = 1 - 2 * special.jv(1, z) / (z * special.jv(0, z))
    assert np.allclose(lhs, -special.jv(2, z) / special.jv(0, z), rtol=1e-10)
