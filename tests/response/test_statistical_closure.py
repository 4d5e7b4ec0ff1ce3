"""The default random closure: statistical linearization of the tube flow."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from isodesign.errors import InputError, ModelValidityWarning
from isodesign.floor import FloorSpectrum
from isodesign.numerics.cplx import Cx
from isodesign.response import Payload, band_response, linear_transmissibility, response_grid
from isodesign.response.isolator import loaded_design
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR
from isodesign.response.random_input import solve_stroke_rms
from isodesign.spring.capillary import statistical_resistance_function
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, tube_velocity_gain2

P = Payload(400.0, 4)


@pytest.fixture(scope="module")
def res(ref):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        return band_response(ref, P, "VC-A", "VC-E", rtol=1e-12)


def test_default_is_statistical_and_self_consistent(res):
    assert res.random_method == "statistical" and res.converged
    assert res.closure_slope is not None and abs(res.closure_slope) < 1
    g, d = res.grid, res.design
    sigma_u = res.tube_velocity_rms_m_s
    # T is the spring with C = linear part + Gaussian-equivalent resistance at sigma_u and
    # the diaphragm at A* = 1.880 sigma
    c = statistical_resistance_function("quasi_steady", d, g.omega)(sigma_u)
    k = air_stiffness(d, g.omega, c, "quasi_steady") + diaphragm_model("viscoelastic").stiffness(
        g.omega, EQUIVALENT_AMPLITUDE_FACTOR * res.stroke_rms_m)
    k = k.to_complex()
    np.testing.assert_allclose(res.transmissibility, k / (k - 100.0 * g.omega**2), rtol=1e-9)
    # both variances, by an independent quadrature: the floor's own band integration
    floor = FloorSpectrum.from_criterion("VC-A")
    f = g.frequency_hz
    rel = res.transmissibility - 1.0
    gain2 = tube_velocity_gain2(d, g.omega, Cx(c.re, c.im), "quasi_steady")

    def on_grid(values):
        def fn(ff):
            return values[np.searchsorted(f, ff)]
        return fn

    s2 = np.sum(floor.band_rms(None, "displacement", 50,
                               power_transmissibility=on_grid(np.abs(rel) ** 2)) ** 2)
    su2 = np.sum(floor.band_rms(None, "displacement", 50,
                                power_transmissibility=on_grid(np.abs(rel) ** 2 * gain2)) ** 2)
    assert res.stroke_rms_m == pytest.approx(math.sqrt(s2), rel=1e-10)
    assert sigma_u == pytest.approx(math.sqrt(su2), rel=1e-10)


def test_solve_stroke_rms_is_the_same_closure(res, ref):
    g = response_grid(FloorSpectrum.from_criterion("VC-A"), res.bands, points_per_band=50)
    s, info = solve_stroke_rms(loaded_design(ref, P), P, g, random_method="statistical")
    assert s == pytest.approx(res.stroke_rms_m, rel=1e-10)
    assert info["tube_velocity_rms_m_s"] == pytest.approx(res.tube_velocity_rms_m_s, rel=1e-10)


def test_linear_models_are_not_changed_by_the_closure(ref):
    """Poiseuille flow without diaphragm is linear: the closure is the linear response."""
    r = band_response(ref, P, "VC-A", "VC-E", flow="poiseuille", diaphragm="none")
    t = linear_transmissibility(ref, P, r.grid.frequency_hz, flow="poiseuille",
                                diaphragm="none")
    np.testing.assert_allclose(r.transmissibility, t, rtol=1e-12)


def test_the_tube_velocity_grows_with_the_floor_and_lowers_the_resonance_peak(ref, res):
    vca = FloorSpectrum.from_criterion("VC-A")
    big = FloorSpectrum.from_band_rms(vca.bands, 4.0 * vca.band_rms_velocity())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        r4 = band_response(ref, P, big, "VC-E")
    assert r4.tube_velocity_rms_m_s > 2.5 * res.tube_velocity_rms_m_s
    # more equivalent damping: the payload's resonance band gains less than 4x (12 dB)
    i = int(np.argmax(res.payload_velocity_rms_m_s / res.floor_velocity_rms_m_s))
    assert r4.payload_velocity_rms_m_s[i] / res.payload_velocity_rms_m_s[i] < 4.0


def test_statistical_closure_input_errors(ref):
    with pytest.raises(InputError, match=r"^flow: 'zhao'"):
        band_response(ref, P, "VC-A", "VC-E", flow="zhao", amplitude_mode="kinematic")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        r = band_response(ref, P, "VC-A", "VC-E", stroke_amplitude_m=2e-5, points_per_band=10)
    assert r.random_method == "equivalent_amplitude" and r.tube_velocity_rms_m_s is None
    with pytest.raises(InputError, match=r"^random_method:"):
        band_response(ref, P, "VC-A", "VC-E", random_method="gauss")
