"""The distributed acoustic model, verified and put to work: the figures of docs/acoustics.md.

Usage (from the repository root)::

    python studies/acoustics_check.py            # verification figures (about 1 minute)
    python studies/acoustics_check.py --studies  # also the re-optimized studies (minutes)

1. The complex air stiffness against the independent finite-difference solution of the
   wave equations (``tests/spring/test_acoustics.py``) from 0.2 Hz to the first chamber
   mode, for the long-tube case (L_c = 1 m) and the large-chamber case (V_b0 = 40 L), and
   the lumped model's error on the same cases.
2. The tube's half-wave resonances in the transmissibility (model, FD, ``n c / (2 L)``).
3. The time-domain rig (lumped, nonlinear) against the distributed harmonic balance on the
   reference grid of docs/simulation.md.
4. With ``--studies``: the vertical study and the 1,200 kg / 8 L study optimized with the
   lumped and the distributed model, the default optimum with wall heat exchange, and the
   lumped robust design of docs/robust.md judged with the distributed model.
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "spring"))

from test_acoustics import _large_chamber, _long_tube, _model_and_fd

from isodesign.spring.chamber import first_longitudinal_mode_hz
from isodesign.spring.design import SpringDesign
from isodesign.spring.equations import air_stiffness
from isodesign.spring.flow_models import resistance_function

#: The 1,200 kg table on 4 isolators, VC-B floor, VC-D target, 8 L envelope (issue 16).
HEAVY_STUDY = {
    "name": "heavy-8L",
    "payload": {"mass_kg": 1200.0, "isolators": 4},
    "floor": {"criterion": "VC-B"},
    "target": {"criterion": "VC-D"},
    "constraints": {"max_total_volume_m3": 8e-3},
}


def fd_figures() -> None:
    """Section 1: FD agreement of both cases."""
    for name, d in (("L_c = 1 m", _long_tube()), ("V_b0 = 40 L", _large_chamber())):
        f_mode = min(first_longitudinal_mode_hz(d, d.top_volume_m3),
                     first_longitudinal_mode_hz(d, d.bottom_volume_m3))
        f = np.geomspace(0.2, f_mode, 40)
        k, k_fd = _model_and_fd(d, f)
        err = np.abs(k - k_fd) / np.abs(k_fd)
        w = 2 * math.pi * f
        kl = air_stiffness(d.replace(acoustics="lumped"), w,
                           resistance_function("womersley", d, w)(2.0 + 0 * f)).to_complex()
        err_l = np.abs(kl - k_fd) / np.abs(k_fd)
        print(f"{name}: 0.2-{f_mode:.0f} Hz (first chamber mode), 40 frequencies: distributed "
              f"max |k - k_FD|/|k_FD| = {err.max():.2e} (at {f[np.argmax(err)]:.1f} Hz); "
              f"lumped {err_l.max():.3f} (at {f[np.argmax(err_l)]:.1f} Hz)")


def resonance_figures() -> None:
    """Section 2: the tube's resonances in the transmissibility."""
    d = SpringDesign.reference().replace(capillary_length_m=2.0, capillary_diameter_m=5e-3,
                                         volume_ratio=4.0, top_volume_m3=0.004)
    f = np.linspace(20.0, 260.0, 481)
    k, k_fd = _model_and_fd(d, f, velocity=0.5)
    w = 2 * math.pi * f

    def peaks(kk):
        t = np.abs(kk / (kk - 150.0 * w * w)) * f * f
        i = np.flatnonzero((t[1:-1] > t[:-2]) & (t[1:-1] > t[2:])) + 1
        return f[i]

    half = d.speed_of_sound_m_s / (2 * d.capillary_length_m)
    print(f"tube resonances (L_c = 2 m, D_c = 5 mm, 4 + 16 L, 150 kg): model "
          f"{peaks(k).tolist()} Hz, FD {peaks(k_fd).tolist()} Hz, n c/(2 L) = "
          f"{half:.1f}, {2 * half:.1f} Hz")


def rig_figures() -> None:
    """Section 3: the rig against the distributed harmonic balance."""
    from isodesign.simulation.harmonic_rig import (
        REFERENCE_AMPLITUDES_M,
        REFERENCE_FREQUENCIES_HZ,
        agreement_table,
        simulate_grid,
    )

    design = SpringDesign.reference()
    grid = simulate_grid(design, REFERENCE_FREQUENCIES_HZ, REFERENCE_AMPLITUDES_M,
                         diaphragm="none")
    for acoustics in ("distributed", "lumped"):
        df = agreement_table(grid, design.replace(acoustics=acoustics),
                             modes=("self_consistent",))
        print(f"rig (quasi_steady, 0.2-24 Hz, 0.05-0.5 mm) against the {acoustics} model: "
              f"worst ||k|/|k_sim| - 1| = {df['self_consistent_abs_err'].max():.4f}, "
              f"|k - k_sim|/|k_sim| = {df['self_consistent_complex_err'].max():.4f}")


def study_figures() -> None:
    """Section 4: the studies re-optimized with both models."""
    from isodesign.optimization.driver import optimize
    from isodesign.optimization.study import vertical_study
    from isodesign.response.random_input import band_response

    base = vertical_study()
    heavy = base.with_changes(**{k: v for k, v in HEAVY_STUDY.items() if k != "name"})
    for label, st in (("default", base), ("1,200 kg / 8 L", heavy)):
        for acoustics in ("lumped", "distributed"):
            s = st.with_changes(models={"acoustics": acoustics})
            res = optimize(s)
            v = res.values
            binding = [c.name for c in res.constraints if c.active]
            validity = ", ".join(f"{c.name} {c.value:.4g} (bound {c.upper:.4g})"
                                 for c in res.constraints
                                 if c.name.startswith(("lumped_", "plane_wave_")))
            at_bound = [n for n, x in v.items()
                        if min(abs(x / b - 1) for b in (s.variable(n).lower,
                                                         s.variable(n).upper)) < 1e-6]
            print(f"{label}, {acoustics}: N = {v['volume_ratio']:.3f}, V_t0 = "
                  f"{v['top_volume_m3'] * 1e3:.3f} L, L_c = {v['capillary_length_m'] * 1e3:.1f}"
                  f" mm, D_c = {v['capillary_diameter_m'] * 1e3:.3f} mm, total "
                  f"{res.design.total_volume_m3 * 1e3:.2f} L; worst-band margin "
                  f"{res.objective_value:+.3f} dB (NLP), {res.analysis.worst_margin_db:+.2f} dB "
                  f"(analysis, worst band {res.analysis.worst_band_hz:g} Hz); binding: "
                  f"{', '.join(binding) or '-'}; at a bound: {', '.join(at_bound) or '-'}; "
                  f"success {res.success}; validity: {validity}")
            if label == "default" and acoustics == "distributed":
                d_hx = res.design.replace(chamber_heat_exchange=True)
                an = band_response(d_hx, s.payload, s.floor, s.target, bands=s.bands,
                                   flow=s.models["flow"], diaphragm=s.models["diaphragm"],
                                   derive_pressure=False, warn=False,
                                   distortion=bool(s.models.get("distortion", False)))
                print(f"  the same design with chamber_heat_exchange: worst-band margin "
                      f"{an.worst_margin_db:+.2f} dB (worst band {an.worst_band_hz:g} Hz)")
                res_hx = optimize(s.with_changes(hardware={"chamber_heat_exchange": True}))
                vh = res_hx.values
                print(f"  re-optimized with chamber_heat_exchange: N = "
                      f"{vh['volume_ratio']:.3f}, V_t0 = {vh['top_volume_m3'] * 1e3:.3f} L, "
                      f"L_c = {vh['capillary_length_m'] * 1e3:.1f} mm, D_c = "
                      f"{vh['capillary_diameter_m'] * 1e3:.3f} mm, margin "
                      f"{res_hx.objective_value:+.3f} dB (NLP)")


def robust_corner_figures() -> None:
    """docs/robust.md: the lumped robust design judged with the distributed model, corners."""
    from isodesign.optimization.scenario_check import scenario_check
    from isodesign.optimization.study import vertical_study

    st = vertical_study().with_changes(scenarios={
        "payload_mass_kg": {"min": 480.0, "max": 720.0},
        "capillary_diameter_m": {"relative": 0.05},
        "capillary_length_m": {"relative": 0.05}})
    lumped_robust = {"volume_ratio": 8.0, "top_volume_m3": 0.6464e-3,
                     "capillary_length_m": 0.1636, "capillary_diameter_m": 2.026e-3}
    rows = [(tuple(float(t) for t in th), scenario_check(st, lumped_robust, th))
            for th in st.scenarios.corners()]
    worst = min(rows, key=lambda r: r[1]["objective"])
    print(f"lumped robust design (N 8, V_t0 0.6464 L, L_c 163.6 mm, D_c 2.026 mm) with the "
          f"distributed model, 8 corners: worst {worst[1]['objective']:+.3f} dB at {worst[0]}; "
          f"largest violation {max(r[1]['max_violation'] for r in rows):.2g}")


def main() -> None:
    """Print the figures."""
    warnings.simplefilter("ignore")
    fd_figures()
    resonance_figures()
    rig_figures()
    if "--studies" in sys.argv[1:]:
        study_figures()
        robust_corner_figures()


if __name__ == "__main__":
    main()
