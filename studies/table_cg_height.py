"""The built-in table study with its centre of gravity raised from 0.1 to 0.8 m.

The table, the isolators (the paper's spring at the study's start), the leveling, the floor
(VC-A in x, y and z) and the instrument points (0.35 m above the CG at the centre and at a
corner) are those of :func:`isodesign.optimization.study.table_study`; only the CG height
``h`` changes (the instrument points keep their height above the CG, the inertia stays the
box's). For each ``h`` the script solves the six modes (nonlinear eigenproblem, springs at
the band response's closure), the rocking stability with the gravity term and the
three-axis band response, and plots:

* the coupled translation-rocking pairs (x+ry and y+rx, lower and upper) against ``h``,
  with the vertical and torsion modes for reference;
* the worst margin per axis (over both points and every band) against ``h``;
* the static margins ``A / (W h)`` (vertical translation condensed, sealed springs at the
  quasi-static 1 mHz; docs/table.md, section 7) against ``h``.

As the CG rises the lower member of each pair drops (the table rocks about an axis further
below the CG), the upper one rises, the rocking margins fall as ``1/h``, and the horizontal
floor drives more rocking, so the margins at the instrument points fall.

Usage::

    python studies/table_cg_height.py -o out/table_cg_height [--heights 0.1:0.8:15]

Outputs: ``table_cg_height.csv`` (one row per height) and ``table_cg_height.png``.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from isodesign.optimization.study import table_study
from isodesign.optimization.table_driver import closure_springs
from isodesign.plotting.style import new_figure, save_figure
from isodesign.table.layout import Table
from isodesign.table.modes import rocking_stability, table_modes
from isodesign.table.response import table_band_response

#: Instrument points' height above the CG, m (the study's: 0.7 m above the plane, CG 0.35 m).
POINT_ABOVE_CG_M = 0.35


def table_at(base: Table, h: float) -> Table:
    """The study's table with its CG at height ``h`` (instrument points follow it)."""
    pts = base.instrument_points_m.copy()
    pts[:, 2] = h + POINT_ABOVE_CG_M
    return Table(base.mass_kg, base.isolators_m, (base.cg_m[0], base.cg_m[1], h),
                 base.inertia_kg_m2, leveling_groups=base.leveling_groups,
                 instrument_points_m=pts, point_names=base.point_names,
                 horizontal=base.horizontal, supply_pressure_pa=base.supply_pressure_pa,
                 g_m_s2=base.g_m_s2)


def row(study, h: float) -> dict:
    """Modes, rocking margins and per-axis worst margins at CG height ``h``."""
    t = table_at(study.table, h)
    m = study.models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = table_band_response(study.start_design(), t, study.floor_axes, study.target,
                                bands=study.bands, flow=m["flow"],
                                amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"],
                                warn=False, distortion=bool(m.get("distortion", False)))
    md = table_modes(r.model, vertical=closure_springs(r.model, r.stroke_rms_m,
                                                       r.tube_velocity_rms_m_s))
    rs = rocking_stability(r.model)
    out = {"cg_height_m": h}
    names = md.names
    for pair in ("x+ry", "y+rx"):
        tr, rot = pair.split("+")
        fs = sorted(f for f, n in zip(md.frequency_hz, names, strict=True)
                    if set(n.split("+")) == {tr, rot})
        out[f"{pair}_low_hz"] = fs[0] if fs else np.nan
        out[f"{pair}_high_hz"] = fs[1] if len(fs) > 1 else np.nan
    out["z_hz"] = next((f for f, n in zip(md.frequency_hz, names, strict=True) if n == "z"),
                       np.nan)
    out["rz_hz"] = next((f for f, n in zip(md.frequency_hz, names, strict=True) if n == "rz"),
                        np.nan)
    for i, ax in enumerate("xyz"):
        out[f"worst_margin_{ax}_db"] = float(r.axis_margin_db()[i])
    out["rocking_margin_weak"], out["rocking_margin_strong"] = rs.margin
    out["stroke_rms_um"] = float(r.stroke_rms_m.mean() * 1e6)
    return out


def figure(df: pd.DataFrame):
    """Three panels: the rocking pairs, the worst margin per axis, the rocking margins."""
    fig = new_figure(12.0, 3.8)
    fig.set_layout_engine("constrained")
    a1, a2, a3 = fig.subplots(1, 3)
    h = df["cg_height_m"]
    for col, st, lab in (("x+ry_low_hz", "C0-", "x+ry lower"), ("x+ry_high_hz", "C0--",
                                                                "x+ry upper"),
                         ("y+rx_low_hz", "C2-", "y+rx lower"), ("y+rx_high_hz", "C2--",
                                                                "y+rx upper"),
                         ("z_hz", "k:", "z"), ("rz_hz", "C7:", "rz")):
        a1.plot(h, df[col], st, marker="o", ms=3, label=lab)
    a1.set_xlabel("CG height above the support plane (m)")
    a1.set_ylabel("mode frequency (Hz)")
    a1.set_title("coupled translation-rocking pairs", fontsize=10)
    a1.legend(fontsize=7)
    for ax, c in zip("xyz", ("C0", "C2", "k"), strict=True):
        a2.plot(h, df[f"worst_margin_{ax}_db"], color=c, marker="o", ms=3, label=f"{ax} axis")
    a2.axhline(0.0, color="C3", lw=0.8)
    a2.set_xlabel("CG height above the support plane (m)")
    a2.set_ylabel("worst margin to VC-C (dB)")
    a2.set_title("margins at the instrument points", fontsize=10)
    a2.legend(fontsize=7)
    a3.plot(h, df["rocking_margin_weak"], "C3-", marker="o", ms=3, label="about x (weakest)")
    a3.plot(h, df["rocking_margin_strong"], "C1-", marker="o", ms=3, label="about y")
    a3.axhline(1.0, color="k", lw=0.8, ls=":")
    a3.set_yscale("log")
    a3.set_xlabel("CG height above the support plane (m)")
    a3.set_ylabel("static margin A / (W h), springs at 1 mHz")
    a3.set_title("rocking stability with gravity", fontsize=10)
    a3.legend(fontsize=7)
    for a in (a1, a2, a3):
        a.grid(True, alpha=0.3)
    return fig


def main(argv=None) -> int:
    """Run the sweep and write the CSV and the figure."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="out/table_cg_height")
    p.add_argument("--heights", default="0.1:0.8:15", help="FIRST:LAST:COUNT, m")
    a = p.parse_args(argv)
    lo, hi, n = a.heights.split(":")
    heights = np.linspace(float(lo), float(hi), int(n))
    study = table_study()
    df = pd.DataFrame([row(study, float(h)) for h in heights])
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "table_cg_height.csv", index=False)
    save_figure(figure(df), out / "table_cg_height.png")
    print(df.round(4).to_string(index=False))
    print(f"wrote {out / 'table_cg_height.csv'} and {out / 'table_cg_height.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
