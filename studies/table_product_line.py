"""The built-in table as a product line: 1,000 optima over payload mass, CG height and floor.

The built-in table study (:func:`isodesign.optimization.study.table_study`: 4 isolators
1.2 m x 0.8 m apart, three leveling valves, VC-C needed at two instrument points in x, y
and z) is optimized again at every point of

* payload mass 300 to 870 kg (20 values; above about 900 kg the pendulum's stiffness
  leaves the torsion mode below the 5 % damping the study asks for, which no spring
  variable changes: such a study is refused),
* CG height 0.15 to 0.60 m above the support plane (10 values; ``payload.cg_height_m``
  moves ``table.cg_m``'s height, the instrument points stay on the table top),
* five floors, from the noisiest to the quietest: ISO residential (day), ISO operating
  theatre, VC-A, VC-B, VC-C (each in x, y and z),

as one :func:`isodesign.sweep` on a local Dask cluster (``--workers``, default 2), each point
two starts: the finished lighter neighbour's optimum along the mass line (continuation) and
one Latin-hypercube start (``docs/sweep.md``, section 7). The sweep directory resumes: an
interrupted run is finished by running the script again; ``--replot`` only redraws the
figure from the sweep directory as it is (finished points; the others blank).

Usage::

    nice -n 19 python studies/table_product_line.py -o out/table_product_line [--workers 2]
    python studies/table_product_line.py -o out/table_product_line --replot
    python studies/table_product_line.py --replot --sweep-dir /tmp/sweep27-1000 \\
        --figure docs/img/table_product_line.png

``--check N`` optimizes N finished points again cold (8 starts, no neighbour's; the points
that changed branch first) and prints how far the sweep's optimum is from it
(``OUT/table_product_line_check.csv``).

Outputs: ``OUT/sweep/`` (the sweep directory, its ``charts/``), ``OUT/table_product_line.png``
(the binding map: the binding set of every point over mass and CG height, one panel per
floor, the boundaries where the set changes drawn, the points whose continuation changed
branch dotted) and ``OUT/table_product_line.csv`` (how many points each binding set holds,
per floor). The same sweep from the command line::

    isodesign sweep --builtin table --vary payload.mass_kg=300:870:20 \\
        --vary payload.cg_height_m=0.15:0.6:10 --vary floor.criterion=ISO-residential-day,\\
    ISO-operating-theatre,VC-A,VC-B,VC-C --vary models.distortion=false --starts 2 \\
        --workers 2 -o OUT/sweep

(``--vary models.distortion=false``: the plain closure the script pins, one value.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import isodesign
from isodesign.optimization.study import table_study
from isodesign.plotting.style import save_figure
from isodesign.plotting.sweep import binding_map, binding_map_data
from isodesign.sweeps import parse_vary, read_table, sweep_record

#: Computed with the plain closure (models.distortion = false): the figures the docs quote.
PLAIN = {"distortion": False}

#: The swept keys and their values (``--vary`` syntax); the first varies slowest.
VARY = ("payload.mass_kg=300:870:20", "payload.cg_height_m=0.15:0.6:10",
        "floor.criterion=ISO-residential-day,ISO-operating-theatre,VC-A,VC-B,VC-C")
#: Starts per point: the neighbour's optimum (or the study's start) and one more.
STARTS = 2


def run_sweep(directory: Path, workers: int, scheduler: str | None = None):
    """The sweep (resumed when ``directory`` holds part of it)."""
    study = table_study().with_changes(solver={"starts": STARTS}, models=PLAIN)
    return isodesign.sweep(study, vary=list(VARY), output=directory, workers=workers,
                           scheduler=scheduler)


def figure(directory: Path, out_png: Path, out_csv: Path | None = None):
    """The binding map of the sweep directory as it is, and the count of each set."""
    rec = sweep_record(directory)
    if rec is None:
        raise SystemExit(f"{directory}: no sweep directory (record.json of isodesign sweep)")
    df = read_table(directory)
    keys = [k for k in (rec.get("sweep") or {}).get("keys") or [] if k in df]
    order = dict(parse_vary(v) for v in VARY)  # the axes and panels in the sweep's order
    total = 1
    for v in order.values():
        total *= len(v)
    done = int(df["status"].isin(["complete", "infeasible"]).sum())
    title = (f"The built-in table over payload mass, CG height and floor: binding set per "
             f"point ({done} of {total} points finished"
             + ("" if done >= total else "; blank: not run yet") + ")")
    fig = binding_map(df, keys, x="payload.mass_kg", y="payload.cg_height_m", title=title,
                      order=order)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, out_png, dpi=110)
    data = binding_map_data(df, keys, x="payload.mass_kg", y="payload.cg_height_m")
    counts = data.groupby(["facet", "category"]).size().rename("points").reset_index()
    if out_csv is not None:
        counts.to_csv(out_csv, index=False)
    return done, total, counts, int(data["branch_changed"].sum())


def cold_check(directory: Path, n: int, starts: int = 8) -> list[dict]:
    """Points of the sweep optimized again cold with ``starts`` starts (no neighbour): the
    points that changed branch first, then points spread over the finished ones.

    Returns one dict per point: its keys, the sweep's and the cold optimum's objective and
    their difference (dB)."""
    import numpy as np

    df = read_table(directory)
    done = df[df["status"] == "complete"].reset_index(drop=True)
    pick = list(done.index[done["branch_changed"].fillna(False).astype(bool)])[:n]
    rest = [i for i in np.linspace(0, len(done) - 1, n).round().astype(int) if i not in pick]
    out = []
    for i in (pick + rest)[:n]:
        r = done.iloc[i]
        h = float(r["payload.cg_height_m"])
        st = table_study().with_changes(payload={"mass_kg": float(r["payload.mass_kg"]),
                                                 "cg_height_m": h},
                                        table={"cg_m": [0.0, 0.0, h]},
                                        floor={"criterion": r["floor.criterion"]},
                                        solver={"starts": starts, "workers": 1},
                                        models=PLAIN)
        cold = isodesign.optimize(st)
        out.append({"payload.mass_kg": r["payload.mass_kg"], "payload.cg_height_m": h,
                    "floor.criterion": r["floor.criterion"],
                    "branch_changed": bool(r["branch_changed"]),
                    "sweep_db": float(r["objective_value"]),
                    "cold_db": float(cold.objective_value),
                    "difference_db": float(r["objective_value"] - cold.objective_value)})
        print(out[-1], flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="out/table_product_line")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", default=None, help="a Dask scheduler address or 'serial'")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw the figure from the sweep directory as it is")
    ap.add_argument("--sweep-dir", default=None, help="the sweep directory (default OUT/sweep)")
    ap.add_argument("--figure", default=None,
                    help="where to write the figure (default OUT/table_product_line.png)")
    ap.add_argument("--check", type=int, default=0, metavar="N",
                    help="optimize N finished points again cold (8 starts, no neighbour) and "
                    "print the difference from the sweep's optimum")
    a = ap.parse_args(argv)
    out = Path(a.output)
    directory = Path(a.sweep_dir) if a.sweep_dir else out / "sweep"
    if not a.replot:
        res = run_sweep(directory, a.workers, a.scheduler)
        print(res, file=sys.stderr)
    png = Path(a.figure) if a.figure else out / "table_product_line.png"
    csv = out / "table_product_line.csv"
    csv.parent.mkdir(parents=True, exist_ok=True)
    done, total, counts, changed = figure(directory, png, csv)
    print(f"{done} of {total} points finished; {changed} changed branch; wrote {png}, {csv}")
    print(counts.to_string(index=False))
    if a.check:
        import pandas as pd

        rows = cold_check(directory, a.check)
        pd.DataFrame(rows).to_csv(out / "table_product_line_check.csv", index=False)
        worst = max(abs(r["difference_db"]) for r in rows)
        print(f"{len(rows)} points against a cold 8-start optimize: largest difference "
              f"{worst:.2g} dB; wrote {out / 'table_product_line_check.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
