"""Robust design of the vertical study: +-5 % D_c and L_c, payload 480-720 kg (docs/robust.md).

``robust_optimize`` end to end (the nominal multi-start optimization included, 2 forked
workers), median of 3 without warm-up (each about 10-20 s); then, informative, the robust
optimum judged at 1,000 uniform draws from the box with the NumPy analysis (2 forked
workers): the largest constraint violation, the continuous peak's largest excess, and
the stated worst case minus the worst draw (must be <= 0.05 dB).
"""

from __future__ import annotations

import statistics
import time

#: Target of the robust vertical study, s.
TARGET_ROBUST_S = 30.0
REPEATS = 3
SCENARIOS = {"payload_mass_kg": {"min": 480.0, "max": 720.0},
             "capillary_diameter_m": {"relative": 0.05},
             "capillary_length_m": {"relative": 0.05}}


def _load() -> str:
    try:
        with open("/proc/loadavg") as f:
            return "load " + " ".join(f.read().split()[:3])
    except OSError:
        return "load n/a"


def run() -> list[dict]:
    """The robust vertical study's wall time and its check at 1,000 draws."""
    from isodesign.optimization.exchange import robust_optimize
    from isodesign.optimization.study import vertical_study
    from isodesign.optimization.yields import estimate_yield

    st = vertical_study().with_changes(scenarios=SCENARIOS)
    load0 = _load()
    times, res = [], None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        res = robust_optimize(st)
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    rounds = len(res.rounds)
    nom_s = res.nominal.wall_s
    rows = [{
        "name": "`robust_optimize` of the vertical study (+-5 % D_c, L_c; 480-720 kg)",
        "target": f"< {TARGET_ROBUST_S:g} s", "unit": "s", "median": med, "min": min(times),
        "max": max(times), "repeats": REPEATS, "ratio": med / TARGET_ROBUST_S,
        "passed": med < TARGET_ROBUST_S,
        "notes": (f"{load0} before, {_load()} after; nominal optimization (8 starts) "
                  f"{nom_s:.1f} s of the last run; {rounds} exchange rounds, "
                  f"{len(res.scenarios)} scenarios "
                  f"({len(res.active_scenarios())} active), converged={res.converged}; "
                  f"worst case {res.objective_value:+.3f} dB, nominal "
                  f"{res.nominal.objective_value:+.3f} dB; per round (scenarios/IPOPT "
                  "iterations/solve s/round s): " + ", ".join(
                      f"{r['scenarios']}/{r['iterations']}/{r['solve_s']:.2f}/"
                      f"{r['wall_s']:.2f}" for r in res.rounds)),
    }]
    t0 = time.perf_counter()
    y = estimate_yield(st, res.values, samples=1000, seed=1, workers=2)
    t_y = time.perf_counter() - t0
    gap = res.objective_value - y.worst("objective", "min")
    rows.append({
        "name": "informative: the robust optimum at 1,000 draws from the box (NumPy analysis)",
        "target": "", "unit": "s", "median": t_y, "ratio": "",
        "notes": (f"yield {100 * y.fraction:.1f} % (CI {100 * y.interval[0]:.2f}-"
                  f"{100 * y.interval[1]:.2f} %); largest violation "
                  f"{y.worst('max_violation'):.1e}; continuous peak excess "
                  f"{y.worst('peak_excess_db'):+.3f} dB; stated worst case - worst draw "
                  f"{gap:+.3f} dB (<= 0.05 required); price in nominal margin "
                  f"{res.nominal.objective_value - res.nominal_at_robust():.3f} dB"),
    })
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
