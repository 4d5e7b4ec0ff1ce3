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
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.plotting.style import candidate_style, new_figure, with_breaks

__all__ = ["BRANCH_JUMP", "chart_breaks", "chart_objectives", "design_chart"]

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
