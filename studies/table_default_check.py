"""A held-out check of the default study's optimum: sample the co-designed table's design
space with the product's NumPy analysis, polish the best samples, compare.

The default study (:func:`isodesign.optimization.study.default_study`: the built-in table with
its spring and its horizontal element free within practical bounds, docs/table.md section
13) is optimized by the product (:func:`isodesign.optimize`: IPOPT on the CasADi NLP, its
starts, its peak refinement). Independently of the NLP, this script

1. samples the design space, the spring's N, V_t0, L_c, D_c (log-uniform within their bounds)
   and every free lever (uniform within its bounds), in a Latin hypercube;
2. evaluates each sample with the NumPy analysis the product re-checks its optimum with:
   the fine-grid three-axis band response (:func:`isodesign.table.response.table_band_response`,
   the statistical closure per isolator) and its worst margin over every point, axis and
   band, and every constraint of the study in its exact form: the total volume, the vertical
   natural frequency ``sqrt(sum K0_i / m)``, the continuous peak of ``|T|`` per point and axis
   (:func:`isodesign.table.peaks.continuous_peaks`, from half the lowest mode to the peak
   rows' top), the static rocking margin with gravity
   (:func:`isodesign.table.modes.rocking_stability`) and the damping ratio of every mode
   below 5 Hz (the nonlinear eigenproblem at the closure,
   :func:`isodesign.table.modes.table_modes`); the peak is held to the product's tolerance
   (:data:`isodesign.optimization.refine.PEAK_TOLERANCE_DB`), the others exactly;
3. polishes the best feasible samples with a derivative-free local search on the same
   NumPy functions (SciPy's COBYQA: the worst margin maximized, every constraint an
   inequality, the bounds the study's);
4. compares: the product's optimum (its fine-grid analysis' worst margin) must be within
   ``--tolerance-db`` (0.05 dB) of the best feasible design found, or better.

Usage::

    python studies/table_default_check.py -o out/table_default_check [--samples 200]
        [--polish 4] [--evals 120] [--seed 0] [--study STUDY.toml] [--product-run DIR]

Outputs: ``samples.csv`` (every sample and every polished design: variables, worst margin,
each constraint's value, feasible), ``check.json`` (the product's optimum, the best found,
the difference and the verdict). Exit status 0 when the check holds, 1 when a better design
was found.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from isodesign.optimization.refine import PEAK_TOLERANCE_DB
from isodesign.optimization.study import default_study, load_study
from isodesign.optimization.table_problem import PEAK_ROWS_MAX_HZ
from isodesign.optimization.variables import GROUP_SPRING_LEVERS
from isodesign.response.isolator import static_stiffness
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.table.modes import rocking_stability, table_modes
from isodesign.table.peaks import closure_springs, continuous_peaks, peak_search_band
from isodesign.table.response import table_band_response
from isodesign.table.statics import level

#: A mode below this frequency has a damping row (as in the table NLP).
DAMPED_MODE_MAX_HZ = 5.0
#: Relative slack of the exact constraints (the NLP's own feasibility is 1e-6 relative).
RELATIVE_SLACK = 1e-6


def free_variables(study) -> list:
    """The study's free design variables and levers: (name, lower, upper, log-scaled); a
    group's spring variable (``<variable>_group<k>``) is log-scaled like the shared one."""
    out = [(v.name, v.lower, v.upper, True) for v in study.variables if not v.fixed]
    out += [(v.name, v.lower, v.upper, v.name in GROUP_SPRING_LEVERS) for v in study.levers
            if not v.fixed]
    return out


def to_values(free, u) -> dict:
    """Variable values of a point ``u`` of the unit cube."""
    vals = {}
    for (name, lo, hi, logged), ui in zip(free, np.clip(u, 0.0, 1.0), strict=True):
        vals[name] = float(math.exp(math.log(lo) + ui * math.log(hi / lo)) if logged
                           else lo + ui * (hi - lo))
    return vals


def to_unit(free, values) -> np.ndarray:
    """The unit-cube point of ``values``."""
    return np.array([(math.log(values[n] / lo) / math.log(hi / lo)) if logged
                     else (values[n] - lo) / (hi - lo) for n, lo, hi, logged in free])


def evaluate(study, values: dict) -> dict:
    """The worst margin and every constraint of the design ``values``, NumPy only.

    Returns
    -------
    dict
        ``margin_db`` (fine-grid analysis), each constraint's value, ``slack`` (each
        constraint's normalized slack, >= 0 when met) and ``feasible``.
    """
    c = study.constraints
    m = study.models
    out = dict(values)
    try:  # a spring outside the models (D_c >= L_c: an orifice) is not a candidate either
        d = study.design_at(values)
        table = study.table_at(values)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = table_band_response(d, table, study.floor_axes, study.target,
                                      bands=study.bands, flow=m["flow"],
                                      amplitude_mode=m["amplitude_mode"],
                                      diaphragm=m["diaphragm"], warn=False,
                                      distortion=bool(m.get("distortion", False)))
            model = res.model
            modes = table_modes(model, vertical=closure_springs(model, res.stroke_rms_m,
                                                                res.tube_velocity_rms_m_s))
            lo, hi = peak_search_band(modes, PEAK_ROWS_MAX_HZ)
            peak_db = continuous_peaks(model, res.stroke_rms_m, res.tube_velocity_rms_m_s,
                                       lo, hi).max_db
            tilt = float(rocking_stability(model).margin[0])
    except Exception as exc:  # a design the analysis cannot evaluate is not a candidate
        return {**out, "margin_db": -math.inf, "feasible": False, "error": str(exc)[:80]}
    lv = level(table, study.hardware["piston_area_m2"])
    dia = diaphragm_model(m["diaphragm"])
    designs = lv.designs(d)  # each isolator's p0 and its leveling group's spring
    k0 = sum(float(static_stiffness(di, dia, float(mi)))
             for di, mi in zip(designs, lv.mass_per_isolator_kg, strict=True))
    fn = math.sqrt(k0 / table.mass_kg) / (2 * math.pi)
    volume = max(di.total_volume_m3 for di in designs)  # the largest group's spring
    xy = np.asarray(table.isolators_m, float)
    f = np.asarray(modes.frequency_hz, float)
    low = np.isfinite(f) & (f < DAMPED_MODE_MAX_HZ)
    zeta = float(np.min(modes.damping_ratio[low])) if np.any(low) else math.inf
    out.update(margin_db=float(res.worst_margin_db), total_volume_m3=volume,
               natural_frequency_hz=fn, peak_db=float(peak_db), tilt_margin=tilt,
               damping_ratio=zeta, stable=bool(np.all(np.isfinite(f))))
    slack = {}
    if c.get("max_total_volume_m3"):
        slack["total_volume"] = 1 - volume / c["max_total_volume_m3"]
    if c.get("footprint_m"):  # every isolator inside [[x_min, y_min], [x_max, y_max]]
        x0, y0, x1, y1 = (float(v) for v in np.ravel(c["footprint_m"]))
        clear = min(float(np.min(xy[:, 0] - x0)), float(np.min(x1 - xy[:, 0])),
                    float(np.min(xy[:, 1] - y0)), float(np.min(y1 - xy[:, 1])))
        out["footprint_clearance_m"] = clear
        slack["footprint"] = clear / max(x1 - x0, y1 - y0)
    if c.get("min_isolator_distance_m"):
        gaps = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=-1)
        dmin = float(np.min(gaps[np.triu_indices(len(xy), 1)]))
        out["isolator_distance_m"] = dmin
        slack["isolator_distance"] = dmin / c["min_isolator_distance_m"] - 1
    if c.get("min_natural_frequency_hz"):
        slack["min_natural_frequency"] = fn / c["min_natural_frequency_hz"] - 1
    if c.get("max_natural_frequency_hz"):
        slack["max_natural_frequency"] = 1 - fn / c["max_natural_frequency_hz"]
    if c.get("max_peak_transmissibility_db") is not None:
        slack["peak"] = (c["max_peak_transmissibility_db"] + PEAK_TOLERANCE_DB - peak_db) / 20
    if c.get("min_tilt_margin"):
        slack["tilt_margin"] = tilt / c["min_tilt_margin"] - 1
    if c.get("min_damping_ratio"):
        slack["damping_ratio"] = zeta / c["min_damping_ratio"] - 1
    out["slack"] = slack
    out["feasible"] = bool(out["stable"] and all(v >= -RELATIVE_SLACK for v in slack.values()))
    return out


def latin_hypercube(n: int, dim: int, seed: int) -> np.ndarray:
    """``n`` points of a Latin hypercube in the unit cube."""
    rng = np.random.default_rng(seed)
    u = (np.argsort(rng.random((n, dim)), axis=0) + rng.random((n, dim))) / n
    return u


def polish(study, free, values: dict, evals: int) -> dict:
    """A derivative-free local search (COBYQA) from ``values``: the best feasible design."""
    from scipy.optimize import Bounds, NonlinearConstraint, minimize

    cache: dict = {}

    def ev(u):
        key = tuple(np.round(np.clip(u, 0, 1), 12))
        if key not in cache:
            cache[key] = evaluate(study, to_values(free, np.asarray(key)))
        return cache[key]

    def objective(u):
        r = ev(u)
        return -r["margin_db"] if math.isfinite(r["margin_db"]) else 1e3

    names = list(evaluate(study, values)["slack"])

    def slack(u):
        r = ev(u)
        return np.array([r.get("slack", {}).get(n, -1.0) for n in names])

    u0 = to_unit(free, values)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        minimize(objective, u0, method="COBYQA", bounds=Bounds(0.0, 1.0),
                 constraints=[NonlinearConstraint(slack, -RELATIVE_SLACK, np.inf)],
                 options={"maxfev": evals, "initial_tr_radius": 0.05, "final_tr_radius": 1e-5})
    feas = [r for r in cache.values() if r["feasible"]]
    return max(feas, key=lambda r: r["margin_db"]) if feas else ev(u0)


def check(study, *, samples: int, polish_n: int, evals: int, seed: int,
          product=None) -> tuple[dict, pd.DataFrame]:
    """Run the check; ``product``: the study's optimum (its result, or its values by name;
    computed when None)."""
    from isodesign.optimization.dispatch import optimize

    free = free_variables(study)
    t0 = time.perf_counter()
    if product is None:
        product = optimize(study)
    t_product = time.perf_counter() - t0
    p_values = dict(product.values) if not isinstance(product, dict) else product
    p_eval = evaluate(study, p_values)
    rows = []
    t0 = time.perf_counter()
    for i, u in enumerate(latin_hypercube(samples, len(free), seed)):
        r = evaluate(study, to_values(free, u))
        rows.append({**r, "kind": "sample", "index": i})
    feas = sorted((r for r in rows if r["feasible"]), key=lambda r: -r["margin_db"])
    for j, r in enumerate(feas[:polish_n]):
        start = {n: r[n] for n, *_ in free}
        best = polish(study, free, start, evals)
        rows.append({**best, "kind": "polished", "index": j})
    t_check = time.perf_counter() - t0
    found = [r for r in rows if r["feasible"]]
    best = max(found, key=lambda r: r["margin_db"]) if found else None
    diff = None if best is None else best["margin_db"] - p_eval["margin_db"]
    summary = {
        "study": study.name, "free": [n for n, *_ in free],
        "product_margin_db": p_eval["margin_db"], "product_feasible": p_eval["feasible"],
        "product_reported_margin_db": (None if isinstance(product, dict)
                                       else product.analysis.worst_margin_db),
        "product_values": p_values, "product_wall_s": t_product,
        "samples": samples, "feasible_samples": sum(1 for r in rows if r["kind"] == "sample"
                                                    and r["feasible"]),
        "polished": polish_n, "evals_per_polish": evals, "seed": seed,
        "best_found_margin_db": None if best is None else best["margin_db"],
        "best_found_values": None if best is None else {n: best[n] for n, *_ in free},
        "best_found_kind": None if best is None else best["kind"],
        "best_minus_product_db": diff, "check_wall_s": t_check,
    }
    frame = pd.DataFrame([{k: v for k, v in r.items() if k != "slack"} for r in rows])
    return summary, frame


def main(argv=None) -> int:
    """Run the check and write ``samples.csv`` and ``check.json``."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", default="out/table_default_check")
    p.add_argument("--study", help="a table study file (default: the built-in default study)")
    p.add_argument("--samples", type=int, default=200)
    p.add_argument("--polish", type=int, default=4, help="best feasible samples polished")
    p.add_argument("--evals", type=int, default=120, help="evaluations per polish")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--tolerance-db", type=float, default=0.05)
    p.add_argument("--product-run", metavar="DIR",
                   help="an isodesign optimize run directory of the same study (its "
                   "design.json's optimum; e.g. out/demo/optimize): not optimized again")
    a = p.parse_args(argv)
    study = default_study() if a.study is None else load_study(a.study)
    product = None
    if a.product_run is not None:
        run = Path(a.product_run)
        rec = json.loads((run / "record.json").read_text(encoding="utf-8"))
        if load_study(run / "study_resolved.toml").raw != study.raw:
            p.error(f"--product-run: {run} is a run of another study ({rec['study']['name']!r})")
        design = json.loads((run / "design.json").read_text(encoding="utf-8"))
        product = {n: v["value"] for n, v in design["variables"].items()}
    summary, frame = check(study, samples=a.samples, polish_n=a.polish, evals=a.evals,
                           seed=a.seed, product=product)
    diff = summary["best_minus_product_db"]
    summary["tolerance_db"] = a.tolerance_db
    summary["holds"] = bool(summary["product_feasible"] and (diff is None
                                                            or diff <= a.tolerance_db))
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / "samples.csv", index=False)
    (out / "check.json").write_text(json.dumps(summary, indent=2, default=float) + "\n",
                                    encoding="utf-8")
    print(f"product optimum: {summary['product_margin_db']:+.3f} dB (feasible: "
          f"{summary['product_feasible']}; {summary['product_wall_s']:.0f} s)")
    print(f"sampled: {a.samples} points, {summary['feasible_samples']} feasible; polished "
          f"{a.polish} x {a.evals} evaluations ({summary['check_wall_s']:.0f} s)")
    if diff is None:
        print("no feasible design found by sampling")
    else:
        print(f"best found: {summary['best_found_margin_db']:+.3f} dB "
              f"({summary['best_found_kind']}); best found - product = {diff:+.3f} dB")
    print(("HOLDS" if summary["holds"] else "FAILS") + f": the product's optimum is within "
          f"{a.tolerance_db:g} dB of the best feasible design found, or better")
    print(f"wrote {out / 'samples.csv'} and {out / 'check.json'}")
    return 0 if summary["holds"] else 1


if __name__ == "__main__":
    sys.exit(main())
