"""Floor spectra from survey time histories (isodesign.floor.survey, ``isodesign floor``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.cli import main as cli_main
from isodesign.errors import InputError
from isodesign.floor import FloorSpectrum, third_octave_bands
from isodesign.floor.survey import (
    SurveyRecord,
    analyze_record,
    floor_from_record,
    is_record_csv,
    read_record,
)
from isodesign.response.model import resolve_floor

FS = 256.0  # Hz: 2.56 x the 80 Hz band's upper edge (89.1 Hz) needs 228 Hz
G = 9.80665


def synthesize(target_rms_m_s, bands, seed, *, fs=FS, duration_s=1200.0):
    """A velocity record with a band-constant PSD giving ``target_rms_m_s`` in each band.

    Frequency-domain synthesis: every FFT bin inside band b gets the amplitude of a sine whose
    mean square is ``S_b df`` (``S_b = V_b^2 / bandwidth``) and a random phase.
    """
    rng = np.random.default_rng(seed)
    n = int(fs * duration_s)
    f = np.fft.rfftfreq(n, 1.0 / fs)
    df = f[1]
    amp = np.zeros_like(f)
    for v, lo, hi in zip(target_rms_m_s, bands.lower_hz, bands.upper_hz, strict=True):
        m = (f >= lo) & (f < hi)
        amp[m] = np.sqrt(2.0 * v**2 / (hi - lo) * df)
    spec = amp * np.exp(1j * rng.uniform(0.0, 2.0 * math.pi, f.size)) * n / 2.0
    return np.fft.irfft(spec, n)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_known_band_spectrum_is_recovered_within_half_a_db(seed):
    bands = third_octave_bands(1, 80)
    rng = np.random.default_rng(100 + seed)
    # a survey-like spectrum: rising slowly, +-4 dB of random structure band to band
    target = 3e-6 * (bands.centre_hz / 8.0) ** 0.3 * 10 ** (rng.uniform(-4, 4, len(bands)) / 20)
    x = synthesize(target, bands, seed)
    rec = SurveyRecord(FS, ("z",), x[:, None], "velocity", "m/s", "synthetic")
    res = analyze_record(rec)
    err_db = 20 * np.log10(res.mean_rms_m_s[0] / target)
    print(f"seed {seed}: max band error {np.abs(err_db).max():.3f} dB")  # shown with -s
    assert np.all(np.abs(err_db) < 0.5)
    assert res.n_segments >= 30 and res.segment_s == pytest.approx(64.0)
    # the statistics are ordered: mean-square average <= p90 <= max (per band)
    assert np.all(res.max_rms_m_s >= res.percentile_rms_m_s)
    assert np.all(res.max_rms_m_s[0] >= res.mean_rms_m_s[0] * 0.999)
    floor = res.floor("mean")
    np.testing.assert_allclose(floor.band_rms_velocity(bands), res.mean_rms_m_s[0], rtol=1e-12)


@pytest.mark.parametrize("f0", [2.0, 8.0, 31.5])
def test_pure_sine_lands_in_its_band_with_the_right_rms(f0):
    """An acceleration sine of amplitude A (RMS A/sqrt 2) at a band's nominal frequency."""
    t = np.arange(int(FS * 400)) / FS
    a_amp = 1e-3  # m/s^2
    x = a_amp * np.sin(2 * math.pi * f0 * t + 0.3)
    rec = SurveyRecord(FS, ("z",), x[:, None], "acceleration", "m/s^2", "sine")
    res = analyze_record(rec)
    v = res.mean_rms_m_s[0]
    i = int(np.argmax(v))
    assert res.bands.nominal_hz[i] == pytest.approx(f0, rel=0.03)
    expected = a_amp / math.sqrt(2) / (2 * math.pi * f0)
    assert v[i] == pytest.approx(expected, rel=0.01)
    others = np.delete(v, i)
    assert np.all(others < 1e-3 * v[i])  # Hann leakage stays in the band
    # a steady sine: every segment the same, max == percentile == mean
    assert res.max_rms_m_s[0][i] == pytest.approx(v[i], rel=0.01)


def _write(path, header, cols, rows):
    lines = [f"# {h}" for h in header] + [",".join(cols)]
    lines += [",".join(f"{v:.10g}" for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    ("unit", "factor", "quantity"),
    [("g", G, "acceleration"), ("m/s^2", 1.0, "acceleration"), ("mg", G * 1e-3, "acceleration"),
     ("m/s", 1.0, "velocity"), ("mm/s", 1e-3, "velocity"), ("um/s", 1e-6, "velocity")],
)  # fmt: skip
def test_units_in_the_header_or_options(tmp_path, unit, factor, quantity):
    fs = 200.0
    t = np.arange(4000) / fs
    y = np.sin(2 * math.pi * 5 * t)
    p = _write(tmp_path / "r.csv", [f"unit: {unit}"], ["time_s", "z"], np.c_[t, y])
    rec = read_record(p)
    assert rec.quantity == quantity and rec.sample_rate_hz == pytest.approx(fs)
    np.testing.assert_allclose(rec.data[:, 0], y * factor, rtol=1e-9, atol=1e-15)
    # option overrides the header; sample rate in the header instead of a time column
    p2 = _write(tmp_path / "s.csv", ["unit: furlong", "sample_rate_hz: 200"], ["x", "y"],
                np.c_[y, 2 * y])  # fmt: skip
    rec2 = read_record(p2, unit=unit)
    assert rec2.axes == ("x", "y") and rec2.sample_rate_hz == 200.0
    np.testing.assert_allclose(rec2.data[:, 1], 2 * y * factor, rtol=1e-9, atol=1e-15)


def test_bad_records_are_rejected_with_clear_messages(tmp_path):
    fs = 256.0
    t = np.arange(int(fs * 200)) / fs
    y = np.sin(t)
    with pytest.raises(InputError, match="unit: unknown record unit 'furlong'"):
        read_record(_write(tmp_path / "a.csv", ["unit: furlong"], ["time_s", "z"], np.c_[t, y]))
    with pytest.raises(InputError, match="unit: not given"):
        read_record(_write(tmp_path / "b.csv", [], ["time_s", "z"], np.c_[t, y]))
    with pytest.raises(InputError, match=r"sample_rate_hz: .* no time column"):
        read_record(_write(tmp_path / "c.csv", ["unit: g"], ["z"], y[:, None]))
    t2 = t.copy()
    t2[100] = t2[99]
    with pytest.raises(InputError, match="not strictly increasing"):
        read_record(_write(tmp_path / "d.csv", ["unit: g"], ["time_s", "z"], np.c_[t2, y]))
    t3 = np.r_[t[:500], t[600:]]
    with pytest.raises(InputError, match="a gap or irregular sampling"):
        read_record(_write(tmp_path / "e.csv", ["unit: g"], ["time_s", "z"],
                           np.c_[t3, y[: t3.size]]))  # fmt: skip
    y4 = y.copy()
    y4[7] = np.nan
    with pytest.raises(InputError, match="NaN or missing value"):
        read_record(_write(tmp_path / "f.csv", ["unit: g"], ["time_s", "z"], np.c_[t, y4]))
    with pytest.raises(InputError, match="1 to 3 axis columns"):
        read_record(_write(tmp_path / "g.csv", ["unit: g"], ["time_s", "a", "b", "c", "d"],
                           np.c_[t, y, y, y, y]))  # fmt: skip
    rec = SurveyRecord(100.0, ("z",), np.zeros((100000, 1)), "velocity", "m/s")
    with pytest.raises(InputError, match=r"sample_rate_hz: 100 Hz is too low for the 80 Hz band"):
        analyze_record(rec)
    short = SurveyRecord(fs, ("z",), y[: int(fs * 30), None], "velocity", "m/s")
    with pytest.raises(InputError, match=r"too short for the 1 Hz band.*64 s"):
        analyze_record(short)
    res = analyze_record(short, f_min_hz=4.0)  # 16 s segments fit
    assert res.n_segments >= 2


def test_cli_floor_and_survey_as_floor(tmp_path, capsys):
    bands = third_octave_bands(1, 80)
    target = np.full(len(bands), 2e-6)
    v = synthesize(target, bands, 7, duration_s=600.0)
    n = v.size
    a = np.fft.irfft(np.fft.rfft(v) * 2j * math.pi * np.fft.rfftfreq(n, 1 / FS), n) / G  # in g
    rec = _write(tmp_path / "site.csv", [f"unit: g; sample_rate_hz: {FS:g}"], ["z"],
                 a[:, None])  # fmt: skip
    assert is_record_csv(rec)
    out = tmp_path / "out"
    assert cli_main(["floor", str(rec), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Welch: Hann window, 64 s segments" in text and "meets VC-" in text
    assert (out / "bands.csv").is_file() and (out / "bands.png").stat().st_size > 10000
    fl = FloorSpectrum.from_csv(out / "floor.csv")
    assert not is_record_csv(out / "floor.csv")
    np.testing.assert_allclose(fl.band_rms_velocity(bands), 2e-6, rtol=0.06)
    direct = resolve_floor(str(rec))
    np.testing.assert_allclose(
        direct.band_rms_velocity(bands), fl.band_rms_velocity(bands), rtol=1e-8
    )
    assert floor_from_record(rec, statistic="max").band_rms_velocity(bands).min() > 0
    assert n == int(FS * 600)
    assert cli_main(["floor", str(rec), "-o", str(tmp_path / "out2"), "--fmax", "125"]) == 2
    assert "too low for the 125 Hz band" in capsys.readouterr().err


def test_study_floor_from_a_record(tmp_path):
    """``[floor] record = "survey.csv"`` with the statistic chosen (path relative to the study)."""
    from isodesign.optimization.study import load_study

    bands = third_octave_bands(1, 80)
    v = synthesize(np.full(len(bands), 2e-6), bands, 3, duration_s=300.0)
    _write(tmp_path / "site.csv", [f"unit: m/s; sample_rate_hz: {FS:g}"], ["z"], v[:, None])
    study = tmp_path / "s.toml"
    study.write_text('[floor]\nrecord = "site.csv"\nstatistic = "max"\n')
    st = load_study(study)
    direct = floor_from_record(tmp_path / "site.csv", statistic="max")
    np.testing.assert_allclose(
        st.floor.band_rms_velocity(bands), direct.band_rms_velocity(bands), rtol=1e-12
    )
    from isodesign.io.record import resolved_study_dict

    assert resolved_study_dict(st)["floor"]["record"] == str((tmp_path / "site.csv").resolve())
    study.write_text('[floor]\nrecord = "site.csv"\nstatistic = "median"\n')
    with pytest.raises(InputError, match=r"floor\.statistic"):
        load_study(study)
    study.write_text('[floor]\nrecord = "site.csv"\nkind = "psd"\n')
    with pytest.raises(InputError, match="do not apply to a record"):
        load_study(study)
    study.write_text('[floor]\nrecord = "site.csv"\ncsv = "site.csv"\n')
    with pytest.raises(InputError, match="exactly one of"):
        load_study(study)
