"""Gaussian-equivalent (random-input) resistance of the capillary: closed forms, quadrature,
backends."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from isodesign.errors import InputError
from isodesign.spring.capillary import (
    churchill_friction_re_product,
    gaussian_equivalent_resistance,
    gaussian_friction_excess,
    linear_resistance,
    statistical_resistance_function,
)
from isodesign.spring.flow_models import resistance


def _excess_by_quad(re_sigma: float) -> float:
    def f(x):
        phi = churchill_friction_re_product(np.array([re_sigma * x]))[0]
        return x * x * (phi - 64.0) * math.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)

    pts = [c / re_sigma for c in (1000.0, 2300.0, 3000.0, 4000.0)]
    return 2.0 * quad(f, 0.0, 40.0, limit=1000, points=pts, epsabs=1e-13, epsrel=1e-12)[0]


@pytest.mark.parametrize("re_sigma", [200.0, 900.0, 1500.0, 2500.0, 4000.0, 1e4, 1e5])
def test_friction_excess_matches_adaptive_quadrature(re_sigma):
    # relative to the whole equivalent friction 64 + excess, to 1e-9
    got = float(gaussian_friction_excess(re_sigma))
    assert got == pytest.approx(_excess_by_quad(re_sigma), abs=1e-9 * (64.0 + got))


def test_friction_excess_vanishes_in_laminar_flow_and_vectorizes():
    assert float(gaussian_friction_excess(50.0)) < 1e-12
    re = np.array([300.0, 3000.0, 3e4])
    np.testing.assert_allclose(
        gaussian_friction_excess(re), [float(gaussian_friction_excess(r)) for r in re], rtol=1e-14
    )


def test_minor_loss_equivalent_is_the_gaussian_closed_form(ref):
    """E[u K rho |u| u / 2] / sigma^2, by quadrature, against K rho sqrt(8/pi) sigma / 2."""
    sigma = 1.7
    d = ref
    rho = d.density_kg_m3

    def f(u):
        return u * 0.5 * d.minor_loss * rho * abs(u) * u * math.exp(-0.5 * (u / sigma) ** 2)

    e = quad(f, -12 * sigma, 12 * sigma, epsrel=1e-12)[0] / (math.sqrt(2 * math.pi) * sigma)
    expect = e / sigma**2 / (rho * d.capillary_area_m2)  # Pa per (kg/s)
    got = gaussian_equivalent_resistance("womersley", d, sigma)
    assert got == pytest.approx(expect, rel=1e-10)
    # sqrt(8/pi) sigma against the harmonic 8 U/(3 pi) at U = sigma: a ratio of 1.880
    harmonic = resistance("womersley", d, 1.0, sigma).re - resistance("womersley", d, 1.0, 0.0).re
    assert got / harmonic == pytest.approx(3.0 * math.sqrt(math.pi / 8.0), rel=1e-12)


def test_quasi_steady_equivalent_resistance_by_sampling(ref):
    """E[u dp_nl(u)] / sigma^2 from the time-domain pressure drop, by Gauss-Hermite with many
    nodes on the smooth parts and quad overall."""
    d = ref
    rho, mu = d.density_kg_m3, d.viscosity_pa_s
    dc, lc = d.capillary_diameter_m, d.capillary_length_m
    sigma = 4.0  # Re_sigma ~ 1200: the law's transition is inside the distribution

    def dp_nl(u):
        re = rho * abs(u) * dc / mu
        phi = churchill_friction_re_product(np.array([max(re, 1e-9)]))[0]
        return lc * mu * (phi - 64.0) * u / (2 * dc * dc) + 0.5 * d.minor_loss * rho * abs(u) * u

    def f(u):
        return u * dp_nl(u) * math.exp(-0.5 * (u / sigma) ** 2) / (math.sqrt(2 * math.pi) * sigma)

    pts = [c * mu / (rho * dc) for c in (1000.0, 2300.0, 3000.0, 4000.0)]
    e = 2.0 * quad(f, 0.0, 12 * sigma, points=pts, limit=500, epsrel=1e-12)[0]
    expect = e / sigma**2 / (rho * d.capillary_area_m2)
    assert gaussian_equivalent_resistance("quasi_steady", d, sigma) == pytest.approx(
        expect, rel=1e-8
    )


def test_linear_part_is_the_small_amplitude_limit(ref):
    w = 2 * math.pi * np.geomspace(0.5, 100.0, 9)
    for flow in ("quasi_steady", "womersley", "poiseuille"):
        lin = linear_resistance(flow, ref, w)
        small = resistance(flow, ref, w, 1e-9)
        np.testing.assert_allclose(lin.re, small.re, rtol=1e-8)
        np.testing.assert_allclose(lin.im, small.im, rtol=1e-12, atol=1e-9 * np.max(small.re))
        c = statistical_resistance_function(flow, ref, w)(2.0)
        np.testing.assert_allclose(c.re - lin.re,
                                   gaussian_equivalent_resistance(flow, ref, 2.0), rtol=1e-12)
    assert gaussian_equivalent_resistance("poiseuille", ref, 3.0) == 0.0


def test_statistical_resistance_on_casadi_symbols_matches_numpy(ref):
    ca = pytest.importorskip("casadi")
    s, dc = ca.SX.sym("sigma_u"), ca.SX.sym("D_c")
    d = ref.replace(capillary_diameter_m=dc)
    w = 2 * math.pi * 3.0
    for flow in ("quasi_steady", "womersley"):
        c = statistical_resistance_function(flow, d, w)(s)
        fn = ca.Function("c", [s, dc], [c.re, c.im, ca.jacobian(c.re, s)])
        for sig in (0.3, 2.0, 9.0):
            re, im, dre = (float(v) for v in fn(sig, ref.capillary_diameter_m))
            cn = statistical_resistance_function(flow, ref, w)(sig)
            assert re == pytest.approx(float(cn.re), rel=1e-12)
            assert im == pytest.approx(float(cn.im), rel=1e-12)
            h = 1e-6 * sig
            fd = (float(statistical_resistance_function(flow, ref, w)(sig + h).re)
                  - float(statistical_resistance_function(flow, ref, w)(sig - h).re)) / (2 * h)
            assert dre == pytest.approx(fd, rel=1e-6)


def test_statistical_linearization_rejects_paper_models(ref):
    with pytest.raises(InputError, match=r"^flow:.*quasi_steady"):
        gaussian_equivalent_resistance("zhao", ref, 1.0)
    with pytest.raises(InputError, match=r"^flow:"):
        linear_resistance("zhao", ref, 1.0)
