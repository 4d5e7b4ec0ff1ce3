"""Entry point of ``isodesign optimize``: sends a study to its optimizer.

A study with ``[scenarios]`` goes to the robust design (:mod:`.robust`), one with a
``[table]`` to the six-degree-of-freedom optimizer (:mod:`.table_optimize`), any other to
the nominal optimizer (:mod:`.optimize`). The dispatch lives here, not in
:mod:`.optimize`, because the robust command builds on the nominal one's helpers: a
module importing both keeps the package free of import cycles. The command's help text
is :mod:`.optimize`'s docstring.
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

__all__ = ["EXIT_WITHOUT_TEARDOWN", "add_arguments", "run"]

#: Run as the program, the process ends as soon as the command returns (its run directory
#: is complete by then): no interpreter teardown (:mod:`isodesign.cli`, "Process exit").
EXIT_WITHOUT_TEARDOWN = True

#: The command's help text (``isodesign optimize --help``): the nominal optimizer's.
__doc__ = _optimize.__doc__


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
    # the robust and the table optimizers' modules import CasADi: only when needed,
    # so that ``isodesign optimize --help`` stays light
    if study.scenarios is not None:  # robust design (docs/robust.md)
        from isodesign.commands.robust import ROBUST_FILES, execute_robust

        with open_run(args, known_outputs=OUTPUT_FILES + ROBUST_FILES) as rundir:
            return execute_robust(study, rundir, args)
    if study.table is not None:  # six degrees of freedom (docs/table.md)
        from isodesign.commands.table_optimize import TABLE_OUTPUT_FILES, execute_table

        with open_run(args, known_outputs=TABLE_OUTPUT_FILES) as rundir:
            return execute_table(study, rundir, args)
    with open_run(args) as rundir:  # the target is checked here, before the computation
        return execute(study, rundir, args)
