"""Diaphragm identification (isodesign.calibration.diaphragm_fit) on simulated rig data.

Data: the product's time-domain simulator (nonlinear chambers and tube) for a spring whose
diaphragm is the known viscoelastic model, with relative noise of 1 % on the real and the
imaginary part. Tolerances (the report quotes the measured errors):

* at the measured amplitudes, Re k_D within 3 % RMS over 0.2-24 Hz (5 % worst point), loss
  factor within 0.03 RMS;
* between them (interpolation in ln X), Re k_D within 6 % RMS;
* the fitted spring's total k within the noise: RMS relative residual 0.7-1.3 x the noise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.calibration import fit_diaphragm, read_measured_csv
from isodesign.cli import main as cli_main
from isodesign.errors import InputError
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import FittedDiaphragm, diaphragm_model
from isodesign.spring.stiffness import complex_stiffness, stiffness_function

REF = SpringDesign.reference()
SIGMA = 0.01


def recovery_errors(true, model, amplitudes_m, f_lo=0.2, f_hi=24.0):
    """Per amplitude: (RMS and max relative error of Re k_D, RMS error of the loss factor)."""
    w = 2 * math.pi * np.geomspace(f_lo, f_hi, 40)
    out = {}
    for x in amplitudes_m:
        kt, kf = true.stiffness(w, x), model.stiffness(w, x)
        e = kf.re / kt.re - 1
        de = kf.im / kf.re - kt.im / kt.re
        out[x] = (np.sqrt(np.mean(e**2)), np.abs(e).max(), np.sqrt(np.mean(de**2)))
    return out


def check_passive_and_softening(model):
    w = 2 * math.pi * np.geomspace(1e-3, 1e4, 300)[:, None]
    x = np.geomspace(1e-6, 5e-3, 60)[None, :]
    k = model.stiffness(w, x)
    assert np.all(np.asarray(k.im) >= 0) and np.all(np.asarray(k.re) > 0)  # passive everywhere
    w_in = 2 * math.pi * np.geomspace(*model.frequency_range_hz, 50)[:, None]
    re = np.asarray(model.stiffness(w_in, x).re)
    assert np.all(np.diff(re, axis=1) <= 1e-9 * re[:, 1:])  # softening in X


@pytest.fixture(scope="module")
def single_fit(single_chamber_rig, rig):
    f, amp, k = single_chamber_rig
    data = rig.measured(f, amp, rig.noisy(k, SIGMA, 1), "single_chamber")
    return data, fit_diaphragm(data, REF)


def test_single_chamber_identification_recovers_the_diaphragm(single_fit, single_chamber_rig, rig):
    _, fit = single_fit
    _, amp, k = single_chamber_rig
    errs = recovery_errors(rig.true_diaphragm, fit.model, amp)
    for x, (rms, worst, eta) in errs.items():
        print(f"measured X={x * 1e3:.3g} mm: Re k_D {rms:.2%} RMS ({worst:.2%} max), "
              f"eta {eta:.4f} RMS")  # fmt: skip
        assert rms < 0.03 and worst < 0.05 and eta < 0.03
    between = recovery_errors(rig.true_diaphragm, fit.model, [0.07e-3, 0.15e-3, 0.3e-3])
    for x, (rms, _, eta) in between.items():
        print(f"between X={x * 1e3:.3g} mm: Re k_D {rms:.2%} RMS, eta {eta:.4f} RMS")
        assert rms < 0.06 and eta < 0.04
    check_passive_and_softening(fit.model)
    # the fitted spring is within the noise of the data, and closer than that to the truth
    assert 0.7 * SIGMA < fit.rms_relative_residual < 1.3 * SIGMA
    k_fit = (fit.k_diaphragm_fit + fit.k_air).reshape(k.shape)
    assert np.sqrt(np.mean(np.abs(k_fit / k - 1) ** 2)) < SIGMA
    assert fit.regularization in dict.fromkeys(c[0] for c in fit.cv_table)
    assert "cross-validation" in fit.report() and "passive by construction" in fit.report()


def test_fitted_model_on_numpy_and_casadi_and_round_trip(single_fit, tmp_path):
    _, fit = single_fit
    p = tmp_path / "dia.toml"
    p.write_text(fit.to_toml())
    m2 = diaphragm_model(f"fit:{p}")
    assert isinstance(m2, FittedDiaphragm)
    w, x = 2 * math.pi * np.array([0.3, 2.0, 17.0]), np.array([6e-5, 1.3e-4, 4e-4])
    a, b = fit.model.stiffness(w, x), m2.stiffness(w, x)
    np.testing.assert_allclose([a.re, a.im], [b.re, b.im], rtol=1e-14)
    fn = stiffness_function(REF, diaphragm=m2)
    for fi, xi in ((0.5, 7e-5), (3.0, 1.3e-4), (12.0, 3.3e-4)):
        re, im, _ = fn(REF.volume_ratio, REF.top_volume_m3, REF.capillary_length_m,
                       REF.capillary_diameter_m, fi, xi)  # fmt: skip
        r = complex_stiffness(REF, fi, xi, diaphragm=m2, warn=False)
        assert float(re) == pytest.approx(float(r.k.real), rel=1e-9)
        assert float(im) == pytest.approx(float(r.k.imag), rel=1e-9)
    # smooth in ln X: a finite-difference slope is continuous across a measured amplitude
    xs = np.exp(np.log(1e-4) + np.array([-2e-3, -1e-3, 1e-3, 2e-3]))
    re = np.asarray(m2.stiffness(2 * math.pi * 2.0, xs).re)
    s1, s2 = (re[1] - re[0]) / 1e-3, (re[3] - re[2]) / 1e-3
    assert s1 == pytest.approx(s2, rel=0.01, abs=1e-6 * abs(re[0]))
    # outside the measured range: edge value, flagged
    assert not m2.in_range(2 * math.pi * 2.0, 1e-3)["diaphragm_fit_range"]


def test_design_file_diaphragm_table(tmp_path, single_fit):
    from isodesign.io.designfile import load_design, load_diaphragm

    _, fit = single_fit
    (tmp_path / "dia.toml").write_text(fit.to_toml())
    text = (
        "volume_ratio = 1.85\ntop_volume_m3 = 8.1e-4\ncapillary_length_m = 0.012\n"
        "capillary_diameter_m = 9e-4\npiston_area_m2 = 5.3e-3\npressure_pa = 4.93e5\n"
    )
    p = tmp_path / "a.toml"
    p.write_text(text + '\n[diaphragm]\nmodel = "viscoelastic"\nk0_n_per_m = 9000.0\n')
    assert load_design(p).volume_ratio == 1.85
    d = load_diaphragm(p)
    assert d.k0_n_per_m == 9000.0 and d.kinf_n_per_m == 4700.0
    assert diaphragm_model(str(p)).k0_n_per_m == 9000.0  # --diaphragm DESIGN.toml
    q = tmp_path / "b.toml"
    q.write_text(text + '\n[diaphragm]\nmodel = "fit:dia.toml"\n')  # relative to the file
    assert isinstance(load_diaphragm(q), FittedDiaphragm)
    bad = tmp_path / "bad.toml"
    bad.write_text(text + "\n[diaphragm]\nk0_n_per_m = 9000.0\nstiffnes = 1.0\n")
    with pytest.raises(InputError, match=r"diaphragm\.stiffnes.*valid: model, k0_n_per_m"):
        load_diaphragm(bad)
    bad.write_text(text + "\n[diaphragm]\nk0_n_per_m = -1.0\n")
    with pytest.raises(InputError, match="k0_n_per_m"):
        load_diaphragm(bad)


@pytest.mark.slow
def test_dual_chamber_identification_recovers_the_diaphragm(dual_chamber_rig, rig):
    """Dual-chamber data: the air model k_d* (harmonic balance) is subtracted; its own error
    against the simulator (up to about 3 % of |k_air|) adds to the noise."""
    d, f, amp, k = dual_chamber_rig
    data = rig.measured(f, amp, rig.noisy(k, SIGMA, 2), "dual_chamber")
    fit = fit_diaphragm(data, d)
    for x, (rms, worst, eta) in recovery_errors(rig.true_diaphragm, fit.model, amp).items():
        print(f"dual, X={x * 1e3:.3g} mm: Re k_D {rms:.2%} RMS ({worst:.2%} max), eta {eta:.4f}")
        assert rms < 0.04 and worst < 0.07 and eta < 0.03
    check_passive_and_softening(fit.model)
    assert fit.rms_relative_residual < 1.5 * SIGMA


def test_non_passive_sparse_and_malformed_data_are_rejected(single_chamber_rig, rig, tmp_path):
    f, amp, k = single_chamber_rig
    kn = rig.noisy(k, SIGMA, 3)
    flipped = rig.measured(f, amp, np.conj(kn), "single_chamber")  # phase sign convention wrong
    with pytest.raises(InputError, match=r"not passive.*phase sign"):
        fit_diaphragm(flipped, REF)
    stiffening = rig.measured(f, amp[::-1], kn, "single_chamber")  # amplitudes reversed
    fit = fit_diaphragm(stiffening, REF)
    assert any("the data stiffen from 0.05 to 0.1 mm" in fl for fl in fit.flags)
    check_passive_and_softening(fit.model)  # the constraints hold whatever the data
    sparse = rig.measured(f[::7], amp, kn[::7], "single_chamber")  # 3 frequencies
    with pytest.raises(InputError, match=r"too sparse: amplitude 0\.05 mm has 3 distinct"):
        fit_diaphragm(sparse, REF)
    cases = {
        "frequency_hz,amplitude_mm,k_real_n_per_m\n1,0.1,2e4\n": "imaginary-stiffness column",
        "frequency_hz,amplitude_mm,k_n_per_m\n1,0.1,2e4\n": "needs stiffness columns",
        "frequency_hz,amplitude_mm,k_real_n_per_m,k_imag_n_per_m\n1,0.1,nan,3\n": "NaN",
        "frequency_hz,amplitude_in,k_real_n_per_m,k_imag_n_per_m\n1,0.1,2,3\n": "amplitude column",
        "frequency_hz,amplitude_mm,k_real_n_per_m,k_imag_n_per_m\n-1,0.1,2,3\n": "must be > 0",
    }
    for body, msg in cases.items():
        p = tmp_path / "m.csv"
        p.write_text("# configuration: single_chamber\n" + body)
        with pytest.raises(InputError, match=msg):
            read_measured_csv(p)
    p.write_text("frequency_hz,amplitude_mm,k_real_n_per_m,k_imag_n_per_m\n1,0.1,2,3\n")
    with pytest.raises(InputError, match="configuration: not given"):
        read_measured_csv(p)


def test_csv_magnitude_phase_and_units(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text(
        "# configuration: dual-chamber\nfrequency_hz,amplitude_um,k_abs_kn_per_m,phase_deg\n"
        "2,50,30,10\n"
    )
    m = read_measured_csv(p)
    assert m.configuration == "dual_chamber" and m.amplitude_m[0] == pytest.approx(5e-5)
    assert m.k[0] == pytest.approx(30e3 * np.exp(1j * math.radians(10)))


def test_cli_fit_diaphragm_and_use_it(single_chamber_rig, rig, tmp_path, capsys):
    f, amp, k = single_chamber_rig
    rig.measured(f, amp, rig.noisy(k, SIGMA, 4), "single_chamber").to_csv(tmp_path / "m.csv")
    out, png = tmp_path / "dia.toml", tmp_path / "fit.png"
    assert cli_main(["fit", "diaphragm", str(tmp_path / "m.csv"), "-o", str(out),
                     "--plot", str(png)]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert "regularization lambda" in text and f"fit:{out}" in text
    assert png.stat().st_size > 20000
    assert cli_main(["stiffness", "--diaphragm", f"fit:{out}", "--freq", "1,5",
                     "--amplitude", "0.1mm"]) == 0  # fmt: skip
    assert "diaphragm=fit" in capsys.readouterr().out
    (tmp_path / "s.csv").write_text(
        "# configuration: single_chamber\nfrequency_hz,amplitude_mm,k_real_n_per_m,"
        "k_imag_n_per_m\n1,0.1,3e4,2e3\n2,0.1,3e4,2e3\n"
    )
    assert cli_main(["fit", "diaphragm", str(tmp_path / "s.csv")]) == 2
    assert "too sparse" in capsys.readouterr().err


def test_study_files_take_a_fitted_or_parameterized_diaphragm(single_fit, tmp_path):
    """``models.diaphragm = "fit:FILE.toml"`` (relative to the study) and a
    ``[models.diaphragm]`` table with viscoelastic parameters."""
    from isodesign.optimization.study import load_study

    _, fit = single_fit
    (tmp_path / "dia.toml").write_text(fit.to_toml())
    study = tmp_path / "s.toml"
    study.write_text('[models]\ndiaphragm = "fit:dia.toml"\n')
    st = load_study(study)
    assert isinstance(diaphragm_model(st.models["diaphragm"]), FittedDiaphragm)
    from isodesign.io.record import resolved_study_dict

    resolved = resolved_study_dict(st)["models"]["diaphragm"]
    assert resolved == f"fit:{(tmp_path / 'dia.toml').resolve()}"
    study.write_text('[models.diaphragm]\nmodel = "viscoelastic"\nk0_n_per_m = 9000.0\n')
    m = diaphragm_model(load_study(study).models["diaphragm"])
    assert m.k0_n_per_m == 9000.0 and m.eta0 == 0.07
    study.write_text('[models.diaphragm]\nk0_n_per_m = "stiff"\n')
    with pytest.raises(InputError, match=r"models\..*k0_n_per_m: expected a number"):
        load_study(study)
