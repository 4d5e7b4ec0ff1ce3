"""One NLP for a sweep (isodesign.optimization.parametric): what a sweep varies is a
parameter, and the parametric NLP solved at a point is a fresh build of that point."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.driver import optimize_vertical
from isodesign.optimization.parametric import ParametricProblem, ProblemCache, structure_key
from isodesign.optimization.problem import Problem
from isodesign.optimization.study import table_study, vertical_study

#: The points: a heavier payload, a lighter one on a quieter floor (VC-B: the VC-A PSD
#: times 1/4), another target criterion with another CG height.
POINTS = ({"payload.mass_kg": 900.0},
          {"payload.mass_kg": 450.0, "floor.criterion": "VC-B"},
          {"target.criterion": "VC-D", "payload.cg_height_m": 0.3})


@pytest.fixture(scope="module")
def base():
    return vertical_study().with_changes(models={"points_per_band": 3, "peak_points": 16},
                                         solver={"starts": 1, "workers": 1})


@pytest.fixture(scope="module")
def parametric(base):
    return ParametricProblem(base)


@pytest.mark.parametrize("change", POINTS)
def test_parametric_solve_equals_a_fresh_build(base, parametric, change):
    st = base.with_changes(change)
    view = parametric.at(st)
    assert view is not None and view.solver is parametric.solver  # nothing built
    fresh = Problem(st)
    start = {v.name: v.start for v in st.variables}
    x0 = fresh.initial_guess(start)
    np.testing.assert_allclose(view.initial_guess(start), x0, rtol=1e-12, atol=1e-12)
    # the same function: objective and every constraint row at the same x, same bounds
    f0, g0 = fresh.eval_fn(x0, fresh.params())
    f1, g1 = view.eval_fn(x0, view.params())
    assert float(f1) == pytest.approx(float(f0), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(np.asarray(g1), np.asarray(g0), rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(view.lbg, fresh.lbg)
    np.testing.assert_array_equal(view.ubg, fresh.ubg)
    # and the same optimum, to the solver's tolerance
    a, b = fresh.solve(x0), view.solve(x0)
    assert a.success and b.success
    assert b.objective == pytest.approx(a.objective, abs=1e-7)
    np.testing.assert_allclose(b.x[: view.nz], a.x[: fresh.nz], atol=1e-5)


def test_the_whole_optimize_on_a_view_is_the_fresh_optimize(base, parametric):
    st = base.with_changes({"payload.mass_kg": 1200.0})
    a = optimize_vertical(st, analyze=False)
    b = optimize_vertical(st, problem=parametric.at(st), analyze=False)
    assert a.feasible and b.feasible
    assert b.objective_value == pytest.approx(a.objective_value, abs=1e-6)
    assert b.recheck_max_rel_diff is not None


def test_cache_builds_once_per_structure(base):
    cache = ProblemCache()
    for m in (500.0, 700.0, 900.0):
        cache.get(base.with_changes({"payload.mass_kg": m, "floor.criterion": "VC-B"}))
    assert cache.builds == 1
    # another isolator count and another objective: NLPs of their own
    four = base.with_changes({"payload.isolators": 6})
    assert structure_key(four) != structure_key(base)
    cache.get(four)
    cache.get(base.with_changes(objective={"kind": "peak_transmissibility"}))
    assert cache.builds == 3 and len(cache) == 3
    cache.get(base.with_changes({"payload.mass_kg": 800.0}))
    assert cache.builds == 3


def test_a_floor_of_another_shape_is_another_structure(base, parametric):
    st = base.with_changes({"floor.criterion": "VC-A", "target.band_min_hz": 8.0})
    assert parametric.at(st) is None


def test_a_table_study_is_refused():
    with pytest.raises(InputError, match=r"\[table\]"):
        ParametricProblem(table_study())
