"""One NLP builder: every study's NLP from ``Problem(study)`` on one machinery, and the
optimum of the vertical and of the built-in table study unchanged by the unification.

The reference numbers were computed on b72ec44 (the commit before the optimizer modules
moved from ``table/`` to ``optimization/`` and the two NLPs were built on
:mod:`isodesign.optimization.nlp`) with ``isodesign.optimize(vertical_study())`` and
``isodesign.optimize(table_study())``: the verdict's worst margin (the fine-grid analysis)
and the binding constraints. Tolerance: 0.01 dB on the worst margin (a refactoring of the
NLP changes no expression; IPOPT's path may differ in the last digits on another machine's
BLAS), the same binding set.
"""

from __future__ import annotations

import pytest

from isodesign.optimization.study import table_study, vertical_study

#: b72ec44: ``optimize(vertical_study())``.
VERTICAL_B72EC44 = {"worst_margin_db": 7.687197145308876, "binding": {"peak_transmissibility"}}
#: b72ec44: ``optimize(table_study())``.
TABLE_B72EC44 = {"worst_margin_db": -4.432010482001565, "binding": {"total_volume"}}
#: Agreement of the worst margin with b72ec44's, dB.
MARGIN_TOL_DB = 0.01


def _binding(result) -> set:
    return {c.name for c in result.constraints if c.active}


@pytest.mark.slow
@pytest.mark.parametrize(("make", "reference"), [(vertical_study, VERTICAL_B72EC44),
                                                 (table_study, TABLE_B72EC44)],
                         ids=["vertical_study", "table_study"])
def test_optimum_is_b72ec44s(make, reference):
    from isodesign.optimization import optimize

    r = optimize(make())
    assert r.feasible
    assert r.worst_margin_db == pytest.approx(reference["worst_margin_db"], abs=MARGIN_TOL_DB)
    assert _binding(r) == reference["binding"]


def test_every_nlp_is_built_on_the_shared_machinery():
    from isodesign.optimization.nlp import NLP
    from isodesign.optimization.parametric import ParametricProblem
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.robust import ScenarioBlock
    from isodesign.optimization.table_problem import TableProblem

    for cls in (Problem, TableProblem, ParametricProblem, ScenarioBlock):
        assert issubclass(cls, NLP)
        # solve, violations and values are the base's, written once
        for name in ("solve", "violations", "values", "ipopt_options", "params"):
            owner = next(c for c in cls.__mro__ if name in c.__dict__)
            assert owner is NLP or name == "params", (cls.__name__, name, owner.__name__)


def test_objective_params_and_rows_are_one_function():
    import numpy as np

    from isodesign.optimization.nlp import NO_BOUND, constraint_rows, objective_params

    p = objective_params(2, weights=None, diameter_weight=0.5, eps=[None, 3.0])
    np.testing.assert_array_equal(p, [1.0, 0.0, 0.5, NO_BOUND, 3.0])
    lbg, ubg, rows = constraint_rows(2, [("a", 3, -np.inf, 0.0), ("b", 1, 1.0, 2.0)])
    np.testing.assert_array_equal(lbg, [0, 0, -np.inf, -np.inf, -np.inf, 1.0])
    np.testing.assert_array_equal(ubg, [0, 0, 0, 0, 0, 2.0])
    assert rows == [("a", 2, 3), ("b", 5, 1)]


def test_problem_of_a_study_builds_the_body_the_study_asks_for(small_table_study):
    """``Problem(study)``: the exact z reduction for a study without ``[table]``, the
    six-degree-of-freedom assembly for a table study (never the other body)."""
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.table_problem import TableProblem

    st = small_table_study()
    prob = Problem(st)
    # the table body (with the distortion power's rows: models.distortion's default)
    assert isinstance(prob, TableProblem) and getattr(prob, "distortion", False)
    plain = Problem(st.with_changes({"models.distortion": False}))
    assert type(plain) is TableProblem
    assert prob.hessian_info["hessian"] == prob.ipopt_options()["ipopt.hessian_approximation"]
    assert prob.n == st.table.n_isolators
    assert type(Problem(vertical_study().with_changes({"models.distortion": False}))) is Problem
    assert isinstance(Problem(vertical_study()), Problem)
    # options of the table body pass through
    two = Problem(st, ("worst_band_margin", "total_volume"), hessian="exact")
    assert two.objectives == ("worst_band_margin", "total_volume")
    assert two.hessian_info == {"hessian": "exact", "reason": "the prebuilt NLP's choice"}


def test_the_table_body_takes_its_objectives_from_the_one_registry(small_table_study):
    from isodesign.errors import InputError
    from isodesign.optimization.objectives import OBJECTIVES
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.table_problem import TABLE_OBJECTIVES

    assert TABLE_OBJECTIVES == ("worst_band_margin", "total_volume", "footprint_area",
                                "added_mass")
    assert all(OBJECTIVES[k].table is not None for k in TABLE_OBJECTIVES)
    # a registered objective without a table form is refused by name, before any build
    with pytest.raises(InputError, match=r"objective\.kind: 'rms_velocity'"):
        Problem(small_table_study(), ("rms_velocity",))
