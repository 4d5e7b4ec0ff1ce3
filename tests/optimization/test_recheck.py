"""The NumPy re-check of the NLP's optimum and evaluate_design (optimization.recheck)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.errors import SolverError
from isodesign.optimization.problem import Problem
from isodesign.optimization.recheck import RECHECK_RTOL, evaluate_design, recheck
from isodesign.optimization.study import vertical_study

#: A small grid: the re-check compares the NLP and the NumPy path on the same grid.
SMALL = {"points_per_band": 3, "peak_points": 20}


def test_evaluate_design_of_a_one_frequency_objective_on_another_study():
    """transmissibility_at asked of a study whose own objective is another one."""
    st = vertical_study().with_changes(models=SMALL)
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


@pytest.fixture(scope="module")
def rms_point():
    """An rms_velocity study's NLP at the start design (implicit unknowns solved)."""
    st = vertical_study().with_changes(models=SMALL, objective={"kind": "rms_velocity"},
                                      solver={"starts": 1})
    prob = Problem(st)
    vals = {v.name: v.start for v in st.variables}
    sol = prob.solve(prob.initial_guess(vals))
    assert sol.feasible, sol.status
    return prob, sol


def test_recheck_accepts_the_nlp_point(rms_point):
    prob, sol = rms_point
    v = math.exp(sol.objective)
    assert 1e-9 < v < 1e-4  # m/s: far below 1, where an absolute tolerance accepts anything
    d = prob.study.design_at(sol.values)
    assert recheck(prob, sol, d) <= RECHECK_RTOL
    # a difference well inside the relative tolerance is accepted
    j = np.array(sol.objectives, float)
    j[0] += 1e-8
    assert recheck(prob, sol.replace(objectives=j, objective=float(j[0])), d) <= RECHECK_RTOL


@pytest.mark.parametrize("factor", [1.1, 1.0 + 1e-4])
def test_recheck_rejects_a_perturbed_rms_velocity_objective(rms_point, factor):
    """The RMS velocity (~1e-5 m/s) reported 10 % or 0.01 % off must fail the re-check
    (an absolute tolerance of 1e-6 m/s accepted both)."""
    prob, sol = rms_point
    j = np.array(sol.objectives, float)
    j[0] += math.log(factor)  # J = ln(v): the natural value times factor
    bad = sol.replace(objectives=j, objective=float(j[0]))
    with pytest.raises(SolverError, match="objective rms_velocity"):
        recheck(prob, bad, prob.study.design_at(sol.values))
