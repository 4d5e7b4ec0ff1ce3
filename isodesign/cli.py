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
with ``--debug`` for the traceback); 130 interrupted (SIGINT or SIGTERM). Every error is
one line on standard error, ``isodesign: error: <message>``; every
:class:`~isodesign.errors.ModelValidityWarning` is one line
``isodesign: warning: <message>``.

Interrupts: while a command runs, SIGINT and SIGTERM go to :func:`_on_signal`, which ends
the forked worker processes, marks every open run directory interrupted
(:func:`isodesign.io.rundir.interrupt_active_runs`), prints one line and exits with 130
at once (``os._exit``: no exception travels through CasADi/IPOPT, which would print its
own ``KeyboardInterruptException``). Forked children ignore SIGINT (the terminal sends it
to the whole process group; the parent ends them), take SIGTERM's default action and die
with the parent (``PR_SET_PDEATHSIG`` on Linux), so no worker prints a traceback or
outlives the run.

Process exit: a command whose module sets ``EXIT_WITHOUT_TEARDOWN = True`` (``optimize``),
run as the program (the ``isodesign`` script or ``python -m isodesign``), ends the process
as soon as it returns: the :mod:`atexit` handlers run and the standard streams are
flushed, then ``os._exit`` skips the interpreter's teardown (freeing every module, the
Matplotlib figure's reference cycles and CasADi's graphs: a sizeable part of the run's exit,
see the `bench_cli.py` row of docs/benchmarks.md). Its output files
are complete by then (a run directory is finished inside the command). :func:`main`
called from Python always returns.

A handled interrupt exits with 130, not by the signal: CPython (3.8 and newer) remembers a
``KeyboardInterrupt`` that left a string passed to ``exec``/``eval`` (``dataclasses`` and
``namedtuple`` build their methods so, e.g. while a module is imported) and, at the end of
the program, kills itself with SIGINT (status -2 to a parent) even though the exception was
caught and the command returned 130. :func:`main` forgets that mark once the command has
returned (:func:`_forget_handled_keyboard_interrupt`).
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
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
        "isodesign.commands.optimize_cli",
        "optimize a study: N, V_t0, L_c, D_c for a payload, floor and target (IPOPT)",
    ),
    "yield": (
        "isodesign.commands.yield_",
        "yield of a design under a study's tolerances (sampling, confidence interval)",
    ),
    "pareto": (
        "isodesign.commands.pareto",
        "Pareto front of two objectives (default: worst-band margin vs total volume)",
    ),
    "sweep": (
        "isodesign.commands.sweep",
        "sweep a study over study changes, one Dask task per point (laptop or cluster)",
    ),
    "modes": (
        "isodesign.commands.modes",
        "modes and rocking stability of a table in six degrees of freedom (docs/table.md)",
    ),
    "stability": (
        "isodesign.commands.stability",
        "static stability and the leveling valves' loop of a table (margins, onset, plots)",
    ),
    "floor": (
        "isodesign.commands.floor",
        "floor spectrum from a survey record (time history): band RMS statistics vs VC",
    ),
    "fit": (
        "isodesign.commands.fit",
        "calibrate from rig data: the diaphragm (passive, cvxpy) or K, D_c, n (CasADi)",
    ),
    "report": (
        "isodesign.commands.report",
        "self-contained HTML report of a design, a run, or candidates side by side",
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
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a writer whose reader left


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
    """ArgumentParser whose usage errors are one line: ``isodesign: error: ...``.

    A word that starts with ``-`` and a digit or ``.digit`` (``-1,2``, ``-1e-3``,
    ``-.5:2:3``) is a value, not an option (argparse's own rule accepts only plain
    negative numbers): ``--freq -1,2`` reaches the option's own check, which names it.
    """

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self._negative_number_matcher = re.compile(r"^-\.?\d")

    def error(self, message: str):
        hint = f" (see '{self.prog} --help')"
        message = _one_line(message) + _did_you_mean(self, message)
        self.exit(EXIT_INPUT, f"{PROG}: error: {message}{hint}\n")


def _known_options(parser: argparse.ArgumentParser) -> set[str]:
    """Every option string of ``parser`` and of its (loaded) subcommand parsers."""
    out = {o for o in parser._option_string_actions if o.startswith("--")}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out |= _known_options(sub)
    return out


def _did_you_mean(parser: argparse.ArgumentParser, message: str) -> str:
    """``"; did you mean --points?"`` for an unknown option or command close to a known one.

    argparse (Python 3.11) suggests nothing for a mistyped option; :mod:`difflib` finds the
    closest known option (``--point`` -> ``--points``, ``--ouput`` -> ``--output``), and
    the closest command for an invalid choice of command (``optimise`` -> ``optimize``).
    """
    import difflib

    m = re.match(r"unrecognized arguments: (.*)", message)
    if m:
        known = sorted(_known_options(parser))
        tips = []
        for word in m.group(1).split():
            if not word.startswith("--"):
                continue
            name = word.split("=", 1)[0]
            close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
            if close:
                tips.append((name, close[0]))
        if len(tips) == 1:
            return f"; did you mean {tips[0][1]}?"
        if tips:
            return "; did you mean " + ", ".join(f"{b} (for {a})" for a, b in tips) + "?"
        return ""
    m = re.match(r"argument (\S+): invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if m:
        choices = [c.strip(" '") for c in m.group(3).split(",")]
        close = difflib.get_close_matches(m.group(2), choices, n=1, cutoff=0.6)
        if close:
            return f"; did you mean {close[0]!r}?"
    return ""


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
            "Exit status: 0 ok, 1 solver failure or no feasible design, 2 bad input,\n"
            "3 internal error, 130 interrupted.\n"
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
            p.set_defaults(_run=mod.run,
                           _exit_without_teardown=getattr(mod, "EXIT_WITHOUT_TEARDOWN", False))
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Print a warning as one line on stderr (replaces :func:`warnings.showwarning`)."""
    text = _one_line(str(message))
    if category.__name__ not in ("ModelValidityWarning", "UnitWarning"):
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


_MAIN_PID: int | None = None
_FORK_HOOK_INSTALLED = False


def _in_forked_child() -> None:
    """Signal dispositions of every process forked while a command runs (its workers)."""
    if os.getpid() == _MAIN_PID:  # pragma: no cover - runs only in the child
        return
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: die with the parent
        except (OSError, AttributeError):  # pragma: no cover - no libc prctl
            pass


def _end_workers() -> None:
    """Terminate (then kill) the multiprocessing children of this process."""
    mp = sys.modules.get("multiprocessing")
    if mp is None:
        return
    try:
        children = mp.active_children()
    except Exception:  # pragma: no cover - best effort inside a signal handler
        return
    for p in children:
        try:
            p.terminate()
        except Exception:  # pragma: no cover
            pass
    for p in children:
        try:
            p.join(timeout=2.0)
            if p.is_alive():  # pragma: no cover - SIGTERM is the default action in workers
                p.kill()
                p.join(timeout=1.0)
        except Exception:  # pragma: no cover
            pass


def _on_signal(signum, frame) -> None:  # pragma: no cover - exercised by subprocess tests
    """SIGINT/SIGTERM while a command runs: end workers, mark runs interrupted, exit 130."""
    if os.getpid() != _MAIN_PID:  # a forked child that kept the parent's handler
        os._exit(EXIT_INTERRUPTED)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not cut the cleanup
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    name = signal.Signals(signum).name
    where = ""
    try:
        _end_workers()
        rundir = sys.modules.get("isodesign.io.rundir")
        if rundir is not None:
            kept = rundir.interrupt_active_runs(f"interrupted by {name}")
            if kept:
                where = "; partial run kept in " + ", ".join(str(p) for p in kept) + \
                    " (run_status interrupted)"
                tables = [str(t) for p in kept for t in rundir.partial_tables(p)]
                if tables:  # named only when written
                    where += "; finished work in " + ", ".join(tables)
        else:
            files = sys.modules.get("isodesign.io.files")
            if files is not None:
                files.discard_pending_writes()
    except Exception as exc:  # never a traceback from the handler
        where = f"; cleanup incomplete ({type(exc).__name__}: {_one_line(str(exc))})"
    try:
        sys.stdout.flush()
    except Exception:
        pass
    try:
        # a progress bar (rich, on a terminal) hid the cursor and holds the line
        tty = "\r\x1b[2K\x1b[?25h" if os.isatty(2) else ""
        os.write(2, f"{tty}{PROG}: interrupted by {name}{where}\n".encode())
    except OSError:
        pass
    os._exit(EXIT_INTERRUPTED)


def _install_signal_handlers() -> dict:
    """Handlers of SIGINT/SIGTERM for the run; returns the previous ones (to restore)."""
    global _MAIN_PID, _FORK_HOOK_INSTALLED
    import threading

    if threading.current_thread() is not threading.main_thread():
        return {}
    _MAIN_PID = os.getpid()
    if not _FORK_HOOK_INSTALLED:
        os.register_at_fork(after_in_child=_in_forked_child)
        _FORK_HOOK_INSTALLED = True
    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        old[sig] = signal.signal(sig, _on_signal)
    return old


def _restore_signal_handlers(old: dict) -> None:
    global _MAIN_PID
    for sig, h in old.items():
        signal.signal(sig, h)
    _MAIN_PID = None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status.

    Run as the program (``argv`` None in the ``isodesign`` script), a command that sets
    ``EXIT_WITHOUT_TEARDOWN`` ends the process here instead of returning (module
    docstring, "Process exit").

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status.
    """
    program = argv is None and _is_program()
    argv = list(sys.argv[1:] if argv is None else argv)
    old_handlers = _install_signal_handlers()
    state: dict = {}
    try:
        status = _main(argv, state)
    except KeyboardInterrupt:  # raised before the handlers were in place, or by a test
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        _restore_signal_handlers(old_handlers)
        _forget_handled_keyboard_interrupt()
    if program and state.get("exit_without_teardown"):
        _exit_process(status)
    return status


def _forget_handled_keyboard_interrupt() -> None:
    """Clear CPython's mark of an unhandled ``KeyboardInterrupt`` once the command returned.

    CPython sets the mark when a ``KeyboardInterrupt`` leaves code run from a string
    (``exec``/``eval``: ``run_eval_code_obj``), even if an outer ``try`` then handles it, and
    ``Py_RunMain`` ends such a program by SIGINT instead of its exit status. Every string
    evaluation clears the mark first, so evaluating an empty statement forgets it. Here every
    interrupt has been handled: the command's status (130) is the answer.
    """
    exec("pass")  # a constant statement: clears the mark (docstring)


def _is_program() -> bool:
    """True when this process is the ``isodesign`` script or ``python -m isodesign``."""
    from pathlib import Path

    p = Path(sys.argv[0]) if sys.argv and sys.argv[0] else Path()
    return p.stem in ("isodesign", "isodesign-script") or (
        p.name == "__main__.py" and p.parent.name == "isodesign")


def _exit_process(status: int) -> None:
    """End the process with ``status`` now: atexit handlers, flushed streams, no teardown.

    Falls back to a normal return (nothing done) while another non-daemon thread runs:
    the interpreter would wait for it.
    """
    import threading

    if any(t.is_alive() and not t.daemon for t in threading.enumerate()
           if t is not threading.current_thread()):
        return
    import atexit

    run_exitfuncs = getattr(atexit, "_run_exitfuncs", None)
    if run_exitfuncs is None:  # pragma: no cover - not CPython
        return
    run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed or broken stream: nothing more to write
            pass
    os._exit(status)


def _main(argv: list[str], state: dict | None = None) -> int:
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
    if state is not None:
        state["exit_without_teardown"] = bool(getattr(args, "_exit_without_teardown", False))
    from isodesign.errors import ModelValidityWarning  # NumPy: only once a command runs

    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        warnings.filterwarnings("always", category=ModelValidityWarning)
        try:
            return int(args._run(args) or 0)
        except BrokenPipeError:  # the reader of stdout went away (`isodesign ... -o - | head`)
            try:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
            except (OSError, ValueError):
                pass
            return EXIT_BROKEN_PIPE
        except Exception as exc:
            return _report(exc, debug)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
