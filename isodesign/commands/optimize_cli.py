"""Entry point of ``isodesign optimize``: the study's answer and the files of its kind.

The answer comes from :func:`isodesign.optimize` (:mod:`isodesign.optimization.dispatch`),
the one dispatcher the Python API and a sweep's ``optimize`` task also call. The files
written depend on the study's kind: a study with ``[scenarios]`` gets the robust design's
(:mod:`.robust`), one with a ``[table]`` the six-degree-of-freedom optimizer's
(:mod:`.table_optimize`), any other the vertical optimizer's (:mod:`.optimize`).
:func:`execute_study` writes them from a result (computed here, or by a sweep point). It
lives here, not in :mod:`.optimize`, because the robust command builds on the nominal
one's helpers: a module importing both keeps the package free of import cycles. The
command's help text is :mod:`.optimize`'s docstring.
"""

from __future__ import annotations

from isodesign.commands import optimize as _optimize
from isodesign.commands.optimize import (
    OUTPUT_FILES,
    add_arguments,
    execute,
    load_study_from_args,
    open_run,
)
from isodesign.errors import InputError

__all__ = ["EXIT_WITHOUT_TEARDOWN", "add_arguments", "execute_study", "output_files", "run"]

#: Run as the program, the process ends as soon as the command returns (its run directory
#: is complete by then): no interpreter teardown (:mod:`isodesign.cli`, "Process exit").
EXIT_WITHOUT_TEARDOWN = True

#: The command's help text (``isodesign optimize --help``): the nominal optimizer's.
__doc__ = _optimize.__doc__


def output_files(study) -> tuple:
    """The files an ``isodesign optimize`` run of ``study`` writes (its kind's).

    Parameters
    ----------
    study : Study
    """
    if study.scenarios is not None:
        from isodesign.commands.robust import ROBUST_FILES

        return OUTPUT_FILES + ROBUST_FILES
    if study.table is not None:
        from isodesign.commands.table_optimize import TABLE_OUTPUT_FILES

        return TABLE_OUTPUT_FILES
    return OUTPUT_FILES


def execute_study(study, run, args, result=None) -> int:
    """Optimize ``study`` (or take its ``result``) and write its kind's files into ``run``.

    Parameters
    ----------
    study : Study
    run : RunDirectory
    args : argparse.Namespace
        The optimize command's options (``no_plots``, ``quiet``, ``yield_samples``).
    result : optional
        The study's answer from :func:`isodesign.optimize`, when already computed (a sweep
        point); computed here otherwise.

    Returns
    -------
    int
        The exit status (0: feasible optimum; 1: no feasible design).
    """
    # the robust and the table optimizers' modules import CasADi: only when needed,
    # so that ``isodesign optimize --help`` stays light
    if study.scenarios is not None:  # robust design (docs/robust.md)
        from isodesign.commands.robust import execute_robust

        return execute_robust(study, run, args, result)
    if study.table is not None:  # six degrees of freedom (docs/table.md)
        from isodesign.commands.table_optimize import execute_table

        return execute_table(study, run, args, result)
    return execute(study, run, args, result=result)


def run(args) -> int:
    """Run ``isodesign optimize``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (:func:`add_arguments`).

    Returns
    -------
    int
        The exit status (0: feasible optimum; 1: no feasible design).
    """
    study = load_study_from_args(args)
    n = getattr(args, "yield_samples", None)
    if n is not None and not 0 <= n <= 10**6:
        raise InputError(f"--yield-samples: must be an integer in [0, 1000000], got {n}")
    # the target is checked here, before the computation
    with open_run(args, known_outputs=output_files(study)) as rundir:
        return execute_study(study, rundir, args)
