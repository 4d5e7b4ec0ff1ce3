"""The numbers quoted in docs/table.md's worked example."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from isodesign.optimization.study import table_study
from isodesign.table.floor import table_floor
from isodesign.table.model import table_model
from isodesign.table.modes import rocking_stability, table_modes
from isodesign.table.response import table_band_response

PAGE = (Path(__file__).parents[2] / "docs" / "table.md").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def job():
    st = table_study()
    m = st.models
    model = table_model(st.start_design(), st.table, flow=m["flow"],
                        amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])
    return st, model


def test_modes_table_of_the_worked_example(job):
    _, model = job
    md = table_modes(model)
    rows = re.findall(r"^\| (\d) \| ([\w+]+) \| ([\d.]+) \| ([\d.]+) \|$", PAGE, re.M)
    assert len(rows) == 6
    for (j, name, f, z) in rows:
        k = int(j) - 1
        assert md.names[k] == name
        assert f"{md.frequency_hz[k]:.3f}" == f and f"{md.damping_ratio[k]:.3f}" == z
    rs = rocking_stability(model)  # sealed springs at the quasi-static 1 mHz
    assert f"{rs.margin[0]:.3g}" == "4.28" and f"{rs.margin[1]:.3g}" == "9.63"
    assert f"{rs.critical_height_m:.3g}" == "1.5"
    assert "4.28 about x" in PAGE and "9.63 about y" in PAGE
    assert "critical CG height 1.5 m" in PAGE
    k0 = rocking_stability(model, frequency_hz=None)  # with K0: the 1-DOF tilt margin
    assert f"{k0.margin[0]:.3g}" == "4.62" and "4.62 with K0" in PAGE


def test_band_figures_of_the_worked_example(job):
    st, _ = job
    d, m = st.start_design(), st.models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r3 = table_band_response(d, st.table, st.floor_axes, st.target, bands=st.bands,
                                 flow=m["flow"], distortion=m["distortion"])
        r1 = table_band_response(d, st.table, table_floor("VC-A", x=False, y=False), st.target,
                                 bands=st.bands, flow=m["flow"], distortion=m["distortion"])
    # what `isodesign response` prints: the study's closure, the distortion on by default
    assert m["distortion"] is True
    # x and y are zero by symmetry on the vertical floor: finite margins (the distortion's
    # round-off of either sign gave NaN there)
    assert not np.isnan(r1.margin_db).any()
    assert r3.worst[:3] == ("corner", "z", "4") and f"{-r3.worst[3]:.2f}" == "8.21"
    assert f"{-r3.margin_db[0, 2].min():.2f}" == "0.51"
    assert f"{-r1.worst_margin_db:.2f}" == "0.16"
    assert f"{r1.stroke_rms_m[0] * 1e6:.1f}" == "25.7" and f"{r3.stroke_rms_m[0] * 1e6:.1f}" \
        == "38.6"
    corner = np.hypot(*st.table.instrument_points_m[1, :2])
    assert f"{corner:.2f}" == "0.58"
    for s in ("8.21 dB in z at 4 Hz", "misses by 0.51 dB", "missed by 0.16 dB", "25.7 to 38.6 um",
              "0.58 m from the CG"):
        assert s in PAGE, s
