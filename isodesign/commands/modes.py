"""Modes and rocking stability of a table in six degrees of freedom.

INPUT is a study file with a [table] (docs/table.md), an optimize run directory of such a
study (its optimum is analysed), or --builtin table (default: the co-designed table's start;
vertical: refused, no [table]). The table is leveled on its three
valves (each isolator's load and p0), and its six modes are solved with the isolators'
frequency-dependent stiffness evaluated at each mode's own frequency (a nonlinear
eigenproblem), in the linear regime (1 um). Prints the leveling, the modes (frequency,
damping ratio, kinetic-energy fraction per direction), every self-consistent solution of
the lowest mode, and the static verdict with the gravity term (vertical translation
condensed, sealed springs at the quasi-static 1 mHz; a mode statically unstable at its own
frequency is never "stable"), its critical CG height and weakest direction. Writes to
OUTDIR: modes.csv (frequency, damping ratio, energy fractions, shape), stability.csv,
leveling.csv, layout.png (top view) and record.json.
"""

from __future__ import annotations

import argparse

from isodesign.commands import (
    BUILTIN_CHOICES,
    BUILTIN_HELP,
    add_output_dir_arguments,
    run_directory,
)

#: Files written by ``isodesign modes``.
OUTPUT_FILES = ("modes.csv", "stability.csv", "leveling.csv", "layout.png", "record.json")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign modes``."""
    parser.add_argument("study", nargs="?", metavar="INPUT",
                        help="study file with a [table], or an optimize run directory of one")
    parser.add_argument("--builtin", choices=BUILTIN_CHOICES,
                        help="use a built-in study instead of INPUT (" + BUILTIN_HELP + ")")
    parser.add_argument("--no-plots", action="store_true", help="write no PNG file")
    add_output_dir_arguments(parser)


def load_table_job(args):
    """``(study, design, label)`` of a table command's INPUT or ``--builtin``.

    Parameters
    ----------
    args : argparse.Namespace
        With ``study`` and ``builtin``.
    """
    from isodesign.errors import InputError
    from isodesign.optimization.study import BUILTIN_STUDIES
    from isodesign.reporting.inputs import input_kind, load_case

    if args.builtin is not None:
        if args.study is not None:
            raise InputError("--builtin: give INPUT or --builtin, not both")
        st = BUILTIN_STUDIES[args.builtin]()
        if st.table is None:
            raise InputError(f"--builtin {args.builtin}: the built-in {args.builtin} study has "
                             "no [table] (docs/table.md); the vertical-only payload has one "
                             "mode: see isodesign response")
        return st, st.start_design(), f"start design of the built-in {args.builtin} study"
    if args.study is None:
        raise InputError("INPUT: give a study file with a [table] (or --builtin table)")
    kind = input_kind(args.study)
    if kind not in ("study", "optimize"):
        raise InputError(f"INPUT: {args.study} is a {kind} input; give a study file with a "
                         "[table] or an optimize run directory of one")
    case = load_case(args.study)
    if case.study.table is None:
        raise InputError(f"INPUT: the study of {args.study} has no [table] (docs/table.md); "
                         "the vertical-only payload has one mode: see isodesign response")
    label = ("start design" if kind == "study" else "optimum") + f" of {args.study}"
    return case.study, case.design, label


def table_job_modes(study, design) -> tuple:
    """A table job's model in the linear regime, its modes, its static stability (gravity
    term, quasi-static springs) and the self-consistent solution of its lowest mode: what
    ``isodesign modes`` prints and ``isodesign stability`` starts from.

    Parameters
    ----------
    study : Study
        A study with ``[table]``.
    design : SpringDesign

    Returns
    -------
    tuple
        ``(TableModel, TableModes, RockingStability, ModeSolutions)``.
    """
    from isodesign.table.model import study_table_model
    from isodesign.table.modes import mode_solutions, rocking_stability, table_modes

    model = study_table_model(study, design)
    modes = table_modes(model)
    return model, modes, rocking_stability(model, modes=modes), mode_solutions(model)


def run(args) -> int:
    """Run ``isodesign modes``."""
    from isodesign.table.plots import layout_figure
    from isodesign.table.summary import leveling_text, modes_text, stability_text

    study, design, label = load_table_job(args)
    rundir = run_directory(args, "modes", known_outputs=OUTPUT_FILES)
    model, modes, stab, lowest = table_job_modes(study, design)
    t = study.table_at(None)  # with its levers: the table the modes are of
    print(f"modes of the table: {label}; {t.mass_kg:g} kg on {t.n_isolators} isolators, CG "
          f"({', '.join(f'{v:g}' for v in t.cg_m)}) m; springs in the linear regime (1 um), "
          "each mode at its own frequency")
    print(leveling_text(model.leveling))
    print(modes_text(modes))
    print(lowest.text())
    print(stability_text(stab))
    with rundir as run:
        run.record["study"] = study.source or study.name
        run.write_csv("modes.csv", modes.to_frame())
        run.write_csv("stability.csv", stab.to_frame())
        run.write_csv("leveling.csv", model.leveling.to_frame())
        if not args.no_plots:
            from isodesign.plotting.style import save_figure

            with run.writing("layout.png") as tmp:
                save_figure(layout_figure(t, model.leveling), tmp)
        print(f"wrote {run.target}")
    return 0


def run_table_response(args, job) -> int:
    """``isodesign response`` for a study with a [table]: three axes, every point.

    Parameters
    ----------
    args : argparse.Namespace
        The response command's options.
    job : types.SimpleNamespace
        :func:`isodesign.commands.response.resolve_job`'s job (its study has a table).
    """
    import warnings

    from isodesign.commands import write_figure, write_frame
    from isodesign.errors import InputError, ModelValidityWarning
    from isodesign.plotting.style import save_figure
    from isodesign.table.floor import table_floor
    from isodesign.table.model import table_model
    from isodesign.table.modes import rocking_stability, table_modes
    from isodesign.table.response import table_band_response
    from isodesign.table.summary import table_summary

    for opt, given in (("--design-pressure", args.design_pressure),
                       ("--payload-kg", args.payload_kg is not None),
                       ("--isolators", args.isolators is not None)):
        if given:
            raise InputError(f"{opt}: not available for a study with a [table] (its loads and "
                             "pressures come from the table's leveling; docs/table.md)")
    m = job.models
    if m.get("random_method", "statistical") != "statistical":
        raise InputError("--random-method: the table response uses the statistical closure")
    st = job.study
    table = st.table_at(None)  # the study's table with its levers (a fixed lever's value)
    floor = st.floor_axes if args.floor is None else table_floor(args.floor)
    res = table_band_response(job.design, table, floor, job.target, bands=job.bands,
                              points_per_band=args.points_per_band, flow=m["flow"],
                              amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"],
                              warn=False, distortion=bool(m.get("distortion", False)))  # fmt: skip
    for line in res.flags:
        warnings.warn(f"spring model at the closure: {line}", ModelValidityWarning,
                      stacklevel=2)
    model = table_model(job.design, table, flow=m["flow"],
                        amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])
    to_stdout = args.output == "-"
    mc = None
    mc_closure, in_force = res, None
    if args.verify_monte_carlo is not None:  # the 6-DOF time-domain check
        from isodesign.commands.table_verify import verify_table
        from isodesign.simulation.lumped import lumped_twin

        mc = verify_table(args, job, res, floor)
        twin = lumped_twin(job.design)  # like with like: the simulator's lumped equations
        if twin is not None:
            mc_closure = table_band_response(
                twin, table, floor, job.target, bands=job.bands,
                points_per_band=args.points_per_band, flow=m["flow"],
                amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"], warn=False,
                distortion=bool(m.get("distortion", False)))
            in_force = res
    if not to_stdout:
        md = table_modes(model)
        print(table_summary(res, md, rocking_stability(model, modes=md), job.label))
    if args.output:
        n = write_frame(res.to_frame(), args.output)
        if not to_stdout:
            print(f"wrote {args.output} ({n} rows)")
    if args.plot:
        with write_figure(args.plot) as tmp:
            save_figure(res.plot(), tmp)
        if not to_stdout:
            print(f"wrote {args.plot}")
    if mc is not None and not to_stdout:
        from isodesign.commands.table_verify import table_monte_carlo_table

        print(table_monte_carlo_table(mc_closure, mc, in_force))
    return 0
