"""The table in six degrees of freedom (docs/table.md): the three-axis band response of a
4-isolator table (target < 100 ms), the three-axis optimize of the built-in table study
(target < 10 s), each against the vertical-only path timed in the same run; informative:
an asymmetric table's band response, the modes (nonlinear eigenproblem), and one NLP solve
with the exact Hessian against the limited-memory one; the co-designed built-in table (the
default study) against the same study with only the spring free (target: within 5x).

Run alone with ``python benchmarks/bench_table.py`` (prints the rows) or through
``python benchmarks/run.py table``.
"""

from __future__ import annotations

import statistics
import time
import warnings

from run import median_time

#: Target: a three-axis band response of a 4-isolator table, 20 bands x 50 points.
TARGET_TABLE_RESPONSE_S = 0.1
#: Target: the default three-axis optimize (the built-in table study).
TARGET_TABLE_OPTIMIZE_S = 10.0
#: Target: the co-designed built-in table (the default study) within this factor of the same
#: study with only the spring variables free (issue 24).
TARGET_CODESIGN_RATIO = 5.0
#: Interleaved repeats of the co-design pair.
CODESIGN_REPEATS = 3


def _symmetric():
    from isodesign.table import Table

    return Table.symmetric(400.0, 1.2, 0.8, 0.35,
                           instrument_points_m=[(0.0, 0.0, 0.7), (0.5, 0.3, 0.7)])


def _asymmetric():
    from isodesign.table import Table

    return Table(400.0, [(0.0, 0.0), (1.2, 0.0), (1.2, 0.8), (0.0, 0.8)], (0.5, 0.45, 0.4),
                 [40.0, 60.0, 90.0], instrument_points_m=[(0.6, 0.4, 0.8), (1.1, 0.7, 0.8)])


def bench_table_response() -> dict:
    """``table_band_response(reference, 4-isolator table, "VC-A" (x, y, z), "VC-E")``.

    Returns
    -------
    dict
        A result row; the notes give the vertical ``band_response`` of the same payload
        timed in the same run and the ratio.
    """
    from isodesign.response import band_response
    from isodesign.response.isolator import Payload
    from isodesign.spring.design import SpringDesign
    from isodesign.table.response import table_band_response

    d = SpringDesign.reference()
    table = _symmetric()
    holder = {}

    def call():
        holder["r"] = table_band_response(d, table, "VC-A", "VC-E", warn=False)

    t = median_time(call)
    t1 = median_time(lambda: band_response(d, Payload(400.0, 4), "VC-A", "VC-E", warn=False))
    r = holder["r"]
    return {
        "name": "table band response, 3 axes, 4 isolators, 2 points (statistical closure "
                "per isolator)",
        "target": f"< {TARGET_TABLE_RESPONSE_S * 1e3:g} ms",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_TABLE_RESPONSE_S,
        "passed": t["median"] < TARGET_TABLE_RESPONSE_S,
        "notes": f"{len(r.bands)} bands x {r.grid.axis_grids[2].points_per_band} points = "
                 f"{r.grid.n_points} frequencies, 3 floor axes, {r.iterations} closure "
                 f"evaluations (Anderson), 6x6 complex solve per frequency; the vertical "
                 f"band_response (4 x 100 kg, with its stability figures) in the same run: "
                 f"{t1['median'] * 1e3:.3g} ms (table / vertical = "
                 f"{t['median'] / t1['median']:.2f}); verdict: {r.verdict()}",
    }


def bench_table_response_asymmetric() -> dict:
    """Informative: an off-centre CG (three distinct p0, no shared spring evaluations).

    Returns
    -------
    dict
    """
    from isodesign.spring.design import SpringDesign
    from isodesign.table.response import table_band_response

    d = SpringDesign.reference()
    table = _asymmetric()
    holder = {}

    def call():
        holder["r"] = table_band_response(d, table, "VC-A", "VC-E", warn=False)

    t = median_time(call)
    r = holder["r"]
    return {"name": "table band response, off-centre CG (3 distinct p0)", "target": "",
            "unit": "s", **t,
            "notes": f"{r.grid.n_points} frequencies, {r.iterations} closure evaluations; "
                     f"stroke RMS {r.stroke_rms_m.min() * 1e6:.3g}-"
                     f"{r.stroke_rms_m.max() * 1e6:.3g} um"}


def bench_table_modes() -> dict:
    """Informative: the six modes of the built-in table (nonlinear eigenproblem).

    Returns
    -------
    dict
    """
    from isodesign.optimization.study import table_study
    from isodesign.table.model import table_model
    from isodesign.table.modes import table_modes

    st = table_study()
    m = st.models
    model = table_model(st.start_design(), st.table, flow=m["flow"],
                        amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])
    holder = {}

    def call():
        holder["r"] = table_modes(model)

    t = median_time(call)
    md = holder["r"]
    return {"name": "table modes (6, frequency-dependent stiffness, fixed point per mode)",
            "target": "", "unit": "s", **t,
            "notes": f"iterations per mode {[int(i) for i in md.iterations]}; frequencies "
                     + ", ".join(f"{f:.3g}" for f in md.frequency_hz) + " Hz"}


def bench_table_optimize() -> list[dict]:
    """``optimize_table(table_study())`` end to end (median of 3), against ``optimize``
    of the vertical study (once, same run); the exact-Hessian solve (informative).

    Returns
    -------
    list of dict
    """
    from isodesign.optimization.driver import optimize
    from isodesign.optimization.study import table_study, vertical_study
    from isodesign.optimization.table_driver import optimize_table
    from isodesign.optimization.table_problem import TableProblem

    st = table_study()
    holder = {}

    def call():
        holder["r"] = optimize_table(st)

    t = median_time(call, n_repeats=3, warmup=0)
    t0 = time.perf_counter()
    optimize(vertical_study())
    t_vert = time.perf_counter() - t0
    r = holder["r"]
    rows = [{
        "name": "optimize the built-in table study (3 axes, 2 points, 4 starts)",
        "target": f"< {TARGET_TABLE_OPTIMIZE_S:g} s",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_TABLE_OPTIMIZE_S,
        "passed": t["median"] < TARGET_TABLE_OPTIMIZE_S,
        "notes": f"NLP build, {len(r.starts)} starts ({r.n_reached_best} reached the best), "
                 f"mode refreshes {r.mode_rounds}, NumPy re-check, fine-grid analyses of "
                 f"optimum and start; worst margin {r.objective_value:+.2f} dB (NLP grid); "
                 f"the vertical optimize(vertical_study()) (8 starts) once in the same run: "
                 f"{t_vert:.3g} s (table / vertical = {t['median'] / t_vert:.2f})",
    }]
    sols = {}
    for h in ("limited-memory", "exact"):
        tb = time.perf_counter()
        prob = TableProblem(st, hessian=h)
        build = time.perf_counter() - tb
        x0 = prob.initial_guess({v.name: v.start for v in st.variables})
        sols[h] = (build, prob.solve(x0))
    (b_l, s_l), (b_e, s_e) = sols["limited-memory"], sols["exact"]
    rows.append({"name": "table NLP, one solve from the study's start: exact Hessian vs "
                         "limited-memory", "target": "", "unit": "s", "median": s_e.wall_s,
                 "notes": f"exact: {s_e.iterations} iterations, {s_e.wall_s:.3g} s (build "
                          f"{b_e:.3g} s), margin {-s_e.objective:+.4f} dB; limited-memory: "
                          f"{s_l.iterations} iterations, {s_l.wall_s:.3g} s (build {b_l:.3g} "
                          f"s), margin {-s_l.objective:+.4f} dB; ratio "
                          f"{s_e.wall_s / s_l.wall_s:.2f}"})
    return rows


def springs_only(st):
    """The study ``st`` with only the spring variables free: every co-design lever fixed at
    its start and no per-group spring (every leveling group takes the shared spring)."""
    import copy

    from isodesign.optimization.study import study_from_dict
    from isodesign.optimization.variables import GROUP_SPRING_LEVERS

    raw = copy.deepcopy(st.raw)
    for name in GROUP_SPRING_LEVERS:
        raw["variables"].pop(name, None)
    for v in st.levers:
        if v.name in raw["variables"]:
            raw["variables"][v.name]["fixed"] = True
    return study_from_dict(raw, source="springs only")


def bench_table_codesign() -> list[dict]:
    """``optimize_table(default_study())`` (the built-in table with its co-design levers
    free: the springs of the three leveling groups, the horizontal element and the spacing)
    against the same study with only the spring free (:func:`springs_only`), interleaved
    repeats in one run; the ratio of the medians.

    Returns
    -------
    list of dict
    """
    from isodesign.optimization.study import default_study
    from isodesign.optimization.table_driver import optimize_table

    st = default_study()
    studies = {"springs": springs_only(st), "co-designed": st}
    walls = {k: [] for k in studies}
    res = {}
    for _ in range(CODESIGN_REPEATS):  # interleaved: both see the same machine load
        for k, s in studies.items():
            t0 = time.perf_counter()
            res[k] = optimize_table(s)
            walls[k].append(time.perf_counter() - t0)
    out = []
    for k, what in (("springs", "only the spring free (N, V_t0, L_c, D_c; levers fixed)"),
                    ("co-designed", "the springs of the three leveling groups, the four "
                                    "horizontal levers and the spacing free (the default "
                                    "study)")):
        r, w = res[k], walls[k]
        out.append({
            "name": f"optimize the built-in table co-design study, {what}",
            "target": "", "unit": "s", "median": statistics.median(w), "min": min(w),
            "max": max(w), "repeats": len(w),
            "notes": f"{len(w)} repeats interleaved with the other row; {len(r.starts)} "
                     f"solves ({r.n_reached_best} reached the best); worst margin "
                     f"{r.analysis.worst_margin_db:+.2f} dB (fine-grid analysis), "
                     f"{r.analysis.verdict().split(':')[0]}",
        })
    ratio = statistics.median(walls["co-designed"]) / statistics.median(walls["springs"])
    out.append({
        "name": "optimize the built-in table: co-designed / springs only",
        "target": f"< {TARGET_CODESIGN_RATIO:g}", "unit": "ratio", "median": ratio,
        "ratio": ratio / TARGET_CODESIGN_RATIO, "passed": ratio < TARGET_CODESIGN_RATIO,
        "notes": "medians of the two rows above, measured in this run (interleaved repeats); "
                 "the co-designed study runs staged starts (docs/table.md, section 13)",
    })
    return out


def run() -> list[dict]:
    """All rows of this file.

    Returns
    -------
    list of dict
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [bench_table_response(), bench_table_response_asymmetric(), bench_table_modes(),
                *bench_table_optimize(), *bench_table_codesign()]


if __name__ == "__main__":
    for row in run():
        print(row)
