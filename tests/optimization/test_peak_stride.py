"""The continuous peak's two-stage search (refine.PEAK_STRIDE) returns what the
evaluation of all 4001 samples returns (issue 27: a cheaper check per point)."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.optimization import refine
from isodesign.optimization.problem import Problem
from isodesign.optimization.study import vertical_study


@pytest.mark.parametrize("mass_kg", [300.0, 900.0, 1540.0])
def test_the_strided_search_finds_the_full_evaluations_peak(mass_kg):
    st = vertical_study().with_changes({"payload.mass_kg": mass_kg})
    prob = Problem(st)
    rng = np.random.default_rng(7)
    names = prob.scaling.names
    for _ in range(6):  # designs across the variables' boxes, the study's start first
        vals = {v.name: v.start for v in st.variables}
        z = rng.uniform(-1.0, 1.0, len(names))
        vals.update(prob.scaling.to_values(z))
        x = prob.initial_guess(vals)
        args = (prob, prob.values(x), prob.sigma(x), prob.tube_rms(x))
        fast = refine.continuous_peak_db(*args)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(refine, "PEAK_STRIDE", 1)
            full = refine.continuous_peak_db(*args)
        assert fast == full
