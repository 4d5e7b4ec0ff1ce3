"""The rig simulator against the frequency-domain model: the agreement table of docs/simulation.md.

Usage (from the repository root)::

    python studies/rig_agreement.py

Simulates the reference spring (no diaphragm) on the grid
``REFERENCE_FREQUENCIES_HZ x REFERENCE_AMPLITUDES_M`` with
:func:`isodesign.simulation.simulate_grid` and prints, per case, the errors of the
self-consistent and the kinematic models against the simulation, then the worst of each.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd

from isodesign import SpringDesign
from isodesign.simulation.harmonic_rig import (
    REFERENCE_AMPLITUDES_M,
    REFERENCE_FREQUENCIES_HZ,
    agreement_table,
    simulate_grid,
)


def main() -> None:
    """Print the agreement table of ``docs/simulation.md``."""
    design = SpringDesign.reference()
    t0 = time.perf_counter()
    grid = simulate_grid(design, REFERENCE_FREQUENCIES_HZ, REFERENCE_AMPLITUDES_M, diaphragm="none")
    elapsed = time.perf_counter() - t0
    df = agreement_table(grid, design)
    sim = grid.to_frame()
    df["cycles"] = sim["cycles"]
    df["periodic_change"] = sim["periodic_change"]
    df["force_distortion"] = sim["force_distortion"]
    with pd.option_context("display.width", 250, "display.max_columns", 40):
        print(df.to_string(float_format=lambda v: f"{v:.4g}"))
    for mode in ("self_consistent", "kinematic"):
        worst = {
            c: float(np.max(np.abs(df[f"{mode}_{c}"])))
            for c in ("abs_err", "re_err", "im_err", "complex_err", "loss_factor_diff")
        }
        print(mode, "worst:", ", ".join(f"{k} {v:.3g}" for k, v in worst.items()))
    print(f"simulate_grid: {elapsed:.1f} s for {df.shape[0]} cases")


if __name__ == "__main__":
    main()
