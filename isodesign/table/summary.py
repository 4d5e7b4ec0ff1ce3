"""Text of the table's results for the command line and reports (one place)."""

from __future__ import annotations

import numpy as np

from isodesign.table.assembly import AXES

__all__ = ["band_table_text", "leveling_text", "modes_text", "stability_text", "table_summary"]


def leveling_text(leveling) -> str:
    """One line per isolator: valve group, load, p0.

    Parameters
    ----------
    leveling : Leveling
    """
    lines = [f"  {'isolator':>8}  {'valve':>5}  {'load':>8}  {'p0':>8}",
             f"  {'':>8}  {'':>5}  {'(N)':>8}  {'(bar)':>8}"]
    for i, (g, w, p) in enumerate(zip(leveling.group_of, leveling.load_n, leveling.pressure_pa,
                                      strict=True)):
        lines.append(f"  {i + 1:>8}  {g + 1:>5}  {w:>8.1f}  {p / 1e5:>8.4g}")
    return "\n".join(lines)


def modes_text(modes) -> str:
    """The modes table: frequency, damping ratio, energy fractions (percent).

    Parameters
    ----------
    modes : TableModes
    """
    head = "  ".join(f"{d:>4}" for d in ("x", "y", "z", "rx", "ry", "rz"))
    lines = [f"  {'mode':>4}  {'name':>7}  {'f (Hz)':>7}  {'zeta':>6}  {head}",
             f"  {'':>4}  {'':>7}  {'':>7}  {'':>6}  kinetic energy per direction (%)"]
    for j in range(6):
        f = modes.frequency_hz[j]
        fs = "unstbl" if np.isnan(f) else f"{f:7.3f}"
        z = modes.damping_ratio[j]
        zs = "" if np.isnan(z) else f"{z:6.3f}"
        e = "  ".join(f"{100 * v:>4.0f}" for v in modes.energy_fraction[j])
        lines.append(f"  {j + 1:>4}  {modes.names[j]:>7}  {fs:>7}  {zs:>6}  {e}")
    return "\n".join(lines)


def stability_text(stab) -> str:
    """The static verdict: margins per principal direction, critical CG height, time scale.

    Parameters
    ----------
    stab : RockingStability
    """
    parts = []
    for j, name in enumerate(("weakest", "strongest")):
        ax = stab.directions[:, j]
        parts.append(f"{name} axis ({ax[0]:+.2f} rx, {ax[1]:+.2f} ry): margin "
                     f"{stab.margin[j]:.3g}")
    if stab.stable:
        verdict = "stable"
    elif stab.unstable_modes and np.all(stab.margin > 1.0):
        verdict = ("UNSTABLE: mode " + ", ".join(str(j) for j in stab.unstable_modes)
                   + " statically unstable at its own frequency")
    else:
        verdict = "UNSTABLE (margin < 1)"
    return ("  static stability with gravity (z condensed, A = K_theta - s s^T / sum k; "
            f"{stab.time_scale}): " + "; ".join(parts)
            + f"; critical CG height {stab.critical_height_m:.4g} m -> {verdict}")


def band_table_text(res) -> str:
    """Band RMS velocity per point and axis against the limit (um/s), margins (dB).

    Parameters
    ----------
    res : TableBandResponse
    """
    lines = []
    for p, name in enumerate(res.point_names):
        xyz = ", ".join(f"{v:g}" for v in res.model.table.instrument_points_m[p])
        lines.append(f"  point {name} ({xyz} m)")
        lines.append(f"  {'band':>6}  {'limit':>8}  " + "  ".join(
            f"{a + ' (um/s)':>10}  {'dB':>6}" for a in AXES))
        for b, lab in enumerate(res.bands.labels):
            cells = "  ".join(f"{res.velocity_rms_m_s[p, a, b] * 1e6:>10.4g}  "
                              f"{res.margin_db[p, a, b]:>+6.2f}" for a in range(3))
            lines.append(f"  {lab:>6}  {res.limit_velocity_rms_m_s[b] * 1e6:>8.4g}  {cells}")
    return "\n".join(lines)


def table_summary(res, modes=None, stab=None, label: str = "") -> str:
    """Header, leveling, modes, stability, band table and verdict of a table response.

    Parameters
    ----------
    res : TableBandResponse
    modes : TableModes, optional
    stab : RockingStability, optional
    label : str
        The design's label.
    """
    t = res.model.table
    lines = [
        f"table band response: {label}; {t.mass_kg:g} kg on {t.n_isolators} isolators, CG "
        f"({', '.join(f'{v:g}' for v in t.cg_m)}) m, three leveling valves",
        "  floor " + ", ".join(f"{a}: {n}" for a, n in zip(AXES, res.grid.floor.names,
                                                          strict=True))
        + f"; target {res.target_name} in every axis; bands {res.bands.labels[0]}-"
        f"{res.bands.labels[-1]} Hz",
    ]
    lines += [f"  note: {n}" for n in res.notes]
    lines.append(leveling_text(res.model.leveling))
    lines.append("  stroke RMS per isolator " + ", ".join(f"{s * 1e6:.3g}"
                                                        for s in res.stroke_rms_m)
                 + f" um ({res.iterations} closure evaluations)")
    if modes is not None:
        lines.append(modes_text(modes))
    if stab is not None:
        lines.append(stability_text(stab))
    lines.append(band_table_text(res))
    lines.append(res.verdict())
    return "\n".join(lines)
