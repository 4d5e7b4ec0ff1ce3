"""The built-in table with its isolators free inside a footprint polygon.

The built-in table study (:func:`isodesign.optimization.study.table_study`: 600 kg on four
isolators 1.2 x 0.8 m apart, CG 0.35 m above them, VC-A floor in three axes, VC-C target)
optimized with its springs and the isolators' layout (docs/table.md, section 15), the
isolators at least 0.5 m apart:

* ``springs``: the springs alone (the layout as given);
* ``rectangle_lever``: the layout stretched about the CG (``layout_length_m``,
  ``layout_width_m``) inside the table top's 1.5 x 1.0 m footprint;
* ``positions_rectangle``: every isolator's x and y free inside the same rectangle as a
  polygon (``variables.isolator_positions_m``);
* ``positions_chamfered``: free inside a chamfered footprint, the rectangle with its
  corners cut by 0.25 m (an octagon: the isolators cannot reach the corners).

Each case reports the worst margin of the NLP (its grid) and of the fine-grid analysis of
its optimum, every isolator's position, the binding footprint and spacing rows in words
with the worst margin's exact sensitivity to each (dB per m of moving the edge outward or
of the minimum distance), and the wall time. The figure draws the margin per case and the
optimum layouts (footprint, positions, CG, half-distance circles).

Usage::

    python studies/table_polygon_layout.py -o out/table_polygon_layout [--cases ...]

Outputs: ``table_polygon_layout.csv`` and ``table_polygon_layout.png``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pandas as pd

from isodesign.optimization.study import table_study
from isodesign.optimization.table_driver import optimize_table
from isodesign.plotting.optimization import case_margin_bars
from isodesign.plotting.style import new_figure, save_figure
from isodesign.table.plots import layout_figure
from isodesign.table.study import study_footprint

RECT = [[-0.75, -0.5], [0.75, -0.5], [0.75, 0.5], [-0.75, 0.5]]
CHAMFER = 0.25
OCTAGON = [[-0.75 + CHAMFER, -0.5], [0.75 - CHAMFER, -0.5], [0.75, -0.5 + CHAMFER],
           [0.75, 0.5 - CHAMFER], [0.75 - CHAMFER, 0.5], [-0.75 + CHAMFER, 0.5],
           [-0.75, 0.5 - CHAMFER], [-0.75, -0.5 + CHAMFER]]
MIN_DISTANCE_M = 0.5
#: The cases: the study's changes.
CASES = {
    "springs": {},
    "rectangle_lever": {"variables": {"layout_length_m": {"fixed": False},
                                      "layout_width_m": {"fixed": False}},
                        "constraints": {"footprint_m": [[-0.75, -0.5], [0.75, 0.5]],
                                        "min_isolator_distance_m": MIN_DISTANCE_M}},
    "positions_rectangle": {"variables": {"isolator_positions_m": {
        "fixed": False, "polygon_m": RECT}},
        "constraints": {"min_isolator_distance_m": MIN_DISTANCE_M}},
    "positions_chamfered": {"variables": {"isolator_positions_m": {
        "fixed": False, "polygon_m": OCTAGON}},
        "constraints": {"min_isolator_distance_m": MIN_DISTANCE_M}},
}


def case_study(name: str, starts: int | None = None):
    """The built-in table study with the case's changes (and ``starts``, if given)."""
    st = table_study()
    if CASES[name]:
        st = st.with_changes(**CASES[name])
    return st.with_changes(solver={"starts": starts}) if starts else st


def row(name: str, starts: int | None = None, workers: int = 1):
    """Optimize one case: its row and its result."""
    st = case_study(name, starts)
    t0 = time.perf_counter()
    r = optimize_table(st, workers=workers)
    out = {"case": name, "success": r.success, "nlp_margin_db": r.objective_value,
           "analysis_margin_db": r.analysis.worst_margin_db,
           "verdict": r.analysis.verdict(), "wall_s": time.perf_counter() - t0}
    xy = st.table_at(r.values).isolators_m
    for i, (x, y) in enumerate(xy):
        out[f"x{i + 1}_m"], out[f"y{i + 1}_m"] = float(x), float(y)
    out["binding"] = "; ".join(f"{s['binding']} ({s['db_per_unit']:+.3g} dB per m)"
                               for s in r.lever_sensitivity if s["at_bound"] == "binding")
    return out, st, r


def figure(df: pd.DataFrame, layouts: list):
    """The worst margin per case, and each free layout's optimum (top view)."""
    fig = new_figure(4.0 + 4.2 * len(layouts), 4.0)
    fig.set_layout_engine("constrained")
    axes = fig.subplots(1, 1 + len(layouts), squeeze=False)[0]
    a1 = axes[0]
    case_margin_bars(a1, df["case"], df["analysis_margin_db"],
                     ylabel="worst margin to VC-C (dB, fine-grid analysis)")
    a1.set_title("built-in table: springs and layout", fontsize=10)
    a1.grid(True, alpha=0.3)
    for ax, (name, st, r) in zip(axes[1:], layouts, strict=True):
        fp, dmin = study_footprint(st)
        layout_figure(st.table_at(r.values), r.analysis.model.leveling, ax=ax, footprint=fp,
                      min_distance_m=dmin)
        ax.set_title(f"{name.replace('_', ' ')}: {r.analysis.worst_margin_db:+.2f} dB",
                     fontsize=9)
        if ax is not axes[-1]:
            ax.get_legend().remove()
    return fig


def main(argv=None) -> int:
    """Run the cases and write the CSV and the figure."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="out/table_polygon_layout")
    p.add_argument("--cases", default=",".join(CASES),
                   help=f"comma-separated, of {', '.join(CASES)}")
    p.add_argument("--starts", type=int, default=None,
                   help="the solver's starts (default: the study's)")
    p.add_argument("--workers", type=int, default=1)
    a = p.parse_args(argv)
    names = [c for c in a.cases.split(",") if c]
    bad = [c for c in names if c not in CASES]
    if bad:
        p.error(f"--cases: unknown {', '.join(bad)}; valid: {', '.join(CASES)}")
    rows, layouts = [], []
    for c in names:
        out, st, r = row(c, a.starts, a.workers)
        rows.append(out)
        if c.startswith("positions"):
            layouts.append((c, st, r))
        print(f"{c}: {out['verdict']} ({out['wall_s']:.0f} s)", flush=True)
    df = pd.DataFrame(rows)
    path = Path(a.output)
    path.mkdir(parents=True, exist_ok=True)
    df.to_csv(path / "table_polygon_layout.csv", index=False)
    save_figure(figure(df, layouts), path / "table_polygon_layout.png")
    with pd.option_context("display.width", 200, "display.max_columns", 30,
                           "display.max_colwidth", 200):
        print(df.drop(columns=["verdict"]).round(4).to_string(index=False))
    print(f"wrote {path / 'table_polygon_layout.csv'} and {path / 'table_polygon_layout.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
