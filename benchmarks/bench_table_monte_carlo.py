"""The rigid-table Monte Carlo verifier (informative): one 320 s realization in six degrees
of freedom, 4 isolators, VC-A in x, y and z, against one 1-DOF realization in the same run.

Run alone with ``python benchmarks/bench_table_monte_carlo.py`` (prints the rows) or
through ``python benchmarks/run.py``.
"""

from __future__ import annotations

import warnings

from run import median_time


def _table():
    from isodesign.table import Table

    # the default study's table: 600 kg, isolators 1.2 m x 0.8 m apart, CG 0.35 m up
    return Table.symmetric(600.0, 1.2, 0.8, 0.35)


def bench_table_monte_carlo() -> dict:
    """One 320 s realization of a 4-isolator table under a three-axis VC-A floor.

    ``simulate_table_response(reference, Table.symmetric(600, 1.2, 0.8, 0.35), "VC-A",
    seeds=1, duration_s=320, diaphragm="none")``: numba RK4 at 1/2048 s with 20 s warm-up,
    the default horizontal element's lateral stiffness as a Prony series. The notes give the
    1-DOF verifier's realization (4 x 150 kg, one spring) timed in the same run, and the
    ratio.

    Returns
    -------
    dict
        A result row (informative, no target).
    """
    from isodesign.response.isolator import Payload
    from isodesign.simulation import simulate_random_response
    from isodesign.simulation.table_monte_carlo import simulate_table_response, table_rig
    from isodesign.spring.design import SpringDesign

    design = SpringDesign.reference()
    rig = table_rig(design, _table())
    holder = {}

    def call():
        holder["r"] = simulate_table_response(None, rig, "VC-A", target="VC-E", seeds=1,
                                              duration_s=320.0, diaphragm="none")  # fmt: skip

    def call_1dof():
        simulate_random_response(design, Payload(600.0, 4), "VC-A", target="VC-E", seeds=1,
                                 duration_s=320.0, diaphragm="none")  # fmt: skip

    t = median_time(call)
    t1 = median_time(call_1dof)
    r = holder["r"]
    steps = round((r.duration_s + r.warmup_s) / r.time_step_s)
    n_lat = len(rig.lateral[0].branch_stiffness_n_per_m)
    return {
        "name": "table Monte Carlo verifier (6 DOF, 4 isolators), one 320 s realization",
        "target": "informative",
        "unit": "s",
        **t,
        "notes": f"{steps} RK4 steps of {r.time_step_s * 1e3:.3g} ms (numba), one core; "
        f"12 body states + 4 x (4 spring + {2 * n_lat} lateral Prony) states; the 1-DOF "
        f"verifier's realization in the same run: {t1['median']:.3g} s (ratio "
        f"{t['median'] / t1['median']:.1f}); stroke RMS "
        f"{r.stroke_rms_m.min() * 1e6:.3g}-{r.stroke_rms_m.max() * 1e6:.3g} um",
    }


def run() -> list[dict]:
    """All rows of this file.

    Returns
    -------
    list of dict
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [bench_table_monte_carlo()]


if __name__ == "__main__":
    for row in run():
        print(row)
