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
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

__all__ = ["check_output_path", "input_error", "parse_values", "write_text"]

#: Unit suffixes accepted by :func:`parse_values`, per quantity: suffix -> factor to SI.
FREQUENCY_UNITS = {"Hz": 1.0, "hz": 1.0}
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6}


def input_error(message: str) -> Exception:
    """An :class:`~isodesign.errors.InputError` (imported lazily: it loads NumPy)."""
    from isodesign.errors import InputError

    return InputError(message)


def _split_unit(text: str, units: dict[str, float]) -> tuple[str, float | None]:
    """Strip a trailing unit suffix (longest match first); return (rest, factor or None)."""
    for suffix in sorted(units, key=len, reverse=True):
        if text.endswith(suffix):
            rest = text[: -len(suffix)].rstrip()
            # "1e-3m" is a number with unit m; "e" alone is no number: let float() decide
            return rest, units[suffix]
    return text, None


def _number(token: str, name: str, units: dict[str, float], default: float, unit_name: str):
    body, factor = _split_unit(token.strip(), units)
    try:
        v = float(body)
    except ValueError:
        raise input_error(f"{name}: {token.strip()!r} is not a number") from None
    if not math.isfinite(v) or v <= 0:
        raise input_error(
            f"{name}: every value must be finite and > 0 {unit_name}, got {token.strip()!r}"
        )
    return v * (default if factor is None else factor)


def parse_values(spec: str, name: str, *, units: dict[str, float], unit_name: str) -> list[float]:
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
    body, factor = _split_unit(text, units)
    default = 1.0 if factor is None else factor
    if ":" in body:
        parts = body.split(":")
        if len(parts) != 3:
            raise input_error(
                f"{name}: a range is start:stop:count (log-spaced), got {spec.strip()!r}"
            )
        start = _number(parts[0], name, units, default, unit_name)
        stop = _number(parts[1], name, units, default, unit_name)
        try:
            count = int(parts[2].strip())
        except ValueError:
            raise input_error(
                f"{name}: the count of start:stop:count must be an integer >= 2, "
                f"got {parts[2].strip()!r}"
            ) from None
        if count < 2:
            raise input_error(f"{name}: the count of start:stop:count must be >= 2, got {count}")
        if not stop > start:
            raise input_error(
                f"{name}: in start:stop:count, stop must be greater than start "
                f"({parts[1].strip()} <= {parts[0].strip()})"
            )
        ratio = math.log(stop / start)
        values = [start * math.exp(ratio * i / (count - 1)) for i in range(count)]
        values[0], values[-1] = start, stop
        return values
    items = body.split(",")
    if any(not it.strip() for it in items):
        raise input_error(f"{name}: empty item in {spec.strip()!r}")
    return [_number(it, name, units, default, unit_name) for it in items]


def check_output_path(path: str | Path | None, option: str) -> None:
    """Fail early (before any computation) if ``path`` cannot be created.

    ``None`` and ``-`` (standard output) pass. Raises InputError naming the
    option if the parent directory does not exist or ``path`` is a directory.
    """
    if path is None or str(path) == "-":
        return
    p = Path(path)
    if p.is_dir():
        raise input_error(f"{option}: {p} is a directory; give a file name")
    parent = p.parent
    if not parent.is_dir():
        raise input_error(f"{option}: directory {parent} does not exist")


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` (``-`` = standard output); return the path."""
    if str(path) == "-":
        sys.stdout.write(text)
        return Path("-")
    p = Path(path)
    p.write_text(text, encoding="utf-8")
    return p


def write_result(res, args, summary_text: str) -> int:
    """Print a result's summary, write its table (``-o``, ``-`` = standard output) and
    its plot (``--plot``); shared by the commands that produce one result object."""
    to_stdout = args.output == "-"
    if not to_stdout:
        print(summary_text)
    if args.output:
        df = res.to_frame()
        df.to_csv(sys.stdout if to_stdout else args.output, index=False)
        if not to_stdout:
            print(f"wrote {args.output} ({len(df)} rows)")
    if args.plot:
        res.plot(args.plot)
        if not to_stdout:
            print(f"wrote {args.plot}")
    return 0
