"""The table's closure against the six-degree-of-freedom Monte Carlo verifier.

For each verified case (table, floor, vertical diaphragm, lateral element) the rigid table
on its nonlinear isolators is simulated in the time domain
(:func:`isodesign.simulation.table_monte_carlo.simulate_table_response`, random-phase floor
in x, y and z, ``--seeds`` realizations of ``--duration`` s) and compared, point by point,
axis by axis and band by band, with :func:`isodesign.table.response.table_band_response`
(the per-isolator statistical closure). See ``docs/table-monte-carlo.md``.

Usage::

    python studies/table_monte_carlo_check.py -o out/table_mc [--seeds 4] [--duration 320]

Prints Markdown tables (worst band error per axis, with its point and band; stroke and
tube-velocity errors per isolator; the Monte Carlo standard errors) and writes
``table_monte_carlo_check.csv`` (one row per case, point, axis and band).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from isodesign.errors import ModelValidityWarning
from isodesign.floor import FloorSpectrum
from isodesign.simulation.monte_carlo import prony_diaphragm
from isodesign.simulation.table_monte_carlo import (
    AXES,
    lateral_prony,
    simulate_table_response,
)
from isodesign.spring.design import SpringDesign
from isodesign.table import HorizontalElement, Table

F_FIT = np.geomspace(0.89, 89.1, 60)
LATERAL = (2.0e4, 0.15)  # k_lat (N/m), loss factor


def _horizontal(lateral_model):
    k, eta = LATERAL
    return HorizontalElement(pendulum_length_m=0.2, lateral_stiffness_n_per_m=k,
                             lateral_loss_factor=eta, lateral_model=lateral_model,
                             elastic_centre_height_m=0.05)  # fmt: skip


def asymmetric_table(lateral_model=None) -> Table:
    """600 kg on 4 isolators of an irregular quadrilateral, CG 0.35 m up and off-centre,
    products of inertia, two instrument points (the test's case)."""
    return Table(mass_kg=600.0, isolators_m=[[0.0, 0.0], [1.2, 0.0], [1.25, 0.85], [-0.05, 0.8]],
                 cg_m=[0.68, 0.37, 0.35], inertia_kg_m2=[[45.0, 3.0, 0.0], [3.0, 80.0, 0.0],
                                                          [0.0, 0.0, 110.0]],
                 instrument_points_m=[[0.6, 0.4, 0.5], [1.1, 0.75, 0.45]],
                 point_names=("centre", "corner"), horizontal=_horizontal(lateral_model))


def three_isolator_table(lateral_model=None) -> Table:
    """360 kg on 3 isolators (one per leveling valve), CG 0.3 m up (the test's case)."""
    return Table(mass_kg=360.0, isolators_m=[[0.0, 0.0], [1.0, 0.1], [0.4, 0.9]],
                 cg_m=[0.5, 0.35, 0.3], inertia_kg_m2=[30.0, 25.0, 45.0],
                 instrument_points_m=[[0.45, 0.35, 0.45], [0.9, 0.2, 0.4]],
                 point_names=("centre", "edge"), horizontal=_horizontal(lateral_model))


def cases():
    """(name, table builder, floor, vertical diaphragm, lateral as realized in the closure)."""
    vca = FloorSpectrum.from_criterion("VC-A")
    vca4 = FloorSpectrum.from_band_rms(vca.bands, 4.0 * vca.band_rms_velocity(), name="4x VC-A")
    return [
        ("asymmetric 4 isolators, VC-A, no diaphragm", asymmetric_table, vca, "none", "prony"),
        ("3 isolators, VC-A, diaphragm as a Prony series at A*", three_isolator_table, vca,
         "prony", "prony"),
        ("asymmetric 4 isolators, VC-A, viscoelastic diaphragm", asymmetric_table, vca,
         "viscoelastic", "prony"),
        ("asymmetric 4 isolators, 4x VC-A, no diaphragm", asymmetric_table, vca4, "none",
         "prony"),
        ("asymmetric 4 isolators, VC-A, no diaphragm, hysteretic lateral in the closure",
         asymmetric_table, vca, "none", "hysteretic"),
    ]


def run_case(design, build, floor, dia, lateral, seeds, duration):
    """Closure and Monte Carlo of one case; returns (closure, mc, diaphragm used)."""
    from isodesign.table.response import table_band_response

    lat, _ = lateral_prony(LATERAL, F_FIT)
    mc_table = build(lat)  # the simulation always integrates the realized (causal) element
    cl_table = mc_table if lateral == "prony" else build(None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        if dia == "prony":
            a = 1.880 * table_band_response(design, mc_table, floor, "VC-E").stroke_rms_m
            dia, _ = prony_diaphragm("viscoelastic", F_FIT, float(np.mean(a)))
        closure = table_band_response(design, cl_table, floor, "VC-E", diaphragm=dia)
    mc = simulate_table_response(design, mc_table, floor, target="VC-E", seeds=seeds,
                                 duration_s=duration, diaphragm=dia)  # fmt: skip
    return closure, mc, dia


def main(argv=None) -> int:
    """Run every case, print the tables, write the CSV."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", required=True, help="output directory")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--duration", type=float, default=320.0)
    a = ap.parse_args(argv)
    out = Path(a.output)
    out.mkdir(parents=True, exist_ok=True)
    design = SpringDesign.reference()
    head = ["case", *(f"worst {ax} (dB)" for ax in AXES), "stroke error (per isolator)",
            "tube velocity error (max)", "MC standard error (max band, max stroke)",
            "s per realization"]  # fmt: skip
    print(f"{a.seeds} seeds x {a.duration:g} s, random-phase floor in x, y, z\n")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    frames = []
    t_all = time.perf_counter()
    for name, build, floor, dia, lateral in cases():
        cl, mc, _ = run_case(design, build, floor, dia, lateral, a.seeds, a.duration)
        err = mc.error_db(cl.velocity_rms_m_s, cl.bands)
        cells = [name]
        for ia in range(3):
            e = err[:, ia, :]
            ip, ib = np.unravel_index(int(np.argmax(np.abs(e))), e.shape)
            cells.append(f"{e[ip, ib]:+.2f} ({mc.point_names[ip]}, {mc.bands.labels[ib]} Hz)")
        se = np.nanmax(mc.standard_error_db()) if len(mc.seeds) > 1 else float("nan")
        serr = cl.stroke_rms_m / mc.stroke_rms_m - 1.0
        uerr = cl.tube_velocity_rms_m_s / mc.tube_velocity_rms_m_s - 1.0
        cells += [", ".join(f"{v:+.1%}" for v in serr),
                  f"{uerr[int(np.argmax(np.abs(uerr)))]:+.1%}",
                  f"{se:.3f} dB, {np.max(mc.stroke_rms_se_m / mc.stroke_rms_m):.2%}",
                  f"{mc.seconds_per_realization:.2f}"]  # fmt: skip
        print("| " + " | ".join(cells) + " |", flush=True)
        df = mc.to_frame()
        df.insert(0, "case", name)
        df["closure_velocity_rms_m_s"] = np.concatenate(
            [cl.velocity_rms_m_s[ip, ia][[list(cl.bands.index).index(b) for b in mc.bands.index]]
             for ip in range(len(mc.point_names)) for ia in range(3)])  # fmt: skip
        df["error_db"] = err.reshape(-1)
        frames.append(df)
    pd.concat(frames, ignore_index=True).to_csv(out / "table_monte_carlo_check.csv", index=False)
    print(f"\n[{time.perf_counter() - t_all:.0f} s; wrote {out / 'table_monte_carlo_check.csv'}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
