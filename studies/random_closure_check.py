"""The random-input closures against the Monte Carlo verifier (docs/random-response.md).

For each verified case (design, payload, floor, flow model, diaphragm) the nonlinear lumped
model is simulated in the time domain (:func:`isodesign.simulation.simulate_random_response`,
random-phase Gaussian floor, ``--seeds`` realizations of ``--duration`` s) and compared,
band by band, with :func:`isodesign.response.band_response` under the statistical
linearization (the default) and the older harmonic closure ``equivalent_amplitude``.

Usage::

    python studies/random_closure_check.py -o out/random_closure [--seeds 8] [--duration 320]

Prints a Markdown table (worst band error in dB and stroke RMS error, before and after, the
Monte Carlo standard errors) and writes ``random_closure_check.csv`` (one row per case and
band) into the output directory.
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
from isodesign.response import Payload, band_response
from isodesign.simulation import simulate_random_response
from isodesign.simulation.monte_carlo import prony_diaphragm
from isodesign.spring.design import SpringDesign


def cases():
    """(name, design, kg per isolator, floor, flow, diaphragm) of the verified cases."""
    vca = FloorSpectrum.from_criterion("VC-A")
    vca4 = FloorSpectrum.from_band_rms(vca.bands, 4.0 * vca.band_rms_velocity(), name="4x VC-A")
    ref = SpringDesign.reference()
    long = ref.replace(volume_ratio=4.1, top_volume_m3=1.18e-3, capillary_length_m=0.18,
                       capillary_diameter_m=2.14e-3)  # fmt: skip
    return [
        ("reference spring, 100 kg, VC-A", ref, 100.0, vca, "quasi_steady", "none"),
        ("reference spring, 100 kg, 4x VC-A", ref, 100.0, vca4, "quasi_steady", "none"),
        ("long capillary, 150 kg, VC-A", long, 150.0, vca, "quasi_steady", "none"),
        ("long capillary, 150 kg, 4x VC-A", long, 150.0, vca4, "quasi_steady", "none"),
        ("reference spring, 100 kg, VC-A, viscoelastic diaphragm", ref, 100.0, vca,
         "quasi_steady", "viscoelastic"),
        ("reference spring, 100 kg, 4x VC-A, viscoelastic diaphragm", ref, 100.0, vca4,
         "quasi_steady", "viscoelastic"),
        ("reference spring, 100 kg, 4x VC-A, diaphragm as a Prony series at A*", ref, 100.0,
         vca4, "quasi_steady", "prony"),
        ("long capillary, 150 kg, 4x VC-A, Womersley flow", long, 150.0, vca4, "womersley",
         "none"),
    ]  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="out/random_closure")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--duration", type=float, default=320.0)
    ap.add_argument("--no-optimum", action="store_true",
                    help="skip the Monte Carlo check of the vertical study's optimum")
    args = ap.parse_args(argv)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows, table = [], []
    for name, d, kg, floor, flow, dia in cases():
        p = Payload(4 * kg, 4)
        if dia == "prony":  # the default diaphragm frozen at the closure's A*, in both
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModelValidityWarning)
                a_star = band_response(d, p, floor, "VC-E", flow=flow).equivalent_amplitude_m
            dia, _ = prony_diaphragm("viscoelastic", np.geomspace(floor.f_min_hz,
                                                                  floor.f_max_hz, 60), a_star)
        t0 = time.perf_counter()
        mc = simulate_random_response(d, p, floor, target="VC-E", seeds=args.seeds,
                                      duration_s=args.duration, flow=flow, diaphragm=dia)
        t_mc = time.perf_counter() - t0  # fmt: skip
        res = {}
        for method in ("equivalent_amplitude", "statistical"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ModelValidityWarning)
                r = band_response(d, p, floor, "VC-E", flow=flow, diaphragm=dia,
                                  random_method=method)  # fmt: skip
            err = mc.error_db(r)
            j = int(np.argmax(np.abs(err)))
            res[method] = (err[j], mc.bands.labels[j], 100 * (r.stroke_rms_m / mc.stroke_rms_m - 1))
            for b, lab in enumerate(mc.bands.labels):
                rows.append({"case": name, "method": method, "band_hz": lab,
                             "closure_um_s": r.payload_velocity_rms_m_s[b] * 1e6,
                             "monte_carlo_um_s": mc.payload_velocity_rms_m_s[b] * 1e6,
                             "monte_carlo_se_db": mc.standard_error_db()[b],
                             "error_db": err[b]})  # fmt: skip
            if method == "statistical":
                su = r.tube_velocity_rms_m_s
        old, new = res["equivalent_amplitude"], res["statistical"]
        table.append(
            f"| {name} | {old[0]:+.2f} ({old[1]} Hz) | {old[2]:+.1f} % | {new[0]:+.2f} "
            f"({new[1]} Hz) | {new[2]:+.1f} % | {su:.3g} / {mc.tube_velocity_rms_m_s:.3g} | "
            f"{np.nanmax(mc.standard_error_db()):.3f} dB, "
            f"{100 * mc.stroke_rms_se_m / mc.stroke_rms_m:.2f} % | "
            f"{mc.tube_velocity_kurtosis:.2f} |"
        )
        print(f"{name}: Monte Carlo {t_mc:.1f} s ({mc.seconds_per_realization:.2f} s per "
              f"realization)", file=sys.stderr, flush=True)  # fmt: skip
    print(f"{args.seeds} seeds x {args.duration:g} s, random-phase floor\n")
    print("| case | A* = 1.880 sigma: worst band | stroke | statistical: worst band | stroke "
          "| sigma_u closure / MC (m/s) | MC standard error (max band, stroke) | "
          "kurtosis of u |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(table))
    pd.DataFrame(rows).to_csv(out / "random_closure_check.csv", index=False)
    if not args.no_optimum:
        print()
        print(optimum_check(args.seeds, args.duration))
    return 0


def optimum_check(seeds: int, duration: float) -> str:
    """The vertical study's optimum under each closure, and its margin by Monte Carlo."""
    from isodesign.optimization.driver import optimize
    from isodesign.optimization.study import vertical_study

    lines = ["| closure of the optimization | optimum N, V_t0 (L), L_c (mm), D_c (mm) | "
             "predicted margin (analysis) | Monte Carlo margin (diaphragm: own A*; Prony at "
             "the closure's A*) |", "|---|---|---|---|"]
    # the third row: the statistical optimum of the lumped acoustics (docs/random-response.md)
    for method, acoustics in (("statistical", None), ("equivalent_amplitude", None),
                              ("statistical", "lumped")):
        # the closures compared without the distortion power (models.distortion's default
        # is on where it applies: docs/random-response.md 3d); the table's rows say so
        models = {"random_method": method, "distortion": False} | (
            {"acoustics": acoustics} if acoustics else {})
        st = vertical_study().with_changes(models=models)
        res = optimize(st)
        d, v = res.design, res.values
        kw = {"flow": st.models["flow"], "derive_pressure": False}
        r = res.analysis
        pdia, _ = prony_diaphragm("viscoelastic", np.geomspace(st.floor.f_min_hz,
                                                                st.floor.f_max_hz, 60),
                                  band_response(d, st.payload, st.floor, st.target,
                                                bands=st.bands, warn=False,
                                                **kw).equivalent_amplitude_m)
        margins = []
        for dia in (st.models["diaphragm"], pdia):
            mc = simulate_random_response(d, st.payload, st.floor, bands=r.bands, seeds=seeds,
                                          duration_s=duration, diaphragm=dia, **kw)
            lim = np.asarray(st.target.velocity_rms_m_s(mc.bands))
            margins.append(float(np.min(20 * np.log10(lim / mc.payload_velocity_rms_m_s))))
        lines.append(
            f"| {method}{', distortion off' if method == 'statistical' else ''}"
            f"{', lumped acoustics' if acoustics else ''} | "
            f"{v['volume_ratio']:.2f}, {v['top_volume_m3'] * 1e3:.3f}, "
            f"{v['capillary_length_m'] * 1e3:.1f}, {v['capillary_diameter_m'] * 1e3:.3f} | "
            f"{r.worst_margin_db:+.2f} dB | {margins[0]:+.2f} dB; {margins[1]:+.2f} dB |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
