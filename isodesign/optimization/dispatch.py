"""One entry point: :func:`optimize` answers the question a study asks.

A study asks one of four questions, decided by its tables (:func:`study_kind`):

================  ==========================  ===============================================
kind              the study has               answered by
================  ==========================  ===============================================
``robust table``  ``[table]`` + ``[scenarios]``  :func:`.robust_table.robust_optimize_table`
``robust``        ``[scenarios]``             :func:`.exchange.robust_optimize`
``table``         ``[table]``                 :func:`.table_driver.optimize_table`
``vertical``      neither                     :func:`.driver.optimize_vertical`
================  ==========================  ===============================================

``isodesign.optimize``, ``isodesign optimize`` and a sweep's ``optimize`` task all call
:func:`optimize`, so the same study gives the same answer through each of them. Every kind's
answer is a :class:`~.result.StudyResult` (one interface: verdict, worst margin, constraint
table with binding flags and the sentence naming what stopped the design, starts,
``to_frame``, ``plot``, text and HTML; its ``kind`` names the question answered). An entry
point that cannot answer a kind refuses it with one line naming the study key
(:func:`refuse`), never by answering another question.
"""

from __future__ import annotations

from isodesign.errors import InputError

__all__ = ["KINDS", "optimize", "refuse", "study_kind"]

#: The study kinds, from the most specific.
KINDS = ("robust table", "robust", "table", "vertical")


def study_kind(study) -> str:
    """The question a study asks: ``robust table``, ``robust``, ``table`` or ``vertical``.

    Parameters
    ----------
    study : Study

    Returns
    -------
    str
    """
    table = getattr(study, "table", None) is not None
    robust = getattr(study, "scenarios", None) is not None
    if robust:
        return "robust table" if table else "robust"
    return "table" if table else "vertical"


def refuse(study, what: str, *, table: bool = True, scenarios: bool = True,
           instead: str | None = None) -> None:
    """Raise the one-line InputError of an entry point that cannot answer this study.

    Parameters
    ----------
    study : Study
    what : str
        The entry point, as the user called it (``isodesign response``, ``stiffness``).
    table, scenarios : bool
        Refuse a study with ``[table]`` / ``[scenarios]`` (default both).
    instead : str, optional
        What answers a study with ``[scenarios]`` instead (default: ``isodesign optimize /
        isodesign.optimize``).

    Raises
    ------
    InputError
        ``[table]: <what> does not answer a table study (...)``, or the same for
        ``[scenarios]``; the same line through the CLI and the Python API.
    """
    if table and getattr(study, "table", None) is not None:
        raise InputError(f"[table]: {what} does not answer a table study (six degrees of "
                         "freedom); use isodesign optimize / isodesign.optimize, or remove "
                         "[table] for the vertical question")
    if scenarios and getattr(study, "scenarios", None) is not None:
        instead = instead or "isodesign optimize / isodesign.optimize"
        raise InputError(f"[scenarios]: {what} does not answer a robust study (its nominal "
                         f"answer would not be the question asked); use {instead}, or remove "
                         "[scenarios] for the nominal question")


def optimize(study, *, progress=None, problem=None, nominal=None, analyze: bool = True):
    """Optimize a study: the answer to the question it asks (see the module docstring).

    Parameters
    ----------
    study : Study
    progress : callable, optional
        ``progress(done, total, solution)`` after each start of the (nominal) multi-start.
    problem : Problem or TableProblem, optional
        A prebuilt NLP of a nominal study (ignored for a study with ``[scenarios]``).
    nominal : OptimizationResult or TableOptimizationResult, optional
        A study with ``[scenarios]``: its nominal optimum, when already computed.
    analyze : bool
        Run the fine-grid analyses of a nominal optimum (default).

    Returns
    -------
    StudyResult
        Its ``kind`` is the study's (:func:`study_kind`): an :class:`~.result.OptimizationResult`,
        :class:`~isodesign.optimization.table_driver.TableOptimizationResult`,
        :class:`~.robust_result.RobustResult` or
        :class:`~.robust_table.TableRobustResult` for a ``vertical``, ``table``, ``robust``
        and ``robust table`` study respectively. Check ``.success`` (or call
        ``.raise_for_status()``).

    Examples
    --------
    >>> import isodesign
    >>> res = isodesign.optimize(isodesign.load_study("granite.toml"))   # doctest: +SKIP
    """
    from isodesign.optimization.study import Study

    if not isinstance(study, Study):
        raise InputError(f"study: expected a Study (load_study(path) or default_study()), "
                         f"got {type(study).__name__} {study!r:.40}")
    if progress is not None and not callable(progress):
        raise InputError(f"progress: expected a callable progress(done, total, solution) or "
                         f"None, got {type(progress).__name__} {progress!r:.40}")
    if not isinstance(analyze, bool):
        raise InputError(f"analyze: expected true or false, got {analyze!r:.40}")
    kind = study_kind(study)
    res = _answer(kind, study, progress, problem, nominal, analyze)
    if res.kind != kind:  # never the answer to another question
        from isodesign.errors import SolverError

        raise SolverError(f"optimize: a {kind} study was answered by a {res.kind} result")
    return res


def _answer(kind, study, progress, problem, nominal, analyze):
    """The optimizer of ``kind`` on ``study`` (see :func:`optimize`)."""
    if kind == "robust table":
        from isodesign.optimization.robust_table import check_robust_table, robust_optimize_table
        from isodesign.optimization.table_driver import optimize_table

        check_robust_table(study)  # before the nominal's minutes
        if nominal is None:
            nominal = optimize_table(study, progress=progress, analyze=False)
        return robust_optimize_table(study, nominal=nominal)
    if kind == "robust":
        from isodesign.optimization.driver import optimize_vertical
        from isodesign.optimization.exchange import robust_optimize

        if nominal is None:
            nominal = optimize_vertical(study, progress=progress, nominal=True)
        return robust_optimize(study, nominal=nominal)
    if kind == "table":
        from isodesign.optimization.table_driver import optimize_table

        return optimize_table(study, progress=progress, problem=problem, analyze=analyze)
    from isodesign.optimization.driver import optimize_vertical

    return optimize_vertical(study, progress=progress, problem=problem, analyze=analyze)
