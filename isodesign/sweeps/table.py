"""The sweep table: one row per point, written whole (Parquet, atomically) as the points finish.

The table is an index of the point run directories: every row is also the point's
``sweep_point.json``, so the table can always be rebuilt from ``points/``
(:func:`collect_rows`). It is written with pyarrow to a temporary file beside the target,
fsync-ed and renamed over it (:func:`isodesign.io.files.atomic_path`): a reader (another
process, a notebook, ``isodesign report``) sees the previous table or the new one, never a
half-written file, however the sweep ends.

Columns, in order: ``point`` (16 hex digits of the study hash), the swept keys (one column
per dotted key, as given), ``task``, ``question`` (the study's kind: ``vertical``,
``table``, ``robust`` or ``robust table``: the question the point answered), ``status``
(the point's ``run_status``: ``complete``, ``infeasible`` or ``failed``), ``feasible``,
``objective``, ``objective_value``, the design variables (``volume_ratio``,
``top_volume_m3``, ``capillary_length_m``, ``capillary_diameter_m``, ``total_volume_m3``),
``binding`` (the binding constraints and the variables at a bound, ``;``-separated), the
task's figures (``worst_band_margin_db``, ``worst_band_hz``, ``natural_frequency_hz``,
...), ``wall_s``, ``cpu_s`` (the CPU time of the thread that computed the point),
``worker``, ``started_utc``, ``study_hash``, ``run_dir``, ``error``, ``warnings`` and
``changes`` (the point's changes as JSON).
"""

from __future__ import annotations

import json
from pathlib import Path

from isodesign.io.files import atomic_path
from isodesign.sweeps.tasks import POINT_FILE, read_point

__all__ = ["TABLE_NAME", "collect_rows", "frame", "read_table", "write_table"]

#: File name of the table in a sweep directory.
TABLE_NAME = "sweep.parquet"
_FIRST = ("point",)
_MIDDLE = ("task", "question", "status", "feasible", "objective", "objective_value",
           "volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m",
           "total_volume_m3", "binding")
_LAST = ("wall_s", "cpu_s", "worker", "started_utc", "study_hash", "run_dir", "error",
         "warnings", "reused", "changes")


def collect_rows(points_dir) -> dict[str, dict]:
    """Rows of every finished point under ``points_dir``, by study hash.

    Parameters
    ----------
    points_dir : str or Path

    Returns
    -------
    dict
    """
    out = {}
    d = Path(points_dir)
    if not d.is_dir():
        return out
    for p in sorted(d.iterdir()):
        if p.name.startswith(".") or not p.is_dir() or not (p / POINT_FILE).is_file():
            continue
        row = read_point(p)
        if row is not None and row.get("study_hash"):
            out[row["study_hash"]] = row
    return out


def frame(rows, keys=()):
    """The table of ``rows`` (dicts): swept keys as columns, a fixed column order.

    Parameters
    ----------
    rows : iterable of dict
    keys : sequence of str
        Swept keys put first (others found in the rows' ``changes`` follow them).

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    recs = []
    allkeys = list(keys)
    for r in rows:
        r = dict(r)
        ch = r.get("changes")
        ch = json.loads(ch) if isinstance(ch, str) and ch else (ch or {})
        r["changes"] = json.dumps(ch)
        for k, v in ch.items():
            if k not in allkeys:
                allkeys.append(k)
            r[k] = v
        r["reused"] = bool(r.get("reused", False))
        recs.append(r)
    df = pd.DataFrame(recs)
    if df.empty:
        return pd.DataFrame(columns=[*_FIRST, *allkeys, *_MIDDLE, *_LAST])
    for c in (*_FIRST, *_MIDDLE, *_LAST):
        if c not in df:
            df[c] = None
    other = [c for c in df.columns if c not in {*_FIRST, *allkeys, *_MIDDLE, *_LAST}]
    df = df[[*_FIRST, *allkeys, *_MIDDLE, *other, *_LAST]]
    for c in df.columns:  # a column mixing text and numbers is stored as text
        if df[c].dtype == object:
            kinds = {type(v) for v in df[c] if v is not None and v == v}
            if str in kinds and len(kinds) > 1:
                df[c] = [None if v is None else str(v) for v in df[c]]
            elif kinds & {list, tuple, dict} and len(kinds) > 1:
                # a range given as a number at one point and as [lower, upper] at another
                # (a [scenarios] tolerance): every value as its JSON text
                df[c] = [None if v is None else json.dumps(v) for v in df[c]]
            elif kinds <= {int, float, bool} and kinds - {bool}:
                df[c] = pd.to_numeric(df[c], errors="coerce")
    sort = [k for k in allkeys if k in df]
    if sort:
        try:
            df = df.sort_values(sort, kind="stable")
        except TypeError:
            pass
    return df.reset_index(drop=True)


def write_table(df, path) -> Path:
    """Write ``df`` as Parquet, whole or not at all.

    Parameters
    ----------
    df : pandas.DataFrame
    path : str or Path

    Returns
    -------
    Path
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)
    return Path(path)


def read_table(path):
    """The sweep table of a sweep directory (or of a Parquet file).

    Parameters
    ----------
    path : str or Path
        A sweep directory or its ``sweep.parquet``.

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    p = Path(path)
    if p.is_dir():
        p = p / TABLE_NAME
    return pd.read_parquet(p)
