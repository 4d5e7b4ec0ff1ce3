"""Monte Carlo verifier of the random response, and the closures checked against it.

Standard errors: with random-phase floors (the default) the band RMS of the payload varies
across seeds by at most 0.06 dB (4 seeds x 160 s, the cases below; printed by
``MonteCarloResult.standard_error_db``), the stroke RMS by about 0.1 %; the tolerances
below leave room for that.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from isodesign.errors import InputError, ModelValidityWarning
from isodesign.floor import FloorSpectrum
from isodesign.response import Payload, band_response, linear_transmissibility
from isodesign.simulation.monte_carlo import (
    MonteCarloResult,
    fit_prony,
    prony_diaphragm,
    simulate_random_response,
)
from isodesign.spring.capillary import churchill_friction_re_product
from isodesign.spring.diaphragm import PronyDiaphragm, diaphragm_model

VCA = FloorSpectrum.from_criterion("VC-A")
VCA4 = FloorSpectrum.from_band_rms(VCA.bands, 4.0 * VCA.band_rms_velocity(), name="4x VC-A")


def _long(ref):
    """A long-capillary design (transitional to turbulent tube flow on 4x VC-A)."""
    return ref.replace(volume_ratio=4.1, top_volume_m3=1.18e-3, capillary_length_m=0.18,
                       capillary_diameter_m=2.14e-3)  # fmt: skip


def _closure(design, payload, floor, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        return band_response(design, payload, floor, "VC-E", **kw)


def test_compiled_churchill_is_the_package_law():
    from isodesign.simulation._mc_kernel import churchill_phi

    re = np.geomspace(1.0, 1e7, 300)
    for rough in (0.0, 1e-3):
        got = np.array([churchill_phi(r, rough) for r in re])
        np.testing.assert_allclose(got, churchill_friction_re_product(re, rough), rtol=1e-13)


def test_prony_fit_of_the_diaphragm():
    dia = diaphragm_model("viscoelastic")
    w = 2 * math.pi * np.geomspace(0.9, 90.0, 60)
    kd = dia.stiffness(w, 4e-5)
    k_inf, k_i, rate_i, err = fit_prony(w, kd.re + 1j * kd.im)
    assert err < 0.05 and k_inf >= 0 and np.all(k_i > 0) and np.all(rate_i > 0)


def test_prony_diaphragm_model():
    pd = PronyDiaphragm(3000.0, (1000.0, 2000.0), (10.0, 300.0))
    k = pd.stiffness(np.array([1e-6, 1e9]), 1e-5)
    np.testing.assert_allclose(k.re, [3000.0, 6000.0], rtol=1e-9)  # static and glassy limits
    assert np.all(k.im > 0) and k.im[0] < 1e-3
    assert diaphragm_model(pd) is pd
    w = 2 * math.pi * np.geomspace(1.0, 80.0, 30)
    kk = pd.stiffness(w, 1e-5)
    _, err = prony_diaphragm(pd, w / (2 * math.pi), 1e-5)
    assert err < 0.01
    assert np.all(np.diff(kk.re) > 0)
    with pytest.raises(InputError, match=r"^diaphragm:"):
        PronyDiaphragm(1.0, (1.0,), ())
    with pytest.raises(InputError, match=r"^diaphragm:"):
        PronyDiaphragm(1.0, (1.0,), (-1.0,))


def test_linear_limit_matches_the_linear_transmissibility(ref):
    """A floor 1000 times below VC-A: the nonlinear simulation is linear; against |T_lin|^2."""
    p = Payload(400.0, 4)
    tiny = FloorSpectrum.from_band_rms(VCA.bands, 1e-3 * VCA.band_rms_velocity())
    mc = simulate_random_response(ref, p, tiny, target="VC-E", seeds=1, duration_s=320.0,
                                  diaphragm="none")  # fmt: skip
    def t2(ff):
        t = linear_transmissibility(ref, p, ff.ravel(), diaphragm="none", amplitude_m=1e-9)
        return np.abs(t.reshape(ff.shape)) ** 2

    expect = tiny.band_rms_velocity(mc.bands, 400, power_transmissibility=t2)
    # the rest: bins of 1/320 Hz against the band integral (the random-phase floor has no
    # estimation variance when the system is linear)
    np.testing.assert_allclose(mc.payload_velocity_rms_m_s, expect, rtol=0.01)
    np.testing.assert_allclose(mc.floor_velocity_rms_m_s, tiny.band_rms_velocity(), rtol=1e-9)
    assert abs(mc.stroke_kurtosis - 3.0) < 0.3


def test_step_halving_converges(ref):
    p = Payload(400.0, 4)
    runs = [
        simulate_random_response(ref, p, VCA4, target="VC-E", seeds=[5], duration_s=40.0,
                                 diaphragm="none", time_step_s=dt)
        for dt in (1 / 1024, 1 / 2048, 1 / 4096)
    ]
    d1 = np.max(np.abs(20 * np.log10(runs[1].payload_velocity_rms_m_s
                                     / runs[0].payload_velocity_rms_m_s)))  # fmt: skip
    d2 = np.max(np.abs(20 * np.log10(runs[2].payload_velocity_rms_m_s
                                     / runs[1].payload_velocity_rms_m_s)))  # fmt: skip
    assert d2 < 0.02 and d2 < d1 / 8  # fourth order: 16x per halving
    assert runs[2].stroke_rms_m == pytest.approx(runs[1].stroke_rms_m, rel=1e-5)


#: Cases whose stroke RMS misses its tolerance (3 %, the last field of CASES), with the
#: measured size of the miss (a known limit, asserted to stay as it is: the test fails if
#: the miss grows or disappears).
#: ref-4xVC-A: a Gaussian linearization of a strongly quadratic damper; the tube velocity is
#: far from Gaussian (kurtosis 2.2), and the closure over-damps the resonance: -3.4 % stroke.
KNOWN_STROKE_MISSES = {"ref-4xVC-A": (0.03, 0.04)}

# the verified cases: (id, design, kg per isolator, floor, flow, diaphragm, stroke tol)
CASES = [
    ("ref-VC-A", None, 100.0, VCA, "quasi_steady", "none", 0.03),
    ("ref-4xVC-A", None, 100.0, VCA4, "quasi_steady", "none", 0.03),
    ("long-VC-A", "long", 150.0, VCA, "quasi_steady", "none", 0.03),
    ("long-4xVC-A", "long", 150.0, VCA4, "quasi_steady", "none", 0.03),
    # end to end with the default diaphragm, frozen in the simulation as a Prony series at
    # 1.880 x its own stroke RMS (that fit errs by 4 %: a causal element cannot follow the
    # model's loss factor over its nearly flat storage stiffness)
    ("ref-VC-A-viscoelastic", None, 100.0, VCA, "quasi_steady", "viscoelastic", 0.03),
    # the same diaphragm fitted at the closure's A*: closure and simulation see the same
    # linear viscoelastic element (no fit error between them)
    ("ref-4xVC-A-prony", None, 100.0, VCA4, "quasi_steady", "prony", 0.03),
    ("long-4xVC-A-womersley", "long", 150.0, VCA4, "womersley", "none", 0.03),
]


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_statistical_closure_against_monte_carlo(ref, case):
    case_id, which, kg, floor, flow, dia, stroke_tol = case
    d = _long(ref) if which == "long" else ref
    p = Payload(4 * kg, 4)
    if dia == "prony":
        a_star = _closure(d, p, floor, flow=flow).equivalent_amplitude_m
        dia, err = prony_diaphragm("viscoelastic", np.geomspace(0.89, 89.1, 60), a_star)
        assert err < 0.1
    mc = simulate_random_response(d, p, floor, target="VC-E", seeds=4, duration_s=160.0,
                                  flow=flow, diaphragm=dia)  # fmt: skip
    assert np.nanmax(mc.standard_error_db()) < 0.08
    new = _closure(d, p, floor, flow=flow, diaphragm=dia)
    err = mc.error_db(new)
    assert np.max(np.abs(err)) < 0.3, err
    assert new.tube_velocity_rms_m_s == pytest.approx(mc.tube_velocity_rms_m_s, rel=0.04)
    # the harmonic closure on the stroke errs by 0.7 to 2.7 dB in these cases
    old = _closure(d, p, floor, flow=flow, diaphragm=dia, random_method="equivalent_amplitude")
    assert np.max(np.abs(mc.error_db(old))) > 0.6
    stroke_err = abs(new.stroke_rms_m / mc.stroke_rms_m - 1.0)
    if case_id in KNOWN_STROKE_MISSES:
        lo, hi = KNOWN_STROKE_MISSES[case_id]
        assert lo < stroke_err < hi, f"known stroke miss changed: {stroke_err:.4f}"
        # the non-Gaussian distortion (docs/random-response.md 3c) closes this miss
        dist = _closure(d, p, floor, flow=flow, diaphragm=dia, distortion=True)
        assert abs(dist.stroke_rms_m / mc.stroke_rms_m - 1.0) < 0.01
        assert np.max(np.abs(mc.error_db(dist))) < 0.3
        pytest.xfail(f"stroke RMS off by {stroke_err:.1%} (> {stroke_tol:.0%}): non-Gaussian "
                     "tube velocity, a limit of the Gaussian closure (docs/random-response.md; "
                     "distortion=True closes it, section 3c)")
    assert stroke_err < stroke_tol


def test_result_api(ref):
    mc = simulate_random_response(ref, Payload(400.0, 4), "VC-A", target="VC-E", seeds=2,
                                  duration_s=40.0, diaphragm="none")  # fmt: skip
    assert isinstance(mc, MonteCarloResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        mc.stroke_rms_m = 0.0
    df = mc.to_frame()
    assert len(df) == len(mc.bands) == 20
    assert df.attrs["stroke_rms_m"] == mc.stroke_rms_m
    assert np.all(np.isfinite(mc.payload_velocity_rms_se_m_s))
    r = repr(mc)
    assert r.startswith("MonteCarloResult(2 seeds x 40 s") and len(r) < 300
    assert mc.seeds == (0, 1) and mc.per_seed_band_ms.shape == (2, 20)
    one = simulate_random_response(ref, Payload(400.0, 4), "VC-A", seeds=[1], duration_s=40.0,
                                   diaphragm="none")  # fmt: skip
    assert np.all(np.isnan(one.payload_velocity_rms_se_m_s))
    np.testing.assert_allclose(one.per_seed_band_ms[0], mc.per_seed_band_ms[1], rtol=1e-12)


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"seeds": 0}, "seeds"),
        ({"seeds": [-1]}, "seeds"),
        ({"duration_s": 5.0}, "duration_s"),
        ({"duration_s": -1.0}, "duration_s"),
        ({"flow": "zhao"}, "flow"),
        ({"amplitudes": "white"}, "amplitudes"),
        ({"time_step_s": 0.01}, "time_step_s"),
        ({"warmup_s": -1.0}, "warmup_s"),
    ],
)
def test_bad_input_is_named(ref, kw, name):
    args = {"seeds": 1, "duration_s": 40.0, "diaphragm": "none"}
    args.update(kw)
    with pytest.raises(InputError, match=rf"^{name}:"):
        simulate_random_response(ref, Payload(400.0, 4), "VC-A", **args)


def test_gaussian_amplitudes_give_a_gaussian_floor(ref):
    """Rayleigh amplitudes: the floor's band mean squares scatter about the spectrum's (each
    band an average of |A_k|^2/2 over its bins), and the linear stroke is Gaussian."""
    tiny = FloorSpectrum.from_band_rms(VCA.bands, 1e-3 * VCA.band_rms_velocity())
    mc = simulate_random_response(ref, Payload(400.0, 4), tiny, seeds=3, duration_s=80.0,
                                  diaphragm="none", amplitudes="gaussian")
    ratio = mc.floor_velocity_rms_m_s / tiny.band_rms_velocity()
    # 3 seeds x (18 to 1400 bins per band): relative scatter of the RMS <= 7 % (1 Hz band)
    assert np.all(np.abs(ratio - 1.0) < 0.25) and abs(np.mean(ratio) - 1.0) < 0.05
    assert abs(mc.stroke_kurtosis - 3.0) < 0.3
    assert np.all(mc.payload_velocity_rms_se_m_s > 0)
