"""Regenerate the paper's Fig. 11: complex stiffness of the reference spring.

Real part of k* and loss factor Im k*/Re k* against frequency (0.2-24 Hz, the
paper's Table 2 frequencies and a fine log grid) at 0.05, 0.15 and 0.5 mm, for

(a) the paper's oscillating-flow model, literally: Zhao's friction (Eq. 24) in
    Eq. 36 with the kinematic tube velocity of Eq. 37
    (``flow="zhao", amplitude_mode="kinematic"``), solid lines in the paper;
(b) the unidirectional laminar model of earlier work, Eq. 41
    (``flow="poiseuille"``), dashed lines in the paper;
(c) the package's self-consistent models (``flow="quasi_steady"`` and
    ``flow="womersley"`` with ``amplitude_mode="self_consistent"``);
(d) optionally, a direct time-domain integration of the nonlinear lumped
    equations (``isodesign.simulation.harmonic_rig.simulate_grid``) as an independent check of
    the harmonic balance behind (c).

Every curve includes the default diaphragm (``"viscoelastic"``, illustrative
parameters): the paper used its measured Fig. 8 diaphragm data, which were never
published, so the absolute levels here are not the paper's. The measured points
of Fig. 11 were not published either; there is nothing to overlay.

Points flagged by the model diagnostics are drawn hollow (``result.valid`` is
False: some validity check fails); frequency bands where the model is not
passive (``ok_passive`` False, Im k < 0: a spring that makes energy) are shaded
red.

Usage::

    python studies/fig11_complex_stiffness.py -o out/fig11 [--no-simulation]

Outputs (in the ``-o`` directory): ``fig11_paper_models.png``,
``fig11_self_consistent.png``, ``fig11_velocity.png``, ``fig11_curves.csv``
(every curve with all diagnostics), ``fig11_summary.csv`` (peak loss factors,
limits, flagged points), ``fig11_checks.txt`` (the numbers quoted in
``docs/spring-model.md``) and, with the simulation, ``fig11_simulation.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from isodesign.errors import ModelValidityWarning
from isodesign.spring.design import SpringDesign
from isodesign.spring.stiffness import complex_stiffness

#: The paper's Table 2 excitation frequencies, Hz.
TABLE2_FREQUENCIES_HZ = (
    0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.8, 2.0, 2.2,
    2.4, 2.7, 3.0, 3.3, 3.7, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 12.0, 14.0, 16.0, 20.0, 24.0,
)  # fmt: skip
#: The three amplitudes of Fig. 11 (a)-(c), m.
AMPLITUDES_M = (0.05e-3, 0.15e-3, 0.5e-3)
#: Frequencies of the (slow) time-domain check: ten of Table 2's, spanning the band.
SIMULATION_FREQUENCIES_HZ = (0.3, 0.6, 1.0, 1.5, 2.2, 3.3, 5.0, 8.0, 14.0, 24.0)
#: Zeros of the denominator of Eq. 24: ``Re_w^0.548 = 2.04``.
ZHAO_POLE_KINETIC_REYNOLDS = 2.04 ** (1.0 / 0.548)

#: The model variants, by key: keyword arguments of ``complex_stiffness`` and a label.
MODELS = {
    "zhao_kinematic": {
        "kw": {"flow": "zhao", "amplitude_mode": "kinematic"},
        "label": "paper: oscillating flow (Zhao, Eq. 24) + Eq. 37",
    },
    "poiseuille": {
        "kw": {"flow": "poiseuille", "amplitude_mode": "kinematic"},
        "label": "paper: unidirectional laminar (Eq. 41)",
    },
    "quasi_steady_sc": {
        "kw": {"flow": "quasi_steady", "amplitude_mode": "self_consistent"},
        "label": "quasi-steady Churchill + K + inertance, self-consistent (default)",
    },
    "womersley_sc": {
        "kw": {"flow": "womersley", "amplitude_mode": "self_consistent"},
        "label": "Womersley + K, self-consistent",
    },
}


def frequency_grids(n_fine: int = 801, pole_hz: float | None = None) -> dict[str, np.ndarray]:
    """The two frequency grids of the study.

    Parameters
    ----------
    n_fine : int
        Number of log-spaced points of the fine grid over 0.2-24 Hz.
    pole_hz : float, optional
        Frequency of the pole of Eq. 24 (:func:`pole_frequency_hz`); 101 extra
        points are placed over 0.8-1.05 times it.

    Returns
    -------
    dict of str to ndarray
        ``"table2"``: the paper's Table 2 frequencies; ``"fine"``: the fine grid
        merged with the Table 2 frequencies and the Zhao pole frequency
        neighbourhood (sorted, unique), so that the narrow non-passive band of
        the literal model is resolved.
    """
    table2 = np.asarray(TABLE2_FREQUENCIES_HZ)
    parts = [np.geomspace(0.2, 24.0, n_fine), table2]
    if pole_hz is not None:
        parts.append(np.linspace(0.8 * pole_hz, 1.05 * pole_hz, 101))
    return {"table2": table2, "fine": np.unique(np.concatenate(parts))}


def pole_frequency_hz(design: SpringDesign) -> float:
    """Frequency of the pole of Eq. 24, where ``Re_w = 2.04^(1/0.548) = 3.673``.

    Parameters
    ----------
    design : SpringDesign
        The spring (density, viscosity and capillary diameter matter).

    Returns
    -------
    float
        ``f = Re_w mu / (2 pi rho D_c^2)`` in Hz.
    """
    return (
        ZHAO_POLE_KINETIC_REYNOLDS
        * design.viscosity_pa_s
        / (2.0 * math.pi * design.density_kg_m3 * design.capillary_diameter_m**2)
    )


def evaluate_curves(design: SpringDesign, grids: dict[str, np.ndarray]) -> pd.DataFrame:
    """Evaluate every model on both grids at the three amplitudes.

    Each model is evaluated with the default diaphragm (``"viscoelastic"``);
    the two paper models are also evaluated without diaphragm
    (``"none"``), for the analytic limits and the hand checks.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    grids : dict of str to ndarray
        Output of :func:`frequency_grids`.

    Returns
    -------
    pandas.DataFrame
        One row per (model, diaphragm, grid, frequency, amplitude) with the
        complex stiffness and every diagnostic column of
        :meth:`isodesign.spring.stiffness.StiffnessResult.to_frame`.
    """
    frames = []
    for key, spec in MODELS.items():
        diaphragms = (
            ("viscoelastic", "none")
            if key in ("zhao_kinematic", "poiseuille")
            else ("viscoelastic",)
        )
        for dia in diaphragms:
            for grid_name, f in grids.items():
                res = complex_stiffness(
                    design, f, AMPLITUDES_M, diaphragm=dia, warn=False, **spec["kw"]
                )
                df = res.to_frame()
                df.insert(0, "grid", grid_name)
                df.insert(0, "diaphragm", res.diaphragm)
                df.insert(0, "amplitude_mode", res.amplitude_mode)
                df.insert(0, "flow", res.flow)
                df.insert(0, "model", key)
                frames.append(df)
    return pd.concat(frames, ignore_index=True)


def run_simulation(design: SpringDesign) -> pd.DataFrame | None:
    """Time-domain check of the self-consistent quasi-steady model.

    Calls ``isodesign.simulation.harmonic_rig.simulate_grid(design, f, X, flow="quasi_steady",
    diaphragm="viscoelastic")`` on :data:`SIMULATION_FREQUENCIES_HZ` x
    :data:`AMPLITUDES_M` and compares with the harmonic balance.

    Parameters
    ----------
    design : SpringDesign
        The spring.

    Returns
    -------
    pandas.DataFrame or None
        One row per point: simulated and harmonic-balance stiffness and their
        relative differences; ``None`` (with a printed note) when
        ``isodesign.simulation.harmonic_rig`` is not available.
    """
    try:
        from isodesign.simulation.harmonic_rig import simulate_grid
    except ImportError as exc:
        print(f"note: time-domain check skipped: the simulator is not available ({exc})")
        return None
    f = np.asarray(SIMULATION_FREQUENCIES_HZ)
    x = np.asarray(AMPLITUDES_M)
    t0 = time.perf_counter()
    sim = simulate_grid(design, f, x, flow="quasi_steady", diaphragm="viscoelastic")
    dt = time.perf_counter() - t0
    k_sim = np.asarray(sim.k, dtype=complex).reshape(f.size, x.size)
    # the rig integrates the lumped acoustics: compare like with like
    hb = complex_stiffness(design.replace(acoustics="lumped"), f, x, warn=False)
    ff, xx = np.meshgrid(f, x, indexing="ij")
    eta_sim = k_sim.imag / k_sim.real
    print(f"time-domain check: {f.size} x {x.size} points in {dt:.1f} s")
    return pd.DataFrame(
        {
            "frequency_hz": ff.ravel(),
            "amplitude_m": xx.ravel(),
            "k_real_sim_n_per_m": k_sim.real.ravel(),
            "k_imag_sim_n_per_m": k_sim.imag.ravel(),
            "loss_factor_sim": eta_sim.ravel(),
            "k_real_hb_n_per_m": hb.k.real.ravel(),
            "k_imag_hb_n_per_m": hb.k.imag.ravel(),
            "loss_factor_hb": hb.loss_factor.ravel(),
            "rel_diff_abs_k": (np.abs(k_sim - hb.k) / np.abs(hb.k)).ravel(),
            "rel_diff_real": (k_sim.real / hb.k.real - 1.0).ravel(),
            "diff_loss_factor": (eta_sim - hb.loss_factor).ravel(),
        }
    )


# ---------------------------------------------------------------------------
# summary numbers
# ---------------------------------------------------------------------------
def summarize(curves: pd.DataFrame, pole_hz: float) -> pd.DataFrame:
    """Peak loss factor, extremes and flagged points per model and amplitude.

    The literal model has a narrow spike on the flank of its pole; for it, the
    ``*_off_pole`` columns give the peak outside ``|f/f_pole - 1| < 0.1``
    (NaN for the other models).

    Parameters
    ----------
    curves : pandas.DataFrame
        Output of :func:`evaluate_curves`.
    pole_hz : float
        Frequency of the pole of Eq. 24 (:func:`pole_frequency_hz`).

    Returns
    -------
    pandas.DataFrame
        One row per (model, diaphragm, amplitude) on the fine grid.
    """
    rows = []
    fine = curves[curves["grid"] == "fine"]
    for (model, dia, amp), g in fine.groupby(["model", "diaphragm", "amplitude_m"], sort=False):
        g = g.sort_values("frequency_hz")
        f = g["frequency_hz"].to_numpy()
        eta = g["loss_factor"].to_numpy()
        i = int(np.argmax(eta))
        j = int(np.argmax(np.where(np.abs(f / pole_hz - 1.0) < 0.1, -np.inf, eta)))
        zhao = model.startswith("zhao")
        nonpassive = f[~g["ok_passive"].to_numpy()]
        rows.append(
            {
                "model": model,
                "diaphragm": dia,
                "amplitude_mm": amp * 1e3,
                "peak_loss_factor": eta[i],
                "peak_frequency_hz": f[i],
                "peak_loss_factor_off_pole": eta[j] if zhao else np.nan,
                "peak_frequency_off_pole_hz": f[j] if zhao else np.nan,
                "min_loss_factor": eta.min(),
                "min_loss_factor_frequency_hz": f[int(np.argmin(eta))],
                "k_real_at_0.2hz_n_per_m": g["k_real_n_per_m"].iloc[0],
                "k_real_at_24hz_n_per_m": g["k_real_n_per_m"].iloc[-1],
                "max_velocity_m_s": g["velocity_amplitude_m_s"].max(),
                "max_mach": g["mach"].max(),
                "max_reynolds": g["reynolds"].max(),
                "points": len(g),
                "flagged_points": int((~g["valid"]).sum()),
                "nonpassive_points": int(nonpassive.size),
                "nonpassive_from_hz": nonpassive.min() if nonpassive.size else np.nan,
                "nonpassive_to_hz": nonpassive.max() if nonpassive.size else np.nan,
            }
        )
    return pd.DataFrame(rows)


def paper_checks(design: SpringDesign) -> list[str]:
    """The numbers the documentation quotes, recomputed (one line each).

    Parameters
    ----------
    design : SpringDesign
        The reference spring.

    Returns
    -------
    list of str
        Human-readable lines.
    """
    ks = design.single_chamber_stiffness_n_per_m
    n = design.volume_ratio
    lines = [
        f"k_s (Eq. 40) = {ks:,.1f} N/m; k_s/(N+1) = {ks / (n + 1):,.1f} N/m; N = {n:.4f}",
        f"Zhao pole: Re_w = 2.04^(1/0.548) = {ZHAO_POLE_KINETIC_REYNOLDS:.4f} at "
        f"f = {pole_frequency_hz(design):.4f} Hz",
        f"Table 1 load: A_p (p0 - p_atm) = {design.load_n:,.0f} N = "
        f"{design.load_n / 9.80665:.1f} kg (text: 100 kg)",
    ]
    for dia in ("none", "viscoelastic"):
        for f in (2.0, 2.1):
            r = complex_stiffness(
                design,
                f,
                0.05e-3,
                flow="zhao",
                amplitude_mode="kinematic",
                diaphragm=dia,
                warn=False,
            )
            lines.append(
                f"zhao/kinematic, diaphragm={dia}, {f} Hz, 0.05 mm: k = {r.k.real.item():,.0f} "
                f"{r.k.imag.item():+,.0f}j N/m, eta = {r.loss_factor.item():+.4f}, "
                f"ok_passive = {bool(r.diagnostics.checks['passive'].item())}"
            )
    # the limits of Eq. 38 (the lumped acoustics; the distributed model's chambers and tube
    # have modes far below 1e5 Hz, outside its plane-wave range)
    lumped = design.replace(acoustics="lumped")
    for flow, mode in (
        ("zhao", "kinematic"),
        ("poiseuille", "kinematic"),
        ("quasi_steady", "self_consistent"),
        ("womersley", "self_consistent"),
    ):
        lo = complex_stiffness(
            lumped, 1e-6, 1e-4, flow=flow, amplitude_mode=mode, diaphragm="none", warn=False
        ).k.item()
        hi = complex_stiffness(
            lumped, 1e5, 1e-4, flow=flow, amplitude_mode=mode, diaphragm="none", warn=False
        ).k.item()
        lines.append(
            f"limits of Eq. 38 (lumped acoustics) without diaphragm, {flow}/{mode}: "
            f"k(1e-6 Hz) = {lo.real:,.2f} N/m, k(1e5 Hz) = {hi.real:,.2f} N/m"
        )
    for x, f in ((0.05e-3, 0.5), (0.05e-3, 20.0), (0.5e-3, 2.0), (0.5e-3, 20.0)):
        kin = complex_stiffness(
            design, f, x, flow="zhao", amplitude_mode="kinematic", warn=False
        ).diagnostics
        qs = complex_stiffness(design, f, x, warn=False).diagnostics
        wo = complex_stiffness(design, f, x, flow="womersley", warn=False).diagnostics
        lines.append(
            f"U at {x * 1e3:g} mm, {f:g} Hz: kinematic (Eq. 37) "
            f"{kin.velocity_amplitude_m_s.item():.1f} m/s (Mach {kin.mach.item():.2f}, "
            f"Re_w {kin.kinetic_reynolds.item():.1f}, "
            f"A0 {kin.dimensionless_amplitude.item():.0f}); "
            f"self-consistent quasi_steady {qs.velocity_amplitude_m_s.item():.2f} m/s "
            f"(Re {qs.reynolds.item():.0f}, {qs.regime.item()}), womersley "
            f"{wo.velocity_amplitude_m_s.item():.2f} m/s"
        )
    return lines


# ---------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------
STYLE = {
    "zhao_kinematic": {"color": "C3", "ls": "-", "lw": 1.6, "marker": "o"},
    "poiseuille": {"color": "C0", "ls": "--", "lw": 1.4, "marker": "s"},
    "quasi_steady_sc": {"color": "C2", "ls": "-", "lw": 1.8, "marker": "o"},
    "womersley_sc": {"color": "C4", "ls": "-.", "lw": 1.4, "marker": "^"},
}


def _spans(f: np.ndarray, bad: np.ndarray):
    """Contiguous frequency intervals where ``bad`` is True (sorted ``f``)."""
    out = []
    i = 0
    while i < f.size:
        if bad[i]:
            j = i
            while j + 1 < f.size and bad[j + 1]:
                j += 1
            lo = f[i - 1] if i > 0 else f[i]
            hi = f[j + 1] if j + 1 < f.size else f[j]
            out.append((math.sqrt(lo * f[i]), math.sqrt(f[j] * hi)))
            i = j + 1
        else:
            i += 1
    return out


def _plot_model(axes_col, curves, key, amp, *, with_markers=True, faint=False):
    """Draw one model's fine curve and Table 2 markers into a (real, eta) column."""
    st = STYLE[key]
    sel = (
        (curves["model"] == key)
        & (curves["diaphragm"] == "viscoelastic")
        & np.isclose(curves["amplitude_m"], amp)
    )
    fine = curves[sel & (curves["grid"] == "fine")].sort_values("frequency_hz")
    tab = curves[sel & (curves["grid"] == "table2")].sort_values("frequency_hz")
    color = "0.6" if faint else st["color"]
    lw = 0.9 if faint else st["lw"]
    label = MODELS[key]["label"]
    for ax, col, scale in (
        (axes_col[0], "k_real_n_per_m", 1e-3),
        (axes_col[1], "loss_factor", 1.0),
    ):
        ax.plot(
            fine["frequency_hz"],
            fine[col] * scale,
            color=color,
            ls=st["ls"],
            lw=lw,
            label=label if not faint else f"{label} (for reference)",
        )
        if with_markers:
            ok = tab["valid"].to_numpy()
            ax.plot(
                tab["frequency_hz"][ok],
                tab[col][ok] * scale,
                st["marker"],
                ms=3.5,
                color=color,
                mfc=color,
                ls="none",
            )
            ax.plot(
                tab["frequency_hz"][~ok],
                tab[col][~ok] * scale,
                st["marker"],
                ms=3.5,
                color=color,
                mfc="none",
                ls="none",
            )
    if faint:
        return
    # shade where the model is not passive (Im k < 0)
    f = fine["frequency_hz"].to_numpy()
    for lo, hi in _spans(f, ~fine["ok_passive"].to_numpy()):
        for ax in axes_col:
            ax.axvspan(lo, hi, color="red", alpha=0.18, lw=0)


def _decorate(fig, axes, design, title):
    ks = design.single_chamber_stiffness_n_per_m
    k0 = design.static_stiffness_n_per_m
    fp = pole_frequency_hz(design)
    for j, amp in enumerate(AMPLITUDES_M):
        ax_r, ax_e = axes[0, j], axes[1, j]
        ax_r.set_title(f"({'abc'[j]}) X_p = {amp * 1e3:g} mm", fontsize=10)
        for ax in (ax_r, ax_e):
            ax.set_xscale("log")
            ax.set_xlim(0.2, 24.0)
            ax.grid(True, which="both", alpha=0.25)
            ax.axvline(fp, color="k", lw=0.6, ls=":")
        for v in (k0, ks):
            ax_r.axhline(v * 1e-3, color="0.5", lw=0.6, ls=":")
        ax_e.axhline(0.0, color="k", lw=0.5)
        ax_e.set_xlabel("frequency (Hz)")
    axes[0, 0].set_ylabel("Re k* (kN/m)")
    axes[1, 0].set_ylabel("loss factor Im k*/Re k*")
    axes[0, 0].annotate("air alone: k_s", (0.21, ks * 1e-3), fontsize=7, color="0.4", va="bottom")
    axes[0, 0].annotate("k_s/(N+1)", (0.21, k0 * 1e-3), fontsize=7, color="0.4", va="bottom")
    axes[1, 0].annotate(
        f"Zhao pole {fp:.2f} Hz", (fp * 1.04, -0.39), fontsize=7, rotation=90, va="bottom"
    )
    fig.suptitle(title, fontsize=10)


def plot_paper_models(curves: pd.DataFrame, design: SpringDesign, path: Path) -> None:
    """Figure (a)+(b): the paper's two models, 2 rows x 3 amplitudes.

    Parameters
    ----------
    curves : pandas.DataFrame
        Output of :func:`evaluate_curves`.
    design : SpringDesign
        The spring (for the limits and the pole line).
    path : Path
        PNG to write.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharex=True, sharey="row")
    for j, amp in enumerate(AMPLITUDES_M):
        for key in ("zhao_kinematic", "poiseuille"):
            _plot_model(axes[:, j], curves, key, amp)
    _decorate(
        fig,
        axes,
        design,
        "Paper's models (Fig. 11), with the illustrative viscoelastic diaphragm (not the paper's "
        "unpublished Fig. 8 data)\nmarkers: Table 2 frequencies, hollow = flagged by the "
        "diagnostics; red band: not passive (Im k < 0)",
    )
    axes[1, 0].set_ylim(-0.4, 0.6)
    _legend(fig, axes)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_self_consistent(
    curves: pd.DataFrame, design: SpringDesign, sim: pd.DataFrame | None, path: Path
) -> None:
    """Figure (c)+(d): self-consistent models and the time-domain check.

    Parameters
    ----------
    curves : pandas.DataFrame
        Output of :func:`evaluate_curves`.
    design : SpringDesign
        The spring.
    sim : pandas.DataFrame or None
        Output of :func:`run_simulation` (``None``: no markers).
    path : Path
        PNG to write.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 7), sharex=True, sharey="row")
    for j, amp in enumerate(AMPLITUDES_M):
        _plot_model(axes[:, j], curves, "zhao_kinematic", amp, with_markers=False, faint=True)
        for key in ("quasi_steady_sc", "womersley_sc"):
            _plot_model(axes[:, j], curves, key, amp)
        if sim is not None:
            s = sim[np.isclose(sim["amplitude_m"], amp)]
            axes[0, j].plot(
                s["frequency_hz"],
                s["k_real_sim_n_per_m"] * 1e-3,
                "kx",
                ms=7,
                mew=1.5,
                label="time-domain simulation (quasi_steady)",
            )
            axes[1, j].plot(s["frequency_hz"], s["loss_factor_sim"], "kx", ms=7, mew=1.5)
    note = "" if sim is not None else " (time-domain check not run)"
    _decorate(
        fig,
        axes,
        design,
        "Self-consistent flow amplitude (harmonic balance), illustrative viscoelastic diaphragm"
        f"{note}\nmarkers: Table 2 frequencies, hollow = flagged by the diagnostics; "
        "x: time-domain integration",
    )
    axes[1, 0].set_ylim(-0.4, 0.6)
    _legend(fig, axes)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_velocity(curves: pd.DataFrame, design: SpringDesign, path: Path) -> None:
    """Tube velocity amplitude: Eq. 37 against the self-consistent solution.

    Parameters
    ----------
    curves : pandas.DataFrame
        Output of :func:`evaluate_curves`.
    design : SpringDesign
        The spring (speed of sound).
    path : Path
        PNG to write.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6), sharey=True)
    c = design.speed_of_sound_m_s
    fine = curves[(curves["grid"] == "fine") & (curves["diaphragm"] == "viscoelastic")]
    for j, amp in enumerate(AMPLITUDES_M):
        ax = axes[j]
        g = fine[np.isclose(fine["amplitude_m"], amp)]
        z = g[g["model"] == "zhao_kinematic"].sort_values("frequency_hz")
        ax.plot(
            z["frequency_hz"],
            z["kinematic_velocity_m_s"],
            color="C3",
            label="Eq. 37 (kinematic, paper)",
        )
        for key in ("quasi_steady_sc", "womersley_sc"):
            m = g[g["model"] == key].sort_values("frequency_hz")
            st = STYLE[key]
            ax.plot(
                m["frequency_hz"],
                m["velocity_amplitude_m_s"],
                color=st["color"],
                ls=st["ls"],
                label=MODELS[key]["label"],
            )
        ax.axhline(c, color="k", lw=0.8, ls=":")
        ax.axhline(0.3 * c, color="0.5", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(0.2, 24)
        ax.set_title(f"X_p = {amp * 1e3:g} mm", fontsize=10)
        ax.set_xlabel("frequency (Hz)")
        ax.grid(True, which="both", alpha=0.25)
    axes[0].set_ylabel("tube velocity amplitude U (m/s)")
    axes[0].annotate("speed of sound", (0.21, c), fontsize=7, va="bottom")
    axes[0].annotate("Mach 0.3", (0.21, 0.3 * c), fontsize=7, va="bottom")
    axes[-1].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _legend(fig, axes):
    handles, labels = [], []
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 0.99))


# ---------------------------------------------------------------------------
# main
# ---------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    """Run the study.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status (0).
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="out/fig11", help="output directory")
    ap.add_argument(
        "--no-simulation",
        action="store_true",
        help="skip the time-domain check (isodesign.simulation.harmonic_rig)",
    )
    ap.add_argument(
        "--fine-points",
        type=int,
        default=801,
        help="points of the fine frequency grid (default 801)",
    )
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")

    t0 = time.perf_counter()
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    design = SpringDesign.reference()
    grids = frequency_grids(args.fine_points, pole_frequency_hz(design))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        curves = evaluate_curves(design, grids)
        summary = summarize(curves, pole_frequency_hz(design))
        checks = paper_checks(design)
    sim = None
    if args.no_simulation:
        print("note: time-domain check skipped (--no-simulation)")
    else:
        sim = run_simulation(design)

    curves.to_csv(out / "fig11_curves.csv", index=False, float_format="%.10g")
    summary.to_csv(out / "fig11_summary.csv", index=False, float_format="%.6g")
    if sim is not None:
        sim.to_csv(out / "fig11_simulation.csv", index=False, float_format="%.8g")
        checks.append(
            "time-domain vs harmonic balance (quasi_steady): max |k_sim - k_hb|/|k_hb| = "
            f"{sim['rel_diff_abs_k'].max():.4f}, max |eta_sim - eta_hb| = "
            f"{sim['diff_loss_factor'].abs().max():.4f}"
        )
    (out / "fig11_checks.txt").write_text("\n".join(checks) + "\n")

    plot_paper_models(curves, design, out / "fig11_paper_models.png")
    plot_self_consistent(curves, design, sim, out / "fig11_self_consistent.png")
    plot_velocity(curves, design, out / "fig11_velocity.png")

    print("\n".join(checks))
    cols = [
        "model",
        "diaphragm",
        "amplitude_mm",
        "peak_loss_factor",
        "peak_frequency_hz",
        "peak_frequency_off_pole_hz",
        "min_loss_factor",
        "flagged_points",
        "points",
        "nonpassive_from_hz",
        "nonpassive_to_hz",
    ]
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(summary[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"wrote {out}/ in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
