"""Stiffness study of the paper's reference spring, default model against the paper's.

Evaluates the Table 1 spring at 0.05, 0.15 and 0.5 mm over the Table 2
frequencies (0.2..24 Hz) with the default model (quasi_steady flow,
self-consistent amplitude, viscoelastic diaphragm) and with the paper's literal
model (flow=zhao, amplitude_mode=kinematic), and writes to DIR:

  stiffness.csv              default model, one row per point
  stiffness_paper_model.csv  the paper's model
  stiffness.png              Re k and loss factor, both models

The paper's model is flagged outside its validity at most points (warnings).
"""

from __future__ import annotations

import argparse

MODELS = (
    ("stiffness.csv", "default model", "quasi_steady", "self_consistent"),
    ("stiffness_paper_model.csv", "paper's model", "zhao", "kinematic"),
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign demo``."""
    parser.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        default="out/demo",
        help="output directory, created if needed (default %(default)s)",
    )


def run(args) -> int:
    """Run ``isodesign demo``."""
    from pathlib import Path

    from isodesign.commands.stiffness import (
        DEFAULT_AMPLITUDES_M,
        TABLE2_FREQUENCIES_HZ,
        compute,
        load,
        summary,
        write_csv,
    )
    from isodesign.plotting import plot_stiffness

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
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
        write_csv(res, out / filename)
        print(summary(res, title=f"{name}, {label}: wrote {out / filename}"))
        results.append((name, res))
    png = out / "stiffness.png"
    plot_stiffness(
        png,
        [r for _, r in results],
        labels=["default (quasi_steady, self-consistent)", "paper (zhao, kinematic)"],
        title=f"Complex stiffness, {label}",
    )
    print(f"wrote {png}")
    return 0
