"""Optimal spring against payload mass: the default study rerun for 300 to 1200 kg.

For each payload mass (on the default study's 4 isolators) the default study
(:func:`isodesign.optimization.study.default_study`: reference spring hardware, VC-A floor,
VC-C needed in the 4-80 Hz bands, total volume <= 6 L, ...) is optimized again
from scratch with ``study.with_changes(payload={"mass_kg": m})``; each run is
independent (its own multi-start). The chamber pressure follows the payload
(p0 = p_atm + m g / (n A_p)), so the spring's stiffness, the natural frequency,
the stroke and the tube flow all change with it.

Besides the optimum, each row records the branches refined before the winner was
chosen (``refined_branches``: refined objective @ start) and the best feasible start
(on the sampled grid) that ended on a *different* volume-ratio branch (final N more
than 10 % away from the optimum's):
the default study has two local optima at the volume cap, a small-N branch
(large top chamber) and a large-N branch (small top chamber), and which one is
global can change with the payload.

Usage::

    python studies/payload_sweep.py -o out/payload_sweep [--starts 8] [--masses 300,600]

Outputs (in the ``-o`` directory): ``payload_sweep.csv`` (one row per mass:
feasible, N, V_t0, L_c, D_c, objective, natural frequency, binding constraints,
the other branch) and ``payload_sweep.png`` (optimal N, V_t0, L_c and D_c
against payload, 2 x 2).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from isodesign.io.record import variables_at_bounds
from isodesign.optimization.driver import optimize
from isodesign.optimization.study import default_study

#: Payload masses of the sweep, kg (on the default study's 4 isolators).
DEFAULT_MASSES_KG = (300.0, 450.0, 600.0, 800.0, 1000.0, 1200.0)
#: Relative difference of the final N that counts as another branch.
BRANCH_TOLERANCE = 0.10


def other_branch(result) -> tuple[float, float]:
    """(objective, N) of the best feasible start ending away from the optimum's N."""
    n_opt = result.values["volume_ratio"]
    best = (np.nan, np.nan)
    for s in result.starts:
        if not s.feasible or not s.final:
            continue
        n = s.final["volume_ratio"]
        if abs(n / n_opt - 1.0) <= BRANCH_TOLERANCE:
            continue
        if np.isnan(best[0]) or s.objective > best[0]:
            best = (s.objective, n)
    return best


def sweep_row(mass_kg: float, result) -> dict:
    """One row of the table: the optimum of one payload mass."""
    v = result.values
    row = {
        "mass_kg": mass_kg,
        "feasible": result.feasible,
        "status": result.status,
        "N": v["volume_ratio"],
        "V_t0_l": v["top_volume_m3"] * 1e3,
        "L_c_mm": v["capillary_length_m"] * 1e3,
        "D_c_mm": v["capillary_diameter_m"] * 1e3,
        "total_volume_l": v["top_volume_m3"] * (1.0 + v["volume_ratio"]) * 1e3,
        "objective_db": result.objective_value,
        "start_objective_db": result.start_objective,
        "natural_frequency_hz": np.nan,
        "worst_margin_db_analysis": np.nan,
        "peak_transmissibility_db": np.nan,
        "pressure_bar": result.design.pressure_pa / 1e5,
        # every branch refined before the winner was chosen: refined objective (dB) @ start
        "refined_branches": ";".join(f"{j:.4f}@{i}" for i, j in result.branches),
        "binding": ";".join([c.name for c in result.constraints if c.active]
                            + [f"{n}={side}" for n, side in variables_at_bounds(result).items()]),
        "n_reached_best": result.n_reached_best,
        "starts": len(result.starts),
        "other_branch_objective_db": np.nan,
        "other_branch_N": np.nan,
        "wall_s": result.wall_s,
    }
    if result.feasible:
        s = result.analysis.stability
        row["natural_frequency_hz"] = s.natural_frequency_hz
        row["worst_margin_db_analysis"] = result.analysis.worst_margin_db
        row["peak_transmissibility_db"] = 20.0 * np.log10(s.excited_peak_transmissibility)
        row["other_branch_objective_db"], row["other_branch_N"] = other_branch(result)
    else:
        row["binding"] = "violated: " + ";".join(n for n, _ in result.violations[:3])
    return row


#: Relative change of the optimal N between neighbouring masses taken as a branch change.
BRANCH_JUMP = 0.3


def plot(df: pd.DataFrame, path: Path) -> Path:
    """Optimal N, V_t0, L_c and D_c against payload (2 x 2), in the package's visual language.

    The optimum is the blue line of every isodesign figure; the line is broken at a mass
    without a feasible design (its best point drawn as a red cross) and where the optimum
    jumps to the other volume-ratio branch, so no design between two masses is implied.
    """
    from isodesign.plotting.style import OPTIMUM, new_figure, save_figure, with_breaks

    fig = new_figure(9.5, 6.8)
    axes = fig.subplots(2, 2, sharex=True).ravel()
    ok = df["feasible"].to_numpy(bool)
    mass = df["mass_kg"].to_numpy(float)
    n_opt = np.where(ok, df["N"].to_numpy(float), np.nan)
    jump = np.zeros(len(df), bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        jump[1:] = np.abs(np.log(n_opt[1:] / n_opt[:-1])) > np.log1p(BRANCH_JUMP)
    line = {k: v for k, v in OPTIMUM.items() if k != "marker"}
    for ax, (col, label) in zip(axes, (("N", "volume ratio N = V_b0/V_t0 (-)"),
                                       ("V_t0_l", "top chamber V_t0 per isolator (L)"),
                                       ("L_c_mm", "capillary length L_c (mm)"),
                                       ("D_c_mm", "capillary diameter D_c (mm)")),
                                strict=True):
        y = np.where(ok, df[col].to_numpy(float), np.nan)
        lx, ly = with_breaks(mass, y, jump)
        ax.plot(lx, ly, **line, label="optimum (line broken at a branch change)")
        ax.plot(mass[ok], y[ok], "o", color=OPTIMUM["color"], ms=5)
        if (~ok).any():
            ax.plot(mass[~ok], df[col].to_numpy(float)[~ok], "x", color="C3", ms=8, mew=1.6,
                    label="no feasible design (best point)")
        if col == "N" and df["other_branch_N"].notna().any():
            ax.plot(mass, df["other_branch_N"], "s", mfc="none", color="0.5",
                    label="other local optimum")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.ticklabel_format(axis="y", useOffset=False)
        yy = y[ok]
        if yy.size and np.ptp(yy) < 1e-3 * abs(np.mean(yy)):
            ax.set_ylim(0.9 * np.mean(yy), 1.1 * np.mean(yy))
            ax.text(0.5, 0.1, "the same at every payload (constraint-bound)",
                    transform=ax.transAxes, ha="center", fontsize=8, color="0.4")
        if col == "N":
            spec = default_study().variable("volume_ratio")
            ax.axhline(spec.lower, color="0.6", ls="--", lw=0.8, label="bounds of N")
            ax.axhline(spec.upper, color="0.6", ls="--", lw=0.8)
    axes[0].legend(fontsize=8)
    for ax in axes[2:]:
        ax.set_xlabel("payload mass on 4 isolators (kg)")
    st = default_study()
    fig.suptitle("Default study re-optimized against payload: floor "
                 f"{st.raw['floor']['criterion']}, limit {st.raw['target']['criterion']} in "
                 f"{st.raw['target']['band_min_hz']:g}-{st.raw['target']['band_max_hz']:g} Hz, "
                 f"total volume <= {st.constraints['max_total_volume_m3'] * 1e3:g} L per isolator",
                 fontsize=10)
    return save_figure(fig, path, dpi=130)


def main(argv=None) -> int:
    """Run the sweep; return 0."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="out/payload_sweep", help="output directory")
    ap.add_argument("--starts", type=int, default=None,
                    help="starts per optimization (default: the study's, 8)")
    ap.add_argument("--workers", type=int, default=None, help="worker processes per run")
    ap.add_argument("--masses", default=",".join(f"{m:g}" for m in DEFAULT_MASSES_KG),
                    help="payload masses, kg, comma separated")
    args = ap.parse_args(argv)
    masses = [float(m) for m in args.masses.split(",")]
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    base = default_study()
    solver = {k: v for k, v in (("starts", args.starts), ("workers", args.workers))
              if v is not None}
    rows = []
    t0 = time.perf_counter()
    for i, m in enumerate(masses):
        study = base.with_changes(payload={"mass_kg": m}, solver=solver) if solver \
            else base.with_changes(payload={"mass_kg": m})
        res = optimize(study)
        row = sweep_row(m, res)
        rows.append(row)
        print(f"[{i + 1}/{len(masses)}] {m:6g} kg: "
              + (f"N {row['N']:.3f}, V_t0 {row['V_t0_l']:.3f} L, L_c {row['L_c_mm']:.1f} mm, "
                 f"D_c {row['D_c_mm']:.3f} mm, margin {row['objective_db']:+.3f} dB, "
                 f"f_n {row['natural_frequency_hz']:.3f} Hz; {row['n_reached_best']}/"
                 f"{row['starts']} starts at the best; {res.wall_s:.1f} s"
                 if res.feasible else f"NO FEASIBLE DESIGN ({res.status}); {row['binding']}"),
              flush=True)
    df = pd.DataFrame(rows)
    df.to_csv(out / "payload_sweep.csv", index=False)
    plot(df, out / "payload_sweep.png")
    cols = ["mass_kg", "feasible", "N", "V_t0_l", "L_c_mm", "D_c_mm", "objective_db",
            "natural_frequency_hz", "other_branch_N", "other_branch_objective_db", "binding"]
    with pd.option_context("display.width", 200, "display.max_colwidth", 80):
        print(df[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"wrote {out / 'payload_sweep.csv'} and {out / 'payload_sweep.png'} "
          f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
