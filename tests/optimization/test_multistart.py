"""Worker processes of the multi-start and of the Pareto sweep: capped by the cores."""

from __future__ import annotations

import os

import pytest

from isodesign.optimization import multistart, pareto


class PidProblem:
    """A stand-in NLP whose 'solve' returns the id of the process that ran it."""

    def initial_guess(self, vals):
        return vals

    def solve(self, x0, params=None):
        return os.getpid()


@pytest.fixture
def one_core(monkeypatch):
    """The process may run on one core only (affinity), of a machine with 8."""
    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)


def test_available_cores_follows_the_affinity(one_core):
    assert multistart.available_cores() == 1


def test_available_cores_without_affinity(monkeypatch):
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: None)
    assert multistart.available_cores() == 1
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    assert multistart.available_cores() == 3


@pytest.mark.parametrize("workers", [2, 8, None])
def test_run_starts_caps_the_workers_at_the_cores(one_core, workers):
    """solver.workers (default 2) above the cores: the starts run in this process."""
    out = multistart.run_starts(PidProblem(), [{"i": i} for i in range(4)], workers=workers)
    assert out == [os.getpid()] * 4


def test_pareto_chains_cap_the_workers_at_the_cores(one_core, monkeypatch):
    monkeypatch.setattr(pareto, "_chain",
                        lambda prob, anchor, idx, eps, anchor_b: {k: os.getpid() for k in idx})
    out = pareto._run_chains(None, [(None, [0, 1]), (None, [3, 2])], None, None, 2)
    assert out == {k: os.getpid() for k in range(4)}


@pytest.mark.skipif(multistart.available_cores() < 2, reason="needs two cores")
def test_run_starts_forks_when_the_cores_are_there():
    out = multistart.run_starts(PidProblem(), [{"i": i} for i in range(4)], workers=2)
    assert len(out) == 4 and os.getpid() not in out


def test_map_in_workers_keeps_the_item_order_and_runs_closures():
    """The function is inherited through fork (a closure: not picklable); results come
    back in item order whatever the completion order."""
    offset = 10

    def fn(x):
        return x * x + offset, os.getpid()

    out = multistart.map_in_workers(fn, range(6), workers=2)
    assert [v for v, _ in out] == [x * x + 10 for x in range(6)]
    if multistart.available_cores() >= 2:
        assert all(pid != os.getpid() for _, pid in out)


def test_map_in_workers_runs_here_on_one_core_and_reports_progress(one_core):
    seen = []
    out = multistart.map_in_workers(lambda x: os.getpid(), ["a", "b", "c"], workers=4,
                                    progress=lambda done, total, r: seen.append((done, total)))
    assert out == [os.getpid()] * 3
    assert seen == [(1, 3), (2, 3), (3, 3)]


def test_a_nested_serial_map_inside_a_worker_keeps_the_outer_task():
    """A worker's task that maps serially itself (a start's optimize inside a sweep's or a
    benchmark's worker) leaves the outer task in place for the worker's next item."""
    from isodesign.optimization.executor import SerialExecutor, use_executor
    from isodesign.optimization.multistart import map_in_workers

    def inner(x):
        return x + 1

    def outer(x):
        with use_executor(SerialExecutor()):
            return sum(map_in_workers(inner, [x, x]))

    assert map_in_workers(outer, [1, 2, 3, 4, 5, 6], workers=2) == [4, 6, 8, 10, 12, 14]


def test_a_start_whose_solve_leaves_the_models_fails_saying_why(one_core):
    """A NumPy evaluation at an iterate outside the models (the distortion's outer fixed
    point evaluates its terms at a round's answer, where a leveling group's capillary may be
    shorter than its bore: ``SpringDesign`` refuses it) fails that start with the message,
    instead of ending the whole multi-start with a traceback; the other starts go on."""
    from isodesign.errors import InputError
    from isodesign.optimization.multistart import run_starts

    class Prob:
        def initial_guess(self, vals):
            return vals["x"]

        def solve(self, x0, params):
            if x0 < 0:
                raise InputError("capillary_diameter_m: must be smaller than "
                                 "capillary_length_m (0.003 >= 0.002 m)")
            return x0 * 2

    out = run_starts(Prob(), [{"x": 1.0}, {"x": -1.0}, {"x": 3.0}], workers=1, params=None)
    assert out[0] == 2.0 and out[2] == 6.0
    assert isinstance(out[1], str)
    assert out[1].startswith("the solve left the models' range at an iterate: "
                             "capillary_diameter_m: must be smaller")
