"""Small, strict file readers: CSV columns and TOML documents.

Every failure raises :class:`~isodesign.errors.InputError` naming the file and,
where it applies, the column, row or key.
"""

from __future__ import annotations

import csv
import math
import tomllib
from pathlib import Path

import numpy as np

from isodesign.errors import InputError

__all__ = ["read_csv_columns", "read_csv_header_comments", "read_toml"]


def read_csv_header_comments(path) -> dict[str, str]:
    """Parse leading ``# key: value; key: value`` comment lines into a dict.

    Parameters
    ----------
    path : str or Path
        The file.
    """
    out: dict[str, str] = {}
    p = Path(path)
    try:
        with p.open(encoding="utf-8") as fh:
            for line in fh:
                s = line.strip()
                if not s:
                    continue
                if not s.startswith("#"):
                    break
                for part in s.lstrip("#").split(";"):
                    if ":" in part:
                        k, v = part.split(":", 1)
                        out[k.strip().lower()] = v.strip()
    except OSError as exc:
        raise InputError(f"{p}: cannot read file ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputError(f"{p}: not a UTF-8 text file") from None
    return out


def read_csv_columns(path, required, *, optional=(), what="CSV") -> dict[str, np.ndarray]:
    """Read named numeric columns from a CSV file with a header row.

    Lines starting with ``#`` are comments. Every required column must exist and
    every value must be a finite number.

    Parameters
    ----------
    path : str or Path
        The file.
    required : sequence of str
        Column names that must exist.
    optional : sequence of str
        Column names read if present.
    what : str
        What the file is, for error messages.

    Returns
    -------
    dict of str to ndarray
        The required columns and whichever optional columns are present.
    """
    p = Path(path)
    try:
        with p.open(encoding="utf-8", newline="") as fh:
            rows = [
                r
                for r in csv.reader(line for line in fh if not line.lstrip().startswith("#"))
                if any(c.strip() for c in r)
            ]
    except OSError as exc:
        raise InputError(f"{what} file {p}: cannot read ({exc.strerror})") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"{what} file {p}: malformed ({exc})") from None
    if not rows:
        raise InputError(
            f"{what} file {p}: empty (expected a header row with columns {', '.join(required)})"
        )
    header = [h.strip() for h in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(
            f"{what} file {p}: missing column(s) {', '.join(missing)}; "
            f"found {', '.join(header) or 'none'}"
        )
    if len(rows) < 2:
        raise InputError(f"{what} file {p}: no data rows")
    out = {}
    for name in (*required, *(c for c in optional if c in header)):
        j = header.index(name)
        vals = []
        for i, r in enumerate(rows[1:], start=2):
            if j >= len(r):
                raise InputError(f"{what} file {p}: row {i} has no value for column {name}")
            try:
                v = float(r[j])
            except ValueError:
                raise InputError(
                    f"{what} file {p}: row {i}, column {name}: not a number ({r[j]!r})"
                ) from None
            if not math.isfinite(v):
                raise InputError(f"{what} file {p}: row {i}, column {name}: NaN or infinite")
            vals.append(v)
        out[name] = np.asarray(vals, dtype=float)
    return out


def read_toml(path, *, what="TOML") -> dict:
    """Parse a TOML file, turning parse errors into :class:`InputError`.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for error messages.
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except OSError as exc:
        raise InputError(f"{what} file {p}: cannot read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{what} file {p}: malformed TOML ({exc})") from None
