"""Run records: every optimizer run written down so that a study can be replayed.

In the spirit of OpenMDAO's case recorders (without its framework): the
output directory of a run holds the resolved study (``study_resolved.toml``,
loadable with ``isodesign optimize``), the solver settings, the package
versions, every start with its status, iterations and time, and the final
design (``record.json``, ``starts.csv``, ``design.json``).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import platform
import sys
from pathlib import Path
from typing import Any

__all__ = ["dumps_toml", "environment", "write_json"]


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def dumps_toml(d: dict, _prefix: str = "") -> str:
    """Serialize nested dicts of scalars and lists as TOML (tables after keys)."""
    lines = []
    tables = []
    for k, v in d.items():
        if v is None:
            continue
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    out = "\n".join(lines)
    for k, v in tables:
        name = f"{_prefix}{k}"
        body = dumps_toml(v, f"{name}.")
        has_scalars = any(not isinstance(x, dict) and x is not None for x in v.values())
        block = (f"[{name}]\n" if has_scalars else "") + body
        out = f"{out}\n\n{block}" if out else block
    return out.strip() + "\n"


def environment() -> dict:
    """Versions of Python, the platform and the numerical packages."""
    from importlib import metadata

    pkgs = {}
    for name in ("isodesign", "numpy", "scipy", "casadi", "pandas", "control", "cvxpy",
                 "matplotlib"):
        try:
            pkgs[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pkgs[name] = None
    return {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "machine": platform.machine(),
        "packages": pkgs,
        "date_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def _jsonable(v):
    import numpy as np

    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.ndarray):
        return _jsonable(v.tolist())
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_json(path, data: dict) -> Path:
    """Write JSON (NumPy values converted, non-finite floats as null)."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(_jsonable(data), indent=2) + "\n", encoding="utf-8")
    return p
