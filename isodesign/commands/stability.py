"""Static stability and the leveling loop of a table in six degrees of freedom.

INPUT is a study file with a [table] (docs/table.md), an optimize run directory of such a
study (its optimum is analysed), or --builtin table (default: the co-designed table's start;
vertical: refused, no [table]). Prints the static verdict (the gravity
term, the vertical translation condensed, the sealed springs at the quasi-static 1 mHz and
at the leveling loop's crossover), the critical CG height and the weakest direction, every
self-consistent solution of the lowest mode, and the leveling loop of the study's
[table.leveling] valves (python-control): gain, phase and delay margins per valve, the
closed-loop poles' verdict, the gain at the onset of the leveling oscillation and its
frequency, and the valves' limit cycle by the describing function. Writes to OUTDIR:
stability.csv, loop.csv, record.json, and with --plot loop.png (Bode and Nyquist).
"""

from __future__ import annotations

import argparse

from isodesign.commands import (
    BUILTIN_CHOICES,
    BUILTIN_HELP,
    add_output_dir_arguments,
    run_directory,
)

#: Files written by ``isodesign stability``.
OUTPUT_FILES = ("stability.csv", "loop.csv", "loop.png", "record.json")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign stability``."""
    parser.add_argument("study", nargs="?", metavar="INPUT",
                        help="study file with a [table], or an optimize run directory of one")
    parser.add_argument("--builtin", choices=BUILTIN_CHOICES,
                        help="use a built-in study instead of INPUT (" + BUILTIN_HELP + ")")
    parser.add_argument("--plot", action="store_true",
                        help="write loop.png: Bode and Nyquist plots of the three valves' loops")
    add_output_dir_arguments(parser)


def run(args) -> int:
    """Run ``isodesign stability``."""
    from isodesign.commands.modes import load_table_job, table_job_modes
    from isodesign.table.leveling_loop import leveling_loop, limit_cycle, study_valves
    from isodesign.table.modes import rocking_stability
    from isodesign.table.stability_report import limit_cycle_text
    from isodesign.table.summary import stability_text

    study, design, label = load_table_job(args)
    system = study_valves(study, design)  # a free valve gain: the optimizer's choice
    rundir = run_directory(args, "stability", known_outputs=OUTPUT_FILES)
    model, modes, stab, lowest = table_job_modes(study, design)
    loop = leveling_loop(model, system)
    at_loop = None
    if loop.crossover_hz > 0:  # NaN (no finite crossover) compares False
        at_loop = rocking_stability(model, frequency_hz=loop.crossover_hz, modes=modes,
                                    time_scale="sealed springs at the leveling loop's "
                                    f"crossover {loop.crossover_hz:.3g} Hz")
    cycle = limit_cycle(loop)
    t = study.table
    print(f"stability of the table: {label}; {t.mass_kg:g} kg on {t.n_isolators} isolators, "
          f"CG ({', '.join(f'{v:g}' for v in t.cg_m)}) m")
    print(stability_text(stab))
    if at_loop is not None:
        print(stability_text(at_loop))
    print(lowest.text())
    print(loop.text())
    print(limit_cycle_text(cycle, system))
    with rundir as run:
        run.record["study"] = study.source or study.name
        run.record["static_critical_height_m"] = stab.critical_height_m
        run.record["static_stable"] = stab.stable
        run.record["loop_stable"] = loop.stable
        run.record["critical_gain_kg_s_per_m"] = loop.critical_gain_kg_s_per_m
        frame = stab.to_frame()
        frame["time_scale"] = stab.time_scale
        import pandas as pd

        frames = [frame]
        if at_loop is not None:
            frame2 = at_loop.to_frame()
            frame2["time_scale"] = at_loop.time_scale
            frames.append(frame2)
        run.write_csv("stability.csv", pd.concat(frames, ignore_index=True))
        run.write_csv("loop.csv", loop.to_frame())
        if args.plot:
            from isodesign.plotting.style import save_figure

            with run.writing("loop.png") as tmp:
                save_figure(loop.plot(), tmp)
        print(f"wrote {run.target}")
    return 0
