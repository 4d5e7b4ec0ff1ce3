"""The executor interface of the optimizer's independent solves: local fork pool or serial."""

from __future__ import annotations

import os

import pytest

from isodesign.optimization import multistart
from isodesign.optimization.executor import (
    ForkExecutor,
    SerialExecutor,
    executor_for,
    local_executor,
    use_executor,
)


class PidProblem:
    """A stand-in NLP whose 'solve' returns the id of the process that ran it."""

    def initial_guess(self, vals):
        return vals

    def solve(self, x0, params=None):
        return os.getpid()


def _square(x):
    return x * x


def test_the_local_default_forks_only_when_there_is_work_for_several():
    assert isinstance(local_executor(1, 8), SerialExecutor)
    assert isinstance(local_executor(4, 1), SerialExecutor)
    ex = local_executor(4, 3)
    assert isinstance(ex, ForkExecutor) and ex.workers == 3
    assert sorted(ex.map_unordered(_square, range(5))) == [0, 1, 4, 9, 16]
    assert list(SerialExecutor().map_unordered(_square, range(3))) == [0, 1, 4]


def test_an_installed_executor_wins_and_the_starts_then_run_in_this_process():
    starts = [{"i": i} for i in range(4)]
    forked = multistart.run_starts(PidProblem(), starts, workers=2)
    if multistart.available_cores() > 1:
        assert os.getpid() not in forked
    with use_executor(SerialExecutor()) as ex:
        assert executor_for(8, 8) is ex
        assert multistart.run_starts(PidProblem(), starts, workers=8) == [os.getpid()] * 4
    assert not isinstance(executor_for(2, 2), SerialExecutor) or multistart.available_cores() < 2


@pytest.mark.parametrize("daemon", [True])
def test_a_daemonic_process_does_not_fork(monkeypatch, daemon):
    import multiprocessing as mp

    monkeypatch.setattr(mp.current_process(), "_config", {**mp.current_process()._config,
                                                           "daemon": daemon})
    assert isinstance(local_executor(4, 4), SerialExecutor)


def test_parallel_allowed_follows_the_executor_the_workers_and_the_cores(monkeypatch):
    """A sweep point (a one-worker executor installed) and a one-worker run keep to one core;
    so does a process with one core; otherwise a second core may be taken."""
    from isodesign.optimization.executor import parallel_allowed

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    assert parallel_allowed(2)
    assert not parallel_allowed(1)
    with use_executor(SerialExecutor()):
        assert not parallel_allowed(2)
    with use_executor(ForkExecutor(2)):
        assert parallel_allowed(1)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)
    assert not parallel_allowed(2)


def test_nlp_build_in_a_sweep_point_uses_no_second_thread(monkeypatch):
    """Inside a one-worker executor (what a sweep point installs) the NLP's derivatives are
    built in this thread, and the solver is the same as one built with the second thread."""
    import numpy as np

    from isodesign.optimization import nlp, problem
    from isodesign.optimization.study import vertical_study

    st = vertical_study().with_changes(models={"points_per_band": 3, "peak_points": 20})

    class NoThreads:
        def __init__(self, *a, **k):
            raise AssertionError("a thread pool was started")

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    threaded = problem.Problem(st)
    monkeypatch.setattr(nlp, "ThreadPoolExecutor", NoThreads)  # derivative_functions' pool
    with use_executor(SerialExecutor()):
        single = problem.Problem(st)
    with pytest.raises(AssertionError, match="thread pool"):
        problem.Problem(st)  # outside the executor the build would take the second core
    x0 = single.initial_guess({v.name: v.start for v in st.variables})
    a, b = threaded.solve(x0), single.solve(x0)
    assert a.iterations == b.iterations and np.array_equal(a.x, b.x)
