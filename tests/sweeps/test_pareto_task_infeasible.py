"""The sweep's pareto task, vertical and table: one refusal of a point with no feasible design."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

import isodesign.optimization.pareto as pareto_module
from isodesign.errors import SolverError
from isodesign.sweeps import tasks


def _run():
    return SimpleNamespace(status="running", record={})


@pytest.mark.parametrize("objective", ["hypervolume", "worst_band_margin"])
def test_a_front_with_no_feasible_design_marks_the_point_infeasible(monkeypatch, objective):
    msg = "pareto: no feasible design when minimizing total_volume alone (Infeasible)"

    def no_front(study, objectives, points):
        raise SolverError(msg)

    monkeypatch.setattr(pareto_module, "pareto_front", no_front)
    run = _run()
    result, row = tasks._front_or_infeasible(object(), run, ("a", "b"), 3, objective)
    assert result is None
    assert row == {"feasible": False, "objective": objective, "binding": "",
                   "solver_status": msg}
    assert run.status == "infeasible" and run.record["error"] == msg


def test_another_solver_failure_is_not_taken_for_an_infeasible_point(monkeypatch):
    def crash(study, objectives, points):
        raise SolverError("solver crashed: Restoration_Failed")

    monkeypatch.setattr(pareto_module, "pareto_front", crash)
    run = _run()
    with pytest.raises(SolverError, match="Restoration_Failed"):
        tasks._front_or_infeasible(object(), run, ("a", "b"), 3, "hypervolume")
    assert run.status == "running" and run.record == {}


def test_a_front_is_passed_through(monkeypatch):
    front = object()
    monkeypatch.setattr(pareto_module, "pareto_front", lambda s, o, p: front)
    assert tasks._front_or_infeasible(object(), _run(), ("a", "b"), 3, "x") == (front, None)
