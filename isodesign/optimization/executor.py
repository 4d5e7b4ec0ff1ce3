"""Where the optimizer's independent solves run: one executor interface, a local default.

The multi-start (:func:`isodesign.optimization.multistart.run_starts`) and the Pareto
sweep's two chains (:func:`isodesign.optimization.pareto.pareto_front`) hand their
independent solves to an executor: an object with ``map_unordered(fn, items)`` that
yields ``fn(item)`` for every item, in any order. Two are provided:

* :class:`ForkExecutor` (the local default when more than one worker is asked for and the
  cores allow): a ``multiprocessing`` pool with the ``fork`` start method, whose workers
  inherit the built NLP (nothing is pickled but the items and the results);
* :class:`SerialExecutor`: every item in this process, one after the other.

:func:`executor_for` picks the executor of a call: the one installed with
:func:`use_executor` if any (a sweep point running as a Dask task installs a
:class:`SerialExecutor`, so a task never starts a nested pool), else the local default.
A daemonic process (a ``multiprocessing`` or Dask worker without a nanny) cannot have
children: there the default is serial too.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
from collections.abc import Callable, Iterable, Iterator
from typing import Protocol

__all__ = [
    "Executor",
    "ForkExecutor",
    "SerialExecutor",
    "available_cores",
    "executor_for",
    "local_executor",
    "parallel_allowed",
    "use_executor",
]


class Executor(Protocol):
    """What the optimizer needs of an executor."""

    workers: int

    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator:
        """``fn(item)`` for every item, yielded as each finishes (any order)."""
        ...  # pragma: no cover


class SerialExecutor:
    """Every item in this process, in order (no pool).

    Attributes
    ----------
    workers : int
        Always 1.
    """

    workers = 1

    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator:
        """Yield ``fn(item)`` for each item, in order.

        Parameters
        ----------
        fn : callable
            Applied to each item.
        items : iterable
            The work.
        """
        for item in items:
            yield fn(item)

    def __repr__(self) -> str:
        return "SerialExecutor()"


class ForkExecutor:
    """A ``multiprocessing`` pool of ``processes`` forked workers (a fresh pool per map).

    Parameters
    ----------
    processes : int
        Number of worker processes (>= 2).

    Notes
    -----
    ``fn`` and the state it reads through module globals are inherited through ``fork``:
    only the items and the results are pickled.
    """

    def __init__(self, processes: int):
        self.workers = int(processes)

    def map_unordered(self, fn: Callable, items: Iterable) -> Iterator:
        """Yield ``fn(item)`` for each item as the workers finish them.

        Parameters
        ----------
        fn : callable
            A module-level function (pickled by reference).
        items : iterable
            The work.
        """
        import multiprocessing as mp

        work = list(items)
        with mp.get_context("fork").Pool(processes=min(self.workers, len(work))) as pool:
            yield from pool.imap_unordered(fn, work)

    def __repr__(self) -> str:
        return f"ForkExecutor(processes={self.workers})"


_SCOPED: contextvars.ContextVar = contextvars.ContextVar("isodesign_executor", default=None)


@contextlib.contextmanager
def use_executor(executor: Executor) -> Iterator[Executor]:
    """Run the optimizer's solves on ``executor`` inside the ``with`` block.

    Parameters
    ----------
    executor : Executor
        E.g. ``SerialExecutor()`` inside a Dask task.

    Examples
    --------
    >>> from isodesign.optimization.executor import SerialExecutor, use_executor
    >>> with use_executor(SerialExecutor()):          # doctest: +SKIP
    ...     optimize(study)                           # the starts run one by one
    """
    token = _SCOPED.set(executor)
    try:
        yield executor
    finally:
        _SCOPED.reset(token)


def available_cores() -> int:
    """Cores this process may run on: its CPU affinity, else ``os.cpu_count()``.

    Returns
    -------
    int
        At least 1; the size of ``os.sched_getaffinity(0)`` where the platform has
        it (a container or ``taskset`` may allow fewer cores than the machine has),
        else ``os.cpu_count()`` (1 when unknown).
    """
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    return max(1, n)


def parallel_allowed(workers: int) -> bool:
    """Whether one computation of the optimizer may occupy more than one core here.

    No when an executor is installed with one worker (a sweep point, a Dask task: the
    parallelism is across the points, none nested inside one), or when ``workers`` (the
    study's ``solver.workers``, ``--workers``) or the cores available allow only one. The NLP
    build (:func:`isodesign.optimization.nlp.derivative_functions`) uses a second thread
    only when this holds.

    Parameters
    ----------
    workers : int
        Worker processes the caller allows (``solver.workers``).

    Returns
    -------
    bool
    """
    ex = _SCOPED.get()
    if ex is not None:
        return ex.workers > 1
    return workers > 1 and available_cores() > 1


def _can_fork() -> bool:
    import multiprocessing as mp

    try:
        mp.get_context("fork")
    except ValueError:
        return False
    return not mp.current_process().daemon  # a daemonic process may not have children


def local_executor(workers: int, tasks: int) -> Executor:
    """The local default: forked workers when ``workers`` and ``tasks`` are both > 1.

    Parameters
    ----------
    workers : int
        Processes allowed (the caller caps it by the cores available).
    tasks : int
        Number of items to run.

    Returns
    -------
    Executor
        :class:`ForkExecutor` of ``min(workers, tasks)`` processes, or
        :class:`SerialExecutor` (one worker, one task, no ``fork``, or a daemonic process).
    """
    if workers > 1 and tasks > 1 and _can_fork():
        return ForkExecutor(min(workers, tasks))
    return SerialExecutor()


def executor_for(workers: int, tasks: int) -> Executor:
    """The executor of a call: the one installed by :func:`use_executor`, else local.

    Parameters
    ----------
    workers : int
        Processes allowed for the local default.
    tasks : int
        Number of items to run.

    Returns
    -------
    Executor
    """
    ex = _SCOPED.get()
    return ex if ex is not None else local_executor(workers, tasks)
