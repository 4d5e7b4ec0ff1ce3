"""The built-in table study co-designed: its springs, then each lever of the horizontal
element, then all of them, then the layout alone and with them.

The built-in table study (:func:`isodesign.optimization.study.table_study`: 600 kg on four
isolators 1.2 x 0.8 m apart, CG 0.35 m above them, VC-A floor in three axes, VC-C target)
is optimized with the springs alone (its documented -4.44 dB at the corner, z, 4 Hz:
rocking driven by the horizontal floor), then with each lever of the horizontal element
free within its practical bounds (docs/table.md, "Co-design levers") and the others at the
table's values, then with all four free; then the layout (the isolators' extent along x and
y, docs/table.md section 15) alone and with the four levers, the isolators inside the table
top's 1.5 x 1.0 m footprint and at least 0.5 m apart; (case ``groups``) each leveling
group's own spring, its four variables free within the shared bounds; the inertia base (a
concrete slab of the table top's 1.5 x 1.0 m under the payload, its mass free from 0 to
the 697 kg the supply carries, docs/table.md section 16) alone and with the four levers;
and last the default
study (the four levers, the spacing and the springs of leveling groups 2 and 3 free within
the practical bounds of :func:`isodesign.optimization.study.default_study`, docs/table.md
section 13, "The default study"). Each case reports the worst margin of the NLP (its
grid) and of the fine-grid NumPy analysis of the optimum, every free lever's value, its
active bound and the worst margin's exact sensitivity to that bound (IPOPT's bound
multiplier), and the run's wall time.

Usage::

    python studies/table_codesign.py -o out/table_codesign [--cases springs,pendulum_length_m]

Outputs: ``table_codesign.csv`` (one row per case) and ``table_codesign.png`` (the worst
margin per case, and the lever values against their bounds).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import pandas as pd

from isodesign.optimization.study import default_study, table_study
from isodesign.optimization.table_driver import optimize_table
from isodesign.optimization.variables import (
    BASE_LEVERS,
    CODESIGN_LEVERS,
    GROUP_SPRING_LEVERS,
    LAYOUT_LEVERS,
    TABLE_LEVER_BOUNDS,
    TABLE_LEVERS,
)
from isodesign.plotting.optimization import case_margin_bars
from isodesign.plotting.style import new_figure, save_figure
from isodesign.table.layout import layout_extent

#: The cases: a name and the levers it frees ("default": the default study, its own bounds).
CASES = {"springs": (), **{name: (name,) for name in TABLE_LEVERS}, "all": TABLE_LEVERS,
         "layout": LAYOUT_LEVERS, "all_and_layout": TABLE_LEVERS + LAYOUT_LEVERS,
         "groups": GROUP_SPRING_LEVERS, "inertia_base": BASE_LEVERS,
         "all_and_inertia_base": TABLE_LEVERS + BASE_LEVERS, "default": None}
#: The layout's constraints in the layout cases: the table top's footprint (box_m 1.5 x 1.0
#: m about the CG) and a minimum distance between isolators.
LAYOUT_CONSTRAINTS = {"footprint_m": [[-0.75, -0.5], [0.75, 0.5]],
                      "min_isolator_distance_m": 0.5}


def case_study(levers):
    """The built-in table study with ``levers`` free (default bounds and starts), the layout
    constraints with a free layout lever; ``None``: the default study (its levers free
    within its practical bounds)."""
    if levers is None:
        return default_study()
    st = table_study()
    if not levers:
        return st
    cons = LAYOUT_CONSTRAINTS if set(levers) & set(LAYOUT_LEVERS) else {}
    return st.with_changes(variables={n: {"fixed": False} for n in levers}, constraints=cons)


def row(name: str, levers, workers: int = 1) -> dict:
    """Optimize one case; its margins, lever values, active bounds and sensitivities."""
    st = case_study(levers)
    t0 = time.perf_counter()
    r = optimize_table(st, workers=workers)
    out = {"case": name, "success": r.success, "nlp_margin_db": r.objective_value,
           "analysis_margin_db": r.analysis.worst_margin_db,
           "verdict": r.analysis.verdict(), "wall_s": time.perf_counter() - t0}
    table = st.table_at(r.values)
    for n in TABLE_LEVERS:
        out[n] = getattr(table.horizontal, n)
    out.update(zip(LAYOUT_LEVERS, layout_extent(table), strict=True))
    out["inertia_base_mass_kg"] = table.inertia_base.mass_kg  # the slab (0: none)
    bounds = {v.name: (v.lower, v.upper) for v in case_study(CODESIGN_LEVERS).levers}
    for n in CODESIGN_LEVERS:  # each lever within its (default) bounds, 0 to 1
        out[f"{n}_in_bounds"] = (out[n] - bounds[n][0]) / (bounds[n][1] - bounds[n][0])
    for s in r.lever_sensitivity:
        out[f"{s['name']}_at_bound"] = s["at_bound"] or ""
        out[f"{s['name']}_db_per_unit"] = s["db_per_unit"]
    return out


def figure(df: pd.DataFrame):
    """The worst margin per case; each lever's optimum within its bounds (0 to 1)."""
    fig = new_figure(11.0, 3.8)
    fig.set_layout_engine("constrained")
    a1, a2 = fig.subplots(1, 2)
    x = range(len(df))
    case_margin_bars(a1, df["case"], df["analysis_margin_db"],
                     ylabel="worst margin to VC-C (dB, fine-grid analysis)")
    a1.set_title("built-in table: springs, levers, layout, inertia base"
                 + (", the default study" if "default" in set(df["case"]) else ""), fontsize=10)
    for j, n in enumerate(CODESIGN_LEVERS):  # within the wide bounds (the default study's
        a2.plot(x, df[f"{n}_in_bounds"], marker="o", ms=4, color=f"C{j}", label=n)  # inside)
    if "default" in set(df["case"]):  # the default study's practical bounds, as bars
        i = list(df["case"]).index("default")
        free = [v for v in default_study().levers if v.free and v.name in TABLE_LEVER_BOUNDS]
        for j, v in enumerate(free):
            lo, hi = TABLE_LEVER_BOUNDS[v.name]
            a2.plot([i + 0.08 * (j - 1.5)] * 2, [(v.lower - lo) / (hi - lo),
                                                  (v.upper - lo) / (hi - lo)],
                    color=f"C{CODESIGN_LEVERS.index(v.name)}", lw=3, alpha=0.35)
    a2.axhline(0.0, color="k", lw=0.6, ls=":")
    a2.axhline(1.0, color="k", lw=0.6, ls=":")
    a2.set_xticks(list(x), [c.replace("_", " ") for c in df["case"]], rotation=30,
                  ha="right", fontsize=7)
    a2.set_ylabel("lever within the wide bounds (0 lower, 1 upper)")
    a2.set_title("lever values at each optimum (bars: the default study's bounds)"
                 if "default" in set(df["case"]) else "lever values at each optimum", fontsize=10)
    a2.legend(fontsize=7)
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    return fig


def main(argv=None) -> int:
    """Run the cases and write the CSV and the figure."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="out/table_codesign")
    p.add_argument("--cases", default=",".join(CASES),
                   help=f"comma-separated, of {', '.join(CASES)}")
    p.add_argument("--workers", type=int, default=1)
    a = p.parse_args(argv)
    names = [c for c in a.cases.split(",") if c]
    bad = [c for c in names if c not in CASES]
    if bad:
        p.error(f"--cases: unknown {', '.join(bad)}; valid: {', '.join(CASES)}")
    rows = []
    for c in names:
        rows.append(row(c, CASES[c], a.workers))
        print(f"{c}: {rows[-1]['verdict']} ({rows[-1]['wall_s']:.0f} s)", flush=True)
    df = pd.DataFrame(rows)
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "table_codesign.csv", index=False)
    save_figure(figure(df), out / "table_codesign.png")
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        print(df.drop(columns=["verdict"]).round(4).to_string(index=False))
    print(f"wrote {out / 'table_codesign.csv'} and {out / 'table_codesign.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
