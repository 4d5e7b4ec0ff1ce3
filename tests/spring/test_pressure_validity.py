"""The static-pressure validity flag: a payload that needs more chamber pressure than the
ideal-gas and rolling-diaphragm assumptions cover is flagged, never silently returned."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from isodesign.errors import ModelValidityWarning
from isodesign.response import band_response
from isodesign.response.isolator import Payload
from isodesign.spring.diagnostics import CHECK_DESCRIPTIONS, MAX_STATIC_PRESSURE_PA
from isodesign.spring.stiffness import complex_stiffness

R_J_PER_MOL_K = 8.314462618


def test_the_bound_keeps_the_ideal_gas_within_half_a_percent():
    # |Z - 1| ~ |B| p / (R T) with |B| < 10 cm^3/mol for air near room temperature
    b_m3_per_mol = 10e-6
    rel = b_m3_per_mol * MAX_STATIC_PRESSURE_PA / (R_J_PER_MOL_K * 293.15)
    assert rel < 0.005
    # and the bound is about twice the paper's Table 1 pressure (4.93e5 Pa)
    assert 1.5 < MAX_STATIC_PRESSURE_PA / 4.93e5 < 2.5


def test_the_reference_spring_is_inside_and_a_huge_pressure_is_flagged(ref):
    ok = complex_stiffness(ref, [1.0, 5.0], [1e-4], warn=False)
    assert ok.diagnostics.checks["static_pressure"].all()
    high = ref.replace(pressure_pa=2.0 * MAX_STATIC_PRESSURE_PA)
    with pytest.warns(ModelValidityWarning, match="static_pressure"):
        res = complex_stiffness(high, [1.0, 5.0], [1e-4])
    assert not res.diagnostics.checks["static_pressure"].any()
    assert not res.valid.any()
    df = res.to_frame()
    assert "ok_static_pressure" in df and not df["ok_static_pressure"].any()
    assert "Pa absolute" in CHECK_DESCRIPTIONS["static_pressure"]


def test_a_payload_that_needs_millions_of_bar_is_flagged(ref):
    # 1e9 kg on 4 isolators of 5.3e-3 m^2: p0 = 4.6e11 Pa (4.6e6 bar)
    heavy = Payload(1e9, 4)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        res = band_response(ref, heavy, "VC-A", "VC-E", points_per_band=4, warn=False)
    assert res.stability.pressure_pa == pytest.approx(4.6e11, rel=0.01)
    assert any(line.startswith("static_pressure:") for line in res.warnings)
    light = band_response(ref, Payload(600.0, 4), "VC-A", "VC-E", points_per_band=4,
                          warn=False)
    assert not any(line.startswith("static_pressure:") for line in light.warnings)
    assert np.isfinite(light.margin_db).all()
