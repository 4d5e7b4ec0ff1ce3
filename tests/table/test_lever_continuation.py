"""The staged starts of a co-designed table with free per-group springs (docs/table.md,
section 13, "Starts"): the tied study and the full problem's warm starts."""

import numpy as np
import pytest

from isodesign.optimization.lever_continuation import (
    TIED_TOL,
    free_group_levers,
    tied_study,
    untie_values,
)
from isodesign.optimization.study import default_study, table_study
from isodesign.optimization.variables import GROUP_SPRING_LEVERS


def test_the_tied_study_is_the_default_study_without_its_free_group_springs():
    st = default_study()
    free = {v.name for v in free_group_levers(st)}
    assert len(free) == 8  # valves 2 and 3, four fields each
    tied = tied_study(st)
    assert not free_group_levers(tied)
    assert not any(v.name in GROUP_SPRING_LEVERS for v in tied.levers)
    # everything else as the study states it: the spring and the other levers
    assert [(v.name, v.start, v.lower, v.upper, v.fixed) for v in tied.variables] == \
        [(v.name, v.start, v.lower, v.upper, v.fixed) for v in st.variables]
    assert [v for v in tied.levers] == [v for v in st.levers if v.name not in free]
    assert tied.constraints == st.constraints
    assert {**tied.solver, "tol": st.solver["tol"]} == st.solver
    assert tied.solver["tol"] == max(st.solver["tol"], TIED_TOL)  # it places starts only


def test_the_tied_table_is_the_full_table_with_every_group_at_the_shared_spring():
    """At the tied study's values, the full study's table (each group lever at the shared
    spring's value) is the tied study's table: the same statics per isolator."""
    st = default_study()
    tied = tied_study(st)
    vals = {v.name: v.start * 1.1 if v.name != "volume_ratio" else 5.0 for v in tied.variables}
    vals.update({"pendulum_length_m": 0.3, "layout_length_m": 1.0})
    full = untie_values(st, vals)
    for v in free_group_levers(st):
        base = v.name.rsplit("_group", 1)[0]
        assert full[v.name] == pytest.approx(min(max(vals[base], v.lower), v.upper))
    from isodesign.table.response import table_band_response

    def worst(study, values):
        res = table_band_response(study.design_at(values), study.table_at(values),
                                  study.floor_axes, study.target, bands=study.bands,
                                  warn=False)
        return res.worst_margin_db, np.asarray(res.stroke_rms_m)

    (m_t, s_t), (m_f, s_f) = worst(tied, vals), worst(st, full)
    assert m_f == pytest.approx(m_t, abs=1e-9)
    np.testing.assert_allclose(s_f, s_t, rtol=1e-9)


def test_a_study_without_free_group_springs_runs_no_stage():
    assert tied_study(table_study()) is None
    assert tied_study(default_study().with_changes(
        {"variables.volume_ratio_group2.fixed": True,
         "variables.top_volume_m3_group2.fixed": True,
         "variables.capillary_length_m_group2.fixed": True,
         "variables.capillary_diameter_m_group2.fixed": True,
         "variables.volume_ratio_group3.fixed": True,
         "variables.top_volume_m3_group3.fixed": True,
         "variables.capillary_length_m_group3.fixed": True,
         "variables.capillary_diameter_m_group3.fixed": True})) is None


def test_a_group_spring_starting_away_from_the_shared_spring_runs_no_stage():
    """A start that is no point of the tied problem (a sweep point continued from its
    neighbour's optimum) keeps the full multi-start."""
    st = default_study()
    n0 = next(v.start for v in st.variables if v.name == "volume_ratio")
    moved = st.with_changes({"variables.volume_ratio_group2.start": n0 * 1.05})
    assert free_group_levers(moved) and tied_study(moved) is None


def test_the_tied_stage_runs_without_the_distortion():
    """The tied multi-start only places the full NLP's start: it runs without the
    distortion's outer rounds; the full NLP keeps the study's models."""
    st = default_study()
    assert st.models["distortion"]
    assert tied_study(st).models["distortion"] is False
