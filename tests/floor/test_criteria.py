"""Tests of isodesign.floor and isodesign.floor.bands against published values."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from isodesign.errors import InputError
from isodesign.floor import (
    STANDARD_GRAVITY_M_S2,
    CriterionCurve,
    CurveSegment,
    FloorSpectrum,
    band_rms_to_psd,
    compliance,
    convert_band_rms,
    convert_psd,
    criteria_table,
    criterion,
    criterion_from_csv,
    criterion_names,
    psd_to_band_rms,
    unit_factor,
)
from isodesign.floor.bands import RELATIVE_BANDWIDTH, Bands, band_index_near, third_octave_bands

UM = 1e-6
UIN = 0.0254e-6
G0 = 9.80665

# --------------------------------------------------------------------------------------------
# Bands (IEC 61260-1, base 10)
# --------------------------------------------------------------------------------------------

EXACT_1_80 = [
    1.000, 1.259, 1.585, 1.995, 2.512, 3.162, 3.981, 5.012, 6.310, 7.943,
    10.00, 12.59, 15.85, 19.95, 25.12, 31.62, 39.81, 50.12, 63.10, 79.43,
]  # fmt: skip
NOMINAL_1_80 = [
    1, 1.25, 1.6, 2, 2.5, 3.15, 4, 5, 6.3, 8, 10, 12.5, 16, 20, 25, 31.5, 40, 50, 63, 80
]  # fmt: skip


def _sig4(x: float) -> float:
    return float(f"{x:.4g}")


def test_band_count_and_exact_centres_1_to_80_hz():
    b = third_octave_bands(1, 80)
    assert len(b) == 20
    assert [_sig4(c) for c in b.centre_hz] == EXACT_1_80
    assert b.index == tuple(range(-30, -10))


def test_nominal_labels_1_to_80_hz():
    b = third_octave_bands(1, 80)
    assert list(b.nominal_hz) == NOMINAL_1_80
    assert b.labels[:6] == ("1", "1.25", "1.6", "2", "2.5", "3.15")
    assert b.labels[-3:] == ("50", "63", "80")


@pytest.mark.parametrize(
    ("nominal", "exact"),
    [(0.1, 0.1), (0.125, 0.1259), (1000, 1000.0), (1250, 1259.0), (20000, 19950.0),
     (16000, 15850.0), (0.315, 0.3162)],
)  # fmt: skip
def test_bands_over_0p1_hz_to_20_khz(nominal, exact):
    b = third_octave_bands(0.1, 20000)
    assert len(b) == 54
    i = list(b.nominal_hz).index(nominal)
    assert _sig4(b.centre_hz[i]) == exact


def test_band_edges_ratio_and_relative_bandwidth():
    b = third_octave_bands(0.1, 20000)
    g = 10**0.3
    np.testing.assert_allclose(b.upper_hz / b.lower_hz, g ** (1 / 3), rtol=1e-13)
    np.testing.assert_allclose(b.lower_hz * b.upper_hz, b.centre_hz**2, rtol=1e-13)
    np.testing.assert_allclose(b.bandwidth_hz / b.centre_hz, RELATIVE_BANDWIDTH, rtol=1e-12)
    assert round(RELATIVE_BANDWIDTH, 4) == 0.2308
    assert RELATIVE_BANDWIDTH == pytest.approx(g ** (1 / 6) - g ** (-1 / 6), rel=1e-14)
    # contiguous bands share edges bit for bit
    assert np.array_equal(b.upper_hz[:-1], b.lower_hz[1:])


def test_band_selection_rule_uses_nominal_centre():
    # the 80 Hz band (exact 79.43 Hz) is in [1, 80]; it is not in [1, 79.5]
    assert third_octave_bands(1, 79.5).labels[-1] == "63"
    assert third_octave_bands(1.0, 1.0).labels == ("1",)
    assert third_octave_bands(0.99, 1.3).labels == ("1", "1.25")


def test_bands_frame_and_len():
    b = third_octave_bands(10, 20)
    df = b.to_frame()
    assert len(df) == len(b) == 4
    assert list(df.columns) == [
        "index", "label", "nominal_hz", "centre_hz", "lower_hz", "upper_hz", "bandwidth_hz"
    ]  # fmt: skip
    assert df["centre_hz"].iloc[0] == 10.0


@pytest.mark.parametrize(
    ("f_min", "f_max", "param"),
    [(0, 80, "f_min_hz"), (-1, 80, "f_min_hz"), (float("nan"), 80, "f_min_hz"),
     (1, float("inf"), "f_max_hz"), (80, 1, "f_min_hz"), (1.1, 1.2, "f_min_hz, f_max_hz"),
     ("a", 80, "f_min_hz")],
)  # fmt: skip
def test_bad_band_ranges(f_min, f_max, param):
    with pytest.raises(InputError, match=param):
        third_octave_bands(f_min, f_max)


@pytest.mark.parametrize("index", [(), (3, 2), (1.5,), (-60,), ("a",)])
def test_bad_band_index(index):
    with pytest.raises(InputError, match="index"):
        Bands(index)


@pytest.mark.parametrize(("f", "x"), [(1.25, -29), (1.2589, -29), (80, -11), (1.1, None)])
def test_band_index_near(f, x):
    assert band_index_near(f) == x


# --------------------------------------------------------------------------------------------
# Named curves
# --------------------------------------------------------------------------------------------

VC = [
    ("VC-A", 50, 2000), ("VC-B", 25, 1000), ("VC-C", 12.5, 500), ("VC-D", 6.25, 250),
    ("VC-E", 3.12, 125), ("VC-F", 1.56, 62.5), ("VC-G", 0.78, 31.25),
]  # fmt: skip


@pytest.mark.parametrize(("name", "um_s", "uin_s"), VC)
def test_vc_curves_flat_1_to_80_hz(name, um_s, uin_s):
    c = criterion(name)
    v = c.velocity_rms_m_s(third_octave_bands(1, 80))
    assert v.shape == (20,)
    np.testing.assert_allclose(v / UM, um_s, rtol=1e-12)
    # published imperial value: the nominal conversion, 1.6 % (VC-E ... G: 1.7 %) apart
    np.testing.assert_allclose(v / UIN, uin_s, rtol=0.018)
    assert c.source and "IEST-RP-CC012" in c.source and not c.unconfirmed


def test_vc_letters_halve():
    v = [criterion(n).velocity_rms_m_s(third_octave_bands(10, 10))[0] for n, _, _ in VC]
    np.testing.assert_allclose(np.array(v[:-1]) / np.array(v[1:]), 2.0, rtol=0.01)


def test_vc_outside_1_80_is_an_error():
    with pytest.raises(InputError, match="bands outside the curve"):
        criterion("VC-A").velocity_rms_m_s(third_octave_bands(63, 100))


@pytest.mark.parametrize(
    ("name", "ug", "um_s"), [("VC-A-legacy", 260, 50), ("VC-B-legacy", 130, 25)]
)
def test_legacy_vc_constant_acceleration_4_to_8_hz(name, ug, um_s):
    c = criterion(name)
    assert c.unconfirmed
    b = third_octave_bands(4, 80)
    v = c.velocity_rms_m_s(b)
    a_lim = ug * 1e-6 * G0
    # 4 Hz band from 260 ug at its exact centre 3.981 Hz
    assert v[0] == pytest.approx(a_lim / (2 * math.pi * 3.981071705534972), rel=1e-12)
    np.testing.assert_allclose(c.acceleration_rms_m_s2(b)[:3], a_lim, rtol=1e-12)
    # 8 Hz band onwards: flat velocity; continuity at 8 Hz within 1.5 %
    np.testing.assert_allclose(v[3:] / UM, um_s, rtol=1e-12)
    assert a_lim / (2 * math.pi * 8) / (um_s * UM) == pytest.approx(1.0146, abs=2e-4)
    with pytest.raises(InputError, match=r"3\.15"):
        c.velocity_rms_m_s(third_octave_bands(3, 8))


ISO_LEVELS = [("workshop", 8, 800), ("office", 4, 400), ("residential-day", 2, 200),
              ("residential-night", 1.4, 140), ("operating-theatre", 1, 100)]  # fmt: skip


@pytest.mark.parametrize(("label", "factor", "um_s"), ISO_LEVELS)
def test_iso_curves_follow_the_z_axis_base_curve(label, factor, um_s):
    """Default ISO curves: ISO 2631-2:1989 z-axis shape, 0.01 f^-1/2, 0.005 m/s^2, velocity."""
    c = criterion(f"ISO-{label}")
    b = third_octave_bands(1, 80)
    f = b.centre_hz
    v = c.velocity_rms_m_s(b)
    a = c.acceleration_rms_m_s2(b)
    np.testing.assert_allclose(v[9:] / UM, um_s, rtol=1e-12)  # 8 ... 80 Hz
    np.testing.assert_allclose(a[:6], factor * 0.01 * f[:6] ** -0.5, rtol=1e-12)  # 1 ... 3.15
    np.testing.assert_allclose(a[6:9], factor * 0.005, rtol=1e-12)  # 4 ... 6.3 Hz (4: smaller)
    assert a[0] == pytest.approx(factor * 0.01, rel=1e-12)  # 1 Hz: twice the 4-8 Hz plateau
    assert "ISO 2631-2" in c.source and "withdrawn" in c.note


@pytest.mark.parametrize(("label", "factor", "um_s"), ISO_LEVELS)
def test_iso_horizontal_curves(label, factor, um_s):
    c = criterion(f"ISO-{label}-xy")
    b = third_octave_bands(1, 80)
    a = c.acceleration_rms_m_s2(b)
    v = c.velocity_rms_m_s(b)
    np.testing.assert_allclose(a[:3], factor * 0.0036, rtol=1e-12)  # 1 ... 1.6 Hz
    np.testing.assert_allclose(v[3:], factor * 0.0036 / (2 * math.pi * 2), rtol=1e-12)
    assert v[-1] / UM == pytest.approx(286.5 * factor, rel=1e-3)
    assert "x-y" in c.source


@pytest.mark.parametrize(("label", "factor", "um_s"), ISO_LEVELS)
def test_iso_const_accel_variant_keeps_the_earlier_shape(label, factor, um_s):
    c = criterion(f"ISO-{label}-const-accel")
    b = third_octave_bands(1, 80)
    v = c.velocity_rms_m_s(b)
    np.testing.assert_allclose(v[9:] / UM, um_s, rtol=1e-12)
    np.testing.assert_allclose(v[9:] / UIN, um_s * 40, rtol=0.017)  # 32000 ... uin/s
    a = c.acceleration_rms_m_s2(b)[:9]  # 1 ... 6.3 Hz: constant acceleration
    np.testing.assert_allclose(a, 2 * math.pi * 8 * um_s * UM, rtol=1e-12)
    # twice as strict at 1 Hz as the z-axis base-curve shape
    assert criterion(f"ISO-{label}").acceleration_rms_m_s2(b)[0] / a[0] == pytest.approx(
        1.989, abs=1e-3
    )


def test_nist_a_published_values():
    c = criterion("NIST-A")
    b = third_octave_bands(1, 100)
    v = dict(zip(b.labels, c.velocity_rms_m_s(b), strict=True))
    assert v["10"] == pytest.approx(2 * math.pi * 10 * 25e-9, rel=1e-12)
    assert v["50"] == pytest.approx(3.1e-6, rel=1e-12)
    assert v["100"] == pytest.approx(3.1e-6, rel=1e-12)
    assert v["20"] == pytest.approx(3.1e-6, rel=1e-12)  # boundary band: the stricter value
    x = dict(zip(b.labels, c.displacement_rms_m(b), strict=True))
    assert x["1"] == pytest.approx(25e-9, rel=1e-12)
    assert x["16"] == pytest.approx(25e-9, rel=1e-12)
    assert 3.1e-6 / UIN == pytest.approx(125, rel=0.025)


@pytest.mark.parametrize("name", ["vc-a", "VC-A", "Vc-A", " vc_a ", "iso operating theatre"])
def test_registry_case_insensitive(name):
    assert criterion(name).name in criterion_names()


def test_registry_names_and_passthrough():
    names = criterion_names()
    assert len(names) == 25 and names[0] == "VC-A" and "NIST-A" in names
    c = criterion("VC-C")
    assert criterion(c) is c
    for n in names:
        c = criterion(n)
        assert c.name == n and c.source and c.description and c.quantity


@pytest.mark.parametrize("bad", ["VC-Z", "", 3, None])
def test_unknown_criterion(bad):
    with pytest.raises(InputError, match=r"criterion: unknown name .*valid: VC-A, VC-B"):
        criterion(bad)


def test_curves_are_immutable():
    c = criterion("VC-A")
    with pytest.raises(AttributeError):
        c.name = "x"


def test_criteria_table_long_and_wide():
    long = criteria_table()
    # 23 curves over 20 bands (7 VC, 15 ISO-derived, NIST-A), legacy curves over 4 ... 80 Hz
    assert len(long) == 23 * 20 + 2 * 14
    row = long[(long.criterion == "VC-A") & (long.label == "31.5")].iloc[0]
    assert row.velocity_rms_m_s == pytest.approx(50e-6)
    assert row.velocity_rms_um_s == pytest.approx(50)
    wide = criteria_table(1, 80, layout="wide", velocity_unit="um/s")
    assert wide.shape == (20, 3 + 25)
    assert wide["VC-B"].iloc[0] == pytest.approx(25)
    assert np.isnan(wide["VC-A-legacy"].iloc[0])
    assert wide.attrs["velocity_unit"] == "um/s"
    with pytest.raises(InputError, match="layout"):
        criteria_table(layout="tall")


def test_curve_to_frame():
    df = criterion("NIST-A").to_frame()
    assert len(df) == 21 and df["criterion"].iloc[0] == "NIST-A"


def test_segment_validation():
    with pytest.raises(InputError, match="quantity"):
        CurveSegment(1, 8, "jerk", 1.0)
    with pytest.raises(InputError, match="f_lo_hz"):
        CurveSegment(8, 1, "velocity", 1.0)
    with pytest.raises(InputError, match="segments"):
        CriterionCurve("x", "d", "s")
    with pytest.raises(InputError, match="exponent"):
        CurveSegment(1, 4, "acceleration", 0.01, float("nan"))


# --------------------------------------------------------------------------------------------
# Conversions
# --------------------------------------------------------------------------------------------


def test_band_rms_psd_known_value():
    b = third_octave_bands(10, 10)
    s = band_rms_to_psd(50e-6, b.bandwidth_hz[0])
    assert s == pytest.approx((50e-6) ** 2 / (10 * RELATIVE_BANDWIDTH), rel=1e-12)
    assert psd_to_band_rms(s, b.bandwidth_hz[0]) == pytest.approx(50e-6, rel=1e-12)


def test_band_rms_psd_round_trip_with_bands():
    b = third_octave_bands(1, 80)
    v = criterion("VC-E").velocity_rms_m_s(b)
    np.testing.assert_allclose(psd_to_band_rms(band_rms_to_psd(v, b), b), v, rtol=1e-12)


@given(
    st.lists(st.floats(1e-12, 1e-1, allow_nan=False), min_size=1, max_size=40),
    st.integers(-45, -5),
)
@settings(max_examples=60, deadline=None)
def test_property_band_rms_round_trip(values, start):
    v = np.array(values)
    idx = tuple(range(start, start + len(v)))
    if idx[-1] > 20:
        return
    b = Bands(idx)
    s = band_rms_to_psd(v, b)
    np.testing.assert_allclose(psd_to_band_rms(s, b), v, rtol=1e-12)
    floor = FloorSpectrum.from_band_rms(b, v)
    np.testing.assert_allclose(floor.band_rms_velocity(), v, rtol=1e-12)
    ones = floor.band_rms_velocity(b, 50, power_transmissibility=np.ones_like)
    np.testing.assert_allclose(ones, v, rtol=1e-12)


@pytest.mark.parametrize("f", [0.5, 10.0, 79.43])
def test_psd_quantity_relations(f):
    w = 2 * math.pi * f
    sv = 3e-12
    assert convert_psd(sv, f, "velocity", "displacement") == pytest.approx(sv / w**2, rel=1e-14)
    assert convert_psd(sv, f, "velocity", "acceleration") == pytest.approx(sv * w**2, rel=1e-14)
    assert convert_psd(sv, f, "displacement", "acceleration") == pytest.approx(sv * w**4, rel=1e-14)
    for q in ("displacement", "acceleration"):
        back = convert_psd(convert_psd(sv, f, "velocity", q), f, q, "velocity")
        assert back == pytest.approx(sv, rel=1e-14)


def test_band_rms_quantity_relations_known_values():
    # 1 um displacement at 10 Hz is 62.83 um/s and 3.948 mm/s^2
    v = convert_band_rms(1e-6, 10.0, "displacement", "velocity")
    assert v == pytest.approx(62.83185e-6, rel=1e-6)
    a = convert_band_rms(1e-6, 10.0, "displacement", "acceleration")
    assert a == pytest.approx(3.947842e-3, rel=1e-6)
    f = np.array([1.0, 8.0, 80.0])
    x = np.array([1e-6, 2e-7, 3e-9])
    back = convert_band_rms(convert_band_rms(x, f, "displacement", "acceleration"), f,
                            "acceleration", "displacement")  # fmt: skip
    np.testing.assert_allclose(back, x, rtol=1e-14)


@pytest.mark.parametrize(
    ("call", "param"),
    [(lambda: convert_psd(-1.0, 1.0, "velocity", "displacement"), "psd"),
     (lambda: convert_psd(1.0, 0.0, "velocity", "displacement"), "frequency_hz"),
     (lambda: convert_psd(1.0, 1.0, "speed", "displacement"), "from_quantity"),
     (lambda: convert_band_rms(1.0, 1.0, "velocity", "jerk"), "to_quantity"),
     (lambda: band_rms_to_psd(-1.0, 1.0), "band_rms"),
     (lambda: band_rms_to_psd(1.0, 0.0), "bandwidth_hz"),
     (lambda: psd_to_band_rms(float("nan"), 1.0), "psd")],
)  # fmt: skip
def test_conversion_bad_inputs(call, param):
    with pytest.raises(InputError, match=param):
        call()


@pytest.mark.parametrize(
    ("quantity", "unit", "factor"),
    [("velocity", "um/s", 1e-6), ("velocity", "µm/s", 1e-6), ("velocity", "in/s", 0.0254),
     ("velocity", "uin/s", 2.54e-8), ("displacement", "nm", 1e-9), ("acceleration", "g", G0),
     ("acceleration", "m/s2", 1.0), ("acceleration", "ug", G0 * 1e-6)],
)  # fmt: skip
def test_unit_factor(quantity, unit, factor):
    assert unit_factor(quantity, unit) == pytest.approx(factor, rel=1e-14)
    assert unit_factor(quantity, f"({unit})^2/Hz", psd=True) == pytest.approx(factor**2)


def test_unit_factor_unknown():
    with pytest.raises(InputError, match=r"unit: unknown velocity unit 'ft/min'; valid: m/s"):
        unit_factor("velocity", "ft/min")
    assert STANDARD_GRAVITY_M_S2 == G0


# --------------------------------------------------------------------------------------------
# FloorSpectrum
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", criterion_names())
def test_floor_from_criterion_reproduces_curve(name):
    c = criterion(name)
    floor = FloorSpectrum.from_criterion(name)
    b = c.bands()
    assert floor.bands == b and floor.kind == "band_constant"
    v = c.velocity_rms_m_s(b)
    np.testing.assert_allclose(floor.band_rms_velocity(), v, rtol=1e-12)
    # integration on a 50-point log grid with the band's own constant (|T| = 1)
    np.testing.assert_allclose(
        floor.band_rms_velocity(b, 50, power_transmissibility=np.ones_like), v, rtol=1e-12
    )
    # displacement is exact at the centre for a velocity PSD flat in the band
    np.testing.assert_allclose(floor.band_rms(b, "displacement"), c.displacement_rms_m(b),
                               rtol=1e-12)  # fmt: skip
    # acceleration: the centre approximation is 0.88 % low
    ratio = floor.band_rms(b, "acceleration") / c.acceleration_rms_m_s2(b)
    g3 = 10 ** (0.1)
    np.testing.assert_allclose(ratio, math.sqrt((g3 + 1 + 1 / g3) / 3), rtol=1e-12)


def test_floor_from_criterion_sub_range_and_outside():
    floor = FloorSpectrum.from_criterion("VC-A", 4, 31.5)
    assert floor.bands.labels[0] == "4" and floor.bands.labels[-1] == "31.5"
    with pytest.raises(InputError, match="bands outside the curve"):
        FloorSpectrum.from_criterion("VC-A-legacy", 1, 80)
    with pytest.raises(InputError, match="bands outside the data"):
        floor.band_rms_velocity(third_octave_bands(1, 10))


def test_floor_psd_values_on_band_grid():
    floor = FloorSpectrum.from_criterion("VC-A")
    b = floor.bands
    expected = (50e-6) ** 2 / b.bandwidth_hz
    grid, s = floor.band_grid(b, 50)
    assert grid.shape == s.shape == (20, 50)
    assert np.array_equal(grid[:, 0], b.lower_hz) and np.array_equal(grid[:, -1], b.upper_hz)
    np.testing.assert_allclose(s, np.repeat(expected[:, None], 50, axis=1), rtol=1e-14)
    assert np.all(s == s[:, :1])  # the band's own constant on the whole row, edges included
    # band-aware look-up at a shared edge gives each band its own value
    edge = b.upper_hz[3]
    assert floor.psd_velocity_on(edge, b.index[3]) == s[3, 0]
    assert floor.psd_velocity_on(edge, b.index[4]) == s[4, 0]
    # staircase: points strictly inside a band
    assert floor.psd_velocity(b.centre_hz[5]) == s[5, 0]
    with pytest.raises(InputError, match="outside the band"):
        floor.psd_velocity_on(b.centre_hz[5], b.index[6])
    with pytest.raises(InputError, match="outside the spectrum's range"):
        floor.psd_velocity(100.0)


def test_band_rms_through_transmissibility():
    floor = FloorSpectrum.from_criterion("VC-C")
    b = floor.bands
    half = floor.band_rms_velocity(b, 50, power_transmissibility=lambda f: 0.25 + 0 * f)
    np.testing.assert_allclose(half, 12.5e-6 / 2, rtol=1e-12)
    with pytest.raises(InputError, match="power_transmissibility"):
        floor.band_rms_velocity(b, 50, power_transmissibility=lambda f: -1 + 0 * f)
    with pytest.raises(InputError, match="points_per_band"):
        floor.band_rms_velocity(b, 1, power_transmissibility=np.ones_like)


def test_pointwise_spectrum_interpolation_and_band_integration():
    # S_v = c / f (power law): exact band mean square c ln(f_u/f_l) = c ln(G^(1/3))
    f = np.geomspace(0.5, 200, 7)
    c0 = 1e-10
    floor = FloorSpectrum(f, c0 / f)
    assert floor.kind == "pointwise"
    assert floor.psd_velocity(3.3) == pytest.approx(c0 / 3.3, rel=1e-12)
    b = third_octave_bands(1, 80)
    v = floor.band_rms_velocity(b)
    np.testing.assert_allclose(v, math.sqrt(c0 * 0.1 * math.log(10)), rtol=1e-5)
    x = floor.band_rms(b, "displacement")
    exact = np.sqrt(c0 / (2 * math.pi) ** 2 * (b.lower_hz**-2 - b.upper_hz**-2) / 2)
    np.testing.assert_allclose(x, exact, rtol=1e-4)
    with pytest.raises(InputError, match="frequency_hz"):
        floor.psd_velocity(0.4)
    assert floor.psd(10.0, "acceleration") == pytest.approx(c0 / 10 * (20 * math.pi) ** 2)
    # default bands: every whole band inside [0.5, 200] Hz, i.e. 0.63 ... 160 Hz
    assert len(floor.band_rms_velocity()) == len(Bands(tuple(range(-32, -7)))) == 25


@pytest.mark.parametrize(
    ("f", "s", "param"),
    [([1.0], [1.0], "frequency_hz"), ([1.0, 1.0], [1.0, 1.0], "frequency_hz"),
     ([2.0, 1.0], [1.0, 1.0], "frequency_hz"), ([1.0, 2.0], [1.0, 0.0], "psd_velocity"),
     ([1.0, 2.0], [1.0], "psd_velocity"), ([1.0, float("nan")], [1.0, 1.0], "frequency_hz")],
)  # fmt: skip
def test_floor_bad_construction(f, s, param):
    with pytest.raises(InputError, match=param):
        FloorSpectrum(np.array(f), np.array(s))


def test_floor_frames():
    df = FloorSpectrum.from_criterion("VC-A").to_frame()
    assert len(df) == 20
    np.testing.assert_allclose(df["velocity_rms_m_s"], 50e-6, rtol=1e-12)
    df2 = FloorSpectrum(np.array([1.0, 10.0]), np.array([1e-10, 1e-11])).to_frame()
    assert list(df2.columns) == ["frequency_hz", "psd_velocity_m2_s2_per_hz"]


def test_compliance():
    b = third_octave_bands(1, 80)
    v = np.full(20, 20e-6)
    v[5] = 30e-6
    r = compliance(v, b, "vc-b")
    assert not r.passes and r.worst_band_hz == 3.15 and r.worst_ratio == pytest.approx(1.2)
    assert compliance(v, b, "VC-A").passes
    assert r.to_frame()["pass"].sum() == 19
    with pytest.raises(InputError, match="velocity_rms_m_s"):
        compliance(v[:3], b, "VC-A")


# --------------------------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------------------------


def _write(tmp_path, text, name="floor.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_csv_round_trip_band_floor(tmp_path):
    floor = FloorSpectrum.from_criterion("NIST-A")
    p = floor.to_csv(tmp_path / "nist.csv")
    back = FloorSpectrum.from_csv(p)
    assert back.bands == floor.bands and back.name == "NIST-A floor"
    np.testing.assert_allclose(back.band_rms_velocity(), floor.band_rms_velocity(), rtol=1e-14)


def test_csv_round_trip_pointwise_floor(tmp_path):
    floor = FloorSpectrum(np.geomspace(1, 100, 9), np.geomspace(1e-9, 1e-13, 9))
    back = FloorSpectrum.from_csv(floor.to_csv(tmp_path / "psd.csv"))
    np.testing.assert_array_equal(back.frequency_hz, floor.frequency_hz)
    np.testing.assert_array_equal(back.psd_velocity_m2_s2_per_hz, floor.psd_velocity_m2_s2_per_hz)


def test_csv_header_parsing_um_s(tmp_path):
    text = (
        "# measured floor, lab 3\n"
        "# quantity: velocity; kind: band_rms; unit: um/s\n"
        "frequency_hz,value\n4,10\n5,20\n6.3,30\n8,40\n"
    )
    floor = FloorSpectrum.from_csv(_write(tmp_path, text))
    assert floor.bands.labels == ("4", "5", "6.3", "8")
    np.testing.assert_allclose(floor.band_rms_velocity(), [10e-6, 20e-6, 30e-6, 40e-6])
    # options override the header
    floor2 = FloorSpectrum.from_csv(_write(tmp_path, text), unit="mm/s")
    np.testing.assert_allclose(floor2.band_rms_velocity(), [10e-3, 20e-3, 30e-3, 40e-3])


def test_csv_acceleration_band_rms_exact_and_exact_centres(tmp_path):
    text = "# quantity: acceleration; kind: band-rms; unit: ug\nfrequency_hz,value\n"
    text += "3.981,260\n5.012,260\n6.310,260\n"
    floor = FloorSpectrum.from_csv(_write(tmp_path, text))
    np.testing.assert_allclose(floor.band_rms(quantity="acceleration"), 260e-6 * G0, rtol=1e-12)


def test_csv_psd_in_g2_per_hz(tmp_path):
    text = "# quantity: acceleration; kind: psd; unit: g^2/Hz\n"
    text += "frequency_hz,value\n1,1e-12\n100,1e-12\n"
    floor = FloorSpectrum.from_csv(_write(tmp_path, text))
    assert floor.psd_velocity(10.0) == pytest.approx(1e-12 * G0**2 / (20 * math.pi) ** 2)


@pytest.mark.parametrize(
    ("text", "kwargs", "match"),
    [("", {}, r"floor\.csv.*empty"),
     ("# quantity: velocity; kind: psd; unit: m/s\n", {}, "empty"),
     ("frequency_hz,value\n1,1\n2,2\n", {}, "quantity: not given"),
     ("frequency_hz,value\n1,1\n2,2\n", {"quantity": "velocity", "kind": "psd"}, "unit: not"),
     ("frequency_hz,value\n1,1\n", {"quantity": "speed", "kind": "psd", "unit": "m/s"},
      "quantity: unknown"),
     ("frequency_hz,value\n1,1\n", {"quantity": "velocity", "kind": "x", "unit": "m/s"},
      "kind: unknown"),
     ("# quantity: velocity; kind: psd; unit: furlong\nfrequency_hz,value\n1,1\n", {},
      "unit: unknown velocity unit 'furlong'"),
     ("# quantity: velocity; kind: band_rms; unit: m/s\nfreq,value\n1,1\n", {},
      r"floor\.csv' has no column 'frequency_hz'"),
     ("# quantity: velocity; kind: band_rms; unit: m/s\nfrequency_hz,val\n1,1\n", {},
      "no column 'value'"),
     ("# quantity: velocity; kind: band_rms; unit: m/s\nfrequency_hz,value\n1,-1\n", {},
      r"line 3, column 'value': must be >= 0"),
     ("# quantity: velocity; kind: psd; unit: m/s\nfrequency_hz,value\n1,1\n2,nan\n", {},
      r"line 4, column 'value': value must be finite"),
     ("# quantity: velocity; kind: psd; unit: m/s\nfrequency_hz,value\n1,1\n2,abc\n", {},
      r"line 4, column 'value': expected a number"),
     ("# quantity: velocity; kind: psd; unit: m/s\nfrequency_hz,value\n1,1\n2\n", {},
      r"line 4: expected 2 fields"),
     ("# quantity: velocity; kind: psd; unit: m/s\nfrequency_hz,value\n2,1\n1,1\n", {},
      r"line 4, column 'frequency_hz': frequencies must be strictly increasing"),
     ("# quantity: velocity; kind: band_rms; unit: m/s\nfrequency_hz,value\n1.1,1\n", {},
      "not a one-third-octave band centre"),
     ("# quantity: velocity; kind: band_rms; unit: m/s\nfrequency_hz,value\n1,1\n2,1\n", {},
      "consecutive"),
     ("# quantity: velocity; kind: psd; unit: m/s\nfrequency_hz,value\n1,1\n", {},
      "at least 2 data rows")],
)  # fmt: skip
def test_csv_floor_bad_inputs(tmp_path, text, kwargs, match):
    with pytest.raises(InputError, match=match):
        FloorSpectrum.from_csv(_write(tmp_path, text), **kwargs)


def test_csv_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"path: file .*nope\.csv' not found"):
        FloorSpectrum.from_csv(tmp_path / "nope.csv")


def test_criterion_from_csv_interpolation_and_range(tmp_path):
    text = (
        "# name: my-tool; source: vendor sheet\n"
        "frequency_hz,velocity_rms_m_s\n2,1e-6\n8,4e-6\n31.5,4e-6\n"
    )
    c = criterion_from_csv(_write(tmp_path, text, "tool.csv"))
    assert c.name == "my-tool" and c.source == "vendor sheet"
    b = third_octave_bands(2, 31.5)
    v = c.velocity_rms_m_s(b)
    assert v[0] == pytest.approx(1e-6, rel=1e-12) and v[6] == pytest.approx(4e-6, rel=1e-12)
    # log-log: straight line between 2 and 8 Hz, slope 1 -> 4 Hz gives 2e-6
    assert v[3] == pytest.approx(2e-6, rel=1e-12)
    np.testing.assert_allclose(v[6:], 4e-6, rtol=1e-12)
    assert c.bands() == b
    with pytest.raises(InputError, match="bands outside the data"):
        c.velocity_rms_m_s(third_octave_bands(1, 10))
    # a user curve is usable as a floor and for compliance
    floor = FloorSpectrum.from_criterion(c)
    np.testing.assert_allclose(floor.band_rms_velocity(), v, rtol=1e-12)


def test_criterion_from_csv_displacement(tmp_path):
    text = "frequency_hz,displacement_rms_m\n1,25e-9\n20,25e-9\n"
    c = criterion_from_csv(_write(tmp_path, text, "nist_like.csv"))
    assert c.name == "nist_like"
    b = third_octave_bands(1, 20)
    np.testing.assert_allclose(c.velocity_rms_m_s(b), 2 * math.pi * b.centre_hz * 25e-9, rtol=1e-12)
    np.testing.assert_allclose(c.displacement_rms_m(b), 25e-9, rtol=1e-12)


@pytest.mark.parametrize(
    ("text", "match"),
    [("", "empty"),
     ("frequency_hz\n1\n", "exactly one value column"),
     ("freq,velocity_rms_m_s\n1,1\n", "no column 'frequency_hz'"),
     ("frequency_hz,velocity_rms_m_s,displacement_rms_m\n1,1,1\n", "exactly one value column"),
     ("frequency_hz,velocity_rms_m_s\n1,1\n", "at least 2 data rows"),
     ("frequency_hz,velocity_rms_m_s\n1,1\n2,-1\n", r"line 3, column 'velocity_rms_m_s'"),
     ("frequency_hz,velocity_rms_m_s\n1,1\n2,0\n", "> 0"),
     ("frequency_hz,velocity_rms_m_s\n1,1\n1.01,1\n", "strictly increasing")],
)  # fmt: skip
def test_criterion_from_csv_bad(tmp_path, text, match):
    with pytest.raises(InputError, match=match) as ei:
        criterion_from_csv(_write(tmp_path, text, "curve.csv"))
    assert "curve.csv" in str(ei.value)


def test_import_is_light():
    code = "import sys, isodesign.floor; print('pandas' in sys.modules, 'scipy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_criteria_table_names_its_bad_arguments():
    # issue 14: names=[] raised pandas' "No objects to concatenate"
    from isodesign.errors import InputError
    from isodesign.floor import criteria_table

    with pytest.raises(InputError, match=r"^names: empty; give at least one criterion name"):
        criteria_table(names=[])
    with pytest.raises(InputError, match=r"^names: expected a sequence of criterion names"):
        criteria_table(names="VC-A")
    with pytest.raises(InputError, match=r"^f_min_hz, f_max_hz: no band of 100-200 Hz"):
        criteria_table(100.0, 200.0, names=("VC-A",))
    assert len(criteria_table(names=("VC-A",))) == 20
