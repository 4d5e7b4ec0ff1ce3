"""Time to equal hypervolume: how long NSGA-II needs to reach the CasADi front's hypervolume.

Used by ``bench_optimize.py``. NSGA-II runs once with :class:`Recorder` as its pymoo
callback, which keeps every generation's non-dominated set (``algorithm.opt``: F, X, CV)
with the wall time spent so far (the recorder's own time taken out). Afterwards
:func:`first_reaching` judges each generation's front like the CasADi front (feasible
points only, the continuous peak-|T| filter of the caller, the CasADi
``ParetoResult``'s normalization) and returns the first generation whose hypervolume is at
least the target: the time NSGA-II needed to match the gradient-based front.
"""

from __future__ import annotations

import time

import numpy as np


def recorder():
    """A pymoo ``Callback`` recording each generation's front and the time so far.

    Returns
    -------
    Callback
        Its ``records`` list holds ``(seconds, evaluations, F, X, CV)`` per generation;
        seconds are wall time since the callback was made, less the callback's own time.
    """
    from pymoo.core.callback import Callback

    class Recorder(Callback):
        def __init__(self):
            super().__init__()
            self.records: list = []
            self._t0 = time.perf_counter()
            self._own = 0.0

        def notify(self, algorithm):
            t = time.perf_counter()
            opt = algorithm.opt
            self.records.append((
                t - self._t0 - self._own,
                int(algorithm.evaluator.n_eval),
                np.atleast_2d(np.array(opt.get("F"), float)),
                np.atleast_2d(np.array(opt.get("X"), float)),
                np.atleast_1d(np.array(opt.get("CV"), float)).ravel(),
            ))
            self._own += time.perf_counter() - t

    return Recorder()


def judged_front(record, keep) -> tuple[np.ndarray, np.ndarray]:
    """(margin dB, volume m^3) rows and z rows of a record's feasible, kept points.

    Parameters
    ----------
    record : tuple
        One entry of ``Recorder.records``.
    keep : callable
        ``keep(z) -> bool``: the continuous peak filter (True keeps the point).
    """
    _, _, F, X, CV = record
    ok = CV <= 0.0
    F, X = F[ok], X[ok]
    if not len(F):
        return np.zeros((0, 2)), np.zeros((0, X.shape[1] if X.ndim == 2 else 0))
    mask = np.array([keep(x) for x in X], dtype=bool)
    nat = np.column_stack([-F[:, 0], F[:, 1]])
    return nat[mask], X[mask]


def first_reaching(records, target: float, hypervolume, keep) -> dict:
    """The first generation whose judged front's hypervolume reaches ``target``.

    Parameters
    ----------
    records : list
        ``Recorder.records``.
    target : float
        The hypervolume to reach (the CasADi front's, normalized).
    hypervolume : callable
        ``hypervolume(natural rows) -> float`` (``ParetoResult.hypervolume_of``).
    keep : callable
        The peak filter of :func:`judged_front`, cached by the caller (designs repeat
        from one generation to the next).

    Returns
    -------
    dict
        ``reached`` (bool), ``generation`` (1-based), ``evaluations``, ``seconds`` and
        ``hv`` of the first reaching generation (of the last one when never reached),
        ``hv_best`` the largest judged hypervolume seen up to there, ``generations`` the
        number recorded.
    """
    best = 0.0
    for g, rec in enumerate(records, start=1):
        nat, _ = judged_front(rec, keep)
        hv = hypervolume(nat) if len(nat) else 0.0
        best = max(best, hv)
        if hv >= target:
            return {"reached": True, "generation": g, "evaluations": rec[1], "seconds": rec[0],
                    "hv": hv, "hv_best": best, "generations": len(records)}
    last = records[-1]
    return {"reached": False, "generation": len(records), "evaluations": last[1],
            "seconds": last[0], "hv": hv, "hv_best": best, "generations": len(records)}
