"""The figures docs/simulation.md quotes about the rig simulator, recomputed.

The agreement table (section 4), its worst values and the measured figures of sections 2-4
come from ``studies/rig_agreement.py`` (the same functions the script prints); each quoted
number must equal the computed one at the precision it is printed with, except figures at the
level of the integration round-off (they move between machines), which the page states as
bounds and the tests check as bounds. The integrator
table (section 2) and the 60-cycle drift figures (section 3) are printed by
``studies/rig_agreement.py --integrators`` and ``--drift`` (a minute or more each: not
re-run here); the integrator table's rows and its default's bound are checked. If one of
these fails, the page and the code disagree: fix the page (or the code), never the tolerance.
"""

from __future__ import annotations

import re
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest

from isodesign import SpringDesign

ROOT = Path(__file__).parents[2]
PAGE = (ROOT / "docs" / "simulation.md").read_text(encoding="utf-8")
FLAT = " ".join(PAGE.split())
REF = SpringDesign.reference()


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in FLAT, text


def agrees(shown: str, value: float, what: str) -> None:
    """``shown`` (as printed: ``0.25``, ``2.7e-04``, ``+0.0019``) is ``value`` rounded."""
    d = Decimal(shown.strip().lstrip("+"))
    half = Decimal(1).scaleb(d.as_tuple().exponent) / 2
    assert abs(Decimal(repr(float(value))) - d) <= half * Decimal("1.000001"), (what, shown, value)


def test_integrator_table_is_the_scripts(study_script):
    """The table names the command that prints it, and the default's bound holds."""
    quoted("`python studies/rig_agreement.py --integrators`")
    mod = study_script("rig_agreement")
    labels = [label for label, _ in mod.INTEGRATOR_VARIANTS]
    rows = re.findall(r"^\| \**([^|*]+?)\** \| \**([0-9.e-]+)\**", PAGE, re.M)
    table = {label.strip(): float(v) for label, v in rows if label.strip() in labels}
    assert list(table) == labels
    assert table[labels[0]] < 1e-9
    quoted("The integration and sampling error of the default settings is below 1e-9")


@pytest.fixture(scope="module")
def study(study_script):
    return study_script("rig_agreement")


@pytest.fixture(scope="module")
def grid(study):
    return study._grid(REF)


@pytest.fixture(scope="module")
def agreement(grid):
    from isodesign.simulation.harmonic_rig import agreement_table

    df = agreement_table(grid, REF.replace(acoustics="lumped"))
    sim = grid.to_frame()
    df["cycles"] = sim["cycles"].to_numpy()
    df["force_distortion"] = sim["force_distortion"].to_numpy()
    df["u1"] = grid._field("velocity_amplitude_m_s", float).ravel()
    return df


def _table_rows():
    rows = []
    for line in PAGE.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 15 and re.fullmatch(r"[0-9.]+", cells[0]):
            rows.append(cells)
    return rows


@pytest.mark.slow
def test_agreement_table(agreement):
    rows = _table_rows()
    assert len(rows) == len(agreement) == 24
    pct = ["abs_err", "re_err", "im_err"]
    for cells, (_, r) in zip(rows, agreement.iterrows(), strict=True):
        where = f"{cells[0]} Hz, {cells[1]} mm"
        assert float(cells[0]) == r["frequency_hz"] and float(cells[1]) == r["amplitude_m"] * 1e3
        re_k, im_k = cells[2].rstrip("j").split(" + ")
        agrees(re_k, r["k_sim_real_n_per_m"], where)
        agrees(im_k, r["k_sim_imag_n_per_m"], where)
        agrees(cells[3], r["loss_factor_sim"], where)
        for k, mode in ((4, "self_consistent"), (8, "kinematic")):
            for i, col in enumerate(pct):
                agrees(cells[k + i].rstrip(" %"), 100 * r[f"{mode}_{col}"], f"{where} {mode} {col}")
            agrees(cells[k + 3], r[f"{mode}_loss_factor_diff"], f"{where} {mode} d-eta")
        agrees(cells[12], r["u1"], f"{where} U1")
        agrees(cells[13].rstrip(" %"), 100 * r["force_distortion"], f"{where} distortion")
        assert int(cells[14]) == r["cycles"], where


@pytest.mark.slow
def test_worst_values_and_bullets(agreement):
    df = agreement

    def worst(mode, col):
        i = int(np.argmax(np.abs(df[f"{mode}_{col}"])))
        r = df.iloc[i]
        return abs(r[f"{mode}_{col}"]), f"({r['frequency_hz']:g} Hz, {r['amplitude_m'] * 1e3:g} mm)"

    sc = [worst("self_consistent", c) for c in ("abs_err", "re_err", "im_err", "complex_err")]
    eta, at = worst("self_consistent", "loss_factor_diff")
    quoted("| self-consistent | " + " | ".join(f"{v:.2%} {w}".replace("%", " %") for v, w in sc)
           + f" | {eta:.3f} {at} |")
    kin = [worst("kinematic", c)[0] for c in ("abs_err", "re_err", "im_err", "complex_err")]
    quoted("| kinematic (Eq. 37) | " + " | ".join(f"{100 * v:.1f} %" for v in kin)
           + f" | {worst('kinematic', 'loss_factor_diff')[0]:.3f} |")
    hi = df[(df["frequency_hz"] >= 10) & (df["amplitude_m"] == 0.5e-3)]
    k_im = [f"{100 * v:.0f} %" for v in hi["kinematic_im_err"]]
    k_c = [f"{100 * v:.1f} %" for v in hi["kinematic_complex_err"]]
    s_c = [f"{100 * v:.2f} %" for v in hi["self_consistent_complex_err"]]
    times = [f"{v:.0f}" for v in hi["kinematic_complex_err"] / hi["self_consistent_complex_err"]]
    quoted(f"the loss stiffness is wrong by {k_im[0]} and {k_im[1]}: complex errors {k_c[0]} and\n"
           f"  {k_c[1]}, against {s_c[0]} and {s_c[1]} for the self-consistent mode ({times[0]} "
           f"and {times[1]} times larger)")
    quoted(f"within {df['self_consistent_abs_err'].max():.1%}".replace("%", " %")
           + f" in `|k|` and {df['self_consistent_loss_factor_diff'].abs().max():.3f} in loss "
           "factor\n  everywhere")

    def at(f, x):
        r = df[(df["frequency_hz"] == f) & (df["amplitude_m"] == x)].iloc[0]
        return f"{r['self_consistent_abs_err']:.2%}".replace("%", " %")

    quoted(f"gives {at(0.5, 5e-5)} (0.05 mm, 0.5 Hz), {at(2.0, 5e-5)} (0.05 mm, 2 Hz) and "
           f"{at(2.0, 5e-4)} (0.5 mm, 2 Hz) in `|k|`")


@pytest.mark.slow
def test_measured_figures(study):
    """Round-off-sized figures are quoted as the bounds the page states, never as the digit one
    machine measured (the integration error moves them between machines); the physical ones
    (velocities, peak ratios, distortion) are printed to a precision the round-off cannot move."""
    v = study.checks(REF)
    lin = max(v["linear_limit_adiabatic"], v["linear_limit_n1"], v["linear_limit_n1_2"])
    assert lin < 1e-7
    quoted("simulation and Eq. 38 agree to within 1e-7\n  at 0.2 to 24 Hz")
    assert v["small_quasi_steady"] < 3e-5
    quoted("(5e-5 asserted, below 3e-5 measured")
    assert v["isothermal"] < 2e-5
    quoted("`p0 A_p^2/((1+N) V_t0)` to within 2e-5")
    assert v["gas_worst"] < 2e-4 and v["gas_small_amplitude"] < 2e-5
    assert (v["gas_worst_hz"], v["gas_worst_mm"]) == (24.0, 0.5)
    # it scales with X: ten times the amplitude, about ten times the difference
    assert 5 < v["gas_worst"] / v["gas_small_amplitude"] < 20
    quoted("differs from Eq. 38 by at most 2e-4 (worst at 24 Hz,\n   0.5 mm; below 2e-5 at 0.05 "
           "mm: it scales with X)")
    assert v["heating_identity"] < 3e-5
    quoted("to within 3e-5 relative (a bound")
    assert v["u_self_consistent"] < 0.03
    quoted("its tube velocity amplitude `U` is within 3 % of the simulated first harmonic")
    quoted(f"overestimates `U` by the factor {v['u_kinematic_low']:.2f} = (N+1)/N at low\n  "
           f"frequency and by up to {v['u_kinematic_max']:.0f} (24 Hz, 0.5 mm: "
           f"{v['u_kinematic_top']:.0f} m/s against {v['u_sim_top']:.1f} m/s simulated)")
    assert f"{v['n_plus_1_over_n']:.2f}" == f"{v['u_kinematic_low']:.2f}"
    quoted(f"(peak {v['peak_ratio_min']:.2f} to {v['peak_ratio_max']:.2f} of the")
    quoted(f"carries up to {v['distortion_max']:.1%}".replace("%", " %") + " of higher harmonics")


def test_sizes_quoted_in_sections_1_and_2():
    d = REF
    quoted(f"for the\nreference spring X < {0.5 * d.top_volume_m3 / d.piston_area_m2 * 1e3:.1f} mm")
    lo = d.static_stiffness_n_per_m * 1e-7 / d.piston_area_m2 / d.pressure_pa
    hi = d.single_chamber_stiffness_n_per_m * 1e-7 / d.piston_area_m2 / d.pressure_pa
    quoted(f"where it is {lo:.0e} (`k_s/(N+1) X/A_p`) to {hi:.0e} (`k_s X/A_p`) of `p0`."
           .replace("e-0", "e-"))
    quoted(f"at most {d.piston_area_m2 * 5e-4 / d.top_volume_m3:.1%}".replace("%", " %")
           + " of the inertance at 0.5 mm")


@pytest.mark.slow
def test_cycles_and_mach_on_the_grid(agreement, grid):
    quoted(f"From there the cases of the reference grid stop after {agreement['cycles'].min()} "
           f"to {agreement['cycles'].max()} cycles.")
    peak = grid._field("peak_velocity_m_s", float)[:, -1].max()
    mach = peak / REF.gas.speed_of_sound(REF.temperature_k)
    quoted(f"the Mach number reaches {mach:.2f} at 0.5 mm")


def test_describing_velocity_of_the_all_regime_friction():
    """Section 4, item 3: Phi(U_eq) against the exact first harmonic of Phi(Re(u)) u."""
    from scipy import integrate

    from isodesign.spring.capillary import churchill_friction_re_product as phi

    per_u = REF.density_kg_m3 * REF.capillary_diameter_m / REF.viscosity_pa_s

    def ratio(u):
        exact = 2 / np.pi * integrate.quad(
            lambda t: float(phi(per_u * u * np.sin(t))) * np.sin(t) ** 2, 0, np.pi, limit=200)[0]
        return float(phi(per_u * 8 * u / (3 * np.pi))) / exact

    peak_re = round(per_u * 8, -2)
    quoted(f"`Phi(U_eq)/Phi_DF = {ratio(8.0):.2f}` at U = 8 m/s (peak Re {peak_re:,.0f}), "
           f"{ratio(10.0):.2f} at 10\n   m/s, {ratio(14.7):.2f} at 14.7 m/s, {ratio(20.0):.2f} at "
           "20 m/s (exact for laminar, U <= 5 m/s)")
    assert ratio(5.0) == pytest.approx(1.0, abs=1e-6)


def test_monte_carlo_warmup_changes_little():
    """Section 7, limits: 20 s against 60 s of warm-up, reference case, one 320 s realization."""
    from isodesign.response import Payload
    from isodesign.simulation import simulate_random_response

    def stroke(warmup_s):
        return simulate_random_response(REF, Payload(400.0, 4), "VC-A", target="VC-E",
                                        seeds=[1], duration_s=320.0, diaphragm="none",
                                        warmup_s=warmup_s).stroke_rms_m

    change = abs(stroke(20.0) / stroke(60.0) - 1)
    assert change < 5e-4
    quoted("20 s against 60 s of warm-up\nchange the stroke RMS by less than 0.05 % in the "
           "reference case, one 320 s realization")
