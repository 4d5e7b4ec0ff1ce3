"""Criterion curves and band values read from CSV files (schema in ``docs/criteria.md``)."""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path

import numpy as np

from isodesign.errors import InputError
from isodesign.floor.bands import (
    band_index_near,
)
from isodesign.floor.curves import CriterionCurve

__all__ = [
    "criterion_from_csv",
]

_HEADER_KEYS = ("quantity", "kind", "unit", "name", "description", "source")


def _read_csv(path) -> tuple[dict[str, str], list[str], list[tuple[int, list[str]]], str]:
    """Read a small CSV with '#' comment lines carrying ``key: value`` pairs."""
    if not isinstance(path, str | os.PathLike):
        raise InputError(f"path: expected a file path, got {path!r}")
    p = Path(path)
    where = f"file '{p}'"
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"path: {where} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"path: cannot read {where}: {exc}") from None
    header: dict[str, str] = {}
    columns: list[str] | None = None
    rows: list[tuple[int, list[str]]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            for part in s.lstrip("#").split(";"):
                if ":" in part:
                    k, v = part.split(":", 1)
                    k = k.strip().lower()
                    if k in _HEADER_KEYS:
                        header[k] = v.strip()
            continue
        fields = [f.strip() for f in next(csv.reader([s]))]
        if columns is None:
            columns = [f.lower() for f in fields]
            continue
        rows.append((lineno, fields))
    if columns is None or not rows:
        raise InputError(f"path: {where} is empty (needs a column header line and data rows)")
    return header, columns, rows, where


def _column(columns: list[str], name: str, where: str, *, what: str = "column") -> int:
    if name not in columns:
        raise InputError(
            f"path: {where} has no {what} '{name}' (found columns: {', '.join(columns)})"
        )
    return columns.index(name)


def _numbers(
    rows: list[tuple[int, list[str]]], ncols: int, col: int, colname: str, where: str
) -> tuple[np.ndarray, list[int]]:
    vals, lines = [], []
    for lineno, fields in rows:
        if len(fields) != ncols:
            raise InputError(
                f"path: {where} line {lineno}: expected {ncols} fields, got {len(fields)}"
            )
        try:
            v = float(fields[col])
        except ValueError:
            raise InputError(
                f"path: {where} line {lineno}, column '{colname}': expected a number, "
                f"got {fields[col]!r}"
            ) from None
        if not math.isfinite(v):
            raise InputError(
                f"path: {where} line {lineno}, column '{colname}': value must be finite, "
                f"got {fields[col]!r}"
            )
        vals.append(v)
        lines.append(lineno)
    return np.array(vals), lines


def _check_frequencies(f: np.ndarray, lines: list[int], where: str) -> None:
    for i, v in enumerate(f):
        if v <= 0:
            raise InputError(
                f"path: {where} line {lines[i]}, column 'frequency_hz': must be > 0 Hz, got {v:g}"
            )
        if i and v <= f[i - 1]:
            raise InputError(
                f"path: {where} line {lines[i]}, column 'frequency_hz': frequencies must be "
                f"strictly increasing, got {v:g} after {f[i - 1]:g}"
            )


def _check_values(v: np.ndarray, lines: list[int], col: str, where: str, strict: bool) -> None:
    for i, x in enumerate(v):
        if x < 0 or (strict and x == 0):
            need = "> 0 (log-log interpolation)" if strict else ">= 0"
            raise InputError(
                f"path: {where} line {lines[i]}, column '{col}': must be {need}, got {x:g}"
            )


def _snap(f: np.ndarray) -> np.ndarray:
    """Replace frequencies within 2 % of a band's exact centre by that exact centre."""
    out = f.copy()
    for i, v in enumerate(f):
        x = band_index_near(v)
        if x is not None:
            out[i] = 10.0 ** (3.0 + x / 10.0)
    return out


_CURVE_COLUMNS = {
    "velocity_rms_m_s": "velocity",
    "displacement_rms_m": "displacement",
    "acceleration_rms_m_s2": "acceleration",
}


def criterion_from_csv(path, name: str | None = None) -> CriterionCurve:
    """Read a user-defined criterion curve from CSV.

    The file has a column ``frequency_hz`` (band centres, Hz, strictly increasing) and exactly
    one of ``velocity_rms_m_s``, ``displacement_rms_m``, ``acceleration_rms_m_s2`` (band RMS,
    SI, > 0). Optional comment lines ``# name: ...; description: ...; source: ...``.
    Frequencies within 2 % of a band's exact centre (so nominal 1.25 or exact 1.2589) are
    taken as that exact centre. The curve is interpolated log-log between the points;
    evaluating it on a band outside the points raises ``InputError`` ("bands outside the
    data").

    Parameters
    ----------
    path : str or os.PathLike
    name : str, optional
        Curve name (default: the header's ``name``, else the file stem).

    Returns
    -------
    CriterionCurve
    """
    header, cols, rows, where = _read_csv(path)
    fcol = _column(cols, "frequency_hz", where)
    present = [c for c in _CURVE_COLUMNS if c in cols]
    if len(present) != 1:
        raise InputError(
            f"path: {where} needs exactly one value column among "
            f"{', '.join(_CURVE_COLUMNS)} (found columns: {', '.join(cols)})"
        )
    vname = present[0]
    vcol = cols.index(vname)
    f, lines = _numbers(rows, len(cols), fcol, "frequency_hz", where)
    v, _ = _numbers(rows, len(cols), vcol, vname, where)
    _check_frequencies(f, lines, where)
    _check_values(v, lines, vname, where, strict=True)
    if len(f) < 2:
        raise InputError(f"path: {where} needs at least 2 data rows, got {len(f)}")
    fs = _snap(f)
    _check_frequencies(fs, lines, where)
    p = Path(path)
    return CriterionCurve(
        name=name or header.get("name") or p.stem,
        description=header.get("description", f"user-defined curve from {p.name}"),
        source=header.get("source", str(p)),
        quantity=f"band RMS {_CURVE_COLUMNS[vname]}",
        points_frequency_hz=tuple(fs.tolist()),
        points_value=tuple(v.tolist()),
        points_quantity=_CURVE_COLUMNS[vname],
    )
