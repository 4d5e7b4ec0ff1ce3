"""Parts of the study schema's validation, one table or rule a function: the floor (``[floor]``,
``[floor.x]``, ``[floor.y]``), the acoustic model in force, dotted changes.

Used by :mod:`isodesign.optimization.study` (which holds the schema and the defaults).
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np

from isodesign.errors import InputError, check_choice, check_range
from isodesign.floor import FloorSpectrum
from isodesign.floor.survey import SURVEY_STATISTICS, floor_from_record

__all__ = ["FLOOR_KEYS"]

#: Keys of ``[floor]``.
FLOOR_KEYS = {"criterion", "csv", "quantity", "kind", "unit", "record", "statistic",
              "percentile", "axis", "sample_rate_hz", "x", "y"}


def _undot(changes, tables: dict) -> dict:
    """``changes`` and ``tables`` merged, dotted keys nested (``"payload.mass_kg"``)."""
    if changes is not None and not isinstance(changes, dict):
        raise InputError(f"with_changes: changes must be a dict of dotted keys or tables "
                         f"({{'payload.mass_kg': 800}}), got {type(changes).__name__} "
                         f"{changes!r:.40}")
    out: dict = {}
    for src in (changes or {}, tables):
        for key, v in src.items():
            if not isinstance(key, str):
                raise InputError(f"with_changes: keys must be strings (dotted, e.g. "
                                 f"'payload.mass_kg'), got {key!r:.40}")
            parts = key.split(".")
            if not all(p.strip() for p in parts):
                raise InputError(f"with_changes: {key!r} is not a study key (dotted, e.g. "
                                 "'payload.mass_kg')")
            tree = v if not isinstance(v, dict) else copy.deepcopy(v)
            for p in reversed(parts[1:]):
                tree = {p: tree}
            out = _merge(out, {parts[0]: tree})
    return out


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _num(where, key, value, lo=None, hi=None, lo_open=False, unit=""):
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}: {key} must be a number, got {value!r}")
    return check_range(f"{where}: {key}", value, lo, hi, lo_open=lo_open, unit=unit)


_RECORD_KEYS = {"record", "statistic", "percentile", "axis", "unit", "sample_rate_hz"}


def _floor_axes(fl: dict, where: str, source: str, table):
    """``[floor]`` and, with a table, its per-axis floors (a TableFloor)."""
    if table is None:
        for k in ("x", "y"):
            if k in fl:
                raise InputError(f"{where}: floor.{k} applies only to a study with a [table]")
        return _floor(fl, where, source), None
    from isodesign.table.floor import table_floor

    base = {k: v for k, v in fl.items() if k not in ("x", "y")}
    z = _floor(base, where, source)
    axes = {}
    for k in ("x", "y"):
        v = fl.get(k)
        if v is False:
            axes[k] = False
        elif isinstance(v, dict):
            axes[k] = _axis_floor(v, k, z, where, source)
        elif v is not None:
            raise InputError(f"{where}: floor.{k} must be a table or false")
        elif "record" in base and "axis" not in base:
            try:  # the survey's own horizontal axis, when the record has it
                axes[k] = _floor({**base, "axis": k}, where, source)
            except InputError:
                pass
    return z, table_floor(z, **axes)


#: Keys of ``[floor.x]`` / ``[floor.y]``: those of ``[floor]`` and ``scale``.
_AXIS_FLOOR_KEYS = (FLOOR_KEYS - {"x", "y"}) | {"scale"}


def _axis_floor(v: dict, axis: str, z: FloorSpectrum, where: str, source: str) -> FloorSpectrum:
    """``[floor.x]``/``[floor.y]``: a floor of its own (the keys of ``[floor]``), optionally
    ``scale``d: ``scale = 0.3`` alone is 30 % of the vertical floor's velocity; with a
    criterion, CSV or record, 30 % of that floor's (the PSD times ``scale^2``)."""
    for key in v:
        if key not in _AXIS_FLOOR_KEYS:
            raise InputError(f"{where}: unknown key {key!r} in [floor.{axis}]; valid: "
                             f"{', '.join(sorted(_AXIS_FLOOR_KEYS))}")
    if "scale" not in v:
        return _floor(v, where, source, f"floor.{axis}")
    sc = _num(where, f"floor.{axis}.scale", v["scale"], 0.0, 10.0, True)
    rest = {k: x for k, x in v.items() if k != "scale"}
    base = _floor(rest, where, source, f"floor.{axis}") if rest else z
    name = f"{sc:g} x {base.name or 'floor'}"
    return dataclasses.replace(base, psd_velocity_m2_s2_per_hz=np.asarray(
        base.psd_velocity_m2_s2_per_hz) * sc * sc, name=name,
        source=f"floor.{axis}.scale = {sc:g} of {base.name or 'the vertical floor'}")


def _floor(fl: dict, where: str, source: str, key_: str = "floor") -> FloorSpectrum:
    """``[floor]``: a criterion, a CSV spectrum or a survey record (paths relative to the study
    file). ``key_`` is the table as the user typed it (``floor``, ``floor.x``): errors name
    its keys (``floor.x.csv``)."""
    if sum(k in fl for k in ("criterion", "csv", "record")) != 1:
        raise InputError(f"{where}: [{key_}] needs exactly one of criterion = \"VC-A\", "
                         "csv = \"file.csv\" or record = \"survey.csv\"")
    for key in ("csv", "record"):
        if key in fl and (not isinstance(fl[key], str) or not fl[key].strip()):
            raise InputError(f"{where}: {key_}.{key} must be a file name (a string), got "
                             f"{fl[key]!r:.40}")
    if "record" in fl:
        extra = set(fl) - _RECORD_KEYS
        if extra:
            raise InputError(f"{where}: [{key_}] keys {', '.join(sorted(extra))} do not apply to "
                             f"a record; valid: {', '.join(sorted(_RECORD_KEYS))}")
        stat = fl.get("statistic", "mean")
        check_choice(f"{where}: {key_}.statistic", stat, SURVEY_STATISTICS)
        kw = {}
        if "percentile" in fl:
            kw["percentile"] = _num(where, f"{key_}.percentile", fl["percentile"], 0, 100)
        if "sample_rate_hz" in fl:
            kw["sample_rate_hz"] = _num(where, f"{key_}.sample_rate_hz", fl["sample_rate_hz"], 0,
                                        None, True, "Hz")
        for key in ("axis", "unit"):
            if key in fl and not isinstance(fl[key], str):
                raise InputError(f"{where}: {key_}.{key} must be a string")
        if "unit" in fl:
            kw["unit"] = fl["unit"]
        path = Path(fl["record"])
        if not path.is_absolute() and source not in ("<dict>", "<default>"):
            path = Path(source).parent / path
        try:
            return floor_from_record(path, statistic=stat, axis=fl.get("axis"), **kw)
        except InputError as exc:
            raise InputError(f"{where}: {key_}.{exc}") from None
    if "criterion" in fl:
        extra = set(fl) - {"criterion"}
        if extra:
            raise InputError(f"{where}: [{key_}] keys {', '.join(sorted(extra))} only apply to csv "
                             "or record")
        try:
            return FloorSpectrum.from_criterion(fl["criterion"])
        except InputError as exc:
            raise InputError(f"{where}: {key_}.{exc}") from None
    path = Path(fl["csv"])
    if not path.is_absolute() and source not in ("<dict>", "<default>"):
        path = Path(source).parent / path
    try:
        return FloorSpectrum.from_csv(path, quantity=fl.get("quantity"), kind=fl.get("kind"),
                                      unit=fl.get("unit"))
    except InputError as exc:
        msg = str(exc)
        msg = msg.removeprefix("path: ")
        raise InputError(msg if msg.startswith(where) else f"{where}: {key_}.csv: {msg}") from None


def _check_acoustics(raw: dict, models: dict, hw: dict, given: dict, where: str) -> None:
    """The acoustic model in force is the one computed, and it computes what the study asks.

    ``models.acoustics = "lumped"`` drops ``hardware.chamber_heat_exchange`` (the wall heat
    exchange lives in the distributed chambers): refused, naming both. A paper's flow model
    (``poiseuille``) is lumped by definition: ``acoustics = "distributed"`` written with it is
    refused; left to the default it is recorded truthfully as ``"lumped"``.
    """
    from isodesign.spring.flow_models import flow_model

    if models["acoustics"] == "lumped" and hw.get("chamber_heat_exchange"):
        raise InputError(f"{where}: models.acoustics = \"lumped\" with "
                         "hardware.chamber_heat_exchange = true: the lumped chambers have no "
                         "wall heat exchange (it is part of the distributed model); use "
                         "acoustics = \"distributed\" or chamber_heat_exchange = false")
    if models["acoustics"] != "lumped" and not flow_model(models["flow"]).distributed:
        written = isinstance(given.get("models"), dict) and "acoustics" in given["models"]
        if written:
            raise InputError(f"{where}: models.acoustics = {models['acoustics']!r} with "
                             f"models.flow = {models['flow']!r}: the paper's flow model is lumped "
                             "by definition and would be computed lumped; use acoustics = "
                             "\"lumped\", or flow = \"womersley\" or \"quasi_steady\"")
        if hw.get("chamber_heat_exchange"):
            raise InputError(f"{where}: models.flow = {models['flow']!r} is computed with lumped "
                             "acoustics, which drop hardware.chamber_heat_exchange = true; use "
                             "flow = \"womersley\" or \"quasi_steady\", or chamber_heat_exchange "
                             "= false")
        models["acoustics"] = "lumped"  # what is computed, recorded
        raw["models"]["acoustics"] = "lumped"
