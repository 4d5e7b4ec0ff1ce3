"""IPOPT's Hessian, exact or limited-memory, measured on three studies: the rule's evidence.

For each study (the built-in vertical study, the built-in table study and a six-isolator
table, 900 kg on a 1.2 m x 0.8 m table) the whole optimization (NLP build, multi-start,
refinement, re-check, analysis) runs with the exact Hessian of the Lagrangian (CasADi) and
with IPOPT's limited-memory quasi-Newton approximation, interleaved (study by study, the
two choices alternating, ``--repeats`` times), and the script prints one row per study and
choice: the NLP's size (variables, constraints), the median wall time, the worst margin of
the optimum (dB, the NLP grid) and the starts that reached the best design. The rule
written from these rows is :func:`isodesign.optimization.hessian.hessian_choice`
(docs/optimization.md, section "The Hessian").

Each NLP is given the Hessian asked for here, whatever the rule would choose (the
vertical ``Problem`` through a subclass that states it; the table's ``TableProblem`` takes
it as an argument).

Usage::

    python studies/hessian_choice.py [--repeats 2] [--starts N] [-o out.csv]
    python studies/hessian_choice.py --solves 6,80 --solves 3,30   # the vertical NLP's solves

``--solves PPB,PEAK`` times instead the vertical NLP alone at that grid (its build, then
its solves from the study's starts one after the other, with each Hessian): the evidence
for the size threshold of the rule.

The load of the machine (``os.getloadavg``) is printed before and after.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import sys
import time
import warnings

import pandas as pd

from isodesign.optimization.study import study_from_dict, table_study, vertical_study

CHOICES = ("exact", "limited-memory")
#: Computed with the plain closure (models.distortion = false): the figures the docs quote.
PLAIN = {"distortion": False}


def six_isolator_table():
    """A 900 kg table on six isolators (three per long side), three leveling groups."""
    raw = copy.deepcopy(table_study().raw)
    raw["table"]["isolators_m"] = [[-0.6, -0.4], [0.0, -0.4], [0.6, -0.4], [0.6, 0.4],
                                   [0.0, 0.4], [-0.6, 0.4]]
    raw["table"]["leveling_groups"] = [[1, 2, 3], [4, 5], [6]]
    raw["payload"].update(mass_kg=900.0, isolators=6)
    return study_from_dict(raw, source="six_isolators.toml", fill_defaults=False)


def _vertical_problem(study, hessian):
    """The vertical NLP with the given Hessian, whatever the rule would choose."""
    from isodesign.optimization.problem import Problem

    class Forced(Problem):
        @property
        def hessian_info(self):
            return {"hessian": hessian, "reason": "forced by studies/hessian_choice.py"}

    return Forced(study)


def run_one(study, hessian):
    """One optimization with the given Hessian: (seconds, NLP size, result)."""
    t0 = time.perf_counter()
    if study.table is None:
        from isodesign.optimization.driver import optimize_vertical

        prob = _vertical_problem(study, hessian)
        res = optimize_vertical(study, problem=prob)
    else:
        from isodesign.optimization.table_driver import optimize_table
        from isodesign.optimization.table_problem import TableProblem

        prob = TableProblem(study, hessian=hessian)
        res = optimize_table(study, problem=prob)
    wall = time.perf_counter() - t0
    return wall, (int(prob.nx) if hasattr(prob, "nx") else int(prob.lbx.size),
                  int(prob.lbg.size)), res


def vertical_solves(points_per_band: int, peak_points: int, repeats: int) -> None:
    """The vertical NLP's build and its solves from the study's starts, one after the
    other, with each Hessian (interleaved): build time, total solve time, IPOPT iterations
    and the objective J each start reaches."""
    from isodesign.optimization.multistart import start_points

    st = vertical_study().with_changes(models={"points_per_band": points_per_band,
                                               "peak_points": peak_points, **PLAIN})
    for rep in range(repeats):
        for h in (CHOICES if rep % 2 == 0 else CHOICES[::-1]):
            t0 = time.perf_counter()
            prob = _vertical_problem(st, h)
            build = time.perf_counter() - t0
            solve, its, js = 0.0, [], []
            for s in start_points(st, prob.scaling):
                x0 = prob.initial_guess(s)
                t1 = time.perf_counter()
                sol = prob.solve(x0)
                solve += time.perf_counter() - t1
                its.append(sol.iterations)
                js.append(round(float(sol.objective), 4))
            print(f"  vertical, {points_per_band} points per band, {peak_points} peak points "
                  f"({prob.nx} variables), {h}: build {build:.2f} s, solves {solve:.2f} s, "
                  f"iterations {its}, J {js}, load {os.getloadavg()[0]:.1f}", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--solves", metavar="PPB,PEAK", action="append", default=[],
                    help="instead: the vertical NLP's solves from its starts at this grid "
                         "(points per band, peak points), e.g. --solves 6,80 --solves 3,30")
    ap.add_argument("--starts", type=int, default=None,
                    help="starts per optimization (default: each study's own)")
    ap.add_argument("-o", "--output", default=None, help="CSV of every run")
    args = ap.parse_args(argv)
    if args.solves:
        print(f"load average before: {os.getloadavg()}; {os.cpu_count()} cores", flush=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for spec in args.solves:
                ppb, peak = (int(v) for v in spec.split(","))
                vertical_solves(ppb, peak, args.repeats)
        return 0
    studies = {"vertical (built-in)": vertical_study(), "table (built-in)": table_study(),
               "table, 6 isolators": six_isolator_table()}
    studies = {k: v.with_changes(models=PLAIN) for k, v in studies.items()}
    if args.starts:
        studies = {k: v.with_changes(solver={"starts": args.starts})
                   for k, v in studies.items()}
    print(f"load average before: {os.getloadavg()}; {os.cpu_count()} cores", flush=True)
    runs = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for rep in range(args.repeats):
            for name, st in studies.items():
                order = CHOICES if rep % 2 == 0 else CHOICES[::-1]
                for h in order:
                    wall, size, res = run_one(st, h)
                    runs.append({"study": name, "hessian": h, "repeat": rep, "wall_s": wall,
                                 "nx": size[0], "ng": size[1],
                                 "n_frequencies": int(getattr(res.study, "models", {}).get(
                                     "points_per_band", 0)),
                                 "worst_margin_db": res.objective_value,
                                 "fine_grid_margin_db": res.worst_margin_db,
                                 "feasible": res.feasible, "success": res.success,
                                 "starts": len(res.starts), "reached_best": res.n_reached_best,
                                 "load_1min": os.getloadavg()[0]})
                    print(f"  {name:20s} {h:15s} repeat {rep}: {wall:7.2f} s, "
                          f"margin {res.objective_value:+.4f} dB, "
                          f"{res.n_reached_best}/{len(res.starts)} at the best", flush=True)
    print(f"load average after: {os.getloadavg()}", flush=True)
    df = pd.DataFrame(runs)
    if args.output:
        df.to_csv(args.output, index=False)
    print()
    print(f"{'study':22s}{'Hessian':16s}{'nx':>6s}{'ng':>6s}{'median s':>10s}"
          f"{'margin dB':>11s}{'best':>6s}")
    for (name, h), g in df.groupby(["study", "hessian"], sort=False):
        print(f"{name:22s}{h:16s}{g.nx.iloc[0]:6d}{g.ng.iloc[0]:6d}"
              f"{statistics.median(g.wall_s):10.2f}{g.worst_margin_db.iloc[0]:+11.4f}"
              f"{g.reached_best.iloc[0]:>3d}/{g.starts.iloc[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
