"""Design charts of a sweep: optimum variables, margin and binding constraint vs the swept keys.

One figure per objective (:func:`design_chart`). The x axis is the first swept key with
numeric values; every combination of the other swept keys is one series (the candidate
colours of :mod:`isodesign.plotting.style`). Panels: the objective, the worst-band margin
(or, when the objective is that margin, the natural frequency), N, V_t0, L_c, D_c, and a
strip naming the binding constraints (and the variables at a bound) of each point.

A series' line is broken where the binding set changes or the optimum jumps to another
volume-ratio branch (N changes by more than :data:`BRANCH_JUMP` relative between
neighbours): no design between two such points is implied. Points without a feasible
design are red crosses (their best point), failed points are marked on the strip.

The binding map (:func:`binding_map`, its data :func:`binding_map_data`): each point's
binding set (its binding constraints and variables at a bound, the table's ``binding``
column) as a category, coloured cells over two swept keys, one panel per value of the
others; the boundaries between cells of different sets are drawn, and the points whose
continuation changed branch are marked.
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.plotting.style import candidate_style, new_figure, with_breaks

__all__ = ["BRANCH_JUMP", "binding_map", "binding_map_data", "chart_breaks", "chart_objectives",
           "design_chart", "has_binding_map", "map_axes"]

#: Relative change of the optimal N between neighbours taken as a branch change.
BRANCH_JUMP = 0.3

_PANELS = (("volume_ratio", "volume ratio N (-)", 1.0),
           ("top_volume_m3", "top chamber V_t0 (L)", 1e3),
           ("capillary_length_m", "capillary length L_c (mm)", 1e3),
           ("capillary_diameter_m", "capillary diameter D_c (mm)", 1e3))


def chart_objectives(df) -> list[str]:
    """The objectives of a sweep table, in order of appearance (one chart each).

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table.

    Returns
    -------
    list of str
    """
    if "objective" not in df or df.empty:
        return []
    return [str(o) for o in dict.fromkeys(df["objective"].dropna())]


def _numeric(s) -> bool:
    try:
        v = np.asarray(s, dtype=float)
    except (TypeError, ValueError):
        return False
    return bool(np.isfinite(v).all())


def _x_key(df, keys) -> str | None:
    for k in keys:
        if k in df and _numeric(df[k]) and df[k].nunique() > 1:
            return k
    return None


def chart_breaks(binding, n_values) -> np.ndarray:
    """True where a series' line must break before a point: binding set or branch changed.

    Parameters
    ----------
    binding : sequence of str
        Each point's binding set (``;``-joined names).
    n_values : array_like
        Each point's optimal N (NaN where none).

    Returns
    -------
    ndarray of bool
    """
    n = np.asarray(n_values, dtype=float)
    b = list(binding)
    out = np.zeros(len(b), dtype=bool)
    for i in range(1, len(b)):
        jump = False
        if np.isfinite(n[i]) and np.isfinite(n[i - 1]) and n[i - 1] > 0:
            jump = abs(math.log(n[i] / n[i - 1])) > math.log1p(BRANCH_JUMP)
        out[i] = b[i] != b[i - 1] or jump
    return out


def _short(binding: str) -> str:
    if not binding:
        return "none"
    parts = [p.replace("_m3", "").replace("_hz", "").replace("_db", "") for p in
             binding.split(";")]
    return ", ".join(parts)


def design_chart(df, keys, *, objective: str | None = None, title: str | None = None):
    """The design chart of one objective of a sweep table.

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table (:mod:`isodesign.sweeps.table`).
    keys : sequence of str
        The swept keys (the first numeric one is the x axis).
    objective : str, optional
        Which objective's points (default: the first in the table).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from isodesign.optimization.objectives import OBJECTIVES

    objs = chart_objectives(df)
    objective = objective or (objs[0] if objs else None)
    d = df if objective is None else df[(df["objective"] == objective) | df["objective"].isna()]
    keys = [k for k in keys if k in d]
    xk = _x_key(d, keys)
    others = [k for k in keys if k != xk and d[k].nunique() > 1]
    fig = new_figure(10.0, 10.5)
    top, bottom = fig.subfigures(2, 1, height_ratios=[3.2, 1.0])  # independent layouts
    axes = list(top.subplots(3, 2, sharex=True).ravel())
    strip = bottom.subplots(1, 1)
    if xk is None:
        xs_all = np.arange(len(d), dtype=float)
        xlabel = "point"
    else:
        xs_all = d[xk].to_numpy(float)
        xlabel = xk
    margin_col = "worst_band_margin_db"
    second = ("natural_frequency_hz", "natural frequency (Hz)", 1.0) \
        if objective == "worst_band_margin" else (margin_col, "worst-band margin (dB)", 1.0)
    obj = OBJECTIVES.get(objective)
    first = ("objective_value",
             f"{objective} ({obj.display_unit})" if obj is not None else str(objective),
             obj.display_scale if obj is not None else 1.0)
    panels = (first, second, *_PANELS)
    labels_all = [_short(b) if isinstance(b, str) else "none" for b in d["binding"]]
    status = d["status"].astype(str).to_numpy()
    feas = d["feasible"].fillna(False).to_numpy(bool) & (status != "failed")
    cats = list(dict.fromkeys(lb for lb, ok in zip(labels_all, feas, strict=True) if ok))
    if (~feas & (status != "failed")).any():
        cats.append("no feasible design")
    if (status == "failed").any():
        cats.append("failed")
    groups = [((), np.ones(len(d), dtype=bool))]
    if others:
        combos = list(dict.fromkeys(zip(*(d[k] for k in others), strict=True)))
        groups = [(c, np.all([d[k].to_numpy() == v for k, v in zip(others, c, strict=True)],
                             axis=0)) for c in combos]
    for gi, (combo, mask) in enumerate(groups):
        sty = candidate_style(gi)
        name = ", ".join(f"{k}={v}" for k, v in zip(others, combo, strict=True)) or "optimum"
        idx = np.flatnonzero(mask)
        idx = idx[np.argsort(xs_all[idx], kind="stable")]
        x = xs_all[idx]
        ok = feas[idx]
        nvals = np.where(ok, d["volume_ratio"].to_numpy(float)[idx], np.nan)
        brk = chart_breaks([labels_all[i] for i in idx], nvals)
        for ax, (col, label, scale) in zip(axes, panels, strict=True):
            if col not in d:
                ax.set_visible(False)
                continue
            y = d[col].to_numpy(float)[idx] * scale
            lx, ly = with_breaks(x, np.where(ok, y, np.nan), brk)
            ax.plot(lx, ly, color=sty["color"], ls=sty["ls"], lw=sty["lw"],
                    label=name if ax is axes[0] else None)
            ax.plot(x[ok], y[ok], ls="none", marker=sty["marker"], ms=4, color=sty["color"])
            bad = ~ok & (status[idx] != "failed")
            if bad.any():
                ax.plot(x[bad], y[bad], "x", color="C3", ms=7, mew=1.5,
                        label="no feasible design (best point)"
                        if ax is axes[0] and gi == 0 else None)
            ax.set_ylabel(label)
            ax.grid(True, lw=0.4, alpha=0.6)
            ax.ticklabel_format(axis="y", useOffset=False)
        ys = []
        for i in idx:
            lab = labels_all[i] if feas[i] else ("failed" if status[i] == "failed"
                                                 else "no feasible design")
            ys.append(cats.index(lab))
        off = (gi - (len(groups) - 1) / 2) * 0.12
        strip.plot(x, np.asarray(ys) + off, ls="none", marker=sty["marker"], ms=6,
                   color=sty["color"])
    if objective == "worst_band_margin" or second[0] == margin_col:
        for ax, (col, _, _) in zip(axes[:2], panels[:2], strict=True):
            if (col in ("objective_value", margin_col) and objective in (None,
                                                                        "worst_band_margin")) \
                    or col == margin_col:
                ax.axhline(0.0, color="black", ls=(0, (6, 3)), lw=1.2)
    strip.set_yticks(range(len(cats)))
    strip.set_yticklabels([c if len(c) < 60 else c[:57] + "..." for c in cats], fontsize=8)
    strip.set_ylim(-0.6, max(len(cats) - 0.4, 0.6))
    strip.set_title("binding constraints and variables at a bound (the lines above break "
                    "where this set or the N branch changes)", fontsize=9, loc="right")
    strip.grid(True, axis="x", lw=0.4, alpha=0.6)
    for ax in (*axes[4:], strip):
        ax.set_xlabel(xlabel)
    handles, _labs = axes[0].get_legend_handles_labels()
    if handles:
        axes[0].legend(fontsize=8)
    task = str(d["task"].iloc[0]) if "task" in d and len(d) else "sweep"
    fig.suptitle(title or f"Sweep ({task}, {len(d)} points): {objective} against {xlabel}",
                 fontsize=11)
    return fig


# ---------------------------------------------------------------------------------------
# the binding map: the binding set per point over two swept keys, faceted by the others
# ---------------------------------------------------------------------------------------
#: The categories of points without a binding set of their own.
NO_DESIGN, FAILED, NO_BINDING = "no feasible design", "failed", "none binding"


def _ordered(values) -> list:
    """Distinct values, numbers sorted, else in order of appearance."""
    vals = list(dict.fromkeys(values))
    return sorted(vals) if _numeric(vals) else vals


def has_binding_map(df, keys) -> bool:
    """Whether a sweep table gets a binding map: two swept keys taking more than one value
    each (one key: the design chart's strip shows the sets) and binding sets (the
    ``optimize`` task's rows).

    Parameters
    ----------
    df : pandas.DataFrame
    keys : sequence of str
    """
    if "binding" not in df or "status" not in df or not df["binding"].map(
            lambda b: isinstance(b, str) and bool(b)).any():
        return False
    return sum(1 for k in keys if k in df and df[k].nunique() > 1) >= 2


def map_axes(df, keys, *, x: str | None = None, y: str | None = None) -> tuple:
    """The binding map's x key, y key (None: one row) and facet keys.

    By default x is the swept key with numbers and the most distinct values (the line
    key of the continuation), y the next one with more than one value (numbers first),
    and every other key with more than one value a facet.

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table.
    keys : sequence of str
        The swept keys.
    x, y : str, optional
        Keys chosen by the caller.

    Returns
    -------
    (str, str or None, list of str)

    Raises
    ------
    InputError
        ``x`` or ``y`` is not a swept key of the table, or no key varies.
    """
    from isodesign.errors import InputError

    keys = [k for k in keys if k in df]
    varying = [k for k in keys if df[k].nunique() > 1]
    for name, k in (("x", x), ("y", y)):
        if k is not None and k not in keys:
            raise InputError(f"binding map: {name}={k!r} is no swept key of the table "
                             f"({', '.join(keys) or 'none'})")
    rank = sorted(varying, key=lambda k: (not _numeric(df[k]), -df[k].nunique(),
                                          keys.index(k)))
    if x is None:
        x = next((k for k in rank if k != y), None)
    if x is None:
        raise InputError("binding map: no swept key takes more than one value")
    if y is None:
        y = next((k for k in rank if k != x), None)
    return x, y, [k for k in varying if k not in (x, y)]


def binding_map_data(df, keys, *, x: str | None = None, y: str | None = None):
    """What the binding map shows: one row per point, its cell and its category.

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table (one objective: the first in the table, as :func:`design_chart`).
    keys : sequence of str
        The swept keys.
    x, y : str, optional
        The map's axes (default :func:`map_axes`).

    Returns
    -------
    pandas.DataFrame
        The swept keys, ``point``, ``facet`` (the facet keys' values as one label),
        ``category`` (the point's binding set, its names ``;``-joined in the table's
        order; :data:`NO_BINDING` when nothing binds, :data:`NO_DESIGN` without a
        feasible design or with status ``infeasible``, a constraint broken at the
        optimum's check; :data:`FAILED` for a failed point) and ``branch_changed``.

    Raises
    ------
    InputError
        The table's points have no binding sets (not the ``optimize`` task), or ``x`` /
        ``y`` is no swept key (:func:`map_axes`).
    """
    import pandas as pd

    from isodesign.errors import InputError

    tasks = set(df["task"].dropna()) if "task" in df else {"optimize"}
    if "binding" not in df or "optimize" not in tasks:
        raise InputError(f"binding map: the sweep's points have no binding sets (task "
                         f"{', '.join(sorted(map(str, tasks))) or 'none'}); the optimize "
                         "task's points have them")
    objs = chart_objectives(df)
    if objs:
        df = df[(df["objective"] == objs[0]) | df["objective"].isna()]
    x, y, facets = map_axes(df, keys, x=x, y=y)
    status = df["status"].astype(str).to_numpy()
    # a point is a design when its optimum is feasible and its run did not find a
    # constraint broken at the check (status ``infeasible``)
    feas = (df["feasible"].fillna(False).to_numpy(bool) if "feasible" in df
            else np.zeros(len(df), bool)) & (status != "infeasible")
    cats = []
    for b, st, ok in zip(df["binding"], status, feas, strict=True):
        if st == "failed":
            cats.append(FAILED)
        elif not ok:
            cats.append(NO_DESIGN)
        else:
            cats.append(b if isinstance(b, str) and b else NO_BINDING)
    out = pd.DataFrame({k: df[k].to_numpy() for k in [x, *([y] if y else []), *facets]})
    out["point"] = df["point"].to_numpy() if "point" in df else np.arange(len(df))
    out["facet"] = [", ".join(f"{k}={v}" for k, v in zip(facets, row, strict=True))
                    for row in zip(*(df[k] for k in facets), strict=True)] \
        if facets else ""
    out["category"] = cats
    out["branch_changed"] = df["branch_changed"].fillna(False).to_numpy(bool) \
        if "branch_changed" in df else False
    return out


def _edges(values) -> np.ndarray:
    """Cell edges around sorted numbers (midpoints; the end cells as wide as their
    neighbour's half-gap), or around positions 0, 1, ... of categories."""
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else v[0] * np.array([0.9, 1.1])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def _label_of(category: str) -> str:
    if category in (NO_DESIGN, FAILED, NO_BINDING):
        return category
    return _short(category)


def binding_map(df, keys, *, x: str | None = None, y: str | None = None,
                title: str | None = None, ncols: int | None = None, order=None):
    """The binding constraint set of every point as categories over two swept keys.

    One panel per combination of the other swept keys (the facets); in each, one cell per
    point, coloured by its binding set (:func:`binding_map_data`); black lines along every
    edge between two cells of different sets (where the binding set changes); a dot on
    the points whose continuation changed branch (the table's ``branch_changed``); blank
    cells: points not in the table (not run yet).

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table.
    keys : sequence of str
        The swept keys.
    x, y : str, optional
        The axes (default :func:`map_axes`).
    title : str, optional
    ncols : int, optional
        Panels per row (default up to 3).
    order : dict, optional
        Each key's values in the sweep's order (``record.json["sweep"]["values"]``,
        :attr:`isodesign.sweeps.SweepResult.values`): the axes span every value (a point
        not run yet is a blank cell) and text values and panels follow it. Default: the
        values in the table, numbers sorted, text in order of appearance.

    Returns
    -------
    matplotlib.figure.Figure
        Each panel's cells are a ``QuadMesh`` whose array holds the category codes, the
        index of the category in the figure legend's labels (masked: no point).

    Raises
    ------
    InputError
        As :func:`binding_map_data`.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    data = binding_map_data(df, keys, x=x, y=y)
    x, y, facets = map_axes(df, keys, x=x, y=y)
    counts = data["category"].value_counts()
    special = [c for c in (NO_BINDING, NO_DESIGN, FAILED) if c in counts]
    cats = [c for c in counts.index if c not in special] + special
    palette = [f"C{i}" for i in (0, 1, 2, 4, 5, 6, 8, 9)] + list(_TAB20_LIGHT)  # C3: failed
    colours = []
    for i, c in enumerate(cats):
        colours.append({NO_DESIGN: "0.55", FAILED: "#d62728", NO_BINDING: "0.9"}.get(
            c, palette[i % len(palette)]))
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(len(cats) + 1) - 0.5, len(cats))
    code = {c: i for i, c in enumerate(cats)}
    order = dict(order or {})

    def values(k):
        given = [v for v in order.get(k) or () if not isinstance(v, bool)]
        seen = _ordered(data[k])
        if given and set(seen) <= set(given):
            return sorted(given) if _numeric(given) else list(given)
        return seen

    xv = values(x)
    yv = values(y) if y else [0]
    xnum, ynum = _numeric(xv), (y is not None and _numeric(yv))
    xe = _edges(xv if xnum else range(len(xv)))
    ye = _edges(yv if ynum else range(len(yv)))
    panels = list(dict.fromkeys(data["facet"]))
    if len(facets) == 1 and order.get(facets[0]):  # every value a panel, run or not
        panels += [f"{facets[0]}={v}" for v in values(facets[0])
                   if f"{facets[0]}={v}" not in panels]
    if facets:  # the panels in the sweep's order of the facet keys' values
        rank = [{v: i for i, v in enumerate(values(k))} for k in facets]
        first = {f: tuple(r.get(v, len(r)) for r, v in zip(rank, row, strict=True))
                 for f, row in zip(data["facet"], zip(*(data[k] for k in facets),
                                                      strict=True), strict=True)}
        if len(facets) == 1:
            first.update({f"{facets[0]}={v}": (i,) for v, i in rank[0].items()})
        panels.sort(key=lambda f: first[f])
    ncols = max(1, min(ncols or 3, len(panels)))
    nrows = math.ceil(len(panels) / ncols)
    fig = new_figure(max(3.6 * ncols + 0.6, 8.0),
                     3.0 * nrows + 0.9 + 0.22 * math.ceil(len(cats) / 2))
    axes = np.atleast_1d(fig.subplots(nrows, ncols, sharex=True, sharey=True,
                                      squeeze=False)).ravel()
    for ax, facet in zip(axes, panels, strict=False):
        sub = data[data["facet"] == facet]
        grid = np.full((len(yv), len(xv)), -1, dtype=int)
        changed = []
        for _, r in sub.iterrows():
            i = yv.index(r[y]) if y else 0
            j = xv.index(r[x])
            grid[i, j] = code[r["category"]]
            if r["branch_changed"]:
                changed.append((i, j))
        arr = np.ma.masked_less(grid, 0)
        ax.pcolormesh(xe, ye, arr, cmap=cmap, norm=norm, shading="flat")
        segs = []
        for i in range(len(yv)):
            for j in range(len(xv)):
                if grid[i, j] < 0:
                    continue
                if j + 1 < len(xv) and grid[i, j + 1] >= 0 and grid[i, j + 1] != grid[i, j]:
                    segs.append([(xe[j + 1], ye[i]), (xe[j + 1], ye[i + 1])])
                if i + 1 < len(yv) and grid[i + 1, j] >= 0 and grid[i + 1, j] != grid[i, j]:
                    segs.append([(xe[j], ye[i + 1]), (xe[j + 1], ye[i + 1])])
        ax.add_collection(LineCollection(segs, colors="black", linewidths=1.3))
        if changed:
            cx = [(xe[j] + xe[j + 1]) / 2 for _, j in changed]
            cy = [(ye[i] + ye[i + 1]) / 2 for i, _ in changed]
            ax.plot(cx, cy, ls="none", marker="o", ms=3.5, mfc="white", mec="black", mew=0.8)
        ax.set_xlim(xe[0], xe[-1])
        ax.set_ylim(ye[0], ye[-1])
        ax.set_title(facet or "", fontsize=9)
        if not xnum:
            ax.set_xticks(range(len(xv)), [str(v) for v in xv], rotation=30, fontsize=8)
        if y and not ynum:
            ax.set_yticks(range(len(yv)), [str(v) for v in yv], fontsize=8)
        if not y:
            ax.set_yticks([])
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    for ax in axes[(nrows - 1) * ncols:]:
        ax.set_xlabel(x)
    for ax in axes[::ncols]:
        ax.set_ylabel(y or "")
    import textwrap

    handles = [Patch(facecolor=colours[i], edgecolor="0.3",
                     label=textwrap.fill(_label_of(c), 62, subsequent_indent="  "))
               for i, c in enumerate(cats)]
    if data["branch_changed"].any():
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], ls="none", marker="o", ms=4, mfc="white", mec="black",
                              label="branch changed (the neighbour's start did not reach the "
                                    "point's optimum)"))
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=7,
               title="binding constraints and variables at a bound (lines: where the set "
                     "changes)", title_fontsize=8, frameon=False)
    task = str(df["task"].iloc[0]) if "task" in df and len(df) else "sweep"
    fig.suptitle(title or f"Binding set per point ({task}, {len(data)} points): {y or 'point'}"
                 f" against {x}" + (f", panels by {', '.join(facets)}" if facets else ""),
                 fontsize=10)
    fig.binding_categories = tuple(cats)  # the legend's order: the meshes' codes
    return fig


#: Further colours after C0..C9 (C3: failed points, C7 grey): tab20's light shades.
_TAB20_LIGHT = ("#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2",
                "#dbdb8d", "#9edae5", "#c7c7c7")
