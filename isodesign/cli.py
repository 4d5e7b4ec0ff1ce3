"""The ``isodesign`` command line.

Subcommands are registered in :data:`COMMANDS` (name -> module path, one-line
help). Only the module of the command being run is imported, and command
modules import their heavy dependencies inside ``run``, so ``isodesign
--help`` loads neither NumPy nor pandas. To add a command, add one entry to
:data:`COMMANDS` and write the module (see :mod:`isodesign.commands` and
``docs/cli.md``).

Exit status: 0 success; 1 solver failure (:class:`~isodesign.errors.SolverError`);
2 bad input (usage errors, :class:`~isodesign.errors.InputError` and any other
``ValueError``, unreadable or malformed files); 3 internal error (a bug: rerun
with ``--debug`` for the traceback); 130 interrupted. Every error is one line on
standard error, ``isodesign: error: <message>``; every
:class:`~isodesign.errors.ModelValidityWarning` is one line
``isodesign: warning: <message>``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import traceback
import warnings
from collections.abc import Sequence

from isodesign import __version__

__all__ = ["COMMANDS", "build_parser", "main"]

#: Subcommands: name -> (module defining add_arguments(parser) and run(args), one-line help).
#: Listed in this order by ``isodesign --help``.
COMMANDS: dict[str, tuple[str, str]] = {
    "stiffness": (
        "isodesign.commands.stiffness",
        "complex stiffness over frequency x amplitude (CSV, plot)",
    ),
    "criteria": (
        "isodesign.commands.criteria",
        "floor vibration criteria (VC, ISO, NIST) per one-third octave",
    ),
    "response": (
        "isodesign.commands.response",
        "payload band response on a floor vs a criterion: margins per band, verdict",
    ),
    "transmissibility": (
        "isodesign.commands.transmissibility",
        "transmissibility for harmonic floor amplitudes (self-consistent stroke)",
    ),
    "optimize": (
        "isodesign.commands.optimize",
        "optimize a study: N, V_t0, L_c, D_c for a payload, floor and target (IPOPT)",
    ),
    "pareto": (
        "isodesign.commands.pareto",
        "Pareto front of two objectives (default: worst-band margin vs total volume)",
    ),
    "floor": (
        "isodesign.commands.floor",
        "floor spectrum from a survey record (time history): band RMS statistics vs VC",
    ),
    "fit": (
        "isodesign.commands.fit",
        "calibrate from rig data: the diaphragm (passive, cvxpy) or K, D_c, n (CasADi)",
    ),
    "demo": (
        "isodesign.commands.demo",
        "the product's main job on the default study, and the reference spring's stiffness",
    ),
}

PROG = "isodesign"

EXIT_OK = 0
EXIT_SOLVER = 1
EXIT_INPUT = 2
EXIT_INTERNAL = 3
EXIT_INTERRUPTED = 130


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Help formatter that keeps subcommand names and their help on one line.

    ``argparse`` measures the indented subcommand names without their indent
    (Python <= 3.12), so names longer than the options wrap; count the indent.
    """

    def __init__(self, prog: str):
        super().__init__(prog, max_help_position=30)

    def add_argument(self, action):
        super().add_argument(action)
        if action.nargs == argparse.PARSER and action.choices and action.help != argparse.SUPPRESS:
            for name in action.choices:
                width = self._current_indent + self._indent_increment + len(str(name))
                self._action_max_length = max(self._action_max_length, width)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line: ``isodesign: error: ...``."""

    def error(self, message: str):
        hint = f" (see '{self.prog} --help')"
        self.exit(EXIT_INPUT, f"{PROG}: error: {_one_line(message)}{hint}\n")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _selected_command(argv: Sequence[str]) -> str | None:
    """The subcommand named in ``argv`` (the first word that is not an option)."""
    for a in argv:
        if a == "--":
            return None
        if not a.startswith("-"):
            return a if a in COMMANDS else None
    return None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser, with the options of ``command`` (only) loaded.

    Parameters
    ----------
    command : str, optional
        Name of the subcommand whose module is imported to add its arguments.
        The other subcommands are listed with their one-line help only.
    """
    parser = _Parser(
        prog=PROG,
        formatter_class=_Formatter,
        description=(
            "Design vibration-isolation tables on dual-chamber pneumatic springs:\n"
            "frequency- and amplitude-dependent complex stiffness of the spring,\n"
            "floor vibration criteria, payload band response, and the optimal spring\n"
            "(volume ratio, chamber volume, capillary) for a payload, floor and target."
        ),
        epilog=(
            f"Run '{PROG} COMMAND --help' for the options of a command.\n"
            "Exit status: 0 ok, 1 solver failure, 2 bad input, 3 internal error.\n"
            "Docs: docs/cli.md, docs/optimization.md, docs/design-file.md."
        ),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("--debug", action="store_true", help="show the full traceback of any error")
    # --debug is also accepted after the command name
    common = _Parser(add_help=False)
    common.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="show the full traceback of any error",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    sub.required = True
    for name, (module_path, help_line) in COMMANDS.items():
        p = sub.add_parser(
            name,
            help=help_line,
            description=help_line,
            parents=[common],
            formatter_class=_Formatter,
        )
        if name == command:
            mod = importlib.import_module(module_path)
            if mod.__doc__:
                p.description = mod.__doc__.strip()
            mod.add_arguments(p)
            p.set_defaults(_run=mod.run)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Print a warning as one line on stderr (replaces :func:`warnings.showwarning`)."""
    text = _one_line(str(message))
    if category.__name__ != "ModelValidityWarning":
        text = f"{category.__name__}: {text}"
    print(f"{PROG}: warning: {text}", file=sys.stderr)


def _classify(exc: BaseException) -> int:
    """Exit status for an exception raised by a command."""
    errors = sys.modules.get("isodesign.errors")
    if errors is not None and isinstance(exc, errors.SolverError):
        return EXIT_SOLVER
    if isinstance(exc, ValueError | OSError):
        return EXIT_INPUT
    return EXIT_INTERNAL


def _error_message(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or exc}"
    return str(exc) or type(exc).__name__


def _report(exc: BaseException, debug: bool) -> int:
    """Print ``exc`` as one error line (and the traceback with ``--debug``); return the status."""
    status = _classify(exc)
    if debug:
        traceback.print_exception(exc)
    msg = _one_line(_error_message(exc))
    if status == EXIT_INTERNAL:
        hint = "" if debug else " (a bug: rerun with --debug for the traceback)"
        msg = f"internal error: {type(exc).__name__}: {msg}{hint}"
    print(f"{PROG}: error: {msg}", file=sys.stderr)
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        parser = build_parser(_selected_command(argv))
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors
        if exc.code is None:
            return EXIT_OK
        return exc.code if isinstance(exc.code, int) else EXIT_INPUT
    except Exception as exc:  # a command module that fails to import or to add its options
        return _report(exc, "--debug" in argv)
    debug = bool(getattr(args, "debug", False))
    from isodesign.errors import ModelValidityWarning  # NumPy: only once a command runs

    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        warnings.filterwarnings("always", category=ModelValidityWarning)
        try:
            return int(args._run(args) or 0)
        except KeyboardInterrupt:
            print(f"{PROG}: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        except Exception as exc:
            return _report(exc, debug)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
