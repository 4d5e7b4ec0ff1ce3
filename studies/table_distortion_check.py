"""The table's distortion power against the six-degree-of-freedom Monte Carlo.

For each case the per-isolator closure without and with the tubes' distortion power
(:func:`isodesign.table.response.table_band_response`, ``distortion=True``;
``docs/random-response.md`` section 3b) is compared with the product's 6-DOF Monte Carlo
(:func:`isodesign.simulation.table_monte_carlo.simulate_table_response`, ``--seeds``
realizations of ``--duration`` s). See ``docs/table-monte-carlo.md``, section
"The distortion power".

Usage::

    python studies/table_distortion_check.py [--seeds 3] [--duration 160]

Prints Markdown tables: per case, the worst band error per axis and the stroke and tube
velocity errors per isolator, without -> with the distortion; for the first case, every band
of every point and axis.
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from table_monte_carlo_check import (
    F_FIT,
    LATERAL,
    _horizontal,
    asymmetric_table,
    three_isolator_table,
)

from isodesign.errors import ModelValidityWarning
from isodesign.floor import FloorSpectrum
from isodesign.simulation.monte_carlo import prony_diaphragm
from isodesign.simulation.table_monte_carlo import (
    AXES,
    lateral_prony,
    simulate_table_response,
)
from isodesign.spring.design import SpringDesign
from isodesign.table import response as tr
from isodesign.table.floor import table_floor
from isodesign.table.response import table_band_response


def offset_table(lateral_model=None):
    """The asymmetric 4-isolator table with its CG moved 0.15 m in x off the isolators'
    centroid (0.6, 0.4125) m."""
    from isodesign.table import Table

    return Table(mass_kg=600.0, isolators_m=[[0.0, 0.0], [1.2, 0.0], [1.25, 0.85], [-0.05, 0.8]],
                 cg_m=[0.75, 0.4125, 0.35], inertia_kg_m2=[[45.0, 3.0, 0.0], [3.0, 80.0, 0.0],
                                                           [0.0, 0.0, 110.0]],
                 instrument_points_m=[[0.6, 0.4, 0.5], [1.1, 0.75, 0.45]],
                 point_names=("centre", "corner"), horizontal=_horizontal(lateral_model))


def cases():
    """(name, table builder, floor, vertical diaphragm)."""
    vca = FloorSpectrum.from_criterion("VC-A")
    half = FloorSpectrum.from_band_rms(vca.bands, 0.5 * vca.band_rms_velocity(), name="VC-A/2")
    vca4 = FloorSpectrum.from_band_rms(vca.bands, 4.0 * vca.band_rms_velocity(), name="4x VC-A")
    return [
        ("asymmetric 4 isolators, VC-A in z, VC-A/2 in x and y, no diaphragm",
         asymmetric_table, table_floor(x=half, y=half, z=vca), "none"),
        ("asymmetric 4 isolators, CG 0.15 m off-centre, VC-A in z, VC-A/2 in x and y, "
         "no diaphragm", offset_table, table_floor(x=half, y=half, z=vca), "none"),
        ("asymmetric 4 isolators, VC-A in x, y, z, no diaphragm", asymmetric_table,
         table_floor(vca), "none"),
        ("3 isolators, VC-A in x, y, z, diaphragm as a Prony series at A*",
         three_isolator_table, table_floor(vca), "prony"),
        ("asymmetric 4 isolators, 4x VC-A in x, y, z, no diaphragm", asymmetric_table,
         table_floor(vca4), "none"),
    ]


def grid_table(lateral_model=None):
    """The CG-offset table with 36 instrument points on a 3 x 3 x 4 grid (x -0.1, 0.6, 1.3 m;
    y -0.1, 0.41, 0.9 m; z -0.3, 0.1, 0.5, 1.0 m): points near the nodes of the rocking
    modes, where the linear response is small and the distortion carries the band."""
    import itertools

    from isodesign.table import Table

    pts = [list(p) for p in itertools.product((-0.1, 0.6, 1.3), (-0.1, 0.4125, 0.9),
                                              (-0.3, 0.1, 0.5, 1.0))]
    return Table(mass_kg=600.0, isolators_m=[[0.0, 0.0], [1.2, 0.0], [1.25, 0.85], [-0.05, 0.8]],
                 cg_m=[0.75, 0.4125, 0.35], inertia_kg_m2=[[45.0, 3.0, 0.0], [3.0, 80.0, 0.0],
                                                           [0.0, 0.0, 110.0]],
                 instrument_points_m=pts,
                 point_names=tuple(f"({x:g}, {y:g}, {z:g})" for x, y, z in pts),
                 horizontal=_horizontal(lateral_model))


def run_case(design, build, floor, dia, seeds, duration):
    """``(plain closure, closure with distortion, Monte Carlo, seconds (plain, distortion),
    closure with the Gaussian residual)``."""
    lat, _ = lateral_prony(LATERAL, F_FIT)
    table = build(lat)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        if dia == "prony":
            a = 1.880 * table_band_response(design, table, floor, "VC-E").stroke_rms_m
            dia, _ = prony_diaphragm("viscoelastic", F_FIT, float(np.mean(a)))
        t0 = time.perf_counter()
        plain = table_band_response(design, table, floor, "VC-E", diaphragm=dia)
        t1 = time.perf_counter()
        dist = table_band_response(design, table, floor, "VC-E", diaphragm=dia, distortion=True)
        t2 = time.perf_counter()
        orig = tr.solve_table_closure_with_distortion
        try:  # the Gaussian residual (section 3b before 3c's correction), for comparison
            tr.solve_table_closure_with_distortion = functools.partial(orig, non_gaussian=False)
            gauss = table_band_response(design, table, floor, "VC-E", diaphragm=dia,
                                        distortion=True)
        finally:
            tr.solve_table_closure_with_distortion = orig
    mc = simulate_table_response(design, table, floor, target="VC-E", seeds=seeds,
                                 duration_s=duration, diaphragm=dia)  # fmt: skip
    return plain, dist, mc, (t1 - t0, t2 - t1), gauss


def _kurtosis_note(r):
    """The closure's predicted tube velocity kurtosis per isolator (distortion only)."""
    k = getattr(r, "distortion_kurtosis", None)
    return "" if k is None else " ".join(f"{v:.2f}" for v in k)


def _worst(err, bands, names):
    """Per axis: 'value (point, band)' of the largest |error|."""
    out = []
    for a in range(3):
        e = err[:, a, :]
        p, b = np.unravel_index(np.nanargmax(np.abs(e)), e.shape)
        out.append(f"{e[p, b]:+.2f} ({names[p]}, {bands.labels[b]} Hz)")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=160.0)
    a = ap.parse_args(argv)
    design = SpringDesign.reference()
    print(f"{a.seeds} seeds x {a.duration:g} s, random-phase floor\n")
    head = ["case", "closure", *(f"worst {ax} (dB)" for ax in AXES),
            "stroke error (%, per isolator)", "tube velocity error (%, per isolator)",
            "kurtosis of u: closure / MC (per isolator)"]
    rows, first, se, cost = [], None, [], []
    for name, build, floor, dia in cases():
        plain, dist, mc, secs, gauss = run_case(design, build, floor, dia, a.seeds, a.duration)
        cost.append(secs[1] / secs[0])
        se.append((np.nanmax(mc.standard_error_db()),
                   100 * np.max(mc.stroke_rms_se_m / mc.stroke_rms_m)))
        if first is None:
            first = (mc, mc.error_db(plain.velocity_rms_m_s, plain.bands),
                     mc.error_db(dist.velocity_rms_m_s, dist.bands))
        for label, r in (("without", plain), ("Gaussian residual (3b)", gauss),
                         ("with distortion (3c)", dist)):
            err = mc.error_db(r.velocity_rms_m_s, r.bands)
            s = 100 * (r.stroke_rms_m / mc.stroke_rms_m - 1)
            u = 100 * (r.tube_velocity_rms_m_s / mc.tube_velocity_rms_m_s - 1)
            rows.append([name, label, *_worst(err, mc.bands, mc.point_names),
                         " ".join(f"{v:+.1f}" for v in s), " ".join(f"{v:+.1f}" for v in u),
                         (_kurtosis_note(r) or "3") + " / "
                         + " ".join(f"{v:.2f}" for v in mc.tube_velocity_kurtosis)])
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        print("| " + " | ".join(r) + " |")
    print("\nMC standard error (max band dB, max stroke %): "
          + "; ".join(f"{b:.2f} dB, {s:.2f} %" for b, s in se))
    print("closure time with / without the distortion: "
          + ", ".join(f"{c:.1f}" for c in cost))
    # the 36-point grid: every point, axis and band
    vca = FloorSpectrum.from_criterion("VC-A")
    half = FloorSpectrum.from_band_rms(vca.bands, 0.5 * vca.band_rms_velocity(), name="VC-A/2")
    plain, dist, mcg, _, gauss = run_case(design, grid_table, table_floor(x=half, y=half, z=vca),
                                          "none", a.seeds, a.duration)
    print("\nThe CG-offset table with 36 instrument points (a 3 x 3 x 4 grid), VC-A in z, "
          "VC-A/2 in x and y: 2160 point-axis-band cells\n")
    print("| closure | worst cell (dB) | cells beyond 0.3 dB | stroke error (%, per isolator) |")
    print("|---|---|---|---|")
    for label, r in (("without", plain), ("Gaussian residual (3b)", gauss),
                     ("with distortion (3c)", dist)):
        err = mcg.error_db(r.velocity_rms_m_s, r.bands)
        p, ax, b = np.unravel_index(np.nanargmax(np.abs(err)), err.shape)
        s = 100 * (r.stroke_rms_m / mcg.stroke_rms_m - 1)
        print(f"| {label} | {err[p, ax, b]:+.2f} ({mcg.point_names[p]}, {AXES[ax]}, "
              f"{mcg.bands.labels[b]} Hz) | {int(np.sum(np.abs(err) > 0.3))} | "
              + " ".join(f"{v:+.1f}" for v in s) + " |")
    print(f"\nMC standard error, max band: {np.nanmax(mcg.standard_error_db()):.2f} dB")
    mc, e0, e1 = first
    print("\nFirst case, every band: error without -> with the distortion (dB)\n")
    print("| point, axis | " + " | ".join(mc.bands.labels) + " |")
    print("|---|" + "---|" * len(mc.bands))
    for p, pn in enumerate(mc.point_names):
        for ax in range(3):
            cells = [f"{e0[p, ax, b]:+.2f} -> {e1[p, ax, b]:+.2f}" for b in range(len(mc.bands))]
            print(f"| {pn}, {AXES[ax]} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
