"""Where a sweep point's time goes (issue 27; docs/sweep.md, section 6): the reproducer.

``python benchmarks/profile_sweep.py [N]`` runs the benchmark sweep's points in small,
serially in this process under ``cProfile``: the vertical study (``vertical_study()``), one
start per point, N payload masses (default 8) x the floors VC-A and VC-B, on one parametric
NLP (built at the first point). It prints the points' table (objective, wall and CPU time,
NLP built, branch changed, solved again), IPOPT's solves by caller (the starts, the peak
refinement, the tie-break) with their iterations, and the cumulative time of the other
parts of a point (the refinement's continuous peak, the band responses, the re-check, the
run directory's files, the parametric NLP's build and its per-point view).

``python benchmarks/profile_sweep.py --table`` runs the built-in table (``table_study()``, 3
points per band, one start) over ``floor.criterion = VC-A,VC-B,VC-C`` x ``floor.x.scale =
0.5,1.0`` serially and prints the NLPs built (the table's parametric NLP, section 7);
``--table-payload`` the same table over ``payload.mass_kg = 500,600,700`` x
``payload.cg_height_m = 0.25,0.45`` (the payload's mass and CG height as parameters);
``--table-nlp [--codesign] [--floor]`` the build's and a solve's CPU time of the table's
parametric NLP against a fresh build at one payload point (``table_study()``, or
``default_study()``; ``--floor``: at another floor, on the NLP that folds the payload).
"""

from __future__ import annotations

import collections
import cProfile
import pstats
import sys
import tempfile
import time
import traceback
import warnings

#: (file, function, what it is): the parts of a point beside IPOPT's solves.
PARTS = [("refine.py", "continuous_peak_db", "continuous peak (refinement)"),
         ("driver.py", "_analyses", "band responses of the optimum and the start"),
         ("recheck.py", "recheck", "NumPy re-check"),
         ("optimize.py", "write_outputs", "run directory's files"),
         ("parametric.py", "get", "parametric NLP: build and per-point view")]


def _vertical(n: int) -> None:
    import isodesign
    from isodesign.optimization import nlp
    from isodesign.optimization.study import vertical_study

    solves = collections.defaultdict(lambda: [0, 0, 0.0])  # caller -> n, iterations, s
    real = nlp.NLP.solve

    def solve(self, x0, p=None, **kw):
        sol = real(self, x0, p, **kw)
        caller = traceback.extract_stack(limit=2)[0].name  # who called solve
        s = solves[caller]
        s[0] += 1
        s[1] += sol.iterations
        s[2] += sol.wall_s
        return sol

    nlp.NLP.solve = solve
    study = vertical_study().with_changes(solver={"starts": 1})
    vary = [f"payload.mass_kg=300:1540:{n}", "floor.criterion=VC-A,VC-B"]
    with tempfile.TemporaryDirectory() as tmp:
        isodesign.sweep(study, ["payload.mass_kg=555"], task="response",
                        output=f"{tmp}/warm", scheduler="serial", charts=False)
        prof = cProfile.Profile()
        t0 = time.perf_counter()
        prof.enable()
        res = isodesign.sweep(study, vary, output=f"{tmp}/s", scheduler="serial",
                              charts=False)
        prof.disable()
        wall = time.perf_counter() - t0
    df = res.table
    print(df[["payload.mass_kg", "floor.criterion", "objective_value", "wall_s", "cpu_s",
              "nlp_built", "branch_changed", "resolved"]].to_string())
    print(f"\n{len(df)} points in {wall:.1f} s, {res.nlp_builds} NLP built")
    print("IPOPT solves by caller: count, iterations, seconds")
    for caller, (k, its, s) in sorted(solves.items(), key=lambda kv: -kv[1][2]):
        print(f"  {caller:<16} {k:4d} {its:6d} {s:7.2f}")
    stats = pstats.Stats(prof)
    print("other parts of the points (cumulative s):")
    for where, name, label in PARTS:
        cum = sum(v[3] for f, v in stats.stats.items()
                  if f[0].endswith(where) and f[2] == name)
        print(f"  {label:<45} {cum:6.2f}")


def _table(payload: bool = False) -> None:
    import copy

    import isodesign
    from isodesign.optimization.study import study_from_dict, table_study

    raw = copy.deepcopy(table_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    base = study_from_dict(raw, source="small_table.toml", fill_defaults=False)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        vary = ["payload.mass_kg=500,600,700", "payload.cg_height_m=0.25,0.45"] if payload \
            else ["floor.criterion=VC-A,VC-B,VC-C", "floor.x.scale=0.5,1.0"]
        res = isodesign.sweep(base, vary, output=f"{tmp}/s", scheduler="serial", charts=False)
        wall = time.perf_counter() - t0
    cols = [v.split("=")[0] for v in vary]
    print(res.table[[*cols, "status", "objective_value", "nlp_built", "nlp_builds_worker",
                     "wall_s"]].to_string())
    print(f"\n{len(res.table)} points in {wall:.1f} s, {res.nlp_builds} NLPs built")


def _table_nlp(codesign: bool, floor: bool = False) -> None:
    """The table's parametric NLP against a fresh build of one point (a heavier payload with
    another CG height; ``floor``: another floor criterion, on the NLP that folds the payload,
    ``payload=False``, as a sweep that varies no payload key builds it): the build's CPU
    time and three solves' CPU time each, from the same start (the same optimum and
    iterations)."""
    import copy

    from isodesign.optimization.study import default_study, study_from_dict, table_study
    from isodesign.optimization.table_parametric import TableParametricProblem
    from isodesign.optimization.table_problem import TableProblem

    raw = copy.deepcopy((default_study if codesign else table_study)().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    base = study_from_dict(raw, source="small_table.toml", fill_defaults=False)
    st = base.with_changes({"floor.criterion": "VC-B"}) if floor else \
        base.with_changes({"payload.mass_kg": 700.0, "table.cg_m": [0.0, 0.0, 0.45]})
    t = time.process_time()
    shared = TableParametricProblem(base, payload=not floor)
    build_p = time.process_time() - t
    t = time.process_time()
    fresh = TableProblem(st)
    build_f = time.process_time() - t
    view = shared.at(st)
    x0 = view.initial_guess({v.name: v.start for v in st.variables})
    for name, prob in (("parametric", view), ("fresh", fresh)):
        cpu = []
        for _ in range(3):
            t = time.process_time()
            sol = prob.solve(x0)
            cpu.append(time.process_time() - t)
        print(f"{name}: solve CPU {', '.join(f'{c:.3f}' for c in cpu)} s, "
              f"{prob.solver.stats()['iter_count']} iterations, worst margin "
              f"{prob.worst_margin_db(sol.x):.9f} dB")
    print(f"build CPU: parametric {build_p:.2f} s, fresh {build_f:.2f} s")


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    if "--table-nlp" in sys.argv[1:]:
        _table_nlp("--codesign" in sys.argv[1:], floor="--floor" in sys.argv[1:])
    elif "--table" in sys.argv[1:] or "--table-payload" in sys.argv[1:]:
        _table(payload="--table-payload" in sys.argv[1:])
    else:
        args = [a for a in sys.argv[1:] if not a.startswith("-")]
        _vertical(int(args[0]) if args else 8)
