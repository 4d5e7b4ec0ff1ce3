"""Multi-start: space-filling starts and their IPOPT solves, in forked workers
(:func:`map_in_workers`, the optimizer's one process pool)."""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.optimization.executor import ForkExecutor, available_cores, executor_for

__all__ = ["DEFAULT_WORKERS", "available_cores", "map_in_workers", "run_starts",
           "run_starts_pipelined", "runs_in_parallel", "start_points"]

#: Worker processes for the starts when none is asked for (capped by the cores
#: available to the process, like any asked-for number).
DEFAULT_WORKERS = 2


def start_points(study, scaling) -> list[dict]:
    """The study's start plus Latin-hypercube starts in the scaled log space.

    A Latin hypercube: each free variable's range is cut into ``n`` equal strata
    and every stratum holds exactly one start, at a random place, the strata
    paired at random between variables (seeded by ``solver.seed``). Written with
    NumPy: importing ``scipy.stats`` for it cost a second of start-up.

    Parameters
    ----------
    study : Study
        Gives the variables' start values, ``solver.starts`` (total number of
        starts, the study's own included) and ``solver.seed``.
    scaling : LogScaling
        The free variables' log scaling (:func:`.variables.log_scaling`); the
        hypercube is drawn in its coordinates ``z``.

    Returns
    -------
    list of dict
        ``solver.starts`` dicts of design-variable values (SI), the study's start
        first (only that one when no variable is free). Each further start sets
        every free variable to ``exp(c + h * 0.98 z)`` with ``z`` in [-1, 1]:
        uniform in ``ln x`` within each stratum, kept 2 % of the log half-range
        inside the bounds; fixed variables keep their start values.
    """
    base = {v.name: v.start for v in study.variables}
    pts = [base]
    n = study.solver["starts"] - 1
    if n > 0 and scaling.names:
        rng = np.random.default_rng(study.solver["seed"])
        d = len(scaling.names)
        strata = np.column_stack([rng.permutation(n) for _ in range(d)])
        z = 2.0 * (strata + rng.random((n, d))) / n - 1.0
        for zi in z:
            vals = dict(base)
            vals.update(scaling.to_values(0.98 * zi))
            pts.append(vals)
    return pts


_TASK = None  # the function the forked workers of map_in_workers inherit


def _run_indexed(item):
    i, x = item
    return i, _TASK(x)


def map_in_workers(fn, items, *, workers=None, progress=None) -> list:
    """``[fn(item) for item in items]``, in forked worker processes when the cores allow.

    The one place where the optimizer fans work out over processes: the starts
    (:func:`run_starts`) and the refinement of distinct branches
    (:func:`isodesign.optimization.refine.refine_branches`) use it. ``fn`` need not be
    picklable: the workers inherit it (and the built NLP it refers to) through ``fork``;
    only the items and the results are pickled.

    Parameters
    ----------
    fn : callable
        Called with one item; its result must be picklable when workers are used.
    items : iterable
        The work items (picklable).
    workers : int, optional
        Worker processes asked for; default :data:`DEFAULT_WORKERS`. Capped by the cores
        available to the process (:func:`available_cores`) and by the number of items.
        With 1 worker after the cap, a single item or no ``fork`` start method, the items
        run one after the other in this process; an executor installed with
        :func:`isodesign.optimization.executor.use_executor` (a sweep task's serial one)
        runs them instead.
    progress : callable, optional
        ``progress(done, total, result)`` after each item (in completion order when
        parallel).

    Returns
    -------
    list
        The results in item order.
    """
    global _TASK

    items = list(items)
    n = len(items)
    workers = min(DEFAULT_WORKERS if workers is None else workers, available_cores())
    results: list = [None] * n
    outer = _TASK  # a call inside a worker's task (its starts, run serially) restores it
    _TASK = fn
    try:
        executor = executor_for(workers, n)  # the local fork pool, or the one installed
        for done, (i, out) in enumerate(executor.map_unordered(_run_indexed,
                                                                list(enumerate(items))), 1):
            results[i] = out
            if progress:
                progress(done, n, out)
    finally:
        _TASK = outer
    return results


def runs_in_parallel(workers, n: int) -> bool:
    """Whether :func:`map_in_workers` of ``n`` items with ``workers`` asked for runs them in
    more than one process (the executor it would use has more than one worker).

    Parameters
    ----------
    workers : int or None
        As for :func:`map_in_workers`.
    n : int
        Number of items.

    Returns
    -------
    bool
    """
    workers = min(DEFAULT_WORKERS if workers is None else workers, available_cores())
    return n > 1 and executor_for(workers, n).workers > 1


def _solve_start(prob, params, vals: dict, rounds=None):
    """Initial guess and IPOPT solve of one start (in a worker or in-process); ``rounds``:
    an outer fixed point's round cap (:meth:`.distortion_rows.OuterFixedPoint.solve`)."""
    try:
        x0 = prob.initial_guess(vals)
    except SolverError as exc:
        return f"initial guess failed: {exc}"
    try:
        return prob.solve(x0, params) if rounds is None else prob.solve(x0, params,
                                                                        rounds=rounds)
    except InputError as exc:  # a NumPy evaluation at an iterate outside the models (the
        # outer fixed point's terms at a round's answer: a group's capillary shorter than
        # its bore): this start fails, saying why; the others go on
        return f"the solve left the models' range at an iterate: {exc}"


def run_starts(prob, starts: list[dict], *, workers=None, progress=None, params=None,
               rounds=None) -> list:
    """Solve every start; in forked worker processes when more than one core is available.

    The workers inherit the built solver through ``fork`` (nothing is pickled but
    the start values and the results), so the NLP is built once
    (:func:`map_in_workers`). Results come back in start order: a
    :class:`~isodesign.optimization.solution.Solution`, or the status of a start that
    failed before IPOPT could finish (its initial guess, or an iterate outside the models).

    Parameters
    ----------
    prob : Problem
        The built NLP (:class:`isodesign.optimization.problem.Problem`).
    starts : list of dict
        Design-variable values (SI) of each start, e.g. from :func:`start_points`.
        Each start gets a consistent initial guess
        (:meth:`~isodesign.optimization.problem.Problem.initial_guess`: sigma and
        the tube velocities from the NumPy solvers) before IPOPT runs.
    workers : int, optional
        Number of worker processes asked for (a study passes ``solver.workers``);
        default :data:`DEFAULT_WORKERS`. Capped by the cores available to the
        process (:func:`available_cores`) and by the number of starts: more
        processes than cores only compete for them. With 1 worker after the cap, a
        single start or no ``fork`` start method, the starts run one after the
        other in this process.
    progress : callable, optional
        ``progress(done, total, result)`` after each start finishes (in completion
        order when parallel); ``result`` is a Solution or an error message.
    params : ndarray, optional
        The NLP's parameter vector (:meth:`~isodesign.optimization.problem.Problem.params`);
        default: minimize the first objective, no epsilon bounds.
    rounds : int, optional
        With the distortion's outer fixed point, at most this many of its rounds per start
        (a solve its caller goes on from, ``Solution.outer_next``); default: converged.

    Returns
    -------
    list
        One entry per start, in start order: a Solution, or a ``str``, the start's status:
        ``initial guess failed: <the SolverError>``, or ``the solve left the models' range
        at an iterate: <the InputError>`` (a NumPy evaluation at it refused the design).
    """
    return map_in_workers(lambda vals: _solve_start(prob, params, vals, rounds), starts,
                          workers=workers, progress=progress)


def _run_tagged(item):
    return item[0], item[1], _TASK(item)


def run_starts_pipelined(prob, starts: list[dict], after, *, choose, workers=None,
                         progress=None) -> tuple[list, dict] | None:
    """Solve every start and, as soon as a start finishes, the follow-ups it calls for.

    The starts of :func:`run_starts` with one more kind of task: after each start finishes,
    ``choose(finished)`` (``finished``: start index -> result of the starts finished so
    far) names the starts that need a follow-up, each with its payload;
    ``after(i, payload)`` of each one not yet given one runs in the next free worker, before
    any start not yet begun. At most one task per worker is in flight, so a follow-up never
    waits behind the queued starts. Each task begins from the study's movable peak
    frequencies (those of ``prob`` at the call): a worker's copy of the NLP moved by a
    follow-up is reset before a start.

    Parameters
    ----------
    prob : Problem
        The built NLP (inherited by the forked workers).
    starts : list of dict
        Design-variable values (SI) of each start.
    after : callable
        ``after(i, payload)`` in a worker; its result must be picklable.
    choose : callable
        ``choose(finished) -> iterable of (start index, payload)``, in this process (the
        payload picklable).
    workers : int, optional
        As for :func:`run_starts`.
    progress : callable, optional
        ``progress(done, total, result)`` after each start (completion order).

    Returns
    -------
    (list, dict) or None
        The starts' results in start order (as :func:`run_starts`) and
        ``{i: after(i, payload)}`` for every start given a follow-up; ``None`` when the
        starts would not run in forked local workers (one worker or start, no ``fork``,
        an executor installed): the caller then runs them as before.
    """
    import multiprocessing as mp
    import queue

    global _TASK

    n = len(starts)
    workers = min(DEFAULT_WORKERS if workers is None else workers, available_cores())
    ex = executor_for(workers, n)
    if not isinstance(ex, ForkExecutor) or n < 2:
        return None
    slots0 = prob.slot_hz.copy()

    def task(item):
        kind, i, payload = item
        if not np.array_equal(prob.slot_hz, slots0):
            prob.set_slots(slots0)
        if kind == "start":
            return _solve_start(prob, None, payload)
        return after(i, payload)

    results: list = [None] * n
    followed: dict = {}
    finished: dict = {}
    queued: set = set()
    todo_starts = list(enumerate(starts))[::-1]  # popped from the end: start order
    todo_after: list = []
    done_q: queue.SimpleQueue = queue.SimpleQueue()
    outer = _TASK
    _TASK = task
    try:
        with mp.get_context("fork").Pool(processes=min(ex.workers, n)) as pool:
            busy = 0
            n_done = 0
            while True:
                while busy < ex.workers and (todo_after or todo_starts):
                    if todo_after:
                        item = ("after", *todo_after.pop(0))
                    else:
                        item = ("start", *todo_starts.pop())
                    pool.apply_async(_run_tagged, (item,), callback=done_q.put,
                                     error_callback=done_q.put)
                    busy += 1
                if busy == 0:
                    break
                msg = done_q.get()
                busy -= 1
                if isinstance(msg, BaseException):
                    raise msg
                kind, i, out = msg
                if kind == "after":
                    followed[i] = out
                    continue
                results[i] = out
                n_done += 1
                if progress:
                    progress(n_done, n, out)
                finished[i] = out
                for j, payload in choose(finished):
                    if j not in queued:
                        queued.add(j)
                        todo_after.append((j, payload))
    finally:
        _TASK = outer
    return results, followed
