"""The built-in table's worst margin against the inertia base's mass (a Pareto front).

The built-in table study (:func:`isodesign.optimization.study.table_study`: 600 kg on four
isolators 1.2 x 0.8 m apart, CG 0.35 m above them, VC-A floor in three axes, VC-C target)
with a concrete slab of the table top's 1.5 x 1.0 m hung under the payload at the support
plane, its mass free from 0 to the 697 kg the supply carries (docs/table.md, section 16):
the front of the worst margin (maximized) against the added mass (minimized) through the
product's own entry point (:func:`isodesign.pareto_front`, objectives
``worst_band_margin,added_mass``; the same as ``isodesign pareto --objectives
worst_band_margin,added_mass``). Each point's combined CG height is reported with it.

Usage::

    python studies/table_inertia_base_front.py -o out/table_inertia_base_front [--points 6]

Outputs: ``table_inertia_base_front.csv`` (one row per point) and
``table_inertia_base_front.png`` (the margin against the added mass, the CG height).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from isodesign.optimization.pareto import pareto_front
from isodesign.optimization.study import table_study
from isodesign.plotting.style import new_figure, save_figure


def front_study(starts: int = 1):
    """The built-in table with the inertia base's mass free (default bounds: 0 to the 697 kg
    the supply carries)."""
    return table_study().with_changes(variables={"inertia_base_mass_kg": {"fixed": False}},
                                      solver={"starts": starts})


def main(argv=None) -> int:
    """Compute the front and write the CSV and the figure."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="out/table_inertia_base_front")
    p.add_argument("--points", type=int, default=6)
    p.add_argument("--starts", type=int, default=1)
    a = p.parse_args(argv)
    st = front_study(a.starts)
    res = pareto_front(st, ("worst_band_margin", "added_mass"), a.points)
    df = res.to_frame()
    df["cg_height_m"] = [st.table_at(d).cg_height_m if np.isfinite(m) else np.nan
                         for d, m in zip(res.designs, res.worst_margin_db, strict=True)]
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "table_inertia_base_front.csv", index=False)
    fig = new_figure(10.0, 3.8)
    fig.set_layout_engine("constrained")
    a1, a2 = fig.subplots(1, 2)
    res.plot(ax=a1)
    ok = np.isfinite(res.worst_margin_db)
    a2.plot(res.costs[ok], df["cg_height_m"][ok], "C1-o", ms=4)
    a2.axhline(0.0, color="k", lw=0.6, ls=":")
    a2.set_xlabel("added mass: the inertia base under the payload (kg)")
    a2.set_ylabel("CG height above the support plane (m)")
    a2.set_title("the combined CG of payload and slab", fontsize=10)
    a2.grid(True, alpha=0.3)
    save_figure(fig, out / "table_inertia_base_front.png")
    print(df[["worst_margin_db", "added_mass_kg", "cg_height_m", "status",
              "nondominated"]].round(4).to_string(index=False))
    print(f"wrote {out / 'table_inertia_base_front.csv'} and "
          f"{out / 'table_inertia_base_front.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
