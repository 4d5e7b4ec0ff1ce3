"""Figures of the table: band response per axis, transmissibility per axis, layout."""

from __future__ import annotations

import numpy as np

from isodesign.plotting.style import FAIL, FLOOR, LIMIT, band_axis, candidate_style, new_figure

__all__ = ["layout_figure", "table_bands_figure", "table_harmonic_figure", "table_modes_figure",
           "table_transmissibility_figure"]

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


def layout_figure(table, leveling=None, *, ax=None, footprint=None, min_distance_m=None):
    """Top view of the table: isolators (numbered, coloured by leveling valve), the support
    polygon, the CG and the instrument points; with a footprint, the polygon the isolators
    stand in and a circle of half the minimum distance around each (two circles that touch:
    a binding spacing).

    Parameters
    ----------
    table : Table
    leveling : Leveling, optional
        Adds each isolator's load.
    ax : matplotlib Axes, optional
    footprint : ndarray (m, 2), optional
        The footprint polygon (:func:`~isodesign.table.study.study_footprint`), m.
    min_distance_m : float, optional
        ``constraints.min_isolator_distance_m``.

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
    if footprint is not None:
        fp = np.vstack([footprint, footprint[:1]])
        ax.plot(fp[:, 0], fp[:, 1], color="k", lw=1.5, label="footprint")
    if min_distance_m:
        t = np.linspace(0.0, 2 * np.pi, 73)
        for i, (x, y) in enumerate(table.isolators_m):
            ax.plot(x + 0.5 * min_distance_m * np.cos(t), y + 0.5 * min_distance_m * np.sin(t),
                    color="0.5", lw=0.8, ls="--",
                    label=f"half the minimum distance ({min_distance_m:g} m)" if i == 0
                    else None)
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


#: Colours of the six degrees of freedom in the mode figure (translations, then rotations).
_DOF_COLOURS = ("C0", "C1", "C2", "C4", "C5", "C6")


def table_modes_figure(modes, *, ax=None):
    """The table's six modes: kinetic energy per degree of freedom, stacked per mode.

    Each bar is one mode (its number, dominant DOFs, frequency and damping ratio under it);
    its segments are the kinetic-energy fractions in x, y, z, rx, ry, rz (they sum to 1).

    Parameters
    ----------
    modes : TableModes
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from isodesign.table.assembly import DOFS

    if ax is None:
        ax = new_figure(7.6, 4.0).subplots()
    fig = ax.figure
    e = np.asarray(modes.energy_fraction, float)
    x = np.arange(e.shape[0])
    bottom = np.zeros(e.shape[0])
    for i, dof in enumerate(DOFS):
        ax.bar(x, e[:, i], 0.6, bottom=bottom, color=_DOF_COLOURS[i], label=dof,
               edgecolor="white", lw=0.5)
        bottom += e[:, i]
    labels = []
    for j, (name, f, z) in enumerate(zip(modes.names, modes.frequency_hz, modes.damping_ratio,
                                         strict=True)):
        freq = "unstable" if not np.isfinite(f) else f"{f:.3g} Hz"
        labels.append(f"{j + 1}: {name}\n{freq}\nzeta {z:.2g}")
    ax.set_xticks(x, labels, fontsize=8)
    ax.set_ylim(0.0, 1.0)
    ax.set_xlabel("mode: dominant motion, frequency, damping ratio")
    ax.set_ylabel("kinetic energy fraction per DOF")
    ax.set_title("table modes (nonlinear eigenproblem): kinetic energy per degree of freedom",
                 fontsize=10)
    ax.legend(fontsize=8, title="DOF", title_fontsize=8, loc="center left",
              bbox_to_anchor=(1.01, 0.5))
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def table_harmonic_figure(res, *, ax=None):
    """|T| (dB) of a harmonic table response: every instrument point and axis.

    Parameters
    ----------
    res : TableHarmonicResponse
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        ax = new_figure(7.0, 4.0).subplots()
    fig = ax.figure
    f = res.frequency_hz
    lines = ("-", "--", ":")
    floor_level = 1e-6 * float(np.max(np.abs(res.transmissibility)))  # -120 dB: zero
    for p, name in enumerate(res.model.table.point_names):
        st = candidate_style(p)
        for a, axis in enumerate(_AXES):
            t = np.abs(res.transmissibility[:, p, a])
            if not np.any(t > floor_level):  # an axis the floor motion does not reach
                continue
            with np.errstate(divide="ignore"):
                ax.semilogx(f, 20 * np.log10(t), color=st["color"], ls=lines[a],
                            lw=max(3.6 - 2.0 * p, 1.2),  # coinciding points stay visible
                            label=f"{name}, {axis}")
    ax.axhline(0.0, color="0.55", lw=0.9)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|T| (dB): point motion per floor motion along {res.direction_name}")
    ax.set_title(f"harmonic floor motion {res.floor_amplitude_m:g} m along "
                 f"{res.direction_name}", fontsize=10)
    ax.grid(True, which="major", alpha=0.4)
    ax.legend(fontsize=7, loc="lower left")
    return fig
