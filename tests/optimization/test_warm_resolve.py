"""Warm re-solves of the same point (issue 27): the peak refinement's re-solves and the
tie-break's start from the previous solution's multipliers (``nlp.WARM_OPTIONS``) and must
reach the optimum the cold re-solves reach, in fewer iterations."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.optimization import nlp
from isodesign.optimization.driver import optimize
from isodesign.optimization.study import vertical_study

#: A coarse peak grid: the refinement must re-solve (as in test_refine.py).
COARSE = {"points_per_band": 3, "peak_points": 10}


def _run(study, warm: bool):
    """optimize() of ``study`` with the warm re-solves on or off; the re-solves' iterations."""
    iters = []
    real = nlp.NLP.solve

    def solve(self, x0, p=None, warm=None):
        sol = real(self, x0, p, warm=warm if use_warm else None)
        if warm is not None:
            iters.append(sol.iterations)
        return sol

    use_warm = warm
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nlp.NLP, "solve", solve)
        res = optimize(study)
    return res, iters


@pytest.mark.parametrize("mass_kg", [450.0, pytest.param(1000.0, marks=pytest.mark.xfail(
    strict=True, reason="known limitation (docs/optimization.md, 'Warm re-solves'): with one "
    "start, the warm refinement re-solve at 1000 kg stops at an interior stationary point "
    "(volume_ratio z = 0.924, 0.035 dB below) where the cold re-solve reaches the bound "
    "z = 1; two local optima of the same NLP, not a fixed-point error (also at 1050 kg "
    "with models.distortion = false, 0.058 dB)"))])
def test_warm_re_solves_reach_the_cold_optimum(mass_kg):
    st = vertical_study().with_changes({"payload.mass_kg": mass_kg}, models=COARSE,
                                       solver={"starts": 1})
    cold, it_cold = _run(st, warm=False)
    assert len(it_cold) >= 2
    warm, it_warm = _run(st, warm=True)
    assert cold.feasible and warm.feasible
    assert len(it_warm) == len(it_cold)  # the same re-solves, warm-started
    # the same optimum (the tie-break's tolerance is 0.01 dB; far tighter here)
    assert warm.objective_value == pytest.approx(cold.objective_value, abs=1e-4)
    for k in ("capillary_diameter_m", "capillary_length_m", "volume_ratio"):
        assert warm.values[k] == pytest.approx(cold.values[k], rel=1e-3)
    assert warm.peak["met"] == cold.peak["met"]
    assert warm.peak["rounds"] == cold.peak["rounds"]


def test_a_solution_carries_its_multipliers_and_a_cold_nlp_ignores_them():
    from isodesign.optimization.problem import Problem

    st = vertical_study().with_changes(models=COARSE, solver={"starts": 1})
    prob = Problem(st)
    x0 = prob.initial_guess({v.name: v.start for v in st.variables})
    sol = prob.solve(x0)
    assert sol.lam_g.shape == (len(prob.lbg),) and sol.lam_x.shape == (prob.nx,)
    again = prob.solve(sol.x, warm=sol)  # at its own optimum: a few iterations
    assert again.objective == pytest.approx(sol.objective, abs=1e-6)
    assert again.iterations <= sol.iterations
    # multipliers of another shape (another NLP): a cold solve, not an error
    other = sol.replace(lam_g=np.zeros(3))
    assert prob.solve(x0, warm=other).objective == pytest.approx(sol.objective, abs=1e-6)
