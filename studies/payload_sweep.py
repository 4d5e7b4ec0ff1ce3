"""Optimal spring against payload mass: the vertical study rerun for 300 to 1200 kg.

For each payload mass (on the vertical study's 4 isolators) the vertical study
(:func:`isodesign.optimization.study.vertical_study`: reference spring hardware, VC-A floor,
VC-C needed in the 4-80 Hz bands, total volume <= 6 L, ...) is optimized again from
scratch: one point of :func:`isodesign.sweep` per mass (``--vary payload.mass_kg=...``),
each an independent optimization with its own multi-start, run as one Dask task on a
local cluster of this machine's cores (or on ``--scheduler ADDRESS``). The chamber
pressure follows the payload (p0 = p_atm + m g / (n A_p)), so the spring's stiffness, the
natural frequency, the stroke and the tube flow all change with it.

Besides the optimum, each row records the best feasible start (on the sampled grid) that
ended on a *different* volume-ratio branch (final N more than 10 % away from the
optimum's), read from the point's run record: the vertical study has two local optima at
the volume cap, a small-N branch (large top chamber) and a large-N branch (small top
chamber), and which one is global can change with the payload.

Usage::

    python studies/payload_sweep.py -o out/payload_sweep [--starts 8] [--masses 300,600]
        [--workers 2] [--scheduler tcp://host:8786]

Outputs (in the ``-o`` directory): ``sweep/`` (the sweep directory: ``sweep.parquet``,
one run directory per mass, the design chart; rerunning resumes it), ``payload_sweep.csv``
(one row per mass: feasible, N, V_t0, L_c, D_c, objective, natural frequency, binding
constraints, the other branch) and ``payload_sweep.png`` (optimal N, V_t0, L_c and D_c
against payload, 2 x 2).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import isodesign
from isodesign.optimization.study import vertical_study

#: Payload masses of the sweep, kg (on the vertical study's 4 isolators).
DEFAULT_MASSES_KG = (300.0, 450.0, 600.0, 800.0, 1000.0, 1200.0)
#: Relative difference of the final N that counts as another branch.
BRANCH_TOLERANCE = 0.10


def other_branch(record: dict) -> tuple[float, float]:
    """(objective, N) of the best feasible start ending away from the optimum's N.

    Parameters
    ----------
    record : dict
        The ``record.json`` of the point's optimize run (its ``starts`` and ``design``).
    """
    n_opt = record["design"]["volume_ratio"]
    best = (np.nan, np.nan)
    for s in record.get("starts", ()):
        if not s.get("feasible") or not s.get("final") or s.get("objective") is None:
            continue
        n = s["final"]["volume_ratio"]
        if abs(n / n_opt - 1.0) <= BRANCH_TOLERANCE:
            continue
        if np.isnan(best[0]) or s["objective"] > best[0]:
            best = (s["objective"], n)
    return best


def sweep_row(row, sweep_dir: Path) -> dict:
    """One row of the table: the optimum of one payload mass (a row of the sweep table)."""
    rec = json.loads((sweep_dir / row["run_dir"] / "record.json").read_text(encoding="utf-8"))
    ok = bool(row["feasible"]) and row["status"] != "failed"
    out = {
        "mass_kg": float(row["payload.mass_kg"]),
        "feasible": ok,
        "status": row.get("solver_status") or row["status"],
        "N": row["volume_ratio"],
        "V_t0_l": row["top_volume_m3"] * 1e3,
        "L_c_mm": row["capillary_length_m"] * 1e3,
        "D_c_mm": row["capillary_diameter_m"] * 1e3,
        "total_volume_l": row["total_volume_m3"] * 1e3,
        "objective_db": row["objective_value"],
        "start_objective_db": rec.get("start_objective_value"),
        "natural_frequency_hz": row.get("natural_frequency_hz", np.nan) if ok else np.nan,
        "worst_margin_db_analysis": row.get("worst_band_margin_db", np.nan) if ok else np.nan,
        "peak_transmissibility_db": row.get("peak_transmissibility_db", np.nan) if ok
        else np.nan,
        "pressure_bar": (rec.get("figures") or {}).get("pressure_pa", np.nan) / 1e5
        if ok else np.nan,
        "binding": row["binding"],
        "n_reached_best": row.get("n_reached_best"),
        "starts": row.get("starts"),
        "other_branch_objective_db": np.nan,
        "other_branch_N": np.nan,
        "wall_s": row["wall_s"],
        "worker": row["worker"],
    }
    if ok:
        out["other_branch_objective_db"], out["other_branch_N"] = other_branch(rec)
    return out


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
            spec = vertical_study().variable("volume_ratio")
            ax.axhline(spec.lower, color="0.6", ls="--", lw=0.8, label="bounds of N")
            ax.axhline(spec.upper, color="0.6", ls="--", lw=0.8)
    axes[0].legend(fontsize=8)
    for ax in axes[2:]:
        ax.set_xlabel("payload mass on 4 isolators (kg)")
    st = vertical_study()
    fig.suptitle("Default study re-optimized against payload: floor "
                 f"{st.raw['floor']['criterion']}, limit {st.raw['target']['criterion']} in "
                 f"{st.raw['target']['band_min_hz']:g}-{st.raw['target']['band_max_hz']:g} Hz, "
                 f"total volume <= {st.constraints['max_total_volume_m3'] * 1e3:g} L per isolator",
                 fontsize=10)
    return save_figure(fig, path, dpi=130)


def main(argv=None) -> int:
    """Run the sweep; return 0 (1 if a mass failed)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="out/payload_sweep", help="output directory")
    ap.add_argument("--starts", type=int, default=None,
                    help="starts per optimization (default: the study's, 8)")
    ap.add_argument("--workers", type=int, default=None,
                    help="worker processes of the local Dask cluster (default: the cores)")
    ap.add_argument("--scheduler", default=None,
                    help="a Dask scheduler address (default: a local cluster)")
    ap.add_argument("--masses", default=",".join(f"{m:g}" for m in DEFAULT_MASSES_KG),
                    help="payload masses, kg, comma separated (or start:stop:count)")
    args = ap.parse_args(argv)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    base = vertical_study()
    if args.starts is not None:
        base = base.with_changes(solver={"starts": args.starts})
    t0 = time.perf_counter()

    def progress(done, total, row, running):
        if row is not None:
            print(f"[{done}/{total}] {json.loads(row['changes'])['payload.mass_kg']:6g} kg: "
                  f"{row['status']}, margin {row.get('objective_value', float('nan')):+.3f} dB, "
                  f"{row.get('wall_s') or 0:.1f} s on {row.get('worker')}", flush=True)

    res = isodesign.sweep(base, [f"payload.mass_kg={args.masses}"], output=out / "sweep",
                          scheduler=args.scheduler, workers=args.workers, progress=progress)
    df = pd.DataFrame([sweep_row(r, res.directory) for _, r in res.table.iterrows()])
    df = df.sort_values("mass_kg").reset_index(drop=True)
    df.to_csv(out / "payload_sweep.csv", index=False)
    plot(df, out / "payload_sweep.png")
    cols = ["mass_kg", "feasible", "N", "V_t0_l", "L_c_mm", "D_c_mm", "objective_db",
            "natural_frequency_hz", "other_branch_N", "other_branch_objective_db", "binding"]
    with pd.option_context("display.width", 200, "display.max_colwidth", 80):
        print(df[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"{res.ran} masses run now, {res.reused} reused, on {res.where}; "
          f"{time.perf_counter() - t0:.0f} s")
    print(f"wrote {out / 'payload_sweep.csv'}, {out / 'payload_sweep.png'} and the sweep "
          f"{res.directory} (isodesign report {res.directory} -o report.html)")
    return 1 if res.status == "failed" else 0


if __name__ == "__main__":
    sys.exit(main())
