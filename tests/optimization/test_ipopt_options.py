"""IPOPT's options of every NLP (``nlp.ipopt_options``): a trial point of the line search
where the model is undefined is IPOPT's to cut back, without a warning per evaluation on
stderr (a co-designed table solve printed 9,634 of them)."""

from __future__ import annotations

import casadi as ca

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
