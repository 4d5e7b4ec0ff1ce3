"""Figures of robust design: worst case per scenario, sensitivity bars, yield histogram."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from isodesign.plotting.style import LIMIT, OPTIMUM, START, new_figure, save_figure

__all__ = ["robustness_figure", "robustness_plot", "scenario_bars", "sensitivity_bars",
           "yield_histogram"]


def _short(desc: str) -> str:
    return (desc.replace("payload_mass_kg=", "m=").replace("capillary_diameter_m=", "D_c ")
            .replace("capillary_length_m=", "L_c ").replace("top_volume_m3=", "V_t0 ")
            .replace("volume_ratio=", "N ").replace("temperature_k=", "T=")
            .replace("ambient_pressure_pa=", "p_amb=").replace("diaphragm_stiffness=", "k_D ")
            .replace(", ", "\n"))


def scenario_bars(result, ax=None):
    """The objective of the robust and of the nominal optimum in each final scenario.

    Parameters
    ----------
    result : RobustResult or dict
        A result, or its :meth:`~isodesign.optimization.robust_result.RobustResult.record`
        (``robust.json``).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from isodesign.optimization.objectives import OBJECTIVES

    rec = result if isinstance(result, dict) else result.record()
    fig = ax.figure if ax is not None else new_figure(7.0, 3.6)
    ax = ax or fig.add_subplot(1, 1, 1)
    obj = OBJECTIVES[rec["objective"]]
    rows = list(rec["scenarios"])
    x = np.arange(len(rows))
    s = obj.display_scale
    rob = np.array([r["objective"] for r in rows], float) * s
    nom = np.array([np.nan if r.get("nominal_objective") is None else r["nominal_objective"]
                    for r in rows], float) * s
    ax.bar(x - 0.2, nom, 0.4, color=START["color"], alpha=0.75, label="nominal optimum")
    ax.bar(x + 0.2, rob, 0.4, color=OPTIMUM["color"], label="robust optimum")
    for i, r in enumerate(rows):
        if r["active"]:
            ax.annotate("active", (x[i] + 0.2, rob[i]), ha="center", va="bottom", fontsize=7)
    w = rec["worst_case_objective"]
    ax.axhline(w * s, **{**LIMIT, "lw": 1.2}, label=f"stated worst case {obj.format(w)}")
    ax.set_xticks(x, [_short(r["description"]) for r in rows], fontsize=6.5)
    ax.set_ylabel(f"{obj.label} ({obj.display_unit})")
    ax.set_title("objective in each scenario of the final set", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
    return fig


def sensitivity_bars(sens, ax=None, *, quantities=None):
    """Change of the objective and binding constraints over each tolerance's half-width.

    Parameters
    ----------
    sens : list of Sensitivity
        From :func:`isodesign.optimization.sensitivity.design_sensitivities`.
    ax : matplotlib Axes, optional
    quantities : list of str, optional
        Quantities to show (default: the objective and the binding constraints in dB).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = ax.figure if ax is not None else new_figure(7.0, 3.4)
    ax = ax or fig.add_subplot(1, 1, 1)
    if quantities is None:
        quantities = list(dict.fromkeys(
            s.quantity for s in sens if s.quantity.startswith("objective")
            or (s.binding and s.unit == "dB")))
    params = list(dict.fromkeys(s.parameter for s in sens))
    y = np.arange(len(params))
    h = 0.8 / max(1, len(quantities))
    for i, q in enumerate(quantities):
        vals = [next((s.effect for s in sens if s.quantity == q and s.parameter == p), 0.0)
                for p in params]
        unit = next((s.unit for s in sens if s.quantity == q), "")
        ax.barh(y + (i - (len(quantities) - 1) / 2) * h, vals, h,
                color=f"C{[0, 3, 2, 4, 5][i % 5]}", label=f"{q} ({unit})")
    ax.axvline(0.0, color="0.4", lw=0.8)
    ax.set_yticks(y, params, fontsize=7.5)
    ax.set_xlabel("change over the tolerance's half-width (unit in the legend)")
    ax.set_title("sensitivities at the design (design held, exact NLP derivatives)",
                 fontsize=9)
    ax.legend(fontsize=7)
    return fig


def yield_histogram(yields, ax=None):
    """Criterion margin over the draws, one histogram per design; failures counted.

    Parameters
    ----------
    yields : YieldResult or list of YieldResult
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    ys = yields if isinstance(yields, list | tuple) else [yields]
    fig = ax.figure if ax is not None else new_figure(7.0, 3.2)
    ax = ax or fig.add_subplot(1, 1, 1)
    colours = [START["color"], OPTIMUM["color"], "C2", "C4"]
    for i, y in enumerate(ys):
        m = np.array([v["margin_db"] for v in y.verdicts], float)
        lo, hi = y.interval
        ax.hist(m[np.isfinite(m)], bins=40, alpha=0.6, color=colours[i % 4],
                label=f"{y.label or 'design'}: yield {100 * y.fraction:.1f} % "
                      f"(CI {100 * lo:.1f}-{100 * hi:.1f} %)")
    ax.axvline(0.0, **LIMIT)
    ax.set_xlabel("worst-band margin of each drawn table (dB)")
    ax.set_ylabel("draws")
    ax.set_title("yield: built tables drawn from the tolerance laws", fontsize=9)
    ax.legend(fontsize=7)
    return fig


def robustness_figure(result, sens=None, yields=None):
    """Scenario bars, sensitivity bars and (with yields) the yield histogram.

    Parameters
    ----------
    result : RobustResult
    sens : list of Sensitivity, optional
    yields : list of YieldResult, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = 1 + (sens is not None) + bool(yields)
    fig = new_figure(7.5, 3.3 * n)
    axes = fig.subplots(n, 1)
    axes = np.atleast_1d(axes)
    scenario_bars(result, ax=axes[0])
    i = 1
    if sens is not None:
        sensitivity_bars(sens, ax=axes[i])
        if getattr(result, "kind", "") == "robust table":  # not the NLP's derivatives
            axes[i].set_title("sensitivities at the design (design held, central differences "
                              "of the table's analysis)", fontsize=9)
        i += 1
    if yields:
        yield_histogram(list(yields), ax=axes[i])
    return fig


def robustness_plot(result, path, sens=None, yields=None) -> Path:
    """Write :func:`robustness_figure` to ``path``.

    Parameters
    ----------
    result : RobustResult
    path : str or Path
    sens, yields : optional

    Returns
    -------
    Path
    """
    return save_figure(robustness_figure(result, sens, yields), path)
