"""Every number docs/response.md quotes outside its listings, recomputed from the code.

(The two listings are re-run by tests/docs/test_listings.py.) A quoted number must equal the
computed value at the precision it is printed with. If one of these fails, the page and the
code disagree: fix the page (or the code), never the tolerance.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from isodesign.response import (
    Payload,
    band_response,
    harmonic_response,
    linear_transmissibility,
    step_metrics,
    to_transfer_function,
)
from isodesign.response.isolator import loaded_design
from isodesign.spring.design import SpringDesign

PAGE = (Path(__file__).parents[2] / "docs" / "response.md").read_text(encoding="utf-8")
REF = SpringDesign.reference()
PAYLOAD = Payload(400.0, 4)


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in " ".join(PAGE.split()), text


def _band(floor="VC-A", target="VC-E", **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return band_response(REF, PAYLOAD, floor, target, **kw)


def test_p0_from_the_payload():
    d = loaded_design(REF, PAYLOAD)
    quoted(f"four reference springs under 400 kg run at {d.pressure_pa / 1e5:.3f} bar, which "
           f"lowers `k_s` from {REF.single_chamber_stiffness_n_per_m / 1e3:.1f} to\n"
           f"{d.single_chamber_stiffness_n_per_m / 1e3:.1f} kN/m")


def test_the_reference_spring_has_one_harmonic_root():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        h = harmonic_response(REF, PAYLOAD, np.geomspace(0.5, 50.0, 200),
                              np.array([1e-7, 1e-6, 1e-5, 1e-4, 1e-3]))
    assert np.all(h.n_roots == 1)
    quoted("The reference spring has a single\n  root everywhere from 0.1 um to 1 mm of floor "
           "motion")


def test_the_stroke_closures_on_the_reference_case():
    ea = _band(random_method="equivalent_amplitude")
    ra = _band(random_method="rayleigh")
    quoted(f"For the reference spring on a VC-A floor it\ntakes {ea.iterations} evaluations.")
    quoted(f"`closure_slope = d ln sigma_new / d ln sigma` at the solution is\nreported "
           f"({ea.closure_slope:.2f} for the reference case)")
    quoted(f"the two methods give sigma = {ea.stroke_rms_m * 1e6:.2f} um\nand "
           f"{ra.stroke_rms_m * 1e6:.2f} um and worst-band margins {ea.worst_margin_db:.2f} dB "
           f"and {ra.worst_margin_db:.2f} dB")
    quoted(f"`verdict()` | one line, e.g. `{ea.verdict()}`")


def test_stability_figures_of_the_reference_case():
    r = _band()
    s = r.stability
    k0 = s.static_stiffness_n_per_m
    air = REF.replace(pressure_pa=loaded_design(REF, PAYLOAD).pressure_pa).static_stiffness_n_per_m
    quoted(f"`f_n` = {s.natural_frequency_hz:.2f} Hz (`K0` = {k0 / 1e3:.1f} kN/m: "
           f"{air / 1e3:.1f} kN/m of\nair plus {(k0 - air) / 1e3:.1f} kN/m of diaphragm), "
           f"linear peak `|T|` = {s.peak_transmissibility:.2f} at {s.peak_frequency_hz:.2f} Hz, "
           f"{s.excited_peak_transmissibility:.2f} at `A*` = "
           f"{s.excitation_amplitude_m * 1e6:.0f} um on a\nVC-A floor, Zener damping ratio "
           f"{s.zener_damping_ratio:.3f} (optimum {s.zener_optimal_damping_ratio:.3f}).")
    quoted(f"the diaphragm is {(k0 - air) / k0:.0%}".replace("%", " %") + " of `K0`")


def test_other_floors_and_targets():
    iso = _band(target="ISO-office")
    quoted(f"meets ISO-office on that floor (worst margin {iso.worst_margin_db:+.1f} dB\nat "
           f"{iso.worst_band_hz:g} Hz)")
    vce = _band(floor="VC-E")
    df = vce.to_frame()
    failing = df[~df["passes"]]
    assert df[df["nominal_hz"] >= 3.15]["passes"].all()
    assert failing["nominal_hz"].min() == 1.0 and failing["nominal_hz"].max() == 2.5
    quoted(f"on a floor at VC-E it meets VC-E from the 3.15 Hz band up and misses it by up to\n"
           f"{-vce.worst_margin_db:.1f} dB between 1 and 2.5 Hz")
    quoted(f"sigma = {vce.stroke_rms_m * 1e6:.1f} um)")


def test_transfer_function_against_the_minor_loss():
    import control

    d = REF.replace(acoustics="lumped")
    f = np.geomspace(0.05, 200.0, 300)
    tf = to_transfer_function(d, PAYLOAD, flow="quasi_steady")
    t_ctl = np.asarray(control.frequency_response(tf, 2 * math.pi * f).complex).ravel()

    def worst(amp):
        t = linear_transmissibility(d, PAYLOAD, f, flow="quasi_steady", diaphragm="none",
                                    amplitude_m=amp)
        return float(np.max(np.abs(t_ctl - t) / np.abs(t)))

    quoted(f"({worst(1e-6):.0%}".replace("%", " %") + " at 1 um, rounding at 1e-18 m;")
    assert worst(1e-18) < 1e-12


def test_step_metrics_of_the_reference_poiseuille_spring():
    sm = step_metrics(REF, PAYLOAD, flow="poiseuille")
    quoted(f"Reference, Poiseuille: overshoot {sm.overshoot_percent:.0f} %, settling "
           f"{sm.settling_time_s:.1f} s.")


def test_quasi_steady_k_flag_of_the_reference_case():
    """The reference capillary under 4 x 100 kg: the quasi-steady law within 1 % in k at every
    point of the band response (the former Womersley-number bound flagged 137 of 981)."""
    r = _band()
    assert r.spring_diagnostics.diagnostics.checks["quasi_steady_k"].all()
    quoted("never for the reference capillary under 4 x 100 kg")


@pytest.mark.parametrize("text", ["60 %", "4.11", "13.4 kN/m", "+22.3 dB", "about 60 Hz"])
def test_drifted_figures_are_gone(text):
    """Figures the page once quoted and the code no longer gives."""
    assert text not in PAGE
