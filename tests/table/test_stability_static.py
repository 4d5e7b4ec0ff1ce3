"""The static verdict against an exact potential-energy Hessian (finite rotations, preloads,
gravity), the time scale of the springs, the consistency with the modes and every
self-consistent solution of the lowest mode near the limit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigvals
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from isodesign.numerics.cplx import Cx
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.table.assembly import dynamic_stiffness
from isodesign.table.layout import HorizontalElement, Table
from isodesign.table.model import table_model
from isodesign.table.modes import mode_solutions, rocking_stability, table_modes
from isodesign.table.statics import (
    QUASI_STATIC_FREQUENCY_HZ,
    condensed_rocking_stiffness,
    sealed_stiffness,
    tilt_margin_rows,
)
from isodesign.table.summary import stability_text

SIX = [(-0.6, -0.225), (0.0, -0.225), (0.6, -0.225), (0.6, 0.225), (0.0, 0.225), (-0.6, 0.225)]


def _six(h, cg_xy=(0.1, 0.05), **kw):
    return Table(mass_kg=600.0, isolators_m=SIX, cg_m=(*cg_xy, h),
                 inertia_kg_m2=[[90.0, 4.0, -3.0], [4.0, 150.0, 2.0], [-3.0, 2.0, 200.0]], **kw)


def _potential(q, table, loads, kv, kh):
    """Potential energy of the rigid body on linear springs (independent of the package).

    Gravity at the CG, each vertical spring preloaded by its leveled load ``W_i`` (its force
    stays vertical: energy ``-W_i u_z + k_i u_z^2 / 2`` of its point's vertical
    displacement), each horizontal spring unloaded at its elastic centre; the body turns by
    the finite rotation ``exp([q_r]x)`` about the CG.
    """
    t, rot = q[:3], Rotation.from_rotvec(q[3:]).as_matrix()
    cg = np.asarray(table.cg_m)
    xy = np.asarray(table.isolators_m)
    e = table.horizontal.elastic_centre_height_m
    v = table.mass_kg * table.g_m_s2 * t[2]
    for i in range(xy.shape[0]):
        rv = np.array([xy[i, 0], xy[i, 1], 0.0]) - cg
        uv = t + (rot - np.eye(3)) @ rv
        v += -loads[i] * uv[2] + 0.5 * kv[i] * uv[2] ** 2
        rh = np.array([xy[i, 0], xy[i, 1], e]) - cg
        uh = t + (rot - np.eye(3)) @ rh
        v += 0.5 * kh[i] * (uh[0] ** 2 + uh[1] ** 2)
    return v


def _hessian(table, loads, kv, kh, step=(1e-5, 1e-4)):
    """Central finite differences of the potential energy at the leveled equilibrium."""
    st = np.r_[[step[0]] * 3, [step[1]] * 3]
    hs = np.zeros((6, 6))
    for i in range(6):
        for j in range(i, 6):
            ei, ej = np.eye(6)[i] * st[i], np.eye(6)[j] * st[j]
            f = [_potential(sgn_i * ei + sgn_j * ej, table, loads, kv, kh)
                 for sgn_i, sgn_j in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
            hs[i, j] = hs[j, i] = (f[0] - f[1] - f[2] + f[3]) / (4 * st[i] * st[j])
    return hs


def _exact_critical_height(ref, make, frequency_hz):
    """The CG height where the exact Hessian's lowest eigenvalue crosses zero."""
    base = table_model(ref, make(0.3))
    rs = rocking_stability(base, frequency_hz=frequency_hz)
    kv, kh, loads = rs.static_stiffness_n_per_m, rs.horizontal_static_n_per_m, \
        base.leveling.load_n

    def lowest(h):
        hs = _hessian(make(h), loads, kv, kh)
        return np.linalg.eigvalsh(0.5 * (hs + hs.T))[0]

    return brentq(lowest, 0.2, 3.0, xtol=1e-12), rs


@pytest.mark.parametrize("frequency_hz", [QUASI_STATIC_FREQUENCY_HZ, 0.05, None])
def test_critical_height_is_the_exact_hessians_six_isolators(ref, frequency_hz):
    h_exact, rs = _exact_critical_height(ref, _six, frequency_hz)
    assert rs.critical_height_m == pytest.approx(h_exact, rel=1e-6)
    # the held vertical translation (K_theta alone) is optimistic on this layout
    w = 600.0 * 9.80665
    assert np.linalg.eigvalsh(rs.rocking_stiffness_n_m_per_rad)[0] / w > h_exact * 1.01
    # the weakest direction is the exact Hessian's null direction at the critical height
    model = table_model(ref, _six(h_exact))
    hs = _hessian(model.table, model.leveling.load_n, rs.static_stiffness_n_per_m,
                  rs.horizontal_static_n_per_m)
    _, vec = np.linalg.eigh(0.5 * (hs + hs.T))
    rot = vec[3:5, 0] / np.linalg.norm(vec[3:5, 0])
    assert abs(rot @ rs.weakest_direction) == pytest.approx(1.0, abs=1e-5)


def test_critical_height_is_the_exact_hessians_five_isolators_elastic_centre_above(ref):
    xy = [(-0.7, -0.4), (0.5, -0.45), (0.8, 0.2), (0.1, 0.5), (-0.6, 0.35)]

    def make(h):
        return Table(mass_kg=450.0, isolators_m=xy, cg_m=(0.12, -0.06, h),
                     inertia_kg_m2=[70.0, 110.0, 150.0], leveling_groups=[[0, 1], [2], [3, 4]],
                     horizontal=HorizontalElement(0.2, 8.0e3, 0.1, elastic_centre_height_m=0.07))

    h_exact, rs = _exact_critical_height(ref, make, QUASI_STATIC_FREQUENCY_HZ)
    assert rs.critical_height_m == pytest.approx(h_exact, rel=1e-6)


def test_verdict_and_margins_around_the_limit(ref):
    h0 = rocking_stability(table_model(ref, _six(0.4))).critical_height_m
    for h, stable in ((0.999 * h0, True), (1.001 * h0, False)):
        rs = rocking_stability(table_model(ref, _six(h)))
        assert rs.stable is stable
        assert rs.margin[0] == pytest.approx(h0 / h, rel=1e-12)
        assert (rs.lowest_static_eigenvalue_rad2_s2 > 0) is stable
    # the time scale: the default diaphragm softens towards low frequency
    m = table_model(ref, _six(0.4))
    h_qs, h_05, h_k0 = (rocking_stability(m, frequency_hz=f).critical_height_m
                        for f in (1e-3, 0.05, None))
    assert h_qs < h_05 < h_k0
    assert "quasi-static" in rocking_stability(m).time_scale


def test_a_mode_unstable_at_its_own_frequency_is_never_stable(ref):
    # at h = 0.69 m the lowest mode has no frequency: the verdict says unstable on every
    # time scale the command prints, and with the modes given whatever the margins say
    model = table_model(ref, _six(0.69))
    md = table_modes(model)
    assert np.isnan(md.frequency_hz[0])
    for f in (QUASI_STATIC_FREQUENCY_HZ, None):
        rs = rocking_stability(model, frequency_hz=f, modes=md)
        assert not rs.stable and rs.unstable_modes == (1,)
        assert "UNSTABLE" in stability_text(rs)
    # the old verdict (z held, K0) called this table stable
    old = rocking_stability(model, frequency_hz=None)
    assert np.linalg.eigvalsh(old.rocking_stiffness_n_m_per_rad)[0] / \
        old.overturning_n_m_per_rad > 1.0


def test_two_self_consistent_solutions_near_the_limit(ref):
    model = table_model(ref, _six(0.64))
    sol = mode_solutions(model)
    assert sol.frequency_hz.size == 2
    # each is a root of the fixed-point map: Re mu(w) = w^2 at its own frequency
    for f in sol.frequency_hz:
        kv = model.vertical_stiffness(np.array([f]), 1e-6)
        kh = model.horizontal_stiffness(np.array([2 * math.pi * f]))
        d, _ = dynamic_stiffness(model.geometry, [Cx.from_complex(k) for k in kv], kh,
                                 np.array([0.0]))
        mu = eigvals((np.asarray(d.re) + 1j * np.asarray(d.im)).reshape(6, 6),
                     model.geometry.mass)
        assert np.min(mu.real) == pytest.approx((2 * math.pi * f) ** 2, rel=1e-8)
    # the fixed point from 1 Hz reaches the upper one
    md = table_modes(model)
    assert md.frequency_hz[0] == pytest.approx(sol.frequency_hz[1], rel=1e-8)
    # below the lower solution the mode is statically unstable: so is the verdict
    assert sol.unstable_below_hz is not None and sol.unstable_below_hz < sol.frequency_hz[0]
    assert not rocking_stability(model, modes=md).stable
    # far from the limit: one solution, the fixed point's
    far = table_model(ref, _six(0.3))
    one = mode_solutions(far)
    assert one.frequency_hz.size == 1 and one.unstable_below_hz is None
    assert one.frequency_hz[0] == pytest.approx(table_modes(far).frequency_hz[0], rel=1e-8)


def test_sealed_stiffness_is_the_spring_model_at_the_quasi_static_frequency(ref):
    for design in (ref.replace(acoustics="lumped"), ref):
        model = table_model(design, _six(0.4))
        dia = diaphragm_model(model.diaphragm)
        k = [float(sealed_stiffness(d, dia, flow=model.flow)) for d in model.designs]
        rs = rocking_stability(model)
        np.testing.assert_allclose(k, rs.static_stiffness_n_per_m, rtol=1e-9)


def test_the_nlp_rows_are_the_analysis_on_numbers_and_symbols(ref):
    import casadi as ca

    model = table_model(ref, _six(0.5))
    rs = rocking_stability(model)
    r = model.table.vertical_points_m
    a = condensed_rocking_stiffness(rs.static_stiffness_n_per_m, r)
    np.testing.assert_allclose([a[0], a[1], a[2]],
                               rs.condensed_stiffness_n_m_per_rad[[0, 0, 1], [0, 1, 1]],
                               rtol=1e-12)
    ks = ca.SX.sym("k", 6)
    rows = ca.Function("rows", [ks], [ca.vertcat(*tilt_margin_rows(
        [ks[i] for i in range(6)], r, rs.overturning_n_m_per_rad, 0.5))])
    got = np.asarray(rows(rs.static_stiffness_n_per_m)).ravel()
    assert got[0] * got[1] - got[2] >= 0  # off-diagonal squared
    b = rs.condensed_stiffness_n_m_per_rad / rs.overturning_n_m_per_rad - 0.5 * np.eye(2)
    np.testing.assert_allclose(got, [b[0, 0], b[1, 1], np.linalg.det(b)], rtol=1e-10)


def test_modes_command_never_calls_an_unstable_mode_stable(tmp_path, capsys):
    from importlib import resources

    from isodesign.cli import main

    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    src = src.replace("isolators = 4", "isolators = 6")
    src = src.replace("spacing_m = 0.8", "spacing_m = 0.45")
    src = src.replace("cg_height_m = 0.35", "cg_height_m = 0.69")
    src = src.replace("isolators_m = [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]]",
                      "isolators_m = " + str([list(p) for p in SIX]))
    src = src.replace("cg_m = [0.0, 0.0, 0.35]", "cg_m = [0.1, 0.05, 0.69]")
    src = src.replace("leveling_groups = [[1, 2], [3], [4]]",
                      "leveling_groups = [[1, 2], [3, 4], [5, 6]]")
    study = tmp_path / "six.toml"
    study.write_text(src)
    assert main(["modes", str(study), "-o", str(tmp_path / "m"), "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert "unstbl" in text
    verdict = [ln for ln in text.splitlines() if "static stability" in ln]
    assert len(verdict) == 1 and "UNSTABLE" in verdict[0] and "-> stable" not in verdict[0]
    assert "critical CG height 0.6261 m" in verdict[0]
    assert "mode 1: self-consistent solutions none" in text


def test_the_figures_docs_table_section_7_quotes(ref):
    from pathlib import Path

    page = " ".join((Path(__file__).parents[2] / "docs" / "table.md").read_text(
        encoding="utf-8").split())
    model = table_model(ref, _six(0.4))
    k0 = rocking_stability(model, frequency_hz=None)
    held = np.linalg.eigvalsh(k0.rocking_stiffness_n_m_per_rad)[0] / model.table.weight_n
    assert f"the held form says {held:.3f} m with `K0`, the condensed " \
        f"{k0.critical_height_m:.3f} m" in page
    h = [rocking_stability(model, frequency_hz=f).critical_height_m for f in (1e-3, 0.05)]
    assert f"critical height is {h[0]:.3f} m at 1 mHz, {h[1]:.3f} m at 0.05 Hz and " \
        f"{k0.critical_height_m:.3f} m with `K0`" in page
    sol = mode_solutions(table_model(ref, _six(0.64)))
    assert f"there are two, {sol.frequency_hz[0]:.2g} Hz and {sol.frequency_hz[1]:.2g} Hz" \
        in page
    assert f"`Re mu_1 <= 0` below {sol.unstable_below_hz:.2g} Hz" in page
