"""One model: a study without ``[table]`` is the symmetric table its ``[payload]`` describes
(docs/table.md, section 14), and that table's analysis is the vertical analysis."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import table_study, vertical_study
from isodesign.response.isolator import Payload
from isodesign.table.layout import Table
from isodesign.table.statics import level
from isodesign.table.study import (
    payload_table,
    study_floor_axes,
    study_table,
    symmetric_layout,
)

A_P = 5.3e-3


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6, 7, 8, 12])
def test_symmetric_layout_is_centred_aligned_and_spaced(n):
    s = 0.9
    xy = symmetric_layout(n, s)
    assert xy.shape == (n, 2)
    np.testing.assert_allclose(xy.mean(axis=0), 0.0, atol=1e-15)
    # principal axes of the support along x and y
    assert abs(np.sum(xy[:, 0] * xy[:, 1])) < 1e-12
    # mirror-symmetric about the y axis: the set of positions maps onto itself
    mirrored = xy * np.array([-1.0, 1.0])
    d = np.linalg.norm(mirrored[:, None] - xy[None], axis=-1)
    assert np.all(d.min(axis=1) < 1e-12)
    if n > 1:
        dist = np.linalg.norm(xy[:, None] - xy[None], axis=-1)[np.triu_indices(n, 1)]
        assert dist.min() == pytest.approx(s, rel=1e-12)


@pytest.mark.parametrize("n", [3, 4, 5, 6, 8, 12])
def test_payload_table_levels_every_isolator_at_the_vertical_p0(ref, n):
    p = Payload(700.0, n, 1.1, 0.4)
    t = payload_table(p, piston_area_m2=ref.piston_area_m2)
    assert t.n_isolators == n and t.mass_kg == 700.0 and t.cg_height_m == 0.4
    np.testing.assert_allclose(t.cg_m[:2], t.isolators_m.mean(axis=0), atol=1e-15)
    # inertia: a homogeneous box over the isolators' span and twice the CG height
    span = np.ptp(t.isolators_m, axis=0)
    np.testing.assert_allclose(np.diag(t.inertia_kg_m2),
                               [700 * (span[1] ** 2 + 0.8 ** 2) / 12,
                                700 * (span[0] ** 2 + 0.8 ** 2) / 12,
                                700 * (span[0] ** 2 + span[1] ** 2) / 12], rtol=1e-12)
    lv = level(t, ref.piston_area_m2)
    p0 = ref.with_load(700.0, n).pressure_pa
    np.testing.assert_allclose(lv.pressure_pa, p0, rtol=1e-13)
    np.testing.assert_allclose(lv.load_n, 700.0 * p.g_m_s2 / n, rtol=1e-13)


def test_payload_table_of_four_is_the_square_table():
    t = payload_table(Payload(600.0, 4, 1.2, 0.35))
    sq = Table.symmetric(600.0, 1.2, 1.2, 0.35)
    np.testing.assert_allclose(t.isolators_m, sq.isolators_m)
    np.testing.assert_allclose(t.inertia_kg_m2, sq.inertia_kg_m2)
    np.testing.assert_allclose(t.cg_m, sq.cg_m)


def test_payload_table_raises_the_supply_for_a_heavy_payload():
    # 4,000 kg on 4 isolators of 5.3e-3 m^2 needs p0 of about 19.5 bar abs: the vertical
    # study has no supply pressure, so the symmetric table's supply follows its p0
    t = payload_table(Payload(4000.0, 4, 1.2, 0.35), piston_area_m2=A_P)
    lv = level(t, A_P)
    assert lv.pressure_pa.max() <= t.supply_pressure_pa


@pytest.mark.parametrize("n", [1, 2, 65])
def test_payload_table_refuses_what_no_table_is(n):
    with pytest.raises(InputError, match="payload.isolators"):
        payload_table(Payload(600.0, n, 1.2, 0.35))


def test_payload_without_geometry_takes_the_documented_defaults():
    t = payload_table(Payload(600.0, 4))
    np.testing.assert_allclose(np.ptp(t.isolators_m, axis=0), [1.2, 1.2])
    assert t.cg_height_m == 0.35


def test_study_table_is_the_table_or_the_payloads():
    st = vertical_study()
    t = study_table(st)
    assert t.n_isolators == st.payload.isolators
    assert t.cg_height_m == st.payload.cg_height_m
    fl = study_floor_axes(st)
    assert fl.x is None and fl.y is None and fl.z is st.floor
    ts = table_study()
    assert study_table(ts) is ts.table
    assert study_floor_axes(ts) is ts.floor_axes
