"""Multi-start: space-filling starts and their IPOPT solves, in forked workers."""

from __future__ import annotations

import numpy as np

from isodesign.errors import SolverError

__all__ = ["DEFAULT_WORKERS", "run_starts", "start_points"]

#: Worker processes for the starts (capped by the machine's cores).
DEFAULT_WORKERS = 2


def start_points(study, scaling) -> list[dict]:
    """The study's start plus Latin-hypercube starts in the scaled log space.

    A Latin hypercube: each free variable's range is cut into ``n`` equal strata
    and every stratum holds exactly one start, at a random place, the strata
    paired at random between variables (seeded by ``solver.seed``). Written with
    NumPy: importing ``scipy.stats`` for it cost a second of start-up.
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


_POOL_PROBLEM = None  # the Problem the forked start workers inherit
_POOL_PARAMS = None  # the NLP parameters of the starts (None: minimize the first objective)


def _solve_start(vals: dict):
    """Initial guess and IPOPT solve of one start (in a worker or in-process)."""
    prob = _POOL_PROBLEM
    try:
        x0 = prob.initial_guess(vals)
    except SolverError as exc:
        return str(exc)
    return prob.solve(x0, _POOL_PARAMS)


def _indexed_start(item):
    i, vals = item
    return i, _solve_start(vals)


def run_starts(prob, starts: list[dict], *, workers=None, progress=None, params=None) -> list:
    """Solve every start; in forked worker processes when more than one core is free.

    The workers inherit the built solver through ``fork`` (nothing is pickled but
    the start values and the results), so the NLP is built once. Results come
    back in start order: a :class:`~isodesign.optimization.solution.Solution`, or the
    error message of a start whose initial guess failed.
    """
    global _POOL_PROBLEM, _POOL_PARAMS
    import os

    n = len(starts)
    if workers is None:
        workers = min(DEFAULT_WORKERS, os.cpu_count() or 1)
    _POOL_PROBLEM = prob
    _POOL_PARAMS = params
    results: list = [None] * n
    try:
        ctx = None
        if workers > 1 and n > 1:
            import multiprocessing as mp

            try:
                ctx = mp.get_context("fork")
            except ValueError:
                ctx = None
        if ctx is None:
            for i, vals in enumerate(starts):
                results[i] = _solve_start(vals)
                if progress:
                    progress(i + 1, n, results[i])
        else:
            with ctx.Pool(processes=min(workers, n)) as pool:
                done = 0
                for i, out in pool.imap_unordered(_indexed_start, list(enumerate(starts))):
                    results[i] = out
                    done += 1
                    if progress:
                        progress(done, n, out)
    finally:
        _POOL_PROBLEM = None
        _POOL_PARAMS = None
    return results
