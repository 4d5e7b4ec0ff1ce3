"""What the robust table's search of the box costs per scenario (docs/robust.md, section 3).

On the built-in table (``table_study()``) on the coarse grid of the robust table tests
(3 points per band, one start, in this process) with payload 560-640 kg and a CG offset in y
of +-30 mm, this script measures

1. a scenario scored through its compiled NLP (``robust_table._Scenarios.check``: the
   scenario's table NLP built, its modes frozen, ``eval`` at the NumPy initial guess), the
   first time (with the build) and again (built);
2. a scenario scored by the NumPy scorer (``table_search.score_table_scenario``: no NLP), the
   median of ``--repeats`` scenarios drawn in the box;
3. the whole robust optimization with ``search_samples = 0`` (corners and centre only) and
   16 (the default: 16 samples and three local maximizations per search), its wall time and
   each round's evaluations; with ``--builtin`` the robust built-in table study instead
   (``table_study()`` on its own grid, payload +-20 %, D_c +-5 %, CG offsets +-50 mm: the
   study of ``benchmarks/bench_unify.py``; several minutes).

Usage::

    python studies/robust_table_search_cost.py [--repeats 10] [--builtin]

Timings depend on the machine and its load; the script prints them, docs/robust.md quotes a
run and the command.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import time

import numpy as np

from isodesign.optimization import robust_table
from isodesign.optimization.study import study_from_dict, table_study
from isodesign.optimization.table_search import score_table_scenario

#: The robust built-in table study's scenarios (benchmarks/bench_unify.py).
BUILTIN = {"payload_mass_kg": {"relative": 0.2}, "capillary_diameter_m": {"relative": 0.05},
           "cg_offset_x_m": {"absolute": 0.05}, "cg_offset_y_m": {"absolute": 0.05}}


def _builtin(samples: int):
    return table_study().with_changes(scenarios={**BUILTIN, "search_samples": samples})


def _study(samples: int):
    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = {"payload_mass_kg": {"min": 560.0, "max": 640.0},
                        "cg_offset_y_m": {"absolute": 0.03}, "search_samples": samples}
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    return study_from_dict(raw, source="robust_table_search_cost", fill_defaults=False)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--builtin", action="store_true",
                    help="run the robust built-in table study (step 3 only)")
    args = ap.parse_args(argv)
    if args.builtin:
        _exchanges(_builtin)
        return
    st = _study(16)
    values = {v.name: v.start for v in st.variables}
    space = st.scenarios
    sc = robust_table._Scenarios(st)
    thetas = space.box_samples(args.repeats, np.random.default_rng(0))
    first, again, cheap = [], [], []
    for th in thetas:
        t0 = time.perf_counter()
        sc.check(th, values, 0.0)
        first.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        sc.check(th, values, 0.0)
        again.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        score_table_scenario(st, th, values, 0.0, n_slots=sc.n_slots)
        cheap.append(time.perf_counter() - t0)
    med = statistics.median
    print(f"scenario through its NLP: {med(first):.3f} s the first time (build), "
          f"{med(again):.3f} s built; NumPy scorer: {med(cheap):.3f} s "
          f"(median of {args.repeats})")
    _exchanges(_study)


def _exchanges(make) -> None:
    for n in (0, 16):
        t0 = time.perf_counter()
        res = robust_table.robust_optimize_table(make(n))
        wall = time.perf_counter() - t0
        ev = [(r["search_samples"], r["search_refinement_evaluations"]) for r in res.rounds
              if r["worst_score"] is not None]
        print(f"search_samples = {n}: {wall:.1f} s, worst case {res.objective_value:.4f} dB, "
              f"{len(res.rounds)} round(s), {len(res.scenarios)} scenarios, NLP builds "
              f"{res.extra['nlp_builds']}, (samples, refinement evaluations) per search "
              f"{ev}, first search {res.extra['first_search']}")


if __name__ == "__main__":
    main()
