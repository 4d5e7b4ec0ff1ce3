"""Subcommands of the ``isodesign`` command line and helpers they share.

Each command is a module ``isodesign.commands.<name>`` registered in
:data:`isodesign.cli.COMMANDS`. A command module defines:

``add_arguments(parser)``
    Add the command's options to its :class:`argparse.ArgumentParser`. Keep the
    module's top level light (standard library only): it is imported to build
    the parser, including for ``isodesign <name> --help``.
``run(args) -> int``
    Do the work and return the exit status (0 on success). Import NumPy,
    pandas, matplotlib and the physics modules inside ``run``. Raise
    :class:`~isodesign.errors.InputError` for bad input; the CLI prints it as
    one line and exits with status 2.

The helpers below use only the standard library, so that importing this
package costs nothing on the ``--help`` path.

Output (``docs/cli.md``, "Output directories" and "Output files"): a command that writes a
directory adds :func:`add_output_dir_arguments` to its parser and, in ``run``, after
validating its inputs and before computing, opens :func:`run_directory`; a command that
writes single files checks them with :func:`check_output_path` first and writes them with
:func:`write_text` / :func:`write_frame` / :func:`write_figure` (whole or not at all).
Every count a user can give is checked with :func:`check_count` (its range in the message).
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from pathlib import Path

from isodesign.errors import InputError
from isodesign.io.files import atomic_path, atomic_write_text, write_probe
from isodesign.io.rundir import RunDirectory, check_outside_whole_runs

__all__ = [
    "MAX_GRID_POINTS",
    "MAX_LIST_VALUES",
    "PLOT_SUFFIXES",
    "acoustics_override",
    "add_output_dir_arguments",
    "check_acoustics",
    "check_count",
    "check_grid_size",
    "check_output_path",
    "input_error",
    "int_option",
    "option_names",
    "parse_values",
    "run_directory",
    "write_figure",
    "write_frame",
    "write_text",
]

#: Unit suffixes accepted by :func:`parse_values`, per quantity: suffix -> factor to SI.
FREQUENCY_UNITS = {"Hz": 1.0, "hz": 1.0}
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6}
#: Most values one list option (``--freq``, ``--amplitude``, ...) may give.
MAX_LIST_VALUES = 10_000
#: Most points of a frequency x amplitude grid (``stiffness``, ``transmissibility``).
MAX_GRID_POINTS = 200_000

#: ``--builtin`` names (:data:`isodesign.optimization.study.BUILTIN_STUDIES`) and their help.
BUILTIN_CHOICES = ("default", "table", "vertical")
BUILTIN_HELP = ("default: the built-in table co-designed (the springs per leveling group, the "
                "pendulum, the elastic-centre height, the lateral element and the isolator "
                "spacing free; what STUDY omitted runs); "
                "table: the 600 kg table in six degrees of freedom with its horizontal element "
                "fixed; vertical: the one-degree-of-freedom payload (docs/table.md)")


def int_option(text: str) -> int:
    """An integer option value (an argparse ``type``): digits only, at most 12 of them.

    ``int()`` would accept ``1_000`` and spend time on a 100000-digit number; the range
    itself is checked by :func:`check_count` (so the message gives it).

    Parameters
    ----------
    text : str
        The word the user typed.

    Returns
    -------
    int

    Raises
    ------
    argparse.ArgumentTypeError
        Not an optional sign and 1-12 digits (argparse prints it naming the option).
    """
    import argparse

    t = text.strip()
    body = t[1:] if t[:1] in "+-" else t
    if not (body.isascii() and body.isdigit()):
        raise argparse.ArgumentTypeError(f"expected an integer, got {t[:24]!r}")
    if len(body) > 12:
        raise argparse.ArgumentTypeError(
            f"expected an integer of at most 12 digits, got one of {len(body)} digits")
    return int(t)


def check_count(value, option: str, lo: int, hi: int) -> int:
    """Require an integer count in [lo, hi]; InputError naming ``option`` and the range.

    Parameters
    ----------
    value : int
        The count.
    option : str
        The option or key as the user typed it (``--points``).
    lo, hi : int
        The valid range, both ends included.

    Returns
    -------
    int
        ``value``.
    """
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        shown = str(value)
        if len(shown) > 24:
            shown = shown[:20] + "..."
        raise input_error(f"{option}: must be an integer in [{lo}, {hi}], got {shown}")
    return value


@contextlib.contextmanager
def option_names(**names: str):
    """Report the library's parameter names as the options the user typed.

    ``with option_names(floor="--floor", diaphragm="--diaphragm"): band_response(...)``
    turns an :class:`~isodesign.errors.InputError` ``"floor: ..."`` into ``"--floor: ..."``.

    Parameters
    ----------
    **names : str
        Library parameter name -> the option that sets it.
    """

    try:
        yield
    except InputError as exc:
        msg = str(exc)
        for param, option in names.items():
            if msg.startswith(f"{param}:"):
                raise InputError(option + msg[len(param):]) from None
            if msg.startswith(f"{param} "):  # "diaphragm table file X: cannot read (...)"
                raise InputError(f"{option}: {msg}") from None
        raise


def check_grid_size(n_a: int, n_b: int, option_a: str, option_b: str) -> None:
    """At most :data:`MAX_GRID_POINTS` points in an ``option_a`` x ``option_b`` grid.

    Parameters
    ----------
    n_a, n_b : int
        Number of values of each option.
    option_a, option_b : str
        The two options, for the message (``--freq``, ``--amplitude``).
    """
    if n_a * n_b > MAX_GRID_POINTS:
        raise input_error(
            f"{option_a} x {option_b}: {n_a} x {n_b} = {n_a * n_b} points; the grid may have "
            f"at most {MAX_GRID_POINTS} (fewer values, or several runs)"
        )


def add_output_dir_arguments(parser, *, required: bool = True, default: str | None = None,
                             what: str = "output directory") -> None:
    """``-o/--output OUTDIR`` and ``--overwrite``: the run-directory contract's options.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    required : bool
        Whether ``-o`` must be given.
    default : str, optional
        The default directory when not required.
    what : str
        What the directory is, for the help text.
    """
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUTDIR",
        required=required,
        default=default,
        help=f"{what}: written whole when the run ends (docs/cli.md, 'Output directories'); "
        "refused if it already holds a run, unless --overwrite"
        + ("" if default is None else " (default %(default)s)"),
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an earlier run in OUTDIR (only the files that run wrote)",
    )


def run_directory(args, command: str, *, known_outputs=(), option: str = "--output"):
    """The :class:`~isodesign.io.rundir.RunDirectory` of ``args.output`` (checked now).

    Use as ``with run_directory(args, "report") as run: run.write_text(...)``; call it
    before the computation so that a bad target fails first.

    Parameters
    ----------
    args : argparse.Namespace
        With ``output`` and (optionally) ``overwrite``.
    command : str
        The command's name (``record.json["kind"] = "isodesign <command>"``).
    known_outputs : iterable of str
        The command's file names (an earlier run without a manifest owns these).
    option : str
        The option naming the directory, for messages.

    Returns
    -------
    RunDirectory
    """
    check_outside_whole_runs(args.output, option=option)  # not inside a sweep's directory
    _refuse_own_input(args, option)
    return RunDirectory(args.output, command=command,
                        overwrite=bool(getattr(args, "overwrite", False)), option=option,
                        known_outputs=known_outputs)


def _refuse_own_input(args, option: str) -> None:
    """Refuse an output directory that is the run the command reads (``yield RUN -o RUN
    --overwrite`` replaced the optimize run by its own yield: no design left to read; ``modes
    RUN -o RUN --overwrite`` the same)."""
    from isodesign.io.rundir import read_run_record

    out = getattr(args, "output", None)
    if not isinstance(out, str | os.PathLike) or not str(out).strip() or \
            read_run_record(out) is None:
        return
    target = Path(out).resolve()
    for attr in ("design", "study", "run", "inputs", "input"):
        given = getattr(args, attr, None)
        for p in given if isinstance(given, list | tuple) else [given]:
            if not isinstance(p, str | os.PathLike) or not str(p).strip():
                continue
            path = Path(p).resolve()
            if attr == "study" and not path.is_dir():
                continue  # a study file is read whole first (optimize it again in place)
            if target == (path if path.is_dir() else path.parent):
                raise InputError(f"{option}: {out} is the run this command reads ({p}); "
                                 "--overwrite would replace its own input: choose another "
                                 "directory")


def check_acoustics(design, flow: str | None, option: str | None) -> None:
    """Refuse an acoustic model the computation would not use (one line, both names).

    ``--acoustics distributed`` with a paper's flow model (``poiseuille``, ``zhao``,
    ``zhao_turbulent``: lumped by definition, computed lumped) would be labelled distributed
    but computed lumped; lumped acoustics with ``chamber_heat_exchange = true`` would drop
    the heat exchange (it lives in the distributed chambers) without a word.

    Parameters
    ----------
    design : SpringDesign
        The spring as it will be computed (``--acoustics`` applied).
    flow : str or None
        The flow model in force.
    option : str or None
        The ``--acoustics`` value the user gave (None: the design's own).
    """
    from isodesign.spring.flow_models import flow_model

    ac = getattr(design, "acoustics", None)
    what = f"--acoustics {option}" if option else f"acoustics = {ac!r}"
    if ac == "lumped" and getattr(design, "chamber_heat_exchange", False):
        raise input_error(f"{what} with chamber_heat_exchange = true: the lumped chambers have "
                          "no wall heat exchange (it is part of the distributed model); use "
                          "--acoustics distributed or set chamber_heat_exchange = false")
    if option == "distributed" and flow is not None and not flow_model(flow).distributed:
        raise input_error(f"--acoustics distributed with --flow {flow}: the paper's flow model "
                          f"{flow!r} is lumped by definition and would be computed lumped; use "
                          "--acoustics lumped, or a distributed flow model (quasi_steady, "
                          "womersley)")
    if flow is not None and not flow_model(flow).distributed \
            and getattr(design, "chamber_heat_exchange", False):
        raise input_error(f"--flow {flow} with chamber_heat_exchange = true: the paper's flow "
                          "model is computed with lumped acoustics, which have no wall heat "
                          "exchange; use a distributed flow model (quasi_steady, womersley) or "
                          "set chamber_heat_exchange = false")


def input_error(message: str) -> Exception:
    """An :class:`~isodesign.errors.InputError` (imported lazily: it loads NumPy).

    Parameters
    ----------
    message : str
        One line naming the option and its valid range.

    Returns
    -------
    InputError
        To be raised by the caller.
    """

    return InputError(message)


def _split_unit(text: str, units: dict[str, float]) -> tuple[str, float | None]:
    """Strip a trailing unit suffix (longest match first); return (rest, factor or None)."""
    for suffix in sorted(units, key=len, reverse=True):
        if text.endswith(suffix):
            rest = text[: -len(suffix)].rstrip()
            # "1e-3m" is a number with unit m; "e" alone is no number: let float() decide
            return rest, units[suffix]
    return text, None


def _units_text(units: dict[str, float], unit_name: str) -> str:
    names = sorted(set(units), key=lambda u: (units[u], u))
    return f"accepted units: {', '.join(names)} (none: {unit_name})"


def _number(token: str, name: str, units: dict[str, float], default: float, unit_name: str):
    body, factor = _split_unit(token.strip(), units)
    try:
        v = float(body)
    except ValueError:
        text = token.strip()
        i = len(text)
        while i > 0 and text[i - 1].isalpha():
            i -= 1
        if 0 < i < len(text):
            try:
                float(text[:i])
            except ValueError:
                pass
            else:
                raise input_error(
                    f"{name}: unknown unit {text[i:]!r} in {text!r}; "
                    f"{_units_text(units, unit_name)}"
                ) from None
        raise input_error(
            f"{name}: {_clip(text)!r} is not a number ({_units_text(units, unit_name)})"
        ) from None
    if not math.isfinite(v) or v <= 0:
        raise input_error(
            f"{name}: every value must be finite and > 0 {unit_name}, got {token.strip()!r}"
        )
    return v * (default if factor is None else factor)


def parse_values(spec: str, name: str, *, units: dict[str, float], unit_name: str,
                 domain: tuple[float, float] | None = None) -> list[float]:
    """Parse a list of positive numbers: ``a,b,c`` or a log-spaced range ``start:stop:count``.

    Parameters
    ----------
    spec : str
        ``0.2,1,5`` (the values) or ``0.2:24:50`` (``count`` values from
        ``start`` to ``stop``, both included, equally spaced in log). A unit
        suffix at the end (``0.05,0.15,0.5mm``, ``0.05:0.5:3mm``) applies to
        every value that carries none of its own (``50um,0.1mm`` works too).
    name : str
        Option name used in error messages (``--freq``).
    units : dict of str to float
        Accepted unit suffixes and their factors to SI.
    unit_name : str
        The SI unit, for messages (``Hz``, ``m``).
    domain : tuple of float, optional
        ``(lo, hi)`` in SI: every value must lie in it (the models' domain,
        :mod:`isodesign.domain`); the message names the option and the value typed.

    Returns
    -------
    list of float
        The values in SI units, in the order given.

    Raises
    ------
    InputError
        Empty items, non-numbers, values that are not finite and > 0, a bad
        range; the message names the option.
    """
    text = spec.strip()
    if not text:
        raise input_error(f"{name}: empty; give values like 0.2,1,5 or a range 0.2:24:50")
    if len(text) > 20 * MAX_LIST_VALUES:
        raise input_error(f"{name}: too long ({len(text)} characters); at most "
                          f"{MAX_LIST_VALUES} values")
    body, factor = _split_unit(text, units)
    if not body.strip():
        raise input_error(f"{name}: no value before the unit in {_clip(text)!r}")
    default = 1.0 if factor is None else factor
    if ":" in body:
        parts = body.split(":")
        if len(parts) != 3:
            raise input_error(
                f"{name}: a range is start:stop:count (log-spaced), got {spec.strip()!r}"
            )
        start = _number(parts[0], name, units, default, unit_name)
        stop = _number(parts[1], name, units, default, unit_name)
        c = parts[2].strip()
        if not (c.isascii() and c.isdigit()) or len(c) > 9 or not 2 <= int(c) <= MAX_LIST_VALUES:
            raise input_error(
                f"{name}: the count of start:stop:count must be an integer in "
                f"[2, {MAX_LIST_VALUES}], got {_clip(c)!r}"
            )
        count = int(c)
        if not stop > start:
            raise input_error(
                f"{name}: in start:stop:count, stop must be greater than start "
                f"({parts[1].strip()} <= {parts[0].strip()})"
            )
        _in_domain([start, stop], [parts[0], parts[1]], name, unit_name, domain)
        ratio = math.log(stop / start)
        values = [start * math.exp(ratio * i / (count - 1)) for i in range(count)]
        values[0], values[-1] = start, stop
        return values
    items = body.split(",")
    if any(not it.strip() for it in items):
        raise input_error(f"{name}: empty item in {_clip(spec.strip())!r}")
    if len(items) > MAX_LIST_VALUES:
        raise input_error(
            f"{name}: {len(items)} values; give between 1 and {MAX_LIST_VALUES}"
        )
    values = [_number(it, name, units, default, unit_name) for it in items]
    _in_domain(values, items, name, unit_name, domain)
    return values


def _in_domain(values, typed, name: str, unit_name: str, domain) -> None:
    """InputError naming the option and the word typed for a value outside ``domain``."""
    if domain is None:
        return
    lo, hi = domain
    for v, t in zip(values, typed, strict=True):
        if not lo <= v <= hi:
            raise input_error(f"{name}: every value must be in [{lo:g}, {hi:g}] {unit_name} "
                              f"(the models' domain), got {_clip(t.strip())!r}")


def _clip(text: str, n: int = 40) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


#: File types of plots (``--plot``).
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def check_output_path(path: str | Path | None, option: str, *, suffixes=None) -> None:
    """Fail early (before any computation) if the file ``path`` cannot be written.

    ``None`` and ``-`` (standard output) pass. Raises InputError naming the
    option if ``path`` is empty or a directory, has a suffix not in ``suffixes``
    (when given), its parent does not exist or is a file, or the parent (or an
    existing ``path``) is not writable.

    Parameters
    ----------
    path : str or Path or None
        The output file.
    option : str
        The option as the user typed it (``--output``).
    suffixes : sequence of str, optional
        Accepted file types (``PLOT_SUFFIXES``).
    """
    if path is None or str(path) == "-":
        return
    if str(path).strip() == "":
        raise input_error(f"{option}: empty; give a file name")
    p = Path(path)
    if p.is_dir():
        raise input_error(f"{option}: {p} is a directory; give a file name")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise input_error(
            f"{option}: unsupported file type {p.suffix or '(none)'!r}; "
            f"valid: {', '.join(suffixes)}"
        )
    parent = p.parent
    if parent.exists() and not parent.is_dir():
        raise input_error(f"{option}: {parent} is a file, not a directory")
    if not parent.is_dir():
        raise input_error(f"{option}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise input_error(f"{option}: cannot write in {parent} (permission denied)")
    if p.exists() and not os.access(p, os.W_OK):
        raise input_error(f"{option}: {p} is not writable (permission denied)")
    if p.exists() and not p.is_file():
        raise input_error(f"{option}: {p} is not a regular file; give a file name")
    why = write_probe(parent)
    if why is not None:
        raise input_error(f"{option}: cannot write {p}: cannot create a file in {parent} "
                          f"({why.lower()})")


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` whole or not at all (``-`` = standard output).

    Parameters
    ----------
    path : str or Path
        The file, or ``-``.
    text : str
        Written as UTF-8.

    Returns
    -------
    Path
    """
    if str(path) == "-":
        sys.stdout.write(text)
        return Path("-")

    return atomic_write_text(path, text)


def write_frame(frame, path: str | Path) -> int:
    """Write a DataFrame as CSV (``-`` = standard output), whole or not at all.

    Parameters
    ----------
    frame : pandas.DataFrame
        Written without its index.
    path : str or Path
        The file, or ``-``.

    Returns
    -------
    int
        Number of rows written.
    """
    if str(path) == "-":
        frame.to_csv(sys.stdout, index=False)
    else:
        write_text(path, frame.to_csv(index=False))
    return len(frame)


@contextlib.contextmanager
def write_figure(path: str | Path):
    """``with write_figure(p) as tmp: fig.savefig(tmp)``: the file appears whole or not.

    Parameters
    ----------
    path : str or Path
        The figure file (its suffix, kept by the temporary name, sets the format).
    """

    with atomic_path(path) as tmp:
        yield tmp


def write_result(res, args, summary_text: str) -> int:
    """Print a result's summary, write its table (``-o``, ``-`` = standard output) and
    its plot (``--plot``); shared by the commands that produce one result object."""
    to_stdout = args.output == "-"
    if not to_stdout:
        print(summary_text)
    if args.output:
        n = write_frame(res.to_frame(), args.output)
        if not to_stdout:
            print(f"wrote {args.output} ({n} rows)")
    if args.plot:
        with write_figure(args.plot) as tmp:
            res.plot(tmp)
        if not to_stdout:
            print(f"wrote {args.plot}")
    return 0


def acoustics_override(study, acoustics: str):
    """``study`` with ``--acoustics``: a refusal names the option first (the user typed it,
    not the study's ``models.acoustics``).

    Parameters
    ----------
    study : Study
    acoustics : str
        ``--acoustics`` as given.
    """
    try:
        return study.with_changes(models={"acoustics": acoustics})
    except InputError as exc:
        raise InputError(f"--acoustics {acoustics}: {exc}") from None
