"""Where Re mu of the lowest mode is <= 0 only above a positive range (a capillary's air
column above its resonance), ``mode_solutions`` does not call it a static instability:
the report and ``isodesign stability`` printed "statically unstable on time scales slower
than 5.8 Hz" beside the static verdict "stable" for the built-in table's optimum."""

from __future__ import annotations

import numpy as np

from isodesign.optimization.study import table_study
from isodesign.table.model import table_model
from isodesign.table.modes import mode_solutions, rocking_stability

# the built-in table study's optimum (1 start, 4 points per band): N = 8, L_c = 0.5 m
OPTIMUM = {"volume_ratio": 8.0, "top_volume_m3": 0.0006666666662482381,
           "capillary_length_m": 0.5, "capillary_diameter_m": 0.002756921628217374}


def test_a_negative_storage_stiffness_band_is_not_a_static_instability():
    st = table_study()
    model = table_model(st.design_at(OPTIMUM), st.table)
    sol = mode_solutions(model)
    assert rocking_stability(model).stable
    assert sol.eigenvalue_rad2_s2[0] > 0 and sol.unstable_below_hz is None
    assert len(sol.negative_ranges_hz) == 1
    lo, hi = sol.negative_ranges_hz[0]
    assert 3.0 < lo < hi < 8.0
    # every scan point inside the range has Re mu <= 0, the points just outside > 0
    f, mu = sol.scan_frequency_hz, sol.eigenvalue_rad2_s2
    inside = (f >= lo) & (f <= hi)
    assert np.all(mu[inside] <= 0) and np.all(mu[~inside] > 0)
    # the cause, independently: the spring's storage stiffness is negative there
    k = np.real(np.asarray(model.vertical_stiffness(np.array([np.sqrt(lo * hi)]), 1e-6)[0]))
    assert k[0] < 0
    text = sol.text()
    assert "statically unstable" not in text and "not a static instability" in text
    assert f"{lo:.3g} to {hi:.3g} Hz" in text
