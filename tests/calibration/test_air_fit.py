"""Air-side calibration (isodesign.calibration.air_fit): K, D_c and n from dual-chamber data.

Data: the time-domain simulator for a spring with K = 2.5, D_c = 1.0 mm, n = 1.3 and the known
viscoelastic diaphragm, 2 % relative noise; the fit starts from the reference spring (K = 1.5,
D_c = 0.9 mm, adiabatic). Each estimate must lie within 3 of its standard errors of the truth
and within an absolute tolerance of about 1.5 standard errors (K 1.2, D_c 8 %, n 0.015): K and
D_c are 99.7 % correlated (the data constrain a combination of them), so each alone is loose
(standard errors about 0.85 and 6 %), n is tight (0.005).
"""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.calibration import MeasuredStiffness
from isodesign.calibration.air_fit import AIR_PARAMETERS, fit_air_side
from isodesign.cli import main as cli_main
from isodesign.commands.fit import AIR_PARAMETER_NAMES
from isodesign.errors import InputError
from isodesign.io.designfile import load_design
from isodesign.spring.design import SpringDesign

REF = SpringDesign.reference()
SIGMA = 0.02
TOL = {"minor_loss": 1.2, "capillary_diameter_m": 0.08e-3, "polytropic_index": 0.015}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_air_side_parameters_are_recovered(dual_chamber_rig, rig, seed):
    _, f, amp, k = dual_chamber_rig
    data = rig.measured(f, amp, rig.noisy(k, SIGMA, 10 + seed), "dual_chamber")
    fit = fit_air_side(data, REF, diaphragm=rig.true_diaphragm)
    print(fit.report())
    assert fit.converged and not fit.at_bound
    for nm, v, se in zip(fit.names, fit.values, fit.standard_errors, strict=True):
        true = rig.true_air[nm]
        print(f"{nm}: {v:.5g} (true {true:g}), error {v - true:+.3g}, {abs(v - true) / se:.2f} SE")
        assert abs(v - true) < TOL[nm] and abs(v - true) < 3 * se
    c = fit.correlation
    np.testing.assert_allclose(np.diag(c), 1.0, rtol=1e-12)
    assert np.allclose(c, c.T) and abs(c[0, 1]) > 0.9  # K and D_c: a flat direction
    assert "K and D_c are" in fit.report()
    # the calibrated spring reproduces the data within the noise
    assert fit.rms_relative_residual < 1.3 * SIGMA


def test_air_fit_on_model_data_and_errors(rig, tmp_path, capsys):
    """Fast check on data from the frequency-domain model itself (exact up to the noise)."""
    from isodesign.spring.stiffness import complex_stiffness

    d = REF.replace(**rig.true_air)
    f, amp = np.geomspace(0.2, 24, 10), np.array([0.05e-3, 0.5e-3])
    k = complex_stiffness(d, f, amp, diaphragm="none", warn=False).k
    ff, xx = np.meshgrid(f, amp, indexing="ij")
    exact = MeasuredStiffness(ff.ravel(), xx.ravel(), k.ravel(), "dual_chamber", "model")
    fit = fit_air_side(exact, REF)
    np.testing.assert_allclose(
        fit.values, [rig.true_air[n] for n in fit.names], rtol=1e-6
    )  # noise-free data: the truth, to the solver's tolerance
    assert set(AIR_PARAMETER_NAMES.values()) == set(AIR_PARAMETERS)
    exact.to_csv(tmp_path / "m.csv")
    out = tmp_path / "spring.toml"
    assert cli_main(["fit", "spring", str(tmp_path / "m.csv"), "-o", str(out)]) == 0
    assert "correlation" in capsys.readouterr().out
    assert load_design(out).minor_loss == pytest.approx(2.5, rel=1e-5)
    single = MeasuredStiffness(ff.ravel(), xx.ravel(), k.ravel(), "single_chamber")
    with pytest.raises(InputError, match="needs dual_chamber data"):
        fit_air_side(single, REF)
    with pytest.raises(InputError, match="parameters"):
        fit_air_side(exact, REF, parameters=("volume_ratio",))
    assert cli_main(["fit", "spring", str(tmp_path / "m.csv"), "--parameters", "K,x"]) == 2
    assert "--parameters: unknown 'x'" in capsys.readouterr().err
