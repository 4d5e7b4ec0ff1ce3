"""Tube end corrections: the entrained mass at each end of the capillary, in both models."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign import SpringDesign, complex_stiffness
from isodesign.numerics.cplx import Cx
from isodesign.spring.capillary import (
    FLANGED_END_CORRECTION,
    QUASI_STEADY_INERTANCE_COEFFICIENT,
    linear_resistance,
    poiseuille_resistance,
    tube_end_length_m,
)
from isodesign.spring.chamber import chamber_line
from isodesign.spring.flow_models import resistance_function
from isodesign.spring.stiffness import stiffness_function
from isodesign.spring.transmission_line import tube_two_port

REF = SpringDesign.reference()
F = np.geomspace(0.5, 200.0, 400)


def _k(d, flow="quasi_steady", f=F):
    return complex_stiffness(d, f, 1e-6, flow=flow, diaphragm="none", warn=False).k_air.ravel()


def _change(lc, dc, vt=0.81e-3, flow="quasi_steady"):
    d = REF.replace(capillary_length_m=lc, capillary_diameter_m=dc, top_volume_m3=vt)
    return np.max(np.abs(_k(d, flow) / _k(d.replace(tube_end_correction=False), flow) - 1))


def test_end_mass_is_the_flanged_correction_in_both_flows():
    w = np.array([3.0, 30.0])
    on, off = REF, REF.replace(tube_end_correction=False)
    a = REF.capillary_diameter_m / 2
    assert tube_end_length_m(on) == pytest.approx(2 * FLANGED_END_CORRECTION * a)
    assert tube_end_length_m(off) == 0.0
    for flow in ("quasi_steady", "womersley"):
        for fn in (lambda d, flow=flow: resistance_function(flow, d, w)(np.full(2, 0.3)),
                   lambda d, flow=flow: linear_resistance(flow, d, w)):
            diff = fn(on).to_complex() - fn(off).to_complex()
            np.testing.assert_allclose(diff, 1j * w * 2 * 0.8216 * a / REF.capillary_area_m2,
                                       rtol=1e-12)
    # the paper's models are as printed
    for flow in ("poiseuille", "zhao"):
        np.testing.assert_array_equal(
            resistance_function(flow, on, w)(np.full(2, 0.3)).to_complex(),
            resistance_function(flow, off, w)(np.full(2, 0.3)).to_complex())


def test_distributed_model_unchanged_without_the_ends():
    """End correction off: the network of docs/acoustics.md section 3, recomputed here from its
    parts with the quasi-steady line law (Poiseuille plus 4/3 of the plug inertance)."""
    d = REF.replace(tube_end_correction=False, capillary_length_m=0.5, capillary_diameter_m=2e-3)
    w = 2 * math.pi * F
    u = 0.7
    c = resistance_function("quasi_steady", d, w)(np.full_like(w, u)).to_complex()
    c_lin = (poiseuille_resistance(d)
             + 1j * QUASI_STEADY_INERTANCE_COEFFICIENT * w * d.capillary_length_m
             / d.capillary_area_m2)
    ch, b, cc = (v.to_complex() for v in tube_two_port(d, w, Cx.from_complex(c_lin)))
    ch_t, b_t, c_t = (v.to_complex() for v in chamber_line(d, d.top_volume_m3, w))
    ch_b, _, c_b = (v.to_complex() for v in chamber_line(d, d.bottom_volume_m3, w))
    r = d.density_kg_m3 * (c - c_lin) / 2
    z2 = ch_b / c_b + r
    z3 = (ch * z2 + b) / (cc * z2 + ch) + r
    expected = 1j * w * d.piston_area_m2**2 * (ch_t * z3 + b_t) / (c_t * z3 + ch_t)
    from isodesign.spring.equations import air_stiffness

    got = air_stiffness(d, w, Cx.from_complex(c), "quasi_steady").to_complex()
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_the_ends_are_outside_the_line():
    """The ends' mass is a lumped series term at each end (not spread along the line): with
    the ends on, the distributed model equals the one without them for the resistance plus
    the end mass as an end term, exactly."""
    d = REF.replace(capillary_length_m=0.5, capillary_diameter_m=4e-3)
    w = 2 * math.pi * F
    from isodesign.spring.acoustics import acoustic_network

    net_on = acoustic_network(d, w, "quasi_steady")
    net_off = acoustic_network(d.replace(tube_end_correction=False), w, "quasi_steady")
    np.testing.assert_allclose(net_on.c_womersley.to_complex(),
                               net_off.c_womersley.to_complex(), rtol=1e-14)
    c = resistance_function("quasi_steady", d, w)(np.full_like(w, 0.2))
    np.testing.assert_allclose(net_on.stiffness(c).to_complex(), net_off.stiffness(c).to_complex(),
                               rtol=1e-13)


@pytest.mark.parametrize("flow", ["quasi_steady", "womersley"])
def test_size_of_the_effect(flow):
    """Tens of % near the tube's resonance for a 50 mm x 4 mm tube, a few % (to 20 %) for
    2.3 mm, under 1 % for tubes of 2 m or longer."""
    assert _change(0.05, 4e-3, flow=flow) > 0.3
    assert 0.02 < _change(0.194, 2.3e-3, 0.655e-3, flow=flow) < 0.05
    assert 0.05 < _change(0.05, 2.3e-3, flow=flow) < 0.2
    for lc, dc, vt in ((2.0, 4e-3, 4e-3), (2.0, 2.3e-3, 0.81e-3), (3.0, 5e-3, 4e-3)):
        assert _change(lc, dc, vt, flow=flow) < 0.01


@pytest.mark.parametrize("acoustics", ["lumped", "distributed"])
def test_casadi_equals_numpy_with_the_ends(acoustics):
    d = REF.replace(capillary_length_m=0.05, capillary_diameter_m=2.3e-3, acoustics=acoustics)
    for flow in ("quasi_steady", "womersley"):
        fn = stiffness_function(d, flow=flow)
        f = np.array([0.7, 7.0, 18.0, 60.0])
        x = 5e-5
        res = complex_stiffness(d, f, x, flow=flow, warn=False)
        for i, fi in enumerate(f):
            kr, ki, u = (float(v) for v in fn(d.volume_ratio, d.top_volume_m3,
                                              d.capillary_length_m, d.capillary_diameter_m, fi, x))
            assert complex(kr, ki) == pytest.approx(res.k[i], rel=1e-7)
            assert u == pytest.approx(res.diagnostics.velocity_amplitude_m_s[i], rel=1e-7)
        # and the ends changed it
        off = complex_stiffness(d.replace(tube_end_correction=False), f, x, flow=flow, warn=False)
        assert np.max(np.abs(res.k / off.k - 1)) > 0.01


def test_short_tube_is_flagged():
    short = REF.replace(capillary_length_m=3e-3, capillary_diameter_m=2e-3)  # 3 radii
    r = complex_stiffness(short, [1.0, 10.0], 5e-5, warn=False)
    assert not r.diagnostics.checks["tube_end_correction"].any()
    assert any(s.startswith("tube_end_correction") for s in r.diagnostics.summary())
    ok = complex_stiffness(REF, [1.0, 10.0], 5e-5, warn=False)  # 12 mm of 0.9 mm: 27 radii
    assert ok.diagnostics.checks["tube_end_correction"].all()
    off = complex_stiffness(short.replace(tube_end_correction=False), [1.0], 5e-5, warn=False)
    assert "tube_end_correction" not in off.diagnostics.checks


def test_design_round_trip():
    d = REF.replace(tube_end_correction=False)
    assert d.to_dict()["tube_end_correction"] is False
    assert "tube_end_correction" not in REF.to_dict()
    from isodesign.errors import InputError

    with pytest.raises(InputError, match="tube_end_correction"):
        REF.replace(tube_end_correction="yes")


def test_design_file_key_round_trip(tmp_path):
    from isodesign.errors import InputError
    from isodesign.io.designfile import design_to_toml, load_design

    d = REF.replace(tube_end_correction=False)
    p = tmp_path / "d.toml"
    p.write_text(design_to_toml(d))
    assert "tube_end_correction = false" in p.read_text()
    back = load_design(p)
    assert back.tube_end_correction is False and back == d
    p.write_text(design_to_toml(REF))
    assert "tube_end_correction" not in p.read_text()
    assert load_design(p).tube_end_correction is True
    p.write_text('tube_end_correction = "no"\n' + design_to_toml(REF))
    with pytest.raises(InputError, match="tube_end_correction"):
        load_design(p)


def test_study_key_reaches_the_design():
    from isodesign.errors import InputError
    from isodesign.optimization.study import vertical_study

    assert vertical_study().start_design().tube_end_correction is True
    st = vertical_study().with_changes(hardware={"tube_end_correction": False})
    assert st.start_design().tube_end_correction is False
    with pytest.raises(InputError, match=r"hardware\.tube_end_correction"):
        vertical_study().with_changes(hardware={"tube_end_correction": "off"})
