"""The built-in table study with its CG raised until the leveling loop, then the statics,
give way.

The table, the isolators (the paper's spring at the study's start), the leveling groups and
the valves (:class:`isodesign.table.leveling.LevelingSystem` defaults: 0.02 kg/s per m of
height error, 10 um dead band, 1 g/s saturation, sensors at the groups' centroids) are those
of :func:`isodesign.optimization.study.table_study`; only the CG height ``h`` changes. For
each ``h`` the script computes

* the static verdict (:func:`isodesign.table.modes.rocking_stability`: the vertical
  translation condensed, sealed springs at the quasi-static 1 mHz): the margin ``h_c / h``;
* the leveling loop (:func:`isodesign.table.leveling_loop.leveling_loop`): the gain at
  which the closed loop's poles cross (the onset of the leveling oscillation), the MIMO gain
  margin ``G_c / G`` and the crossing pair's frequency, and the smallest per-valve phase
  margin;
* the lowest mode's frequency (sealed springs).

and plots the two margins (dB) against ``h``, the frequencies, and valve 1's Bode
magnitude at three heights. The loop gives way first (the table rocks at the frequency of
its lowest rocking mode while the valves hiss), long before the table tips.

Usage::

    python studies/table_stability.py -o out/table_stability [--heights 0.2:1.7:16]

Outputs: ``table_stability.csv`` (one row per height) and ``table_stability.png``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from isodesign.optimization.study import table_study
from isodesign.plotting.style import new_figure, save_figure
from isodesign.table.layout import Table
from isodesign.table.leveling import LevelingSystem
from isodesign.table.leveling_loop import leveling_loop, loop_response
from isodesign.table.model import table_model
from isodesign.table.modes import rocking_stability, table_modes


def model_at(study, h: float):
    """The study's table model with its CG at height ``h``."""
    t = study.table
    tt = Table(t.mass_kg, t.isolators_m, (t.cg_m[0], t.cg_m[1], h), t.inertia_kg_m2,
               leveling_groups=t.leveling_groups, horizontal=t.horizontal,
               supply_pressure_pa=t.supply_pressure_pa, g_m_s2=t.g_m_s2)
    m = study.models
    return table_model(study.start_design(), tt, flow=m["flow"],
                       amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])


def row(study, h: float, system: LevelingSystem) -> dict:
    """Static margin, loop margins and frequencies at CG height ``h``."""
    model = model_at(study, h)
    md = table_modes(model)
    rs = rocking_stability(model, modes=md)
    loop = leveling_loop(model, system)
    f1 = md.frequency_hz[0]
    return {"cg_height_m": h, "critical_height_m": rs.critical_height_m,
            "static_margin": float(rs.margin[0]), "static_stable": rs.stable,
            "critical_gain_kg_s_per_m": loop.critical_gain_kg_s_per_m,
            "loop_gain_margin_db": loop.mimo_gain_margin_db, "loop_stable": loop.stable,
            "oscillation_frequency_hz": loop.oscillation_frequency_hz,
            "min_phase_margin_deg": float(np.min(loop.phase_margin_deg)),
            "lowest_mode_hz": f1}


def figure(df: pd.DataFrame, study, system: LevelingSystem, bode_heights):
    """Three panels: margins (dB), frequencies, valve 1's |L| at three heights."""
    fig = new_figure(12.0, 3.8)
    a1, a2, a3 = fig.subplots(1, 3)
    h = df["cg_height_m"]
    a1.plot(h, df["loop_gain_margin_db"], "C0-o", ms=3,
            label="leveling loop: MIMO gain margin")
    a1.plot(h, 20 * np.log10(df["static_margin"].clip(lower=1e-6)), "C3-o", ms=3,
            label="statics: 20 log10(h_c / h)")
    a1.axhline(0.0, color="k", lw=0.8)
    a1.set_xlabel("CG height above the support plane (m)")
    a1.set_ylabel("margin (dB)")
    a1.set_title("the loop gives way, then the statics", fontsize=10)
    a1.legend(fontsize=7)
    a2.plot(h, df["oscillation_frequency_hz"], "C0-o", ms=3,
            label="leveling oscillation (onset)")
    a2.plot(h, df["lowest_mode_hz"], "k:", marker="o", ms=3, label="lowest mode (sealed)")
    a2.set_xlabel("CG height above the support plane (m)")
    a2.set_ylabel("frequency (Hz)")
    a2.set_title("frequencies", fontsize=10)
    a2.legend(fontsize=7)
    f = np.geomspace(1e-3, 10.0, 500)
    for hb, c in zip(bode_heights, ("C2", "C1", "C3"), strict=False):
        loop = leveling_loop(model_at(study, hb), system)
        a3.loglog(f, np.abs(loop_response(loop.plant, 0, loop.gain_kg_s_per_m, f)), c,
                  label=f"h = {hb:g} m")
    a3.axhline(1.0, color="k", lw=0.8)
    a3.set_xlabel("frequency (Hz)")
    a3.set_ylabel("|L| of valve 1 (others closed)")
    a3.set_title("the loop's resonance climbs through |L| = 1", fontsize=10)
    a3.legend(fontsize=7)
    for a in (a1, a2, a3):
        a.grid(True, alpha=0.3)
    return fig


def main(argv=None) -> int:
    """Run the sweep and write the CSV and the figure."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="out/table_stability")
    p.add_argument("--heights", default="0.2:1.7:16", help="FIRST:LAST:COUNT, m")
    a = p.parse_args(argv)
    lo, hi, n = a.heights.split(":")
    heights = np.linspace(float(lo), float(hi), int(n))
    study = table_study()
    system = LevelingSystem()
    df = pd.DataFrame([row(study, float(h), system) for h in heights])
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "table_stability.csv", index=False)
    bode = [float(heights[0]), float(heights[len(heights) // 2]), float(heights[-1])]
    save_figure(figure(df, study, system, bode), out / "table_stability.png")
    with pd.option_context("display.width", 200):
        print(df.round(4).to_string(index=False))
    gm = df["loop_gain_margin_db"].to_numpy()
    k = int(np.argmax(gm < 0)) if np.any(gm < 0) else None
    if k:
        h0 = float(np.interp(0.0, -gm[k - 1:k + 1], heights[k - 1:k + 1]))
        print(f"the leveling loop gives way at h = {h0:.3g} m "
              f"({df['oscillation_frequency_hz'][k]:.3g} Hz); the statics at "
              f"{df['critical_height_m'][0]:.4g} m")
    print(f"wrote {out / 'table_stability.csv'} and {out / 'table_stability.png'}")
    _ = math
    return 0


if __name__ == "__main__":
    sys.exit(main())
