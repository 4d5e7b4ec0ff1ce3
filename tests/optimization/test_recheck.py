"""The NumPy re-check of the NLP's optimum and evaluate_design (optimization.recheck)."""

from __future__ import annotations

import pytest

from isodesign.optimization.recheck import evaluate_design
from isodesign.optimization.study import default_study

#: A small grid: the re-check compares the NLP and the NumPy path on the same grid.
SMALL = {"points_per_band": 3, "peak_points": 20}


def test_evaluate_design_of_a_one_frequency_objective_on_another_study():
    """transmissibility_at asked of a study whose own objective is another one."""
    st = default_study().with_changes(models=SMALL)
    assert st.objective["kind"] == "worst_band_margin"
    vals = {v.name: v.start for v in st.variables}
    ev = evaluate_design(st, vals, objectives=("transmissibility_at", "worst_band_margin"))
    # the same |T| from a study whose own objective is |T| at the default frequency, 10 Hz
    own = st.with_changes(objective={"kind": "transmissibility_at", "frequency_hz": 10.0})
    ev_own = evaluate_design(own, vals)
    t_db = ev_own["objectives"]["transmissibility_at"]
    assert ev["objectives"]["transmissibility_at"] == pytest.approx(t_db, rel=1e-12)
    assert ev["objectives"]["worst_band_margin"] == pytest.approx(
        evaluate_design(st, vals)["objectives"]["worst_band_margin"], rel=1e-12)
    assert t_db < -10.0  # 10 Hz is far above the natural frequency: isolation
