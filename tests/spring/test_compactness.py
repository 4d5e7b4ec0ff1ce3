"""The lumped model's validity check: a first-order error estimate against the line model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign import SpringDesign, complex_stiffness
from isodesign.spring.acoustics import acoustic_network
from isodesign.spring.capillary import linear_resistance
from isodesign.spring.compactness import LUMPED_TOLERANCE, lumped_error_estimate
from isodesign.spring.equations import air_stiffness

REF = SpringDesign.reference()


def _errors(d, f_hz, flow="womersley"):
    w = 2 * np.pi * np.asarray(f_hz, float)
    c = linear_resistance(flow, d, w)
    k_line = acoustic_network(d.replace(acoustics="distributed"), w, flow).stiffness(c)
    k_lumped = air_stiffness(d.replace(acoustics="lumped"), w, c, flow)
    exact = np.abs(k_lumped.to_complex() / k_line.to_complex() - 1)
    return exact, lumped_error_estimate(d, w, c, flow)


def test_low_frequency_error_is_the_tube_volume():
    """At 0.1 Hz the lumped model misses the tube's gas, n V_c / V_total: the estimate says so."""
    d = REF.replace(capillary_length_m=2.0, capillary_diameter_m=4e-3, top_volume_m3=0.3e-3)
    exact, est = _errors(d, [0.1])
    tube = d.process_index * d.capillary_area_m2 * d.capillary_length_m / d.total_volume_m3
    assert exact[0] == pytest.approx(tube, rel=0.05)
    assert est["total"][0] == pytest.approx(exact[0], rel=0.05)
    assert est["tube"][0] == pytest.approx(tube, rel=0.05)


def test_top_chamber_alone_is_x2_over_3():
    """Tube blocked (high frequency, thin tube): k = k_s (w l/c) cot(w l/c), error x^2/3."""
    d = REF.replace(capillary_diameter_m=0.3e-3, top_volume_m3=5e-3, chamber_aspect_ratio=4.0)
    from isodesign.spring.chamber import chamber_dimensions

    length, _ = chamber_dimensions(d, d.top_volume_m3)
    cn = math.sqrt(d.process_index * d.pressure_pa / d.density_kg_m3)
    f = 20.0
    x = 2 * math.pi * f * length / cn
    exact, est = _errors(d, [f])
    assert est["top_chamber"][0] == pytest.approx(x * x / 3, rel=0.02)
    assert exact[0] == pytest.approx(x * x / 3, rel=0.05)


def test_chamber_length_comes_from_its_shape():
    """A tall chamber (aspect 6) is less compact than a squat one of the same volume."""
    tall, squat = (REF.replace(top_volume_m3=5e-3, chamber_aspect_ratio=a) for a in (6.0, 0.5))
    assert _errors(tall, [40.0])[1]["top_chamber"][0] > 4 * _errors(squat, [40.0])[1][
        "top_chamber"][0]


def test_check_passes_only_within_tolerance_on_a_grid(study_script):
    """The flag is true only where the lumped k is within 1 % of the line's (main grid of
    studies/lumped_flag_check.py: 51,840 points), and is far less conservative than w l/c."""
    r = study_script("lumped_flag_check").lumped_flag_grid("main")
    assert r["passed_outside"] == 0
    assert r["worst_passed"] <= LUMPED_TOLERANCE
    assert r["old_passed_outside"] > 1000  # the former check passed points 40 % off
    assert r["flagged_within"] < 0.5 * r["old_flagged_within"]


def test_flag_reports_the_estimated_error():
    d = REF.replace(acoustics="lumped", capillary_length_m=2.0, capillary_diameter_m=4e-3)
    r = complex_stiffness(d, [0.5, 5.0, 60.0], 5e-5, diaphragm="none", warn=False)
    diag = r.diagnostics
    assert diag.lumped_error is not None
    assert not diag.checks["lumped"].all()
    line = next(s for s in diag.summary() if s.startswith("lumped"))
    assert "estimated error up to" in line
    assert "lumped_error_estimate" in diag.columns()
    # the distributed model has no lumped check
    rd = complex_stiffness(d.replace(acoustics="distributed"), [5.0], 5e-5, warn=False)
    assert "lumped" not in rd.diagnostics.checks and rd.diagnostics.lumped_error is None


def test_reference_spring_is_lumped_in_its_band():
    """The reference spring (0.81 L, 0.2 m tube) passes up to about 30 Hz and is flagged
    near its chamber modes."""
    r = complex_stiffness(REF.replace(acoustics="lumped"), [1.0, 10.0, 30.0], 5e-5,
                          diaphragm="none", warn=False)
    assert r.diagnostics.checks["lumped"].all()
    exact, _ = _errors(REF, [1.0, 10.0, 30.0], flow="quasi_steady")
    assert np.all(exact < LUMPED_TOLERANCE)
