"""The staged starts of a co-designed table with free per-group springs (docs/table.md,
section 13, "Starts"): the tied study and the full problem's warm starts."""

import numpy as np
import pytest

from isodesign.optimization.lever_continuation import (
    TIED_MAX_ITER,
    TIED_TOL,
    free_group_levers,
    solve_tied,
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
    assert {**tied.solver, "tol": st.solver["tol"], "max_iter": st.solver["max_iter"]} == \
        st.solver
    assert tied.solver["tol"] == max(st.solver["tol"], TIED_TOL)  # it places starts only
    assert tied.solver["max_iter"] == min(st.solver["max_iter"], TIED_MAX_ITER)


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


def test_the_pipelined_full_solve_is_the_one_from_the_chosen_tied_optimum():
    """With forked workers the full NLP is solved from the best tied optimum so far while
    the other tied starts run (lever_continuation.solve_tied); what it keeps is the solve
    from the optimum the stage chooses at its end, the same solve as in this process."""
    import copy

    from isodesign.optimization.distortion_rows import capped
    from isodesign.optimization.multistart import _solve_start, available_cores, start_points
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.study import study_from_dict
    from isodesign.optimization.table_driver import _modes_at

    raw = copy.deepcopy(default_study().raw)  # coarse: 3 points per band, 4-20 Hz
    raw["solver"].update(starts=2, workers=2)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    st = study_from_dict(raw, source="small_default.toml", fill_defaults=False)
    prob = Problem(st)
    prob.set_modes(_modes_at(prob, st.start_design()))
    red = tied_study(st)
    rprob = Problem(red)
    rstarts = start_points(red, rprob.scaling)
    rprob.set_modes(_modes_at(rprob, red.design_at(rstarts[0])))
    rounds = capped(prob, 1).get("rounds")
    outs, full_starts, done = solve_tied(st, rprob, rstarts, prob, workers=2, rounds=rounds)
    assert len(full_starts) == len(done) == 1
    best = min((o for o in outs if not isinstance(o, str) and o.feasible),
               key=lambda o: o.objective)
    assert full_starts[0] == untie_values(st, best.values)
    here = _solve_start(prob, None, full_starts[0], rounds)
    if available_cores() < 2:  # no forked workers: nothing pipelined, solved by the caller
        assert done[0] is None
        return
    # the best optimum was the best so far when it finished: always followed in a worker
    assert done[0] is not None
    np.testing.assert_allclose(done[0].x, here.x, rtol=0, atol=1e-10)
    assert done[0].outer_pending == here.outer_pending
