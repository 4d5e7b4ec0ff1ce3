"""Modes (nonlinear eigenproblem) and rocking stability with the gravity term."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.numerics.cplx import Cx
from isodesign.response.isolator import Payload
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M
from isodesign.response.stability import stability_figures
from isodesign.table.layout import HorizontalElement, Table
from isodesign.table.model import table_model
from isodesign.table.modes import rocking_stability, table_modes


def test_constant_stiffness_modes_are_harris_and_undamped(ref):
    m, kz, kx, h = 600.0, 2.0e5, 4.0e4, 0.35
    t = Table.symmetric(m, 1.2, 0.8, h, size_m=(1.3, 0.9, 0.5),
                        horizontal=HorizontalElement(None, kx, 0.0))
    model = table_model(ref, t, include_gravity=False)
    md = table_modes(model, vertical=lambda w: [Cx(kz + 0 * w, 0 * w)] * 4)
    fz = math.sqrt(4 * kz / m) / (2 * math.pi)
    kappa = kx / kz
    expect = [fz]
    for half, inertia in ((0.6, t.inertia_kg_m2[1, 1]), (0.4, t.inertia_kg_m2[0, 0])):
        rho = math.sqrt(inertia / m)
        a, c = half / rho, h / rho
        b = kappa * (1 + c * c) + a * a
        d = math.sqrt(b * b - 4 * kappa * a * a)
        expect += [fz * math.sqrt((b - d) / 2), fz * math.sqrt((b + d) / 2)]
    r = math.sqrt(4 * kx * (0.6**2 + 0.4**2) / t.inertia_kg_m2[2, 2]) / (2 * math.pi)
    np.testing.assert_allclose(md.frequency_hz, np.sort([*expect, r]), rtol=1e-9)
    np.testing.assert_allclose(md.damping_ratio, 0.0, atol=1e-12)
    np.testing.assert_allclose(md.energy_fraction.sum(axis=1), 1.0, rtol=1e-12)


def test_vertical_mode_solves_the_nonlinear_eigenproblem(ref):
    t = Table.symmetric(600.0, 1.2, 0.8, 0.35)
    model = table_model(ref, t)
    md = table_modes(model)
    j = md.names.index("z")
    f = md.frequency_hz[j]
    k = model.vertical_stiffness(np.array([f]), LINEAR_REFERENCE_AMPLITUDE_M)[0][0]
    # at its own frequency: w^2 = Re(n k*)/m and zeta = Im k*/(2 Re k*)
    assert (2 * math.pi * f) ** 2 == pytest.approx(4 * k.real / 600.0, rel=1e-9)
    assert md.damping_ratio[j] == pytest.approx(k.imag / (2 * k.real), rel=1e-9)
    # a one-frequency evaluation at 1 Hz would not give it
    k1 = model.vertical_stiffness(np.array([1.0]), LINEAR_REFERENCE_AMPLITUDE_M)[0][0]
    assert abs(math.sqrt(4 * k1.real / 600.0) / (2 * math.pi) - f) > 1e-3
    assert np.all(md.converged)


def test_rocking_margin_reduces_to_the_tilt_margin(ref):
    t = Table.symmetric(600.0, 1.2, 0.8, 0.35)
    # with the 1-DOF figure's K0 (a symmetric table: the stiffness centre under the CG, s = 0)
    rs = rocking_stability(table_model(ref, t), frequency_hz=None)
    s = stability_figures(ref, Payload(600.0, 4, spacing_m=0.8, cg_height_m=0.35))
    assert rs.margin[0] == pytest.approx(s.tilt_margin, rel=1e-12)
    assert rs.margin[1] == pytest.approx(s.tilt_margin * (1.2 / 0.8) ** 2, rel=1e-12)
    assert rs.stable and rs.lowest_static_eigenvalue_rad2_s2 > 0
    # the weakest direction turns about x (rocking across the narrow 0.8 m spacing)
    assert abs(rs.directions[0, 0]) == pytest.approx(1.0)
    # the default verdict takes the sealed springs at the quasi-static 1 mHz: the same
    # formula with that stiffness, and the critical height is the margin times h
    qs = rocking_stability(table_model(ref, t))
    k = qs.static_stiffness_n_per_m[0]
    assert qs.margin[0] == pytest.approx(4 * k * 0.4**2 / (600.0 * 9.80665 * 0.35), rel=1e-12)
    assert qs.critical_height_m == pytest.approx(qs.margin[0] * 0.35, rel=1e-12)
    assert qs.margin[0] < rs.margin[0]


def test_a_high_cg_is_unstable_and_its_rocking_mode_has_no_frequency(ref):
    t = Table.symmetric(600.0, 0.5, 0.4, 3.0)
    model = table_model(ref, t)
    rs = rocking_stability(model)
    assert rs.margin[0] < 1 and not rs.stable
    assert rs.lowest_static_eigenvalue_rad2_s2 < 0
    md = table_modes(model)
    assert np.isnan(md.frequency_hz).any()


@pytest.mark.parametrize("builtin", ["table", "default"])
def test_modes_side_by_side_are_the_mode_by_mode_iteration(builtin):
    """table_modes iterates the six modes' fixed points side by side, the springs evaluated
    once per step at every moving mode's frequency (the default); mode by mode
    (side_by_side=False, the optimizer's frozen modes) each step evaluates them at one
    frequency. The same iterates: the same iteration counts, frequencies and damping to
    rounding, at the linear amplitude and at a large one (docs/table.md section 6)."""
    from isodesign.optimization.study import default_study, table_study

    st = table_study() if builtin == "table" else default_study()
    d = st.design_at({"volume_ratio": 4.0, "top_volume_m3": 1.0e-3,
                      "capillary_length_m": 0.3, "capillary_diameter_m": 2.5e-3})
    model = table_model(d, st.table_at(None))
    for amp in (LINEAR_REFERENCE_AMPLITUDE_M, 1e-4):
        a = table_modes(model, amplitude_m=amp)
        b = table_modes(model, amplitude_m=amp, side_by_side=False)
        np.testing.assert_array_equal(a.iterations, b.iterations)
        np.testing.assert_allclose(a.frequency_hz, b.frequency_hz, rtol=1e-12)
        np.testing.assert_allclose(a.damping_ratio, b.damping_ratio, rtol=1e-9)
        assert a.converged.all() and b.converged.all()
        assert a.iterations.max() > 1  # the springs depend on frequency: a real iteration
