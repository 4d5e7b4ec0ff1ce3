"""A report section of a table's stability: the static verdict and the leveling loop.

:func:`stability_section` returns the rows and the figure an HTML report shows (the
reporting package renders them; this module computes only): the static verdict at the
quasi-static 1 mHz and at the leveling loop's crossover (critical CG height, weakest
direction, margins), every self-consistent solution of the lowest mode, and the loop's
margins per valve with its Bode and Nyquist plots (docs/table.md, sections 7 and 12).
"""

from __future__ import annotations

__all__ = ["stability_section"]


def stability_section(model, system=None, modes=None) -> dict:
    """Rows and figure of a table's stability for a report.

    Parameters
    ----------
    model : TableModel
    system : LevelingSystem, optional
        The valves (default :class:`~isodesign.table.leveling.LevelingSystem`).
    modes : TableModes, optional
        The modes (solved here if not given; a statically unstable one makes the verdict
        unstable).

    Returns
    -------
    dict
        ``static_head``, ``static_rows`` (one per time scale), ``solutions`` (the lowest
        mode's self-consistent frequencies, text), ``loop_summary``, ``loop_head``,
        ``loop_rows`` (one per valve), ``loop_svg`` (Bode and Nyquist).
    """
    from isodesign.plotting.style import figure_svg
    from isodesign.table.leveling_loop import leveling_loop
    from isodesign.table.modes import mode_solutions, rocking_stability, table_modes

    modes = table_modes(model) if modes is None else modes
    loop = leveling_loop(model, system)
    rows = []
    for stab in (rocking_stability(model, modes=modes),
                 rocking_stability(model, frequency_hz=loop.crossover_hz, modes=modes,
                                   time_scale=f"sealed springs at the leveling loop's "
                                   f"crossover {loop.crossover_hz:.3g} Hz")):
        ax = stab.weakest_direction
        rows.append([stab.time_scale, f"{stab.critical_height_m:.4g}",
                     f"{ax[0]:+.2f} rx, {ax[1]:+.2f} ry",
                     ", ".join(f"{m:.3g}" for m in stab.margin),
                     "stable" if stab.stable else "UNSTABLE"])
    loop_rows = [[str(g + 1), f"{loop.gain_margin_db[g]:.3g}",
                  f"{loop.phase_margin_deg[g]:.3g}", f"{loop.delay_margin_s[g]:.3g}",
                  f"{loop.gain_crossover_hz[g]:.3g}", f"{loop.phase_crossover_hz[g]:.3g}"]
                 for g in range(3)]
    return {
        "static_head": ["springs", "critical CG height (m)", "weakest axis", "margins",
                        "verdict"],
        "static_rows": rows,
        "solutions": mode_solutions(model).text().strip(),
        "loop_summary": ("stable" if loop.stable else "UNSTABLE (leveling oscillation)")
        + f"; onset at {loop.critical_gain_kg_s_per_m:.4g} kg/s/m "
        f"({loop.mimo_gain_margin_db:+.2f} dB), {loop.oscillation_frequency_hz:.3g} Hz",
        "loop_head": ["valve", "gain margin (dB)", "phase margin (deg)", "delay margin (s)",
                      "gain crossover (Hz)", "phase crossover (Hz)"],
        "loop_rows": loop_rows,
        "loop_svg": figure_svg(loop.plot()),
    }
