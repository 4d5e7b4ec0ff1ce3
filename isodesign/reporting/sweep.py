"""The HTML report of a sweep directory: design charts and the table of points.

``isodesign report SWEEP_DIR -o report.html`` (:func:`isodesign.reporting.render.report`
with one sweep directory) renders ``templates/sweep.html.j2``: what was swept and how it
ran, one design chart per objective (:func:`isodesign.plotting.sweep.design_chart`, inline
SVG), the binding map of a sweep over two or more keys (the binding set per point over two
swept keys, faceted by the others: :func:`isodesign.plotting.sweep.binding_map`), the table
of every point (swept keys, status, objective, the optimum's variables,
worst-band margin, binding constraints, time, worker), the failed points with their
errors, and the provenance. Self-contained like every report: no script, no external
resource.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from pathlib import Path

from isodesign import __version__
from isodesign.errors import InputError

__all__ = ["is_sweep_dir", "sweep_context"]


def is_sweep_dir(path) -> bool:
    """Whether ``path`` is a sweep directory (``record.json`` of kind ``isodesign sweep``).

    Parameters
    ----------
    path : str or Path
    """
    p = Path(path) / "record.json"
    if not p.is_file():
        return False
    try:
        return json.loads(p.read_text(encoding="utf-8")).get("kind") == "isodesign sweep"
    except (OSError, ValueError, AttributeError):
        return False


def _fmt(v, fmt=".4g", scale=1.0) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int | float):
        return f"{v * scale:{fmt}}"
    return str(v)


_COLUMNS = (("status", "status", None, 1.0), ("objective_value", "objective", ".5g", 1.0),
            ("volume_ratio", "N", ".4g", 1.0), ("top_volume_m3", "V_t0 (L)", ".4g", 1e3),
            ("capillary_length_m", "L_c (mm)", ".4g", 1e3),
            ("capillary_diameter_m", "D_c (mm)", ".4g", 1e3),
            ("worst_band_margin_db", "worst-band margin (dB)", "+.2f", 1.0),
            ("natural_frequency_hz", "f_n (Hz)", ".3g", 1.0),
            ("binding", "binding constraints, variables at a bound", None, 1.0),
            ("wall_s", "time (s)", ".1f", 1.0), ("worker", "worker", None, 1.0))


def sweep_context(directory, *, command=None, title=None) -> dict:
    """The template context of a sweep directory's report.

    Parameters
    ----------
    directory : str or Path
    command : sequence of str, optional
        The command line recorded in the provenance.
    title : str, optional

    Returns
    -------
    dict
    """
    from isodesign.io.record import environment
    from isodesign.plotting.style import figure_svg
    from isodesign.plotting.sweep import chart_objectives, design_chart
    from isodesign.sweeps.table import TABLE_NAME, read_table

    d = Path(directory)
    rec = json.loads((d / "record.json").read_text(encoding="utf-8"))
    if not (d / TABLE_NAME).is_file():
        raise InputError(f"{d}: the sweep has no table yet ({TABLE_NAME})")
    df = read_table(d)
    sw = rec.get("sweep") or {}
    keys = [k for k in sw.get("keys") or [] if k in df]
    charts = []
    for obj in chart_objectives(df):
        n = int((df["objective"] == obj).sum())
        charts.append({"objective": obj, "points": n,
                       "svg": figure_svg(design_chart(df, keys, objective=obj))})
    binding = None
    from isodesign.plotting.sweep import has_binding_map

    if has_binding_map(df, keys):
        from isodesign.plotting.sweep import binding_map, binding_map_data, map_axes

        x, y, facets = map_axes(df, keys)
        data = binding_map_data(df, keys)
        order = sw.get("values")
        binding = {"svg": figure_svg(binding_map(df, keys, order=order)), "x": x, "y": y,
                   "facets": ", ".join(facets), "points": len(data),
                   "sets": int(data["category"].nunique()),
                   "changed": int(data["branch_changed"].sum())}
    head = [*keys, *(h for _, h, _, _ in _COLUMNS)]
    rows, failed = [], []
    for _, r in df.iterrows():
        cells = [{"t": _fmt(r.get(k)), "l": isinstance(r.get(k), str)} for k in keys]
        r = r.copy()
        r["binding"] = "; ".join(str(r.get("binding") or "").split(";"))
        for col, _, fmt, scale in _COLUMNS:
            v = r.get(col)
            cells.append({"t": _fmt(v, fmt, scale) if fmt else _fmt(v), "l": fmt is None})
        rows.append({"cells": cells, "status": str(r.get("status")),
                     "run_dir": str(r.get("run_dir") or "")})
        if r.get("status") == "failed":
            failed.append({"changes": r.get("changes"), "error": r.get("error"),
                           "run_dir": r.get("run_dir")})
    counts = df["status"].value_counts().to_dict() if len(df) else {}
    env = environment()
    walls = [float(w) for w in df["wall_s"] if w is not None and w == w] if "wall_s" in df \
        else []
    base_name = (sw.get("base_study") or {}).get("name", "study")
    summary = [
        ("sweep directory", str(d)),
        ("task", str(sw.get("task"))),
        ("base study", f"{base_name!r} ({sw.get('base_study_source')})"),
        ("swept keys", ", ".join(sw.get("keys") or []) or "a points file"),
        ("combination", str(sw.get("combine"))),
        ("points", f"{len(df)} in the table: "
                   + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))),
        ("run status", f"{rec.get('run_status')} (started {rec.get('started_utc')}, finished "
                       f"{rec.get('finished_utc')})"),
        ("where it ran", str(rec.get("where", ""))),
        ("time per point", f"median {sorted(walls)[len(walls) // 2]:.2f} s over {len(walls)} "
                           "points" if walls else "n/a"),
    ]
    if rec.get("error"):
        summary.append(("note", str(rec["error"])))
    return {
        "title": title or f"Sweep report: {sw.get('task')} of {base_name!r} over "
                          f"{', '.join(sw.get('keys') or []) or 'a points file'}",
        "summary": summary, "charts": charts, "binding": binding, "head": head,
        "rows": rows, "failed": failed,
        "provenance": {
            "version": __version__, "python": env["python"], "platform": env["platform"],
            "packages": [(k, v or "not installed") for k, v in env["packages"].items()],
            "date": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
            "command": " ".join(command) if command else "",
            "sweep_command": " ".join(rec.get("argv") or []),
            "base_study_toml": (d / "study_base.toml").read_text(encoding="utf-8")
            if (d / "study_base.toml").is_file() else "",
        },
    }
