"""Harmonic floor motion on the table: the closure per isolator reduces to the 1-DOF one."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.response.harmonic import harmonic_response
from isodesign.response.isolator import Payload
from isodesign.table.harmonic import table_harmonic_response
from isodesign.table.layout import Table


@pytest.mark.parametrize("floor_m", [1e-6, 3e-5])
def test_vertical_harmonic_reduces_to_the_payload(ref, floor_m):
    t = Table.symmetric(600.0, 1.2, 0.8, 0.35)
    f = np.geomspace(0.5, 20.0, 25)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = table_harmonic_response(ref, t, f, floor_m, "z")
        h = harmonic_response(ref, Payload(600.0, 4), f, floor_m)
    assert r.converged.all()
    assert np.all(h.n_roots.ravel() == 1)  # one branch: the comparison is meaningful
    db = 20 * np.log10(np.abs(r.transmissibility[:, 0, 2]) / np.abs(h.transmissibility.ravel()))
    assert np.max(np.abs(db)) < 0.01
    np.testing.assert_allclose(r.stroke_amplitude_m, np.repeat(h.stroke_m.reshape(-1, 1), 4, 1),
                               rtol=1e-6)


def test_horizontal_harmonic_rocks_the_table(ref):
    t = Table(600.0, [(0, 0), (1.2, 0), (1.2, 0.8), (0, 0.8)], (0.5, 0.45, 0.4), [70, 90, 130],
              instrument_points_m=[(1.1, 0.7, 0.8)])
    r = table_harmonic_response(ref, t, [1.0, 2.0, 5.0], 1e-5, "x")
    assert r.converged.all()
    # an x floor moves the off-centre point vertically (rocking) and strokes the isolators
    assert np.all(r.point_amplitude_m[:, 0, 2] > 1e-3 * r.point_amplitude_m[:, 0, 0])
    assert np.all(r.stroke_amplitude_m > 0)
    assert len(r.to_frame()) == 3 * 3
    with pytest.raises(InputError, match=r"^direction: "):
        table_harmonic_response(ref, t, [1.0], 1e-5, "w")
