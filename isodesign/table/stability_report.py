"""A report section of a table's stability: the static verdict and the leveling loop.

:func:`stability_section` returns the rows and the figure an HTML report shows (the
reporting package renders them; this module computes only): the static verdict at the
quasi-static 1 mHz and at the leveling loop's crossover (critical CG height, weakest
direction, margins), every self-consistent solution of the lowest mode, and the loop's
margins per valve with its Bode and Nyquist plots (docs/table.md, sections 7 and 12).
The verdicts are worded as ``isodesign stability`` prints them (the same functions write
both): the report never says "stable" where the command says unstable.
"""

from __future__ import annotations

__all__ = ["limit_cycle_text", "stability_section", "static_verdict"]


def static_verdict(stab) -> str:
    """The static verdict's words, as ``isodesign stability`` and ``isodesign modes`` print
    them: ``stable``, ``UNSTABLE (margin < 1)`` or ``UNSTABLE: mode k statically unstable
    at its own frequency``.

    Parameters
    ----------
    stab : RockingStability
    """
    from isodesign.errors import check_instance
    from isodesign.table.modes import RockingStability
    from isodesign.table.summary import stability_text

    check_instance("stab", stab, RockingStability, "a RockingStability (rocking_stability(model))")
    return stability_text(stab).rsplit(" -> ", 1)[1]


def limit_cycle_text(cycle, system) -> str:
    """The valves' limit cycle (describing function) in one line, as the command prints it.

    Parameters
    ----------
    cycle : LimitCycle
    system : LevelingSystem
    """
    if cycle.amplitude_m is None:
        return ("  valves' limit cycle (describing function): none (the valve's slope is below "
                "the loop's critical gain, or the loop has none)")
    line = (f"  valves' limit cycle (describing function: dead band "
            f"{system.dead_band_m * 1e6:.3g} um, saturation "
            f"{system.saturation_flow_kg_s * 1e3:.3g} g/s): {cycle.amplitude_m * 1e6:.4g} "
            f"um at the sensors, {cycle.frequency_hz:.3g} Hz")
    if cycle.threshold_m is not None:
        line += f" (from disturbances above {cycle.threshold_m * 1e6:.3g} um)"
    return line


def stability_section(model, system=None, modes=None) -> dict:
    """Rows and figure of a table's stability for a report.

    Parameters
    ----------
    model : TableModel
    system : LevelingSystem, optional
        The valves (default :class:`~isodesign.table.leveling.LevelingSystem`; a study's
        are :func:`~isodesign.table.leveling.leveling_of_study`).
    modes : TableModes, optional
        The modes (solved here in the linear regime if not given, as ``isodesign
        stability`` does; a statically unstable one makes the verdict unstable).

    Returns
    -------
    dict
        ``static_head``, ``static_rows`` (one per time scale; the last cell the verdict's
        words), ``stable``, ``verdict`` (the quasi-static verdict, the table's),
        ``critical_height_m``, ``weakest`` (the weakest rotation axis, text),
        ``static`` (the :class:`~isodesign.table.modes.RockingStability` per time scale),
        ``solutions`` (the lowest mode's self-consistent frequencies, text),
        ``loop_stable``, ``loop_summary``, ``loop_head``, ``loop_rows`` (one per valve),
        ``limit_cycle``, ``lines`` (what ``isodesign stability`` prints for these
        analyses, line by line) and ``loop_svg`` (Bode and Nyquist).
    """
    import math

    from isodesign.plotting.style import figure_svg
    from isodesign.table.leveling import LevelingSystem
    from isodesign.table.leveling_loop import leveling_loop, limit_cycle
    from isodesign.table.modes import mode_solutions, rocking_stability, table_modes
    from isodesign.table.summary import stability_text

    system = LevelingSystem() if system is None else system
    modes = table_modes(model) if modes is None else modes
    loop = leveling_loop(model, system)
    stabs = [rocking_stability(model, modes=modes)]
    if loop.crossover_hz > 0:  # NaN (no finite crossover) compares False
        stabs.append(rocking_stability(model, frequency_hz=loop.crossover_hz, modes=modes,
                                       time_scale="sealed springs at the leveling loop's "
                                       f"crossover {loop.crossover_hz:.3g} Hz"))
    rows = []
    for stab in stabs:
        ax = stab.weakest_direction
        rows.append([stab.time_scale, f"{stab.critical_height_m:.4g}",
                     f"{ax[0]:+.2f} rx, {ax[1]:+.2f} ry",
                     ", ".join(f"{m:.3g}" for m in stab.margin), static_verdict(stab)])
    loop_rows = [[str(g + 1), f"{loop.gain_margin_db[g]:.3g}",
                  f"{loop.phase_margin_deg[g]:.3g}", f"{loop.delay_margin_s[g]:.3g}",
                  f"{loop.gain_crossover_hz[g]:.3g}", f"{loop.phase_crossover_hz[g]:.3g}"]
                 for g in range(3)]
    solutions = mode_solutions(model).text()
    cycle = limit_cycle_text(limit_cycle(loop), system)
    if math.isfinite(loop.critical_gain_kg_s_per_m) and loop.critical_gain_kg_s_per_m > 0:
        summary = (("stable" if loop.stable else "UNSTABLE (leveling oscillation)")
                   + f"; onset at {loop.critical_gain_kg_s_per_m:.4g} kg/s/m "
                   f"({loop.mimo_gain_margin_db:+.2f} dB), "
                   f"{loop.oscillation_frequency_hz:.3g} Hz")
    else:  # the loop's own words: unstable at every gain (the table tips), or stable at all
        summary = loop.text().splitlines()[0].split("; closed loop ", 1)[1]
    st = stabs[0]
    w = st.weakest_direction
    return {
        "static_head": ["springs", "critical CG height (m)", "weakest axis", "margins",
                        "verdict"],
        "static_rows": rows,
        "static": stabs,
        "stable": st.stable,
        "verdict": static_verdict(st),
        "critical_height_m": st.critical_height_m,
        "cg_height_m": float(model.table.cg_height_m),
        "weakest": f"{w[0]:+.2f} rx, {w[1]:+.2f} ry",
        "solutions": solutions.strip(),
        "loop_stable": bool(loop.stable),
        "loop_summary": summary,
        "system": (f"valve gain {system.gain_kg_s_per_m:.4g} kg/s/m, dead band "
                   f"{system.dead_band_m * 1e6:.3g} um, saturation "
                   f"{system.saturation_flow_kg_s * 1e3:.3g} g/s, line resistance "
                   f"{system.line_resistance_pa_s_per_kg:.3g} Pa s/kg, feeding the "
                   f"{system.fed_chamber} chamber"),
        "loop_head": ["valve", "gain margin (dB)", "phase margin (deg)", "delay margin (s)",
                      "gain crossover (Hz)", "phase crossover (Hz)"],
        "loop_rows": loop_rows,
        "limit_cycle": cycle.strip(),
        "lines": [*(stability_text(s).strip() for s in stabs), solutions.strip(),
                  *(x.strip() for x in loop.text().splitlines()), cycle.strip()],
        "loop_svg": figure_svg(loop.plot()),
    }
