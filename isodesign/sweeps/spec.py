"""What a sweep varies: study changes by key, combined into points; each point's study and hash.

A change names a study key by its dotted path, as a study file would (``payload.mass_kg``,
``floor.criterion``, ``variables.top_volume_m3.upper``, ``solver.starts``), and gives its
values:

* a comma list: ``300,600,900`` or ``VC-A,VC-B`` (numbers, ``true``/``false``, else text);
* a linear range ``start:stop:count``, both ends included: ``300:1500:13`` is 300, 400, ...,
  1500 (values rounded to 12 significant digits, so that an extended range meets the same
  points again).

The changes combine into points as a cartesian product (the first key varies slowest) or
as a zip (every key the same number of values), or come from a file of study-change tables
(:func:`read_points`). Each point's study is the base study with its changes applied
(:meth:`~isodesign.optimization.study.Study.with_changes`, validated again) and
``solver.workers = 1`` (inside a task the starts run serially); its identity is the
SHA-256 of the resolved study (:func:`study_hash`), which names its run directory and
lets a rerun skip it.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path

from isodesign.errors import InputError
from isodesign.io.record import resolved_study_dict
from isodesign.optimization.study import SCHEMA_KEYS, Study
from isodesign.optimization.variables import (
    CODESIGN_LEVERS,
    DESIGN_VARIABLES,
    GROUP_SPRING_LEVERS,
)
from isodesign.table.study import POSITION_KEYS

__all__ = [
    "MAX_POINTS",
    "SweepPoint",
    "build_points",
    "combine",
    "nest",
    "parse_vary",
    "read_points",
    "study_hash",
]

#: Most points one sweep may have.
MAX_POINTS = 100_000
#: Most values one ``--vary`` may give.
MAX_VALUES = 10_000
#: Tables whose keys a sweep may vary (``variables`` has one table per design variable).
_TABLES = ("payload", "hardware", "floor", "target", "models", "constraints", "objective",
           "solver")


def _variables() -> list[str]:
    """Every ``[variables.NAME]`` a study takes: the design variables, then a table's levers
    (docs/table.md sections 13 and 15), as ``optimize`` takes them."""
    return [*DESIGN_VARIABLES, *CODESIGN_LEVERS, *GROUP_SPRING_LEVERS]


def _valid_keys() -> list[str]:
    keys = [f"{t}.{k}" for t in _TABLES for k in sorted(SCHEMA_KEYS[t]) if k != "gas"]
    keys += [f"hardware.gas.{k}" for k in sorted(SCHEMA_KEYS["hardware.gas"])]
    keys += [f"variables.{v}.{f}" for v in _variables() for f in ("start", "lower", "upper",
                                                                  "fixed")]
    keys += [f"variables.isolator_positions_m.{f}" for f in POSITION_KEYS]
    return ["name", *keys]


#: The free positions' keys whose value is a list of [x, y] pairs (docs/table.md, section
#: 15): a points file gives them, ``--vary``'s values (one number or word each) cannot.
POSITION_LIST_KEYS = ("variables.isolator_positions_m.start",
                      "variables.isolator_positions_m.polygon_m")


def check_key(key: str, option: str = "--vary") -> str:
    """A study key by its dotted path, or InputError naming it and what is valid there.

    Parameters
    ----------
    key : str
        E.g. ``payload.mass_kg``.
    option : str
        The option or file, for messages.

    Returns
    -------
    str
        ``key``, stripped.
    """
    k = key.strip()
    if k in _valid_keys():
        return k
    parts = k.split(".")
    head = parts[0]
    if head in SCHEMA_KEYS[""] and head not in (*_TABLES, "variables", "name", "description") \
            and len(parts) >= 2 and all(parts):
        return k  # a table with its own schema ([table], [scenarios]): checked by the study
    if head in _TABLES and len(parts) == 3 and all(parts) and parts[1] in SCHEMA_KEYS[head]:
        return k  # a sub-table ([floor.x], [floor.y]): checked by the study
    head = parts[0]
    if head in _TABLES and len(parts) >= 2:
        table = ".".join(parts[:2]) if parts[:2] == ["hardware", "gas"] else head
        valid = sorted(SCHEMA_KEYS[table] - {"gas"})
        where = f"[{table}]"
    elif head == "variables":
        base, sep, _ = parts[1].rpartition("_group") if len(parts) > 1 else ("", "", "")
        if len(parts) == 3 and sep and base in DESIGN_VARIABLES:
            return k  # a group number out of 1..3: the study names the valid groups
        valid = [f"variables.{v}.{{start,lower,upper,fixed}}"
                 for v in (*DESIGN_VARIABLES, *CODESIGN_LEVERS)]
        valid.append("variables.<variable>_group<1..3>.{start,lower,upper,fixed}")
        valid.append("variables.isolator_positions_m.{fixed,start,polygon_m}")
        where = "[variables]"
    else:
        others = sorted(set(SCHEMA_KEYS[""]) - {*_TABLES, "variables", "name", "description"})
        valid = ["name", *(f"{t}.KEY" for t in (*_TABLES, *others)), "variables.NAME.FIELD"]
        where = "a study"
    raise InputError(f"{option}: unknown key {k!r}; valid in {where}: {', '.join(valid)}")


def _scalar(text: str):
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    try:
        return int(t) if t.lstrip("+-").isdigit() and len(t) <= 18 else float(t)
    except ValueError:
        return t


def _round(v: float) -> float:
    return float(f"{v:.12g}")


def parse_vary(text: str, option: str = "--vary") -> tuple[str, list]:
    """``KEY=VALUES`` -> (key, values).

    Parameters
    ----------
    text : str
        ``payload.mass_kg=300:1500:13`` (linear range, both ends included),
        ``floor.criterion=VC-A,VC-B`` (a list).
    option : str
        For messages.

    Returns
    -------
    (str, list)
        The key and its values (numbers as int or float, ``true``/``false`` as bool,
        other words as str).

    Raises
    ------
    InputError
        No ``=``, an unknown key, no values, an empty range (count 0, or start = stop with
        more than one value), a non-numeric range, more than :data:`MAX_VALUES` values.
    """
    if "=" not in text:
        raise InputError(f"{option}: give KEY=VALUES (e.g. payload.mass_kg=300:1500:13 or "
                         f"floor.criterion=VC-A,VC-B), got {text[:60]!r}")
    key, _, spec = text.partition("=")
    key = check_key(key, option)
    if key in POSITION_LIST_KEYS:
        raise InputError(f"{option} {key}: takes a list of [x, y] pairs, m, which --vary's "
                         "values (one number or word each) cannot give; give it per point in "
                         "--points-file ([[point]] tables of a TOML file)")
    spec = spec.strip()
    name = f"{option} {key}"
    if not spec:
        raise InputError(f"{name}: no values; give a list a,b,c or a range start:stop:count")
    if spec.count(":") == 2 and "," not in spec:
        a, b, c = (x.strip() for x in spec.split(":"))
        try:
            start, stop = float(a), float(b)
        except ValueError:
            raise InputError(f"{name}: a range start:stop:count needs numbers, got "
                             f"{spec!r}") from None
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise InputError(f"{name}: range ends must be finite, got {spec!r}")
        if not (c.isascii() and c.isdigit()) or len(c) > 9:
            raise InputError(f"{name}: the count of start:stop:count must be an integer in "
                             f"[1, {MAX_VALUES}], got {c!r}")
        count = int(c)
        if count == 0:
            raise InputError(f"{name}: empty range {spec!r} (count 0); the count must be in "
                             f"[1, {MAX_VALUES}]")
        if count > MAX_VALUES:
            raise InputError(f"{name}: {count} values; the count must be in [1, {MAX_VALUES}]")
        if count > 1 and start == stop:
            raise InputError(f"{name}: empty range {spec!r}: start equals stop; give "
                             "different ends or a count of 1")
        if count == 1:
            return key, [_round(start)]
        step = (stop - start) / (count - 1)
        vals = [_round(start + i * step) for i in range(count)]
        vals[-1] = _round(stop)
        integral = a.lstrip("+-").isdigit() and b.lstrip("+-").isdigit() and \
            all(v == int(v) for v in vals)
        return key, [int(v) for v in vals] if integral else vals
    items = spec.split(",")
    if any(not it.strip() for it in items):
        raise InputError(f"{name}: empty item in {spec[:60]!r}")
    if len(items) > MAX_VALUES:
        raise InputError(f"{name}: {len(items)} values; at most {MAX_VALUES}")
    return key, [_scalar(it) for it in items]


def combine(varies: list[tuple[str, list]], mode: str = "product") -> list[dict]:
    """The points' change tables (dotted key -> value) of several varied keys.

    Parameters
    ----------
    varies : list of (str, list)
        From :func:`parse_vary`, in the order given.
    mode : {'product', 'zip'}
        Cartesian product (the first key varies slowest) or zip (same lengths).

    Returns
    -------
    list of dict
    """
    if mode not in ("product", "zip"):
        raise InputError(f"--combine: {mode!r}; valid: product, zip")
    keys = [k for k, _ in varies]
    dup = {k for k in keys if keys.count(k) > 1}
    if dup:
        raise InputError(f"--vary: key {sorted(dup)[0]!r} given more than once")
    if not varies:
        return [{}]
    if mode == "zip":
        lens = {k: len(v) for k, v in varies}
        if len(set(lens.values())) != 1:
            shown = ", ".join(f"{k}: {n}" for k, n in lens.items())
            raise InputError(f"--combine zip: every --vary needs the same number of values "
                             f"({shown})")
        rows = zip(*(v for _, v in varies), strict=True)
    else:
        n = math.prod(len(v) for _, v in varies)
        if n > MAX_POINTS:
            raise InputError(f"--vary: {n} points; a sweep may have at most {MAX_POINTS}")
        rows = itertools.product(*(v for _, v in varies))
    return [dict(zip(keys, r, strict=True)) for r in rows]


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def read_points(path) -> list[dict]:
    """Study-change tables from a file: TOML ``[[point]]`` tables, or a CSV of dotted keys.

    Parameters
    ----------
    path : str or Path
        A TOML file with one ``[[point]]`` table per point (``payload.mass_kg = 300``,
        ``floor.criterion = "VC-B"``: dotted keys or sub-tables), or a CSV file whose
        header names the keys and whose rows are the points.

    Returns
    -------
    list of dict
        One change table (dotted key -> value) per point, in file order.
    """
    p = Path(path)
    option = f"--points-file {p}"
    if not p.is_file():
        raise InputError(f"{option}: no such file")
    if p.suffix.lower() == ".csv":
        import csv

        try:
            with open(p, newline="", encoding="utf-8-sig") as fh:  # a spreadsheet's BOM
                rows = list(csv.reader(row for row in fh if not row.lstrip().startswith("#")))
        except UnicodeDecodeError as exc:
            raise InputError(f"--points-file {path}: not a UTF-8 text file (undecodable byte "
                             f"at offset {exc.start}); a CSV or TOML points file is "
                             "expected") from None
        except (OSError, csv.Error) as exc:
            raise InputError(f"--points-file {path}: cannot read ({exc})") from None
        if not rows:
            raise InputError(f"{option}: empty file")
        if len(rows[0]) == 1 and ";" in rows[0][0]:
            raise InputError(f"{option}: the header {rows[0][0]!r:.60} is one cell; the cells "
                             "of a points CSV are separated by commas, not semicolons")
        header = [check_key(h, option) for h in rows[0]]
        twice = sorted({h for h in header if header.count(h) > 1})
        if twice:  # one value per key and point: which would the point take?
            raise InputError(f"{option}: the header names {twice[0]} twice")
        pts = []
        for i, r in enumerate(rows[1:], 2):
            if not any(c.strip() for c in r):
                continue
            if len(r) != len(header):
                raise InputError(f"{option}: row {i} has {len(r)} cells, the header "
                                 f"{len(header)}")
            pts.append({k: _scalar(c) for k, c in zip(header, r, strict=True)})
    else:
        from isodesign.io.files import read_toml

        doc = read_toml(p, what="sweep points")
        tables = doc.get("point")
        if set(doc) - {"point"} or not isinstance(tables, list):
            raise InputError(f"{option}: expected [[point]] tables only (each a set of study "
                             "changes such as payload.mass_kg = 300)")
        pts = []
        for t in tables:
            flat = _flatten(t)
            for k in flat:
                check_key(k, option)
            pts.append(flat)
    if not pts:
        raise InputError(f"{option}: no points in the file")
    if len(pts) > MAX_POINTS:
        raise InputError(f"{option}: {len(pts)} points; at most {MAX_POINTS}")
    return pts


def nest(changes: dict) -> dict:
    """Dotted keys -> nested tables (``{"payload.mass_kg": 300}`` -> ``{"payload": {...}}``).

    Parameters
    ----------
    changes : dict
    """
    out: dict = {}
    for key, v in changes.items():
        cur = out
        parts = key.split(".")
        for p in parts[:-1]:
            cur = cur.setdefault(p, {})
        cur[parts[-1]] = v
    return out


def study_hash(study: Study) -> str:
    """SHA-256 of the resolved study (canonical JSON, integers as floats): a point's identity.

    The study's ``name`` and ``description`` are labels, not part of it: they are left out
    (:meth:`~isodesign.optimization.study.Study.with_changes` renames a changed study).

    Parameters
    ----------
    study : Study

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    def canon(v):  # 300 and 300.0 are the same study
        if isinstance(v, dict):
            return {k: canon(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [canon(x) for x in v]
        if isinstance(v, int) and not isinstance(v, bool):
            return float(v)
        return v

    raw = {k: v for k, v in resolved_study_dict(study).items()
           if k not in ("name", "description")}  # labels, not the study
    text = json.dumps(canon(raw), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass(frozen=True, eq=False)
class SweepPoint:
    """One point of a sweep: its changes, its study and the study's hash.

    Attributes
    ----------
    changes : dict
        Dotted key -> value, as given.
    study : Study
        The base study with the changes applied (``solver.workers = 1``).
    study_hash : str
        :func:`study_hash` of ``study``.
    """

    changes: dict
    study: Study
    study_hash: str

    @property
    def key(self) -> str:
        """The point's name: the first 16 hexadecimal digits of its study hash."""
        return self.study_hash[:16]


def _label(changes: dict) -> str:
    return ", ".join(f"{k}={v}" for k, v in changes.items()) or "(the base study)"


def build_points(base: Study, tables: list[dict], option: str = "--vary"
                 ) -> tuple[list[SweepPoint], int]:
    """Each change table's study (validated) and hash; duplicates (same hash) dropped.

    Parameters
    ----------
    base : Study
        The base study.
    tables : list of dict
        Change tables (dotted key -> value).
    option : str
        For messages.

    Returns
    -------
    (list of SweepPoint, int)
        The points in order, and the number of duplicates dropped.

    Raises
    ------
    InputError
        A point whose study is invalid: the message names the point's changes and the key.
    """
    points: list[SweepPoint] = []
    seen: set[str] = set()
    dropped = 0
    _check_values_first(base, tables, option)
    for t in tables:
        st = _point_study(base, t, option)
        h = study_hash(st)
        if h in seen:
            dropped += 1
            continue
        seen.add(h)
        points.append(SweepPoint(dict(t), st, h))
    return points, dropped


def point_tree(base: Study, t: dict) -> dict:
    """The nested changes of a point, a table study's CG height carried into its table.

    A table study's model takes the CG from ``table.cg_m`` (``payload.cg_height_m`` must
    agree with its height). A point that changes ``payload.cg_height_m`` alone moves the
    table's CG to that height, over the same ``x, y`` (the instrument points stay where
    they are): ``--vary payload.cg_height_m=0.2:0.6:5`` sweeps the table's CG height. A
    point that also gives ``table.cg_m`` keeps it (the study checks that both agree).

    Parameters
    ----------
    base : Study
        The base study.
    t : dict
        The point's changes (dotted key -> value).

    Returns
    -------
    dict
        Nested changes for :meth:`~isodesign.optimization.study.Study.with_changes`.
    """
    tree = nest(t)
    h = tree.get("payload", {}).get("cg_height_m") if isinstance(tree.get("payload"),
                                                                 dict) else None
    table = (base.raw or {}).get("table")
    if (h is not None and isinstance(table, dict) and table.get("cg_m") is not None
            and not (isinstance(tree.get("table"), dict) and "cg_m" in tree["table"])):
        cg = list(table["cg_m"])
        if len(cg) == 3 and isinstance(h, int | float) and not isinstance(h, bool):
            tree.setdefault("table", {})["cg_m"] = [cg[0], cg[1], h]
    return tree


def _point_study(base: Study, t: dict, option: str) -> Study:
    """The base study with the change table ``t`` (InputError naming the point's changes)."""
    import warnings

    tree = point_tree(base, t)
    tree.setdefault("solver", {})["workers"] = 1  # starts run serially inside a task
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            st = base.with_changes(**tree)
        except InputError as exc:
            msg = str(exc)
            if base.source and msg.startswith(base.source + ": "):
                msg = msg[len(base.source) + 2:]
            raise InputError(f"{option} {_label(t)}: {msg}") from None
    for w in caught:  # a unit slip of the point's own value: named as the point, not the file
        msg = str(w.message)
        if base.source and msg.startswith(base.source + ": ") and any(
                str(k) in msg for k in t):
            msg = f"{option} {_label(t)}: {msg[len(base.source) + 2:]}"
        warnings.warn(msg, w.category, stacklevel=2)
    return st


def _check_values_first(base: Study, tables: list[dict], option: str) -> None:
    """Each varied key's distinct values checked once, before the points one by one.

    A sweep of 30,000 points validates 30,000 studies (milliseconds each); a value that no
    study accepts (``payload.mass_kg = 0``) is found here in a few checks, not after
    minutes. Each distinct ``(key, value)`` is applied alone to the base study; when that
    fails, the first point holding it is validated whole (keys varied together, e.g. a
    variable's ``lower`` and ``upper``, may be valid only together), and its error, naming
    the point's changes, is raised.
    """
    if len(tables) < 2:
        return
    first: dict = {}
    for i, t in enumerate(tables):
        for k, v in t.items():
            try:
                first.setdefault((k, json.dumps(v, sort_keys=True, default=str)), i)
            except (TypeError, ValueError):
                continue
            if len(first) > max(64, len(tables) // 4):
                return  # as many values as points: the points' own checks are as quick
    import warnings

    for (k, _), i in first.items():
        try:
            with warnings.catch_warnings():  # the points' own checks warn, once
                warnings.simplefilter("ignore")
                base.with_changes(**point_tree(base, {k: tables[i][k]}))
        except InputError:
            _point_study(base, tables[i], option)  # raises, naming the point, if it fails
