"""The product's main job on the built-in default study, and the reference spring's stiffness.

1. DIR/optimize: `isodesign optimize` of the default study (isodesign/data/
   default_study.toml: a 600 kg table on 4 isolators in six degrees of freedom, on a VC-A
   floor in three axes, for an instrument that needs VC-C in every axis at two points; the
   springs of its leveling groups, the horizontal element (pendulum length, elastic-centre
   height, lateral stiffness and loss factor) and the isolator spacing, co-designed within
   practical bounds, docs/table.md section 13). The table's start misses VC-C (the run
   prints by how much, and where); the co-designed table meets it in every axis. Writes
   design.json, design.toml, bands.csv, modes.csv, starts.csv, record.json,
   study_resolved.toml, response.png and layout.png (see docs/table.md, section 11).
2. DIR/stiffness: the Table 1 spring at 0.05, 0.15 and 0.5 mm over the Table 2
   frequencies (0.2..24 Hz) with the default model (quasi_steady flow, self-consistent
   amplitude, viscoelastic diaphragm) and with the paper's literal model (flow=zhao,
   amplitude_mode=kinematic): stiffness.csv, stiffness_paper_model.csv, stiffness.png.
   The paper's model is flagged outside its validity at most points (warnings).
3. DIR/report.html: the HTML report of the optimization (`isodesign report DIR/optimize`):
   verdict, job and scope, design, bands, transmissibility, stiffness, stability,
   constraints and what stopped the design, provenance. Its path is printed last: open it
   in a browser.

DIR appears whole when the demo ends, with the run's status in DIR/record.json; a DIR that
holds an earlier run is refused unless --overwrite (docs/cli.md). Exit status 0 when both
parts succeed (1 if the optimization finds no feasible design).
"""

from __future__ import annotations

import argparse

from isodesign.commands import add_output_dir_arguments, run_directory
from isodesign.commands.optimize import execute
from isodesign.commands.stiffness import (
    DEFAULT_AMPLITUDES_M,
    TABLE2_FREQUENCIES_HZ,
    compute,
    load,
    summary,
)
from isodesign.commands.table_optimize import execute_table
from isodesign.optimization.study import default_study
from isodesign.plotting import plot_stiffness

MODELS = (
    ("stiffness.csv", "default model", "quasi_steady", "self_consistent"),
    ("stiffness_paper_model.csv", "paper's model", "zhao", "kinematic"),
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign demo``."""

    add_output_dir_arguments(parser, required=False, default="out/demo")
    parser.add_argument(
        "--quiet", action="store_true", help="no progress bar; short optimization summary"
    )


#: Entries of the demo's directory.
OUTPUT_FILES = ("optimize", "stiffness", "report.html", "record.json")


def stiffness_comparison(run, prefix: str = "stiffness/") -> None:
    """The reference spring's complex stiffness, default model vs the paper's, into ``run``."""

    design, label = load(None)
    results = []
    for filename, name, flow, mode in MODELS:
        res = compute(
            design,
            list(TABLE2_FREQUENCIES_HZ),
            list(DEFAULT_AMPLITUDES_M),
            flow=flow,
            amplitude_mode=mode,
            diaphragm="viscoelastic",
            label=name,
        )
        path = run.write_csv(prefix + filename, res.to_frame())
        print(summary(res, title=f"{name}, {label}: wrote {path}"))
        results.append((name, res))
    with run.writing(prefix + "stiffness.png") as tmp:
        plot_stiffness(
            tmp,
            [r for _, r in results],
            labels=["default (quasi_steady, self-consistent)", "paper (zhao, kinematic)"],
            title=f"Complex stiffness, {label}",
        )
    print(f"wrote {run.final_path(prefix + 'stiffness.png')}")


def run(args) -> int:
    """Run ``isodesign demo``."""
    from pathlib import Path


    study = default_study()
    rundir = run_directory(args, "demo", known_outputs=OUTPUT_FILES)
    opt_args = argparse.Namespace(
        study=None, output=str(Path(args.output) / "optimize"), starts=None, workers=None,
        seed=None, quiet=args.quiet, no_plots=False, overwrite=False,
    )
    with rundir:
        print("== 1. optimization of the default study (isodesign optimize): the table "
              "co-designed ==")
        if study.table is not None:
            status = execute_table(study, rundir, opt_args, prefix="optimize/")
        else:
            status = execute(study, rundir, opt_args, prefix="optimize/")
        if status != 0:
            rundir.status = "infeasible"
        print()
        print("== 2. complex stiffness of the reference spring: default model vs the paper's ==")
        stiffness_comparison(rundir)
        if status == 0:
            print()
            print("== 3. the HTML report of the optimization (isodesign report) ==")
            demo_report(rundir, args)
    if status == 0:
        print(f"report: {Path(rundir.final or args.output) / 'report.html'} (open it in a "
              "browser)")
    return status


def demo_report(run, args) -> None:
    """``isodesign report DIR/optimize -o DIR/report.html``, inside the run (whole or not)."""
    from pathlib import Path

    from isodesign.reporting.render import timed_report

    staged = Path(run.path)
    final = Path(args.output)
    command = ["isodesign", "report", str(final / "optimize"), "-o", str(final / "report.html")]
    with run.writing("report.html") as tmp:
        _, wall = timed_report([staged / "optimize"], tmp, command=command)
        # the report names the run's final place, not the staging directory
        text = Path(tmp).read_text(encoding="utf-8")
        Path(tmp).write_text(text.replace(str(staged), str(final)), encoding="utf-8")
    print(f"wrote report.html ({wall:.1f} s)")
