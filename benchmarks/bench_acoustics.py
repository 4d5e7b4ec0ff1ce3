"""Distributed acoustics (issue 16): its cost against the lumped model's, measured in one run.

Targets: the band response (reference spring, 4 x 100 kg, VC-A floor, VC-E target, the
default statistical closure) and one default ``optimize`` (all 8 starts, end to end) with
the distributed acoustics (the default) within 1.5 x of the same call with
``acoustics="lumped"`` (the model before issue 16), both timed here, interleaved, on the
same machine state. The optimize rows take 2 x 3 repeats of a few seconds each.

Run alone with ``python benchmarks/bench_acoustics.py`` (prints the rows) or through
``python benchmarks/run.py acoustics``.
"""

from __future__ import annotations

import statistics
import time
import warnings

from run import median_time

#: Target ratio distributed / lumped of the band response and of optimize.
TARGET_RATIO = 1.5
#: Timed repeats of each optimize (each is a few seconds).
OPTIMIZE_REPEATS = 3


def _band_rows() -> list[dict]:
    from isodesign.response import band_response
    from isodesign.response.isolator import Payload
    from isodesign.spring.design import SpringDesign

    payload = Payload(400.0, 4)
    out, times = [], {}
    for acoustics in ("lumped", "distributed"):
        design = SpringDesign.reference().replace(acoustics=acoustics)
        holder = {}

        def call(design=design, holder=holder):
            holder["r"] = band_response(design, payload, "VC-A", "VC-E", warn=False)

        t = median_time(call)
        times[acoustics] = t["median"]
        r = holder["r"]
        out.append({
            "name": f"band response, {acoustics} acoustics (reference spring, 4 x 100 kg)",
            "target": "",
            "unit": "s",
            **t,
            "notes": (f"{r.grid.n_points} frequencies, statistical closure, {r.iterations} "
                      f"evaluations; worst-band margin {r.worst_margin_db:+.3f} dB"),
        })
    ratio = times["distributed"] / times["lumped"]
    out.append({
        "name": "band response: distributed / lumped acoustics",
        "target": f"< {TARGET_RATIO:g}",
        "unit": "ratio",
        "median": ratio,
        "ratio": ratio / TARGET_RATIO,
        "passed": ratio < TARGET_RATIO,
        "notes": "medians of the two rows above, measured in this run",
    })
    return out


def _optimize_rows() -> list[dict]:
    from isodesign.optimization.driver import optimize
    from isodesign.optimization.study import vertical_study

    st = vertical_study()
    studies = {a: st.with_changes(models={"acoustics": a}) for a in ("lumped", "distributed")}
    walls = {a: [] for a in studies}
    res = {}
    for _ in range(OPTIMIZE_REPEATS):  # interleaved: both see the same machine load
        for a, s in studies.items():
            t0 = time.perf_counter()
            res[a] = optimize(s)
            walls[a].append(time.perf_counter() - t0)
    out = []
    for a in studies:
        r, w = res[a], walls[a]
        v = r.values
        out.append({
            "name": f"`optimize(vertical_study())`, {a} acoustics, all 8 starts",
            "target": "",
            "unit": "s",
            "median": statistics.median(w),
            "min": min(w),
            "max": max(w),
            "repeats": len(w),
            "notes": (f"{len(w)} repeats interleaved with the other model; worst-band margin "
                      f"{r.objective_value:+.4f} dB; N={v['volume_ratio']:.3f}, V_t0="
                      f"{v['top_volume_m3'] * 1e3:.4f} L, L_c={v['capillary_length_m'] * 1e3:.2f}"
                      f" mm, D_c={v['capillary_diameter_m'] * 1e3:.4f} mm; binding: "
                      + (", ".join(c.name for c in r.constraints if c.active) or "none")),
        })
    ratio = statistics.median(walls["distributed"]) / statistics.median(walls["lumped"])
    out.append({
        "name": "optimize: distributed / lumped acoustics",
        "target": f"< {TARGET_RATIO:g}",
        "unit": "ratio",
        "median": ratio,
        "ratio": ratio / TARGET_RATIO,
        "passed": ratio < TARGET_RATIO,
        "notes": "medians of the two rows above, measured in this run (interleaved repeats)",
    })
    return out


def _nlp_rows() -> list[dict]:
    """Where the optimize ratio comes from: the NLP's size and one solve's cost per model."""
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.study import vertical_study

    st = vertical_study()
    out = []
    for a in ("lumped", "distributed"):
        s = st.with_changes(models={"acoustics": a})
        t0 = time.perf_counter()
        prob = Problem(s)
        build = time.perf_counter() - t0
        sizes = {n: prob.solver.get_function(n).n_instructions()
                 for n in ("nlp_g", "nlp_jac_g", "nlp_hess_l")}
        sol = prob.solve(prob.initial_guess({v.name: v.start for v in s.variables}))
        stats = prob.solver.stats()
        per = {k: 1e3 * stats[f"t_wall_{k}"] / max(stats[f"n_call_{k}"], 1)
               for k in ("nlp_hess_l", "nlp_jac_g", "nlp_g")}
        out.append({
            "name": f"NLP of the vertical study, {a} acoustics: one solve from the study's start",
            "target": "",
            "unit": "s",
            "median": sol.wall_s,
            "repeats": 1,
            "notes": (f"{sol.iterations} IPOPT iterations ({sol.wall_s / sol.iterations * 1e3:.2f}"
                      f" ms each: Hessian {per['nlp_hess_l']:.2f} ms, Jacobian "
                      f"{per['nlp_jac_g']:.2f} ms, constraints {per['nlp_g']:.2f} ms per call);"
                      f" build {build:.2f} s; instructions: Hessian of the Lagrangian "
                      f"{sizes['nlp_hess_l']:,}, Jacobian {sizes['nlp_jac_g']:,}, constraints "
                      f"{sizes['nlp_g']:,}"),
        })
    return out


def run() -> list[dict]:
    """All rows of this file.

    Returns
    -------
    list of dict
        One result row per measurement.
    """
    warnings.simplefilter("ignore")
    return _band_rows() + _optimize_rows() + _nlp_rows()


if __name__ == "__main__":
    for row in run():
        print(row)
