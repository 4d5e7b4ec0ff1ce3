"""The rig simulator against the frequency-domain model: the tables of docs/simulation.md.

Usage (from the repository root)::

    python studies/rig_agreement.py                 # the agreement table (section 4)
    python studies/rig_agreement.py --integrators   # the integrator table (section 2)
    python studies/rig_agreement.py --drift         # the 60-cycle drift check (section 3)
    python studies/rig_agreement.py --checks        # the measured figures of sections 2-4
    python studies/rig_agreement.py --stiff         # the large-amplitude figures (2, 3, 5)

Simulates the reference spring (no diaphragm) on the grid
``REFERENCE_FREQUENCIES_HZ x REFERENCE_AMPLITUDES_M`` with
:func:`isodesign.simulation.simulate_grid` and prints, per case, the errors of the
self-consistent and the kinematic models against the simulation, then the worst of each.

``--integrators`` runs every integrator variant of the table "Verified numerical error" for
exactly 6 cycles (the periodic-state stop is switched off, so that every variant carries the
same secular drift) and prints, per variant, the largest relative difference of ``k_air``
over the 24 cases against DOP853 at ``rtol = 1e-11`` with 2048 samples per cycle, and its
wall time (one run each, on whatever machine runs it).

``--drift`` re-runs the grid for 60 cycles and prints, per case, the change per cycle at
cycle 60 against ``heating_per_cycle``, and the difference between the early stop (the
default criterion) and cycle 60.

``--checks`` prints the other measured figures the page quotes: the heating identity, the
linear limit (``flow="poiseuille"`` at 0.1 um and on the grid's amplitudes), the small-amplitude
quasi-steady agreement, the isothermal low-frequency stiffness, the tube velocity amplitudes
(harmonic balance and Eq. 37 against the simulated first harmonic) and the waveform's peak
over its first harmonic.

``--stiff`` runs the large-amplitude cases the page quotes: the right-hand sides per cycle at
0.2 Hz, 5 mm with LSODA and DOP853 (counted by wrapping the simulator's right-hand side),
the heating per cycle at 1 Hz, 20 mm, and the tube's peak Mach number at 5 mm.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import os
import time

import numpy as np
import pandas as pd

from isodesign import SpringDesign
from isodesign.simulation import harmonic_rig
from isodesign.simulation.harmonic_rig import (
    REFERENCE_AMPLITUDES_M,
    REFERENCE_FREQUENCIES_HZ,
    agreement_table,
    simulate_grid,
)

#: (label, keyword arguments of simulate_grid) in the order of docs/simulation.md, section 2
INTEGRATOR_VARIANTS = [
    ("LSODA, rtol 1e-9, 512 samples (default)", {}),
    ("LSODA, rtol 1e-10", {"rtol": 1e-10}),
    ("LSODA, 256 samples", {"samples_per_cycle": 256}),
    ("LSODA, 2048 samples", {"samples_per_cycle": 2048}),
    ("DOP853, rtol 1e-9", {"method": "DOP853"}),
    ("BDF, rtol 1e-9", {"method": "BDF"}),
    ("Radau, rtol 1e-9", {"method": "Radau"}),
]
#: the reference solution of the integrator table
INTEGRATOR_REFERENCE = {"method": "DOP853", "rtol": 1e-11, "samples_per_cycle": 2048}


@contextlib.contextmanager
def fixed_cycles():
    """Switch off the periodic-state stop: every case runs ``max_cycles`` cycles.

    The stop allows ``periodic_tol + 2 * heating_per_cycle``; with the allowance at 0 and
    ``periodic_tol = 1e-15`` no case stops early, so every variant integrates the same
    number of cycles and carries the same secular drift.
    """
    saved = harmonic_rig._HEATING_ALLOWANCE
    harmonic_rig._HEATING_ALLOWANCE = 0.0
    try:
        yield {"max_cycles": 6, "periodic_tol": 1e-15, "allow_unconverged": True}
    finally:
        harmonic_rig._HEATING_ALLOWANCE = saved


def _grid(design, **kwargs):
    return simulate_grid(design, REFERENCE_FREQUENCIES_HZ, REFERENCE_AMPLITUDES_M,
                         diaphragm="none", **kwargs)


def integrators(design: SpringDesign) -> pd.DataFrame:
    """The integrator table: max relative difference of ``k_air`` and wall time per variant.

    Parameters
    ----------
    design : SpringDesign
        The spring (the reference spring in docs/simulation.md).

    Returns
    -------
    pandas.DataFrame
        One row per variant: ``variant``, ``max_rel_difference``, ``time_s``, ``time_ratio``
        (wall time over the default's, measured in the same run).
    """
    rows = []
    with fixed_cycles() as fixed:
        t0 = time.perf_counter()
        ref = _grid(design, **INTEGRATOR_REFERENCE, **fixed).k_air
        t_ref = time.perf_counter() - t0
        for label, kwargs in INTEGRATOR_VARIANTS:
            t0 = time.perf_counter()
            g = _grid(design, **kwargs, **fixed)
            elapsed = time.perf_counter() - t0
            assert np.all(g.cycles == fixed["max_cycles"]), label
            diff = float(np.max(np.abs(g.k_air - ref) / np.abs(ref)))
            rows.append({"variant": label, "max_rel_difference": diff, "time_s": elapsed})
    df = pd.DataFrame(rows)
    df["time_ratio"] = df["time_s"] / df["time_s"].iloc[0]
    df.attrs["reference_time_s"] = t_ref
    return df


def drift(design: SpringDesign) -> pd.DataFrame:
    """The 60-cycle check of section 3: the change per cycle at cycle 60 is the heating.

    Parameters
    ----------
    design : SpringDesign
        The spring.

    Returns
    -------
    pandas.DataFrame
        Per case: ``frequency_hz``, ``amplitude_mm``, ``cycles_early`` (the default stop),
        ``change_60`` (``|k_60 - k_59|/|k_60|``), ``heating_60`` (``heating_per_cycle``
        at cycle 60) and ``early_vs_60`` (``|k_early - k_60|/|k_60|``).
    """
    early = _grid(design)
    with fixed_cycles() as fixed:
        long = _grid(design, **{**fixed, "max_cycles": 60})
    rows = []
    for i, f in enumerate(early.frequency_hz):
        for j, x in enumerate(early.amplitude_m):
            e, g = early.results[i, j], long.results[i, j]
            rows.append({
                "frequency_hz": f, "amplitude_mm": x * 1e3, "cycles_early": e.cycles,
                "change_60": g.periodic_change, "heating_60": g.heating_per_cycle,
                "early_vs_60": abs(e.k_air - g.k_air) / abs(g.k_air),
            })
    return pd.DataFrame(rows)


def _worst_rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1)))


def checks(design: SpringDesign) -> dict[str, float]:
    """The measured figures of ``docs/simulation.md`` besides the two tables.

    Parameters
    ----------
    design : SpringDesign
        The spring (the reference spring in the page).

    Returns
    -------
    dict
        Named figures (relative errors as fractions); :func:`format_checks` prints them.
    """
    from isodesign import complex_stiffness

    lumped = design.replace(acoustics="lumped")  # the rig integrates the lumped acoustics
    v: dict[str, float] = {}
    f_lin = np.array([0.2, 1.0, 3.0, 10.0, 24.0])
    for key, n in (("adiabatic", None), ("n1", 1.0), ("n1_2", 1.2)):
        d = lumped.replace(polytropic_index=n)
        g = simulate_grid(d, f_lin, 1e-7, flow="poiseuille", diaphragm="none")
        fd = complex_stiffness(d, f_lin, [1e-7], flow="poiseuille", diaphragm="none", warn=False)
        v[f"linear_limit_{key}"] = _worst_rel(g.k_air, fd.k_air)
    f_qs = np.array([0.2, 3.0, 10.0, 24.0])
    g = simulate_grid(lumped, f_qs, 1e-7, diaphragm="none")
    fd = complex_stiffness(lumped, f_qs, [1e-7], diaphragm="none", warn=False)
    v["small_quasi_steady"] = _worst_rel(g.k_air, fd.k_air)
    iso = lumped.replace(polytropic_index=1.0)
    r = harmonic_rig.simulate_stiffness(iso, 0.05, 5e-5, diaphragm="none")
    expected = (design.pressure_pa * design.piston_area_m2**2
                / ((1 + design.volume_ratio) * design.top_volume_m3))
    v["isothermal"] = abs(r.k_air.real / expected - 1)
    f, x = REFERENCE_FREQUENCIES_HZ, REFERENCE_AMPLITUDES_M
    gp = _grid(lumped, flow="poiseuille")
    fdp = complex_stiffness(lumped, f, x, flow="poiseuille", diaphragm="none", warn=False)
    rel = np.abs(gp.k_air / fdp.k_air - 1)
    i, j = np.unravel_index(np.argmax(rel), rel.shape)
    v.update(gas_worst=rel[i, j], gas_worst_hz=f[i], gas_worst_mm=x[j] * 1e3,
             gas_small_amplitude=rel[i, 0])
    grid = _grid(design)
    kappa = design.gas.heat_capacity_ratio
    work = np.pi * np.asarray(x)[None, :] ** 2 * grid.k_air.imag
    heat = (kappa - 1) * work / (design.pressure_pa * design.total_volume_m3)
    v["heating_identity"] = _worst_rel(grid._field("heating_per_cycle", float), heat)
    u_sim = grid._field("velocity_amplitude_m_s", float)
    sc = complex_stiffness(lumped, f, x, diaphragm="none", warn=False).diagnostics
    kin = complex_stiffness(lumped, f, x, diaphragm="none", amplitude_mode="kinematic",
                            warn=False).diagnostics
    ratio = kin.velocity_amplitude_m_s / u_sim
    v.update(u_self_consistent=_worst_rel(sc.velocity_amplitude_m_s, u_sim),
             u_kinematic_low=ratio[0, 0], n_plus_1_over_n=(design.volume_ratio + 1)
             / design.volume_ratio, u_kinematic_max=ratio.max(),
             u_kinematic_top=kin.velocity_amplitude_m_s[-1, -1], u_sim_top=u_sim[-1, -1])
    peak = grid._field("peak_velocity_m_s", float) / u_sim
    sel = np.ix_([f.index(2.0), f.index(3.0)], [x.index(0.15e-3), x.index(0.5e-3)])
    v.update(peak_ratio_min=peak[sel].min(), peak_ratio_max=peak[sel].max(),
             distortion_max=np.max(grid._field("force_distortion", float)))
    return {k: float(val) for k, val in v.items()}


def format_checks(v: dict[str, float]) -> list[str]:
    """The lines ``--checks`` prints, from :func:`checks`.

    Parameters
    ----------
    v : dict
        The output of :func:`checks`.

    Returns
    -------
    list of str
        One line per figure.
    """
    return [
        f"linear limit (poiseuille, X = 0.1 um), simulation against Eq. 38, worst of 0.2-24 Hz: "
        f"adiabatic {v['linear_limit_adiabatic']:.1g}, n = 1 {v['linear_limit_n1']:.1g}, "
        f"n = 1.2 {v['linear_limit_n1_2']:.1g}",
        f"small-amplitude quasi_steady (X = 0.1 um): {v['small_quasi_steady']:.2g}",
        f"isothermal spring at 0.05 Hz against p0 A_p^2/((1+N) V_t0): {v['isothermal']:.2g}",
        f"gas nonlinearity (poiseuille on the grid): simulation against Eq. 38 at most "
        f"{v['gas_worst']:.2g} ({v['gas_worst_hz']:g} Hz, {v['gas_worst_mm']:g} mm); "
        f"{v['gas_small_amplitude']:.2g} at {v['gas_worst_hz']:g} Hz, 0.05 mm",
        f"heating per cycle against (kappa - 1) pi X^2 Im k_air/(p0 V_tot): "
        f"{v['heating_identity']:.2g} (worst case)",
        f"tube velocity: harmonic balance within {v['u_self_consistent']:.1%} of the simulated "
        f"first harmonic; Eq. 37 / simulated {v['u_kinematic_low']:.2f} at 0.2 Hz, 0.05 mm "
        f"((N+1)/N = {v['n_plus_1_over_n']:.2f}), at most {v['u_kinematic_max']:.0f} "
        f"({v['u_kinematic_top']:.0f} m/s against {v['u_sim_top']:.1f} m/s at 24 Hz, 0.5 mm)",
        f"peak tube velocity / first harmonic at 2-3 Hz, 0.15-0.5 mm: "
        f"{v['peak_ratio_min']:.2f} to {v['peak_ratio_max']:.2f}; largest force distortion "
        f"{v['distortion_max']:.1%}",
    ]


@contextlib.contextmanager
def counted_rhs():
    """Count the simulator's right-hand-side calls (a wrapper, restored on exit)."""
    count = {"calls": 0}
    original = harmonic_rig._Model.rhs

    def rhs(self, theta, y, cases):
        count["calls"] += 1
        return original(self, theta, y, cases)

    harmonic_rig._Model.rhs = rhs
    try:
        yield count
    finally:
        harmonic_rig._Model.rhs = original


def stiff(design: SpringDesign) -> list[str]:
    """The large-amplitude figures of ``docs/simulation.md`` (sections 2, 3 and 5).

    Parameters
    ----------
    design : SpringDesign
        The spring.

    Returns
    -------
    list of str
        One line per figure.
    """
    out = []
    for method in ("LSODA", "DOP853"):
        with counted_rhs() as count:
            t0 = time.perf_counter()
            r = harmonic_rig.simulate_stiffness(design, 0.2, 5e-3, diaphragm="none",
                                                method=method)
            elapsed = time.perf_counter() - t0
        out.append(f"0.2 Hz, 5 mm, {method}: {count['calls'] / r.cycles:,.0f} right-hand sides "
                   f"per cycle ({r.cycles} cycles, {elapsed:.1f} s)")
    r = simulate_grid(design, [1.0], [20e-3], diaphragm="none").results[0, 0]
    out.append(f"1 Hz, 20 mm: heating per cycle {r.heating_per_cycle:.2g} "
               f"({r.cycles} cycles)")
    c = design.gas.speed_of_sound(design.temperature_k)
    g = simulate_grid(design, [5.0, 10.0, 15.0, 24.0], [5e-3], diaphragm="none")
    mach = max(r.peak_velocity_m_s for r in g.results[:, 0]) / c
    out.append(f"5 mm, 5-24 Hz: peak tube Mach number {mach:.2f}")
    return out


def agreement(design: SpringDesign) -> None:
    """Print the agreement table of ``docs/simulation.md``, section 4.

    The rig integrates the lumped acoustics (uniform chamber pressures, a slug in the tube),
    so it is compared with the frequency-domain model of the same lumped acoustics: like with
    like, whatever acoustics ``design`` names.
    """
    grid = _grid(design)
    df = agreement_table(grid, design.replace(acoustics="lumped"))
    sim = grid.to_frame()
    df["cycles"] = sim["cycles"]
    df["periodic_change"] = sim["periodic_change"]
    df["force_distortion"] = sim["force_distortion"]
    with pd.option_context("display.width", 250, "display.max_columns", 40):
        print(df.to_string(float_format=lambda v: f"{v:.4g}"))
    for mode in ("self_consistent", "kinematic"):
        worst = {
            c: float(np.max(np.abs(df[f"{mode}_{c}"])))
            for c in ("abs_err", "re_err", "im_err", "complex_err", "loss_factor_diff")
        }
        print(mode, "worst:", ", ".join(f"{k} {v:.3g}" for k, v in worst.items()))


def main(argv: list[str] | None = None) -> None:
    """Print the table of ``docs/simulation.md`` that the options select."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--integrators", action="store_true",
                    help="the integrator table of section 2 (about 15 grid runs' worth)")
    ap.add_argument("--drift", action="store_true", help="the 60-cycle check of section 3")
    ap.add_argument("--checks", action="store_true",
                    help="the other measured figures of sections 2-4")
    ap.add_argument("--stiff", action="store_true",
                    help="the large-amplitude figures of sections 2, 3 and 5")
    args = ap.parse_args(argv)
    design = SpringDesign.reference()
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    print(f"# {stamp}, {os.cpu_count()} CPUs, load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    if args.integrators:
        df = integrators(design)
        print("max relative difference of k_air over the 24 cases against DOP853, rtol 1e-11, "
              "2048 samples; every variant exactly 6 cycles")
        for r in df.itertuples():
            print(f"| {r.variant} | {r.max_rel_difference:.1e} | {r.time_s:.1f} s | "
                  f"{r.time_ratio:.2f} |")
        print(f"reference solution: {df.attrs['reference_time_s']:.1f} s")
    elif args.stiff:
        print("\n".join(stiff(design)))
    elif args.checks:
        print("\n".join(format_checks(checks(design))))
    elif args.drift:
        df = drift(design)
        with pd.option_context("display.width", 200):
            print(df.to_string(float_format=lambda v: f"{v:.3g}"))
        k = int(np.argmax(df["early_vs_60"]))
        print(f"largest early-stop vs cycle-60 difference {df['early_vs_60'].iloc[k]:.2g} at "
              f"{df['frequency_hz'].iloc[k]:g} Hz, {df['amplitude_mm'].iloc[k]:g} mm")
    else:
        t0 = time.perf_counter()
        agreement(design)
        print(f"simulate_grid and the table: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
