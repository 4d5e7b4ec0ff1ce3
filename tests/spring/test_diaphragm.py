"""Diaphragm models: viscoelastic defaults, the table model, Eq. 43."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign import SpringDesign, complex_stiffness
from isodesign.errors import InputError
from isodesign.spring.design import piston_area_from_diaphragm
from isodesign.spring.diaphragm import (
    NoDiaphragm,
    TableDiaphragm,
    ViscoelasticDiaphragm,
    diaphragm_model,
)

TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------
# viscoelastic model: what the paper describes (issue: ~8 kN/m at 0.05 mm falling to
# ~5 kN/m at 0.5 mm, loss factor ~0.08 to ~0.2, both rising slowly with frequency)
# ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("amplitude_m", "k_expected", "eta_expected"),
    [(0.05e-3, 8.0e3, 0.08), (0.5e-3, 5.0e3, 0.2)],
)
def test_viscoelastic_defaults_reproduce_the_paper_description(amplitude_m, k_expected,
                                                               eta_expected):
    k = ViscoelasticDiaphragm().stiffness(TWO_PI * 1.0, amplitude_m)
    assert float(k.re) == pytest.approx(k_expected, rel=0.02)
    assert float(k.im / k.re) == pytest.approx(eta_expected, rel=0.06)


def test_viscoelastic_softens_and_loses_more_with_amplitude_and_is_passive():
    dia = ViscoelasticDiaphragm()
    x = np.geomspace(1e-7, 1e-2, 200)
    for f in (0.1, 1.0, 10.0, 100.0):
        k = dia.stiffness(TWO_PI * f, x)
        assert np.all(np.diff(k.re) < 0)  # softening (Payne effect)
        assert np.all(np.diff(k.im / k.re) > 0)  # loss factor rises with amplitude
        assert np.all(k.im > 0)  # passive


def test_viscoelastic_frequency_dependence_is_a_weak_power_law():
    dia = ViscoelasticDiaphragm()
    k1 = dia.stiffness(TWO_PI * 1.0, 1e-4)
    k10 = dia.stiffness(TWO_PI * 10.0, 1e-4)
    # storage stiffness and loss factor rise by 10^beta and 10^gamma per decade
    assert float(k10.re / k1.re) == pytest.approx(10**dia.stiffness_frequency_exponent)
    eta1, eta10 = float(k1.im / k1.re), float(k10.im / k10.re)
    assert eta10 / eta1 == pytest.approx(10**dia.loss_frequency_exponent)


def test_viscoelastic_on_casadi_matches_numpy():
    ca = pytest.importorskip("casadi")
    dia = ViscoelasticDiaphragm()
    w, x = ca.SX.sym("w"), ca.SX.sym("x")
    k = dia.stiffness(w, x)
    f = ca.Function("k", [w, x], [k.re, k.im])
    for wv, xv in [(0.7, 3e-6), (20.0, 1e-4), (500.0, 2e-3)]:
        re, im = (float(v) for v in f(wv, xv))
        kn = dia.stiffness(wv, xv)
        assert re == pytest.approx(float(kn.re), rel=1e-13)
        assert im == pytest.approx(float(kn.im), rel=1e-13)


@pytest.mark.parametrize(
    "kwargs",
    [{"k0_n_per_m": -1.0}, {"kinf_n_per_m": 1e5}, {"eta0": -0.1}, {"critical_amplitude_m": 0.0},
     {"softening_exponent": float("nan")}, {"loss_frequency_exponent": 2.0}],
)
def test_viscoelastic_bad_parameters_name_the_parameter(kwargs):
    name = next(iter(kwargs))
    with pytest.raises(InputError, match=name):
        ViscoelasticDiaphragm(**kwargs)


# ---------------------------------------------------------------------------
# table model
# ---------------------------------------------------------------------------
def _table_from_viscoelastic():
    f = np.array([0.2, 1.0, 5.0, 24.0])
    x = np.array([5e-5, 1.5e-4, 5e-4])
    k = ViscoelasticDiaphragm().stiffness(TWO_PI * f[:, None], x[None, :])
    return TableDiaphragm(f, x, np.asarray(k.re), np.asarray(k.im), source="test")


def test_table_reproduces_its_nodes_and_interpolates_bilinearly_in_logs():
    tab = _table_from_viscoelastic()
    kn = tab.stiffness(TWO_PI * tab.frequency_hz[:, None], tab.amplitude_m[None, :])
    np.testing.assert_allclose(kn.re, tab.k_real_n_per_m, rtol=1e-14)
    np.testing.assert_allclose(kn.im, tab.k_imag_n_per_m, rtol=1e-14)
    # midpoint in (ln f, ln X) of the first cell = mean of its four corners
    fm = math.sqrt(tab.frequency_hz[0] * tab.frequency_hz[1])
    xm = math.sqrt(tab.amplitude_m[0] * tab.amplitude_m[1])
    k = tab.stiffness(TWO_PI * fm, xm)
    assert float(np.asarray(k.re)) == pytest.approx(tab.k_real_n_per_m[:2, :2].mean(), rel=1e-13)


def test_table_clamps_outside_its_grid_and_flags_it():
    tab = _table_from_viscoelastic()
    k_out = tab.stiffness(TWO_PI * 100.0, 1e-3)
    assert float(np.asarray(k_out.re)) == pytest.approx(tab.k_real_n_per_m[-1, -1], rel=1e-14)
    res = complex_stiffness(SpringDesign.reference(), [1.0, 100.0], 1e-4, diaphragm=tab,
                            warn=False)
    ok = res.diagnostics.checks["diaphragm_table_range"].ravel()
    assert ok.tolist() == [True, False]
    assert any("diaphragm_table_range" in w for w in res.warnings)


def test_table_csv_round_trip_and_casadi_equals_numpy(tmp_path):
    ca = pytest.importorskip("casadi")
    tab = _table_from_viscoelastic()
    path = tmp_path / "dia.csv"
    tab.to_frame().sample(frac=1.0, random_state=1).to_csv(path, index=False)  # any row order
    back = diaphragm_model(f"table:{path}")
    np.testing.assert_array_equal(back.k_real_n_per_m, tab.k_real_n_per_m)
    np.testing.assert_array_equal(back.k_imag_n_per_m, tab.k_imag_n_per_m)
    assert diaphragm_model(str(path)).k_imag_n_per_m.shape == (4, 3)
    w, x = ca.SX.sym("w"), ca.SX.sym("x")
    k = back.stiffness(w, x)
    fn = ca.Function("k", [w, x], [k.re, k.im])
    for f, a in [(0.5, 7e-5), (3.0, 2e-4), (20.0, 4.9e-4)]:
        kn = back.stiffness(TWO_PI * f, a)
        re, im = (float(v) for v in fn(TWO_PI * f, a))
        assert re == pytest.approx(float(np.asarray(kn.re)), rel=1e-12)
        assert im == pytest.approx(float(np.asarray(kn.im)), rel=1e-12)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty"),
        ("frequency_hz,amplitude_m,k_real_n_per_m\n1,1e-4,5000\n", "k_imag_n_per_m"),
        ("frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m\n1,1e-4,5000,abc\n",
         "not a number"),
        ("frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m\n"
         "1,1e-4,5000,100\n2,1e-4,5000,100\n1,2e-4,5000,100\n", "full frequency x amplitude"),
        ("frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m\n"
         "1,1e-4,5000,-100\n2,1e-4,5000,100\n1,2e-4,5000,100\n2,2e-4,5000,100\n", ">= 0"),
        ("frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m\n"
         "1,1e-4,5000,nan\n2,1e-4,5000,100\n1,2e-4,5000,100\n2,2e-4,5000,100\n", "NaN"),
    ],
)
def test_table_bad_csv_gives_an_error_naming_the_problem(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        TableDiaphragm.from_csv(path)


def test_unknown_diaphragm_names_the_choices():
    with pytest.raises(InputError, match="viscoelastic, none"):
        diaphragm_model("rubber")
    with pytest.raises(InputError, match="table:PATH"):
        diaphragm_model("table")
    assert isinstance(diaphragm_model("none"), NoDiaphragm)


# ---------------------------------------------------------------------------
# Eq. 43 and the parallel sum Eq. 42
# ---------------------------------------------------------------------------
def test_piston_area_eq43_by_hand():
    r1, r2 = 0.01, 0.0306
    by_hand = math.pi * (r2**2 + 2 * r2 * r1 + 4 * r1**2 / 3)
    assert piston_area_from_diaphragm(r1, r2) == pytest.approx(by_hand, rel=1e-15)
    # Eq. 43 is the outer circle pi (r1 + r2)^2 plus pi r1^2 / 3 from the conical roll
    assert piston_area_from_diaphragm(r1, r2) == pytest.approx(
        math.pi * (r1 + r2) ** 2 + math.pi * r1**2 / 3, rel=1e-14)
    with pytest.raises(InputError, match="diaphragm_r1_m"):
        piston_area_from_diaphragm(-1.0, r2)


def test_total_stiffness_is_the_parallel_sum_eq42():
    d = SpringDesign.reference()
    f, x = np.array([0.5, 3.0, 20.0]), np.array([5e-5, 5e-4])
    both = complex_stiffness(d, f, x, warn=False)
    air = complex_stiffness(d, f, x, diaphragm="none", warn=False)
    dia = ViscoelasticDiaphragm().stiffness(TWO_PI * f[:, None], x[None, :])
    np.testing.assert_allclose(both.k, air.k + (dia.re + 1j * dia.im), rtol=1e-14)
