"""The table's band response: the 1-DOF payload is its decoupled vertical mode; the closure."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.response.isolator import Payload
from isodesign.response.model import linear_transmissibility
from isodesign.response.random_input import band_response
from isodesign.table.floor import table_floor, table_grid
from isodesign.table.layout import Table
from isodesign.table.model import table_model
from isodesign.table.response import TableStatistical, table_band_response

TABLE = Table.symmetric(600.0, 1.2, 0.8, 0.35)


@pytest.mark.parametrize("floor, target, flow", [
    ("VC-A", "VC-C", "quasi_steady"),
    ("VC-B", "VC-D", "womersley"),
])  # fmt: skip
def test_vertical_band_response_reduces_to_the_payload_to_001_db(ref, floor, target, flow):
    """Symmetric layout, CG over the centroid, vertical floor only: the table's z band RMS at
    the CG is today's 1-DOF band response (statistical closure included)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = table_band_response(ref, TABLE, table_floor(floor, x=False, y=False), target,
                                bands=(4, 80), flow=flow)
        b = band_response(ref, Payload(600.0, 4), floor, target, bands=(4, 80), flow=flow)
    db = 20 * np.log10(r.velocity_rms_m_s[0, 2] / b.payload_velocity_rms_m_s)
    assert np.max(np.abs(db)) < 0.01
    np.testing.assert_allclose(r.stroke_rms_m, b.stroke_rms_m, rtol=1e-6)
    np.testing.assert_allclose(r.tube_velocity_rms_m_s, b.tube_velocity_rms_m_s, rtol=1e-6)
    # the vertical floor does not move the table horizontally
    assert np.max(r.velocity_rms_m_s[0, :2]) < 1e-9 * np.max(r.velocity_rms_m_s[0, 2])
    tdb = 20 * np.log10(np.abs(r.transmissibility[:, 0, 2, 2] / b.transmissibility))
    assert np.max(np.abs(tdb)) < 0.01


def test_vertical_transmissibility_reduces_to_the_payload(ref):
    f = np.geomspace(0.2, 100.0, 300)
    model = table_model(ref, TABLE)
    t = model.linear_outputs(f).points[:, 0, 2, 2]
    t1 = linear_transmissibility(ref, Payload(600.0, 4), f)
    assert np.max(np.abs(20 * np.log10(np.abs(t / t1)))) < 0.01
    np.testing.assert_allclose(t, t1, rtol=1e-10)


def test_asymmetric_closure_is_self_consistent(ref):
    t = Table(700.0, [(0.0, 0.0), (1.2, 0.0), (1.2, 0.8), (0.0, 0.8)], (0.5, 0.45, 0.4),
              [70.0, 90.0, 130.0], instrument_points_m=[(0.6, 0.4, 0.8), (1.1, 0.7, 0.8)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = table_band_response(ref, t, "VC-A", "VC-C", bands=(2, 80), points_per_band=12)
    # distinct p0 per group -> distinct strokes, and each RMS reproduces itself
    assert len(set(np.round(r.stroke_rms_m, 12))) >= 3
    st = TableStatistical(r.model, r.grid)
    s2, su2, *_ = st.variances(r.stroke_rms_m, r.tube_velocity_rms_m_s)
    np.testing.assert_allclose(np.sqrt(s2), r.stroke_rms_m, rtol=1e-8)
    np.testing.assert_allclose(np.sqrt(su2), r.tube_velocity_rms_m_s, rtol=1e-8)
    df = r.to_frame()
    assert list(df.columns[:3]) == ["point", "axis", "band"]
    assert len(df) == 2 * 3 * len(r.bands)
    assert "vertical floor" in r.notes[0] and "rigid floor" in r.notes[-1]
    assert r.verdict().startswith(("PASS", "FAIL"))
    assert r.worst_margin_db == pytest.approx(df["margin_db"].min())


def test_floor_per_axis():
    fl = table_floor("VC-A", x="VC-B", y=False)
    assert fl.names == ("VC-B floor", "none", "VC-A floor") and fl.notes == ()
    g = table_grid(fl, (4, 80), target="VC-C", points_per_band=6)
    assert np.all(g.stroke_weight[1] == 0) and np.all(g.band_weight[1] == 0)
    assert np.all(g.floor_velocity_rms_m_s[0] < g.floor_velocity_rms_m_s[2])
    with pytest.raises(InputError, match=r"^floor.x: "):
        table_floor("VC-A", x="VC-Q")
    with pytest.raises(InputError, match=r"^floor: no axis"):
        table_floor(x=False, y=False, z=False)
