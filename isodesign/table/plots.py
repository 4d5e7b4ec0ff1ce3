"""Figures of the table: band response per axis, transmissibility per axis, layout."""

from __future__ import annotations

import numpy as np

from isodesign.plotting.style import FAIL, FLOOR, LIMIT, band_axis, candidate_style, new_figure

__all__ = ["layout_figure", "table_bands_figure", "table_transmissibility_figure"]

_AXES = ("x", "y", "z")


def table_bands_figure(res, *, axes=None):
    """Band RMS velocity per axis at every instrument point, with floor and limit.

    Parameters
    ----------
    res : TableBandResponse
    axes : sequence of 3 matplotlib Axes, optional
        Default: a new figure with three panels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if axes is None:
        fig = new_figure(11.0, 3.6)
        axes = fig.subplots(1, 3, sharey=True)
    fig = axes[0].figure
    bands = res.bands
    x = np.asarray(bands.centre_hz, float)
    for a, ax in enumerate(axes):
        band_axis(ax, bands)
        ax.plot(x, res.floor_velocity_rms_m_s[a] * 1e6, **FLOOR,
                label=f"floor: {res.grid.floor.names[a]}")
        ax.plot(x, res.limit_velocity_rms_m_s * 1e6, **LIMIT, label=res.target_name)
        for p, name in enumerate(res.point_names):
            st = candidate_style(p)
            v = res.velocity_rms_m_s[p, a] * 1e6
            ax.plot(x, v, **st, label=name)
            bad = v > res.limit_velocity_rms_m_s * 1e6
            if bad.any():
                ax.plot(x[bad], v[bad], **FAIL)
        ax.set_yscale("log")
        ax.grid(True, which="major", lw=0.4, alpha=0.6)
        ax.set_title(f"{_AXES[a]} axis (worst {res.margin_db[:, a].min():+.1f} dB)", fontsize=10)
    axes[0].set_ylabel("band RMS velocity (um/s)")
    axes[0].legend(fontsize=7, loc="lower left")
    return fig


def layout_figure(table, leveling=None, *, ax=None):
    """Top view of the table: isolators (numbered, coloured by leveling valve), the support
    polygon, the CG and the instrument points.

    Parameters
    ----------
    table : Table
    leveling : Leveling, optional
        Adds each isolator's load.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig = new_figure(6.8, 4.2)
        ax = fig.subplots()
    fig = ax.figure
    hull = table.support_polygon()
    closed = np.vstack([hull, hull[:1]])
    ax.plot(closed[:, 0], closed[:, 1], color="0.6", lw=1.0, ls=":", label="support polygon")
    xy = table.isolators_m
    for g, grp in enumerate(table.leveling_groups):
        st = candidate_style(g)
        pts = xy[list(grp)]
        ax.plot(pts[:, 0], pts[:, 1], ls="", marker="s", ms=12, color=st["color"], zorder=3,
                label=f"valve {g + 1}")
        if len(grp) > 1:
            ax.plot(pts[:, 0], pts[:, 1], color=st["color"], lw=2.0, alpha=0.5)
    for i, (x, y) in enumerate(xy):
        txt = f"{i + 1}" if leveling is None else f"{i + 1}: {leveling.load_n[i]:.0f} N"
        ax.annotate(txt, (x, y), xytext=(8, 8), textcoords="offset points", fontsize=8)
    cx, cy, cz = table.cg_m
    ax.plot([cx], [cy], ls="", marker="X", ms=11, color="k", zorder=4,
            label=f"CG (h = {cz:g} m)")
    p = table.instrument_points_m
    ax.plot(p[:, 0], p[:, 1], ls="", marker="^", ms=8, color="C3", zorder=4,
            label="instrument points")
    for name, (x, y, z) in zip(table.point_names, p, strict=True):
        ax.annotate(f"{name} (z {z:g})", (x, y), xytext=(6, -12), textcoords="offset points",
                    fontsize=8, color="C3")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.25)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("table layout (top view)", fontsize=10)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    ax.grid(True, alpha=0.3)
    return fig


def table_transmissibility_figure(res, *, axes=None):
    """|T| (dB) per axis at every instrument point: at the closure and in the linear regime.

    ``T_p,aa``: the point's motion along axis ``a`` per floor motion along ``a``.

    Parameters
    ----------
    res : TableBandResponse
    axes : sequence of 3 matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if axes is None:
        fig = new_figure(11.0, 3.4)
        axes = fig.subplots(1, 3, sharey=True)
    fig = axes[0].figure
    f = res.grid.frequency_hz
    for a, ax in enumerate(axes):
        for p, name in enumerate(res.point_names):
            st = candidate_style(p)
            t = np.abs(res.transmissibility[:, p, a, a])
            tl = np.abs(res.transmissibility_linear[:, p, a, a])
            ax.semilogx(f, 20 * np.log10(t), color=st["color"], ls=st["ls"], lw=1.5,
                        label=f"{name} (closure)")
            ax.semilogx(f, 20 * np.log10(tl), color=st["color"], ls=":", lw=1.0,
                        label=f"{name} (linear, 1 um)")
        ax.axhline(0.0, color="0.55", lw=0.9)
        ax.set_title(f"{_AXES[a]} floor -> {_AXES[a]} at the points", fontsize=10)
        ax.set_xlabel("frequency (Hz)")
        ax.grid(True, which="major", alpha=0.4)
    axes[0].set_ylabel("|T| (dB)")
    axes[0].legend(fontsize=7, loc="lower left")
    return fig
