"""Measured data in: a diaphragm fit on 80 rig points, and a one-hour 1 kHz three-axis
survey record's analysis (Welch, 1-80 Hz bands, mean/max/p90 per band).

Run alone with ``python benchmarks/bench_calibration.py`` (prints the rows) or through
``python benchmarks/run.py``.
"""

from __future__ import annotations

import sys

import numpy as np
from run import median_time

#: Targets (interactive use: a fit or a survey answers within seconds).
TARGET_DIAPHRAGM_FIT_S = 10.0
TARGET_SURVEY_HOUR_S = 10.0


def bench_diaphragm_fit() -> dict:
    """``fit_diaphragm`` on simulated single-chamber data: 20 frequencies x 4 amplitudes.

    Returns
    -------
    dict
        A result row.
    """
    from isodesign.calibration import MeasuredStiffness, fit_diaphragm
    from isodesign.simulation.harmonic_rig import simulate_grid
    from isodesign.spring.design import SpringDesign

    ref = SpringDesign.reference()
    f = np.geomspace(0.2, 24.0, 20)
    x = np.array([0.05, 0.1, 0.2, 0.5]) * 1e-3
    g = simulate_grid(ref.replace(capillary_diameter_m=1e-5), f, x, flow="poiseuille")
    rng = np.random.default_rng(0)
    k = g.k + np.abs(g.k) * 0.01 * (rng.standard_normal(g.k.shape) + 1j * rng.standard_normal(
        g.k.shape))  # fmt: skip
    ff, xx = np.meshgrid(f, x, indexing="ij")
    data = MeasuredStiffness(ff.ravel(), xx.ravel(), k.ravel(), "single_chamber", "bench")
    holder = {}

    def call():
        holder["r"] = fit_diaphragm(data, ref)

    t = median_time(call)
    r = holder["r"]
    notes = (
        f"{data.k.size} points; {len(r.cv_table)} CV settings x 5 folds + 1 final QP "
        f"(cvxpy/Clarabel, {r.model.relaxation_times_s.size} relaxation times, degree "
        f"{r.model.degree}); lambda {r.regularization:.3g}, RMS residual "
        f"{r.rms_relative_residual:.2%}"
    )
    return {
        "name": "diaphragm fit (80 points, cross-validated)",
        "target": f"< {TARGET_DIAPHRAGM_FIT_S:g} s",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_DIAPHRAGM_FIT_S,
        "passed": t["median"] < TARGET_DIAPHRAGM_FIT_S,
        "notes": notes,
    }


def bench_survey_hour() -> dict:
    """``analyze_record`` of a one-hour, 1 kHz, three-axis acceleration record (in memory).

    Returns
    -------
    dict
        A result row.
    """
    from isodesign.floor.survey import SurveyRecord, analyze_record

    fs = 1000.0
    n = int(3600 * fs)
    rng = np.random.default_rng(0)
    data = rng.standard_normal((n, 3)) * 1e-4
    rec = SurveyRecord(fs, ("x", "y", "z"), data, "acceleration", "m/s^2", "bench")
    holder = {}

    def call():
        holder["r"] = analyze_record(rec)

    t = median_time(call)
    r = holder["r"]
    notes = (
        f"{n:.2e} samples x 3 axes; {r.n_segments} Hann segments of {r.segment_s:.4g} s, 50 % "
        f"overlap; {len(r.bands)} bands; CSV reading not included"
    )
    return {
        "name": "survey analysis, 1 h at 1 kHz, 3 axes",
        "target": f"< {TARGET_SURVEY_HOUR_S:g} s",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_SURVEY_HOUR_S,
        "passed": t["median"] < TARGET_SURVEY_HOUR_S,
        "notes": notes,
    }


def run() -> list[dict]:
    """Every row of this file."""
    return [bench_diaphragm_fit(), bench_survey_hour()]


if __name__ == "__main__":
    for row in run():
        print(row, file=sys.stdout)
