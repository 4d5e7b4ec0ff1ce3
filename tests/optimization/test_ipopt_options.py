"""IPOPT's options of every NLP (``nlp.ipopt_options``): a trial point of the line search
where the model is undefined is IPOPT's to cut back, without a warning per evaluation on
stderr (a co-designed table solve printed 9,634 of them)."""

from __future__ import annotations

import casadi as ca
import pytest

from isodesign.optimization.nlp import ipopt_options
from isodesign.optimization.study import default_study


def test_an_undefined_trial_point_prints_nothing_and_the_solve_still_succeeds(capfd):
    """``sqrt(x) >= 0`` from ``x = 1`` while the objective pulls towards ``x = -2``: IPOPT's
    trial steps cross ``x < 0`` (NaN rows) and are cut back; the answer is the bound."""
    x = ca.SX.sym("x")
    opts = ipopt_options(default_study(), "limited-memory")
    solver = ca.nlpsol("toy", "ipopt", {"x": x, "f": (x + 2) ** 2, "g": ca.sqrt(x)}, opts)
    res = solver(x0=1.0, lbg=0.0, ubg=10.0)
    assert solver.stats()["return_status"] == "Solve_Succeeded"
    assert abs(float(res["x"])) < 1e-6
    out, err = capfd.readouterr()
    assert "NaN detected" not in out + err and "WARNING" not in out + err

    loud = ca.nlpsol("toy_loud", "ipopt", {"x": x, "f": (x + 2) ** 2, "g": ca.sqrt(x)},
                     {**opts, "show_eval_warnings": True})
    loud(x0=1.0, lbg=0.0, ubg=10.0)
    out, err = capfd.readouterr()
    assert "NaN detected" in out + err  # the same solve does meet undefined points


@pytest.mark.slow
def test_the_acceptable_stop_leaves_the_vertical_studys_starts_as_they_were(monkeypatch):
    """docs/optimization.md, section 3: the limited-memory solves stop at IPOPT's acceptable
    level (``nlp.LIMITED_MEMORY_ACCEPTABLE``); the built-in vertical study's starts (its
    209-variable NLP is limited-memory) take the same iterations to the same optimum with
    and without it, in the same process."""
    import isodesign
    from isodesign.optimization import nlp
    from isodesign.optimization.study import vertical_study

    st = vertical_study().with_changes(solver={"workers": 1})
    with_stop = isodesign.optimize(st)
    monkeypatch.setattr(nlp, "LIMITED_MEMORY_ACCEPTABLE", {})
    without = isodesign.optimize(st)
    assert [s.iterations for s in with_stop.starts] == [s.iterations for s in without.starts]
    assert with_stop.objective_value == pytest.approx(without.objective_value, abs=1e-9)
    assert with_stop.hessian_choice()["hessian"] == "limited-memory"
