"""A shareable HTML report of a design, an optimization or a Pareto run, or a comparison.

Each INPUT is a design file, a study file, or an ``isodesign optimize`` / ``isodesign
pareto`` run directory; several inputs give a comparison report (the candidates side by
side: one band plot, one transmissibility plot, one table). The report is one
self-contained HTML file (figures as inline SVG, styles inline, no script, no network
access when opened) that prints sensibly (A4 print style sheet). Without -o, the report of
one run directory RUN is written to RUN/report.html. Contents in the order a
reviewer reads: verdict, the job, the design and its models, band table, transmissibility,
complex stiffness, stability, optimization (constraints, start vs optimum, flat
direction), Pareto front, validity flags, provenance. See docs/report.md.
"""

from __future__ import annotations

import argparse

from isodesign.commands import check_output_path, input_error
from isodesign.io.files import atomic_path
from isodesign.reporting.render import timed_report


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign report``."""
    parser.add_argument(
        "inputs",
        nargs="+",
        metavar="INPUT",
        help="design file, study file, or optimize/pareto run directory (several: comparison)",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="REPORT.html",
        help="the HTML file to write (default, for one run directory RUN: RUN/report.html; "
        "required otherwise)",
    )
    parser.add_argument(
        "--study",
        metavar="STUDY.toml",
        help="the job (payload, floor, criterion, judged bands) of design-file inputs "
        "(default: the built-in vertical study)",
    )
    parser.add_argument(
        "--label",
        action="append",
        metavar="NAME",
        help="name of a candidate, once per input in order (default from the inputs)",
    )
    parser.add_argument("--title", metavar="TEXT", help="the report's title")


def run(args) -> int:
    """Run ``isodesign report``."""

    if args.output is None:
        from pathlib import Path

        if len(args.inputs) == 1 and Path(args.inputs[0]).is_dir():
            args.output = str(Path(args.inputs[0]) / "report.html")
        else:
            raise input_error("--output: required unless the only input is a run directory "
                              "(then the report is RUN/report.html)")
    check_output_path(args.output, "--output", suffixes=(".html", ".htm"))
    if args.label is not None and len(args.label) != len(args.inputs):
        raise input_error(f"--label: give one per input ({len(args.inputs)}), "
                          f"got {len(args.label)}")

    command = ["isodesign", "report", *map(str, args.inputs), "-o", str(args.output)]
    if args.study:
        command += ["--study", str(args.study)]
    for lab in args.label or ():
        command += ["--label", lab]
    if args.title:
        command += ["--title", args.title]
    from pathlib import Path


    with atomic_path(args.output) as tmp:  # the report appears whole or not at all
        _, wall = timed_report(args.inputs, tmp, study=args.study, labels=args.label,
                               title=args.title, command=command)
    path = Path(args.output)
    size = path.stat().st_size
    print(f"wrote {path} ({size / 1024:.0f} kB, {len(args.inputs)} input"
          f"{'s' if len(args.inputs) > 1 else ''}, {wall:.1f} s)")
    return 0
