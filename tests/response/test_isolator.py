"""Tests of isodesign.response.isolator: payload, transmissibility, Zener form, tilt margin."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.response.isolator import (
    Payload,
    loaded_design,
    natural_frequency_hz,
    relative_transmissibility,
    tilt_margin,
    transmissibility,
    zener_damping_ratio,
    zener_optimum,
    zener_transmissibility,
)
from isodesign.spring.gas import P_ATM

# --------------------------------------------------------------------------------------------
# Payload and p0
# --------------------------------------------------------------------------------------------


def test_payload_validation():
    p = Payload(400.0, 4, spacing_m=1.0, cg_height_m=0.3)
    assert p.mass_per_isolator_kg == 100.0
    assert p.load_per_isolator_n == pytest.approx(100.0 * 9.80665)
    for kwargs, name in (
        ({"mass_kg": -1.0}, "mass_kg"),
        ({"mass_kg": 0.0}, "mass_kg"),
        ({"mass_kg": float("nan")}, "mass_kg"),
        ({"mass_kg": 1.0, "isolators": 0}, "isolators"),
        ({"mass_kg": 1.0, "isolators": 2.5}, "isolators"),
        ({"mass_kg": 1.0, "isolators": True}, "isolators"),
        ({"mass_kg": 1.0, "spacing_m": -1.0}, "spacing_m"),
        ({"mass_kg": 1.0, "cg_height_m": 0.0}, "cg_height_m"),
    ):
        with pytest.raises(InputError, match=name):
            Payload(**kwargs)


def test_loaded_design_eq1(ref):
    p = Payload(400.0, 4)
    d = loaded_design(ref, p)
    # Eq. 1: A_p (p0 - p_atm) = m g / n
    assert d.load_n == pytest.approx(100.0 * 9.80665, rel=1e-12)
    assert d.pressure_pa == pytest.approx(P_ATM + 100.0 * 9.80665 / 5.3e-3, rel=1e-12)
    # other fields unchanged
    assert d.volume_ratio == ref.volume_ratio and d.top_volume_m3 == ref.top_volume_m3
    # gravity of the payload is used
    d_moon = loaded_design(ref, Payload(400.0, 4, g_m_s2=1.62))
    assert d_moon.load_n == pytest.approx(100.0 * 1.62, rel=1e-12)
    with pytest.raises(InputError, match="payload"):
        loaded_design(ref, 400.0)


# --------------------------------------------------------------------------------------------
# Transmissibility formulas
# --------------------------------------------------------------------------------------------


def test_transmissibility_formulas_numpy_arrays():
    w = np.linspace(1.0, 100.0, 7)
    k = Cx(np.full(7, 1e4), np.full(7, 2e3))
    m = 100.0
    kc = 1e4 + 2e3j
    t = transmissibility(k, m, w)
    rel = relative_transmissibility(k, m, w)
    assert isinstance(rel.re, np.ndarray) and rel.re.dtype == float  # not an object array
    np.testing.assert_allclose(t.to_complex(), kc / (kc - m * w**2), rtol=1e-14)
    np.testing.assert_allclose(rel.to_complex(), m * w**2 / (kc - m * w**2), rtol=1e-14)
    np.testing.assert_allclose(rel.to_complex(), t.to_complex() - 1.0, rtol=1e-12, atol=1e-15)


def test_transmissibility_scalars_and_casadi():
    import casadi as ca

    t = transmissibility(Cx(1e4, 2e3), 100.0, 5.0)
    assert t.to_complex() == pytest.approx((1e4 + 2e3j) / (1e4 + 2e3j - 2500.0))
    rel = relative_transmissibility(Cx(1e4, 2e3), 100.0, 5.0)
    assert rel.to_complex() == pytest.approx(2500.0 / (1e4 + 2e3j - 2500.0))
    kr, ki, w = ca.SX.sym("kr"), ca.SX.sym("ki"), ca.SX.sym("w")
    r = relative_transmissibility(Cx(kr, ki), 100.0, w)
    f = ca.Function("r", [kr, ki, w], [r.re, r.im])
    re, im = f(1e4, 2e3, 5.0)
    assert complex(float(re), float(im)) == pytest.approx(2500.0 / (1e4 + 2e3j - 2500.0))


def test_natural_frequency_and_tilt_margin():
    assert natural_frequency_hz(1e4, 100.0) == pytest.approx(math.sqrt(100.0) / (2 * math.pi))
    p = Payload(400.0, 4, spacing_m=1.0, cg_height_m=0.25)
    k = 1e4
    assert tilt_margin(k, p) == pytest.approx(4 * k * 0.25 / (400.0 * 9.80665 * 0.25))
    with pytest.raises(InputError, match="spacing_m"):
        tilt_margin(k, Payload(400.0, 4))


# --------------------------------------------------------------------------------------------
# Zener form (docs/physics.md, section 5)
# --------------------------------------------------------------------------------------------


def _zener_k(n, k, c, w):
    """Spring k in parallel with (N k in series with c)."""
    k1 = n * k
    series = (k1 * 1j * w * c) / (k1 + 1j * w * c)
    return k + series


@pytest.mark.parametrize("n", [0.5, 1.852, 4.0])
@pytest.mark.parametrize("zeta", [0.05, 0.3, 1.0])
def test_zener_closed_form_matches_model(n, zeta):
    m, k = 100.0, 5e3
    wn = math.sqrt(k / m)
    c = 2.0 * zeta * math.sqrt(k * m)
    r = np.geomspace(0.05, 20.0, 301)
    kz = _zener_k(n, k, c, r * wn)
    t = np.abs(kz / (kz - m * (r * wn) ** 2))
    np.testing.assert_allclose(zener_transmissibility(n, zeta, r), t, rtol=1e-12)


def test_zener_damping_ratio_from_design(ref):
    d = loaded_design(ref, Payload(400.0, 4))
    n = d.volume_ratio
    ks = d.single_chamber_stiffness_n_per_m
    tau = (
        d.compliance_factor_kg_per_pa
        * 128
        * d.viscosity_pa_s
        * d.capillary_length_m
        / (math.pi * d.density_kg_m3 * d.capillary_diameter_m**4)
    )
    c = ks * n * tau / (n + 1) ** 2
    assert zener_damping_ratio(d, 100.0) == pytest.approx(
        c / (2 * math.sqrt(ks / (n + 1) * 100.0)), rel=1e-12
    )


@pytest.mark.parametrize("n", [0.5, 1.852, 5.0])
def test_zener_optimum_is_the_minimum_peak(n):
    tmax, r_pk, z_opt = zener_optimum(n)
    r = np.geomspace(0.2, 5.0, 20001)
    peak = np.max(zener_transmissibility(n, z_opt, r))
    assert peak == pytest.approx(tmax, rel=1e-6)  # grid-limited
    assert peak <= tmax * (1 + 1e-12)
    assert r[np.argmax(zener_transmissibility(n, z_opt, r))] == pytest.approx(r_pk, rel=1e-3)
    for z in (0.9 * z_opt, 1.1 * z_opt):
        assert np.max(zener_transmissibility(n, z, r)) > tmax
    with pytest.raises(InputError, match="volume_ratio"):
        zener_optimum(-1.0)
