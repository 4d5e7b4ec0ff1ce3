"""Calibrate a spring from test-rig measurements of its complex stiffness.

'fit diaphragm': identify the diaphragm k_D*(w, X) from MEASURED.csv, single-chamber data
(capillary blocked: the air is k_s, Eq. 40) or dual-chamber data (the air is k_d*, Eq. 38),
with a passive Prony-series model whose coefficients vary smoothly with ln X; a convex fit
(cvxpy) with softening in X as a constraint and the regularization chosen by cross-validation.
Writes the model (-o FILE.toml, usable as --diaphragm fit:FILE.toml) and a plot of measured
against fitted with the residuals (--plot).

'fit spring': calibrate the minor-loss coefficient K, the capillary diameter D_c and the
polytropic index n from dual-chamber data by nonlinear least squares (CasADi exact
derivatives), given the diaphragm (--diaphragm, e.g. fit:diaphragm.toml). Writes the
calibrated design file (-o FILE.toml). Both print a report. CSV schema: docs/calibration.md.
"""

from __future__ import annotations

import argparse

from isodesign.calibration import fit_diaphragm, read_measured_csv
from isodesign.calibration.air_fit import fit_air_side
from isodesign.commands import (
    PLOT_SUFFIXES,
    check_output_path,
    input_error,
    write_figure,
    write_text,
)
from isodesign.commands.stiffness import load

#: Calibratable air-side parameters (short name -> design field); kept here, not imported, so
#: that ``--help`` does not load NumPy (tests check it matches calibration.air_fit).
AIR_PARAMETER_NAMES = {"K": "minor_loss", "D_c": "capillary_diameter_m", "n": "polytropic_index"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign fit``."""
    parser.add_argument("what", choices=("diaphragm", "spring"), help="what to calibrate")
    parser.add_argument("measured", metavar="MEASURED.csv", help="measured complex stiffness")
    parser.add_argument(
        "-o", "--output", metavar="OUT.toml", help="write the fitted model / calibrated design"
    )
    parser.add_argument(
        "--design",
        metavar="DESIGN.toml",
        help="the spring on the rig (default: the paper's reference spring)",
    )
    parser.add_argument(
        "--configuration",
        choices=("single_chamber", "dual_chamber"),
        help="what was measured (overrides the CSV header)",
    )
    parser.add_argument(
        "--flow",
        default="quasi_steady",
        choices=("quasi_steady", "womersley", "poiseuille"),
        help="capillary model of the air (dual-chamber data; default %(default)s)",
    )
    parser.add_argument(
        "--plot", metavar="OUT.png", help="diaphragm: measured vs fitted with residuals"
    )
    parser.add_argument(
        "--hysteretic",
        choices=("auto", "yes", "no"),
        default="auto",
        help="diaphragm: constant-loss term (auto: kept if cross-validation wants it)",
    )
    parser.add_argument(
        "--diaphragm",
        default="none",
        metavar="MODEL",
        help="spring: the diaphragm in parallel: none (default), viscoelastic, "
        "fit:FILE.toml, table:FILE.csv",
    )
    parser.add_argument(
        "--parameters",
        default="K,D_c,n",
        metavar="LIST",
        help="spring: parameters to calibrate, from K, D_c, n (default %(default)s)",
    )


def run(args) -> int:
    """Run ``isodesign fit``."""

    check_output_path(args.output, "--output")
    check_output_path(args.plot, "--plot", suffixes=PLOT_SUFFIXES)
    if args.plot and args.what != "diaphragm":
        raise input_error("--plot: only 'fit diaphragm' makes a plot")
    design, label = load(args.design)
    measured = read_measured_csv(args.measured, configuration=args.configuration)
    if args.what == "diaphragm":
        hyst = {"auto": "auto", "yes": True, "no": False}[args.hysteretic]
        fit = fit_diaphragm(measured, design, flow=args.flow, hysteretic=hyst)
        print(f"spring: {label}")
        print(fit.report())
        if args.output:
            write_text(args.output, fit.to_toml())
            print(f"wrote {args.output} (use it as --diaphragm fit:{args.output})")
        if args.plot:
            with write_figure(args.plot) as tmp:  # whole or not at all
                fit.plot(tmp)
            print(f"wrote {args.plot}")
        return 0
    names = []
    for tok in args.parameters.split(","):
        t = tok.strip()
        if t not in AIR_PARAMETER_NAMES:
            raise input_error(
                f"--parameters: unknown {t!r}; valid: {', '.join(AIR_PARAMETER_NAMES)}"
            )
        names.append(AIR_PARAMETER_NAMES[t])
    fit = fit_air_side(
        measured, design, parameters=tuple(names), diaphragm=args.diaphragm, flow=args.flow
    )
    print(f"spring: {label} (starting point)")
    print(fit.report())
    if args.output:
        write_text(args.output, fit.to_toml())
        print(f"wrote {args.output} (a design file)")
    return 0
