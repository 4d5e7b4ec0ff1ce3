"""The flow-model registry: every entry's declared properties hold for its functions."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.spring import flow_models as fm
from isodesign.spring.diagnostics import CHECK_DESCRIPTIONS
from isodesign.spring.stiffness import check_models, complex_stiffness

NAMES = tuple(fm.FLOW_MODEL_REGISTRY)


def test_name_tuples_are_derived_from_the_registry():
    reg = fm.FLOW_MODEL_REGISTRY
    assert fm.FLOW_MODELS == NAMES
    assert fm.SMOOTH_FLOW_MODELS == tuple(n for n in NAMES if reg[n].smooth)
    assert fm.RATIONAL_FLOW_MODELS == tuple(n for n in NAMES if reg[n].rational)
    assert fm.SIMULATION_FLOW_MODELS == tuple(n for n in NAMES if reg[n].time_domain)
    assert fm.FLOW_MODELS == ("quasi_steady", "womersley", "poiseuille", "zhao", "zhao_turbulent")
    assert all(reg[n].name == n and reg[n].description for n in NAMES)


def test_registry_is_read_only_and_names_are_unique():
    with pytest.raises(TypeError):
        fm.FLOW_MODEL_REGISTRY["new"] = fm.FLOW_MODEL_REGISTRY["poiseuille"]  # type: ignore[index]
    with pytest.raises(ValueError, match="registered twice"):
        fm._register(fm.FLOW_MODEL_REGISTRY["poiseuille"])


def test_unknown_model_names_the_valid_ones():
    with pytest.raises(InputError, match="flow: unknown model 'darcy'; valid: quasi_steady"):
        fm.flow_model("darcy")
    with pytest.raises(InputError, match="flow: unknown model"):
        fm.resistance("laminar", None, 1.0, 1.0)


@pytest.mark.parametrize("name", NAMES)
def test_every_model_evaluates_on_numpy(ref, name):
    w = 2 * math.pi * np.array([0.5, 5.0, 20.0])
    u = np.array([0.5, 2.0, 8.0])
    c = fm.resistance(name, ref, w, u)
    assert np.all(np.isfinite(c.re)) and np.all(np.asarray(c.re) > 0)


@pytest.mark.parametrize("name", NAMES)
def test_smooth_flag_matches_the_casadi_face(ref, name):
    """Smooth models build CasADi graphs that agree with NumPy; the others refuse symbols."""
    model = fm.flow_model(name)
    w_sym, u_sym, dc = ca.SX.sym("w"), ca.SX.sym("u"), ca.SX.sym("dc")
    d = ref.replace(capillary_diameter_m=dc)
    if not model.smooth:
        with pytest.raises(InputError, match="not available on CasADi symbols"):
            fm.resistance(name, d, w_sym, u_sym)
        return
    c = fm.resistance(name, d, w_sym, u_sym)
    f = ca.Function("c", [w_sym, u_sym, dc], [c.re, c.im])
    grad = ca.Function("g", [w_sym, u_sym, dc], [ca.gradient(c.re, dc)])
    for w, u in [(2 * math.pi * 1.0, 0.3), (2 * math.pi * 12.0, 6.0)]:
        re, im = (float(v) for v in f(w, u, ref.capillary_diameter_m))
        num = fm.resistance(name, ref, w, u)
        assert re == pytest.approx(float(num.re), rel=1e-8)
        assert im == pytest.approx(float(np.asarray(num.im)), rel=1e-8, abs=1e-6)
        assert math.isfinite(float(grad(w, u, ref.capillary_diameter_m)))


@pytest.mark.parametrize("name", NAMES)
def test_rational_flag_means_affine_in_s_at_small_amplitude(ref, name):
    """Rational: ``C(jw) = c0 + c1 jw`` at U -> 0, c0 and c1 independent of w."""
    w = 2 * math.pi * np.array([0.1, 1.0, 10.0, 50.0])
    c = fm.resistance(name, ref, w, 1e-9 * np.ones(4))
    re, im = np.asarray(c.re) * np.ones(4), np.asarray(c.im) * np.ones(4)
    affine = np.allclose(re, re[0], rtol=1e-9) and np.allclose(im / w, im[0] / w[0], rtol=1e-9)
    if fm.flow_model(name).rational:
        assert affine
    elif fm.flow_model(name).smooth:  # womersley: frequency-dependent resistance
        assert not affine


@pytest.mark.parametrize("name", NAMES)
def test_amplitude_dependent_flag(ref, name):
    w = 2 * math.pi * 3.0
    c1, c2 = fm.resistance(name, ref, w, 0.1), fm.resistance(name, ref, w, 5.0)
    changes = not math.isclose(float(c1.re), float(c2.re), rel_tol=1e-9)
    assert changes == fm.flow_model(name).amplitude_dependent


@pytest.mark.parametrize("name", NAMES)
def test_self_consistent_flag_matches_check_models(name):
    if fm.flow_model(name).self_consistent:
        check_models(name, "self_consistent")
    else:
        with pytest.raises(InputError, match="amplitude_mode"):
            check_models(name, "self_consistent")
    check_models(name, "kinematic")


@pytest.mark.parametrize("name", NAMES)
def test_checks_reach_the_diagnostics_with_their_descriptions(ref, name):
    model = fm.flow_model(name)
    mode = "self_consistent" if model.self_consistent else "kinematic"
    res = complex_stiffness(ref, [1.0, 10.0], 1e-4, flow=name, amplitude_mode=mode, warn=False)
    for check in model.checks:
        assert check.name in res.diagnostics.checks
        assert CHECK_DESCRIPTIONS[check.name] == check.description
    others = {c.name for m in fm.FLOW_MODEL_REGISTRY.values() for c in m.checks} - {
        c.name for c in model.checks
    }
    assert not others & set(res.diagnostics.checks)


def test_laminar_check_flags_turbulent_points(ref):
    res = complex_stiffness(ref, 2.0, 5e-4, flow="womersley", warn=False)
    assert res.diagnostics.reynolds.item() > 2300
    assert not res.diagnostics.checks["laminar"].item()


def test_simulator_accepts_exactly_the_time_domain_models():
    from isodesign.simulation.harmonic_rig import _check_flow

    for name in NAMES:
        if fm.flow_model(name).time_domain:
            assert fm.flow_model(name).time_domain in ("inertial", "algebraic")
            assert _check_flow(name) == name
        else:
            with pytest.raises(InputError, match="time-domain simulation"):
                _check_flow(name)


def test_mean_reynolds_number_eq27(ref):
    """Eq. 27 with Eq. 28's cycle-averaged velocity ``2U/pi``."""
    res = complex_stiffness(ref, [0.5, 5.0], 2e-4, warn=False)
    d = res.diagnostics
    u = d.velocity_amplitude_m_s
    peak = ref.density_kg_m3 * u * ref.capillary_diameter_m / ref.viscosity_pa_s
    np.testing.assert_allclose(d.reynolds, peak, rtol=1e-12)
    np.testing.assert_allclose(d.reynolds_mean, 2 * peak / math.pi, rtol=1e-12)


def test_spring_stiffness_eq42_on_every_backend():
    """Eq. 42 (air + diaphragm) on NumPy complex arrays, Cx pairs and CasADi symbols."""
    from isodesign.numerics.cplx import Cx
    from isodesign.spring.equations import spring_stiffness

    air = np.array([8000 + 500j, 9000 + 2500j])
    dia = np.array([5000 + 400j, 5200 + 900j])
    out = spring_stiffness(air, dia)
    assert isinstance(out, np.ndarray) and np.array_equal(out, air + dia)
    pair = spring_stiffness(Cx.from_complex(air), Cx.from_complex(dia))
    assert np.array_equal(pair.to_complex(), air + dia)
    mixed = spring_stiffness(Cx.from_complex(air), dia)
    assert isinstance(mixed, Cx) and np.array_equal(mixed.to_complex(), air + dia)
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    sym = spring_stiffness(Cx(a, 2 * a), Cx(b, 0.5 * b))
    f = ca.Function("k", [a, b], [sym.re, sym.im])
    assert [float(v) for v in f(3.0, 4.0)] == [7.0, 8.0]
