"""CSV text of a table given as columns, the same text ``pandas.DataFrame.to_csv`` writes.

A run's small tables (``starts.csv``, ``bands.csv``) do not need pandas: importing it (and
the pyarrow it loads) cost ``isodesign optimize`` about half a second of CPU time, a tenth
of the whole run. :func:`columns_csv` writes the text pandas would write for the frame
``pandas.DataFrame(columns)`` with ``to_csv(index=False)``: the same column types
(a column of booleans, of integers, of numbers, else of objects), the same cell text
(floats as the shortest text that reads back to the same double, ``inf``, a missing value
or NaN as an empty cell) and the csv module's minimal quoting (tests/io/test_csvtable.py
compares the two).
"""

from __future__ import annotations

import csv
import io
import math
import numbers
from collections.abc import Mapping, Sequence

__all__ = ["columns_csv", "records_columns"]


def records_columns(rows: Sequence[Mapping]) -> dict[str, list]:
    """Columns of a list of records, as ``pandas.DataFrame(rows)`` orders them.

    Parameters
    ----------
    rows : sequence of mapping
        One mapping per row.

    Returns
    -------
    dict
        Column name -> values, the names in the order they first appear; a row without
        a column has ``None`` there.
    """
    names: dict[str, None] = {}
    for r in rows:
        for k in r:
            names.setdefault(k, None)
    return {k: [r.get(k) for r in rows] for k in names}


def _is_bool(v) -> bool:
    return isinstance(v, bool) or type(v).__name__ in ("bool", "bool_")


def _missing(v) -> bool:
    """None, or a NaN (pandas' missing value)."""
    if v is None:
        return True
    return (isinstance(v, numbers.Real) and not isinstance(v, numbers.Integral)
            and not _is_bool(v) and math.isnan(float(v)))


def _is_int(v) -> bool:
    return isinstance(v, numbers.Integral) and not _is_bool(v)


def _float_text(v) -> str:
    x = float(v)
    if math.isnan(x):
        return ""
    return repr(x)


def _column_texts(values: list) -> list[str]:
    """The cells of one column as pandas writes them (its type inferred like pandas')."""
    present = [v for v in values if not _missing(v)]
    n_missing = len(values) - len(present)
    if present and all(_is_bool(v) for v in present) and not n_missing:
        return ["True" if bool(v) else "False" for v in values]
    if present and all(_is_int(v) for v in present) and not n_missing:
        return [str(int(v)) for v in values]
    if all(isinstance(v, numbers.Real) and not _is_bool(v) for v in present):
        return ["" if _missing(v) else _float_text(v) for v in values]  # float64
    out = []  # object column: each value as it is
    for v in values:
        if _missing(v):
            out.append("")
        elif _is_bool(v):
            out.append("True" if bool(v) else "False")
        elif isinstance(v, numbers.Real) and not _is_int(v):
            out.append(_float_text(v))
        else:
            out.append(str(v))
    return out


def columns_csv(columns: Mapping[str, Sequence]) -> str:
    """The CSV text of a table of columns (a header line, then one line per row).

    Parameters
    ----------
    columns : mapping of str to sequence
        Column name -> values (Python or NumPy scalars, strings, ``None``), all of
        one length.

    Returns
    -------
    str
        What ``pandas.DataFrame(columns).to_csv(index=False)`` returns.

    Raises
    ------
    ValueError
        When the columns differ in length.
    """
    cols = {str(k): list(v) for k, v in columns.items()}
    lengths = {len(v) for v in cols.values()}
    if len(lengths) > 1:
        raise ValueError(f"columns_csv: columns of different lengths {sorted(lengths)}")
    texts = []
    for given, values in zip(columns.values(), cols.values(), strict=True):
        dt = getattr(given, "dtype", None)
        if dt is not None and dt.kind == "f" and dt.itemsize < 8:
            # an array of a narrower float keeps its type: its own shortest text
            texts.append(["" if _missing(v) else str(v) for v in values])
        else:
            texts.append(_column_texts(values))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n", quoting=csv.QUOTE_MINIMAL)
    if not cols:
        return "\n"
    w.writerow(list(cols))
    for row in zip(*texts, strict=True):
        w.writerow(row)
    return buf.getvalue()
