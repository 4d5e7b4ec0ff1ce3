"""The table's transmissibility arrays as labelled frames, and the labelled mode and
harmonic figures (issue 23: no unlabelled (n_freq, k, 3, 3) array, no anonymous axes)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from isodesign.optimization.study import table_study
from isodesign.table.assembly import AXES, DOFS
from isodesign.table.frames import COLUMNS
from isodesign.table.harmonic import table_harmonic_response
from isodesign.table.model import table_model
from isodesign.table.modes import table_modes
from isodesign.table.response import table_band_response


@pytest.fixture(scope="module")
def study():
    return table_study()


@pytest.fixture(scope="module")
def band(study):
    m = study.models
    return table_band_response(study.start_design(), study.table, study.floor_axes,
                               study.target, bands=study.bands, points_per_band=3,
                               flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                               diaphragm=m["diaphragm"], warn=False)


def test_band_transmissibility_frame_labels_every_index(band):
    df = band.transmissibility_frame()
    assert tuple(df.columns) == (*COLUMNS, "transmissibility_linear_db")
    f = band.grid.frequency_hz
    k = len(band.point_names)
    assert len(df) == f.size * k * 9
    assert set(df["axis_in"]) == set(df["axis_out"]) == set(AXES)
    assert list(df["point"].unique()) == list(band.point_names)
    for p, name in enumerate(band.point_names):
        for i, a_in in enumerate(AXES):
            for o, a_out in enumerate(AXES):
                sel = df[(df["point"] == name) & (df["axis_in"] == a_in)
                         & (df["axis_out"] == a_out)]
                t = band.transmissibility[:, p, o, i]  # [f, point, out, in]
                np.testing.assert_array_equal(sel["frequency_hz"], f)
                np.testing.assert_allclose(sel["transmissibility_abs"], np.abs(t), rtol=1e-12)
                np.testing.assert_allclose(sel["phase_deg"], np.degrees(np.angle(t)),
                                           rtol=1e-12)
                lin = np.abs(band.transmissibility_linear[:, p, o, i])
                np.testing.assert_allclose(sel["transmissibility_linear_db"],
                                           20 * np.log10(lin), rtol=1e-12)
    # the diagonal's peak, read from the frame, is the result's own peak per point and axis
    diag = df[df["axis_in"] == df["axis_out"]]
    peak = diag.groupby(["point", "axis_out"])["transmissibility_db"].max()
    own = band.peak_transmissibility_db()
    for p, name in enumerate(band.point_names):
        for a, ax in enumerate(AXES):
            assert peak[(name, ax)] == pytest.approx(own[p, a], abs=1e-9)


def test_harmonic_frame_and_figure_are_labelled(study):
    m = study.models
    f = np.geomspace(0.8, 20.0, 12)
    r = table_harmonic_response(study.start_design(), study.table, f, 1e-5, "y",
                                flow=m["flow"], diaphragm=m["diaphragm"])
    df = r.to_frame()
    assert tuple(df.columns) == (*COLUMNS, "amplitude_m", "converged")
    assert set(df["axis_in"]) == {"y"} and r.direction_name == "y"
    assert len(df) == f.size * len(study.table.point_names) * 3
    np.testing.assert_allclose(df["amplitude_m"], df["transmissibility_abs"] * 1e-5,
                               rtol=1e-12)
    np.testing.assert_allclose(df["transmissibility_db"],
                               20 * np.log10(df["transmissibility_abs"]), rtol=1e-12)
    fig = r.plot()
    ax = fig.axes[0]
    assert ax.get_xlabel() == "frequency (Hz)"
    assert ax.get_ylabel().startswith("|T| (dB)") and "along y" in ax.get_title()
    oblique = table_harmonic_response(study.start_design(), study.table, f[:2], 1e-5,
                                      (1.0, 0.0, 1.0), flow=m["flow"],
                                      diaphragm=m["diaphragm"])
    assert oblique.direction_name == "(0.707, 0, 0.707)"
    assert set(oblique.to_frame()["axis_in"]) == {"(0.707, 0, 0.707)"}


def test_mode_figure_has_labelled_axes_and_a_title(study):
    m = study.models
    model = table_model(study.start_design(), study.table, flow=m["flow"],
                        amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])
    modes = table_modes(model)
    fig = modes.plot()
    ax = fig.axes[0]
    assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title()
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    for j, (name, fr) in enumerate(zip(modes.names, modes.frequency_hz, strict=True)):
        assert ticks[j].startswith(f"{j + 1}: {name}\n") and f"{fr:.3g} Hz" in ticks[j]
    # the stacked bars are the energy fractions: each mode's bars reach 1
    heights = np.array([b.get_height() for b in ax.patches]).reshape(len(DOFS), 6)
    np.testing.assert_allclose(heights.T, modes.energy_fraction, atol=1e-12)
    np.testing.assert_allclose(heights.sum(axis=0), 1.0, rtol=1e-9)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == list(DOFS)
