"""Every number docs/optimization.md quotes about the vertical study, checked against a run.

Each entry of :data:`CHECKS` is a regular expression over the document whose named
groups are quoted numbers; the group's name (before an optional ``__n`` suffix) is a
key of :func:`quoted_values`, computed from a full ``optimize(vertical_study())``. A
quoted number must equal the computed value rounded to the precision it is printed
with, so the document cannot drift from the code.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from isodesign.optimization.driver import optimize
from isodesign.optimization.problem import Problem
from isodesign.optimization.recheck import evaluate_design
from isodesign.optimization.refine import continuous_peak_db
from isodesign.optimization.study import vertical_study
from isodesign.response.random_input import band_response

DOC = Path(__file__).resolve().parents[2] / "docs" / "optimization.md"
README = Path(__file__).resolve().parents[2] / "README.md"
NUM = r"[+-]?\d+(?:\.\d+)?"

#: (regular expression, with named groups of quoted numbers)
CHECKS = [
    # section 2
    rf"p0 = (?P<start_p0_bar>{NUM}) bar abs",
    rf"\*\*The start design misses by (?P<start_miss_db>{NUM}) dB\.\*\* The paper's spring under "
    rf"150 kg has\nk_s = (?P<start_ks_kn_m>{NUM}) kN/m and f_n = (?P<start_fn_hz>{NUM}) Hz\. "
    rf"At 4 Hz, only (?P<start_fn_ratio>{NUM}) f_n, the payload band velocity is\n"
    rf"(?P<start_v4_um_s>{NUM}) um/s",
    rf"The optimum \(section 9\) is N = (?P<opt_n>{NUM}), V_t0 = (?P<opt_vt_l>{NUM}) L, "
    rf"L_c = (?P<opt_lc_mm>{NUM}) mm, D_c = (?P<opt_dc_mm>{NUM}) mm: (?P<opt_total_l>{NUM}) L\n"
    rf"total \(the tie-break point of section 5\), k_s = (?P<opt_ks_kn_m>{NUM}) kN/m, "
    rf"f_n = (?P<opt_fn_hz>{NUM}) Hz, \*\*(?P<opt_margin_analysis_db>{NUM}) dB\*\* at "
    rf"(?P<opt_worst_band_hz>{NUM}) Hz\n\(analysis; (?P<opt_margin_nlp_db>{NUM}) dB on the NLP's "
    rf"grid\)",
    rf"The best objective the NLP finds is (?P<tie_cost_db>{NUM}) dB higher, "
    rf"(?P<anchor_margin_db>{NUM}) dB, at the (?P<anchor_total_l>{NUM}) L envelope \(N = "
    rf"(?P<anchor_n>{NUM}),\nV_t0 = (?P<anchor_vt_l>{NUM}) L, L_c = (?P<anchor_lc_mm>{NUM}) mm, "
    rf"D_c = (?P<anchor_dc_mm>{NUM}) mm",
    rf"With the lumped model the optimum stopped on the\nmodel's own edge: "
    rf"N = (?P<lumped_n>{NUM}), V_t0 = (?P<lumped_vt_l>{NUM}) L, "
    rf"L_c = (?P<lumped_lc_mm>{NUM}) mm, D_c = (?P<lumped_dc_mm>{NUM}) mm, "
    rf"(?P<lumped_margin_db>{NUM}) dB",
    rf"which capped L_c at (?P<lumped_lc_mm__2>{NUM}) mm",
    rf"shortening the tube from (?P<opt_lc_mm__3>{NUM}) mm to 12 mm \(D_c "
    rf"(?P<opt_dc_mm__2>{NUM}) ->\n(?P<short_dc_mm>{NUM}) mm\) loses (?P<short_loss_db>{NUM}) dB "
    rf"\((?P<opt_margin_analysis_db__2>{NUM}) -> (?P<short_margin_db>{NUM}) dB, analysis\)",
    # section 3
    r"at every grid frequency\n  \(`amplitude_residual = 0`; (?P<n_grid>\d+) frequencies in the "
    r"default study\)",
    r"sigma² is a sum over all (?P<n_floor>\d+) floor-grid points",
    r"\*\*Sizes\*\* \(default study\): (?P<nx>\d+) variables, (?P<ng>\d+) constraint rows "
    r"\((?P<n_eq>\d+) equalities;",
    # section 4
    rf"the large-N branch \(N = (?P<large_n>{NUM}),\nV_t0 = (?P<large_vt_l>{NUM}) L, "
    rf"(?P<large_margin_db>{NUM}) dB on the sampled peak grid, reached by (?P<large_count>\d+) of "
    rf"(?P<n_starts>\d+) starts, the study's own start among them\) and a\nsmall-N branch "
    rf"\(N = (?P<small_n>{NUM}), V_t0 = (?P<small_vt_l>{NUM}) L, (?P<small_margin_db>{NUM}) dB, "
    rf"(?P<small_count>\d+) of (?P<n_starts__2>\d+)\)",
    # section 5
    rf"\(inertance, minor loss\): D_c spans (?P<flat_dc_lo_mm>{NUM})-(?P<flat_dc_hi_mm>{NUM}) "
    rf"mm and L_c (?P<flat_lc_lo_mm>{NUM})-(?P<flat_lc_hi_mm>{NUM}) mm",
    # section 6
    r"The default study agrees to better than 1e-(?P<recheck_exponent>\d+)\.",
    # section 8
    rf"worst-band margin: (?P<opt_margin_nlp_db__2>{NUM}) dB on the NLP's grid, "
    rf"(?P<opt_margin_analysis_db__3>{NUM}) dB in the analysis",
    rf"the first solve gave (?P<first_peak_db>{NUM}) dB between grid points",
    rf"one round brings the\s+continuous peak to (?P<final_peak_db>{NUM}) dB and costs about "
    rf"(?P<refine_cost_db>{NUM}) dB of worst-band margin\s+\((?P<large_margin_db__2>{NUM}) -> "
    rf"(?P<opt_margin_nlp_db__3>{NUM}) dB\)",
    # section 9: the listing of `isodesign optimize`
    rf"N = V_b0/V_t0 (?P<start_n>{NUM}) (?P<opt_n__4>{NUM})",
    rf"V_t0 \(L\) (?P<start_vt_l>{NUM}) (?P<opt_vt_l__4>{NUM})",
    rf"D_c \(mm\) (?P<start_dc_mm>{NUM}) (?P<opt_dc_mm__5>{NUM})",
    rf"k_s \(kN/m\) (?P<start_ks_kn_m__2>{NUM}) (?P<opt_ks_kn_m__2>{NUM})",
    rf"worst-band margin \(dB\) (?P<start_margin_db>{NUM}) at 4 Hz "
    rf"(?P<opt_margin_analysis_db__4>{NUM}) at (?P<opt_worst_band_hz__2>{NUM}) Hz",
    rf"objective worst_band_margin \(NLP grid\) (?P<start_objective_db>{NUM}) dB "
    rf"(?P<opt_margin_nlp_db__6>{NUM}) dB",
    rf"within 0\.010 dB of the optimum, D_c spans (?P<flat_dc_lo_mm__2>{NUM})-"
    rf"(?P<flat_dc_hi_mm__2>{NUM}) mm and L_c (?P<flat_lc_lo_mm__2>{NUM})-"
    rf"(?P<flat_lc_hi_mm__2>{NUM}) mm",
    # section 10: the anchor of the front is the optimum before the tie-break
    rf" 0 +(?P<anchor_margin_db__2>{NUM}) dB +(?P<anchor_total_l__2>{NUM}) L "
    rf"+(?P<anchor_n__2>{NUM}) +(?P<anchor_vt_l__2>{NUM}) +(?P<anchor_lc_mm__2>{NUM}) "
    rf"+(?P<anchor_dc_mm__2>{NUM}) +yes",
    # section 11: the 600 kg row of the payload sweep
    rf"\| 600 \| (?P<opt_n__3>{NUM}) \| (?P<opt_vt_l__3>{NUM}) \| (?P<opt_lc_mm__5>{NUM}) \| "
    rf"(?P<opt_dc_mm__4>{NUM}) \| (?P<opt_margin_nlp_db__5>{NUM}) \| (?P<opt_fn_hz__2>{NUM}) \| "
    rf"(?P<small_n__2>{NUM}), (?P<small_margin_db__2>{NUM}) \|",
]


def _doc() -> str:
    """The document with every run of white space made one space (line breaks move)."""
    return re.sub(r"\s+", " ", DOC.read_text(encoding="utf-8"))


def matches() -> list[dict]:
    """The quoted numbers of every check, {group name: text}."""
    text = _doc()
    out = []
    for pattern in CHECKS:
        found = list(re.finditer(re.sub(r"\\n *", " ", pattern), text))
        assert len(found) == 1, f"{len(found)} matches in {DOC.name} for: {pattern}"
        out.append(found[0].groupdict())
    return out


def printed_as(value: float, quoted: str) -> str:
    """``value`` printed with the sign and the number of decimals of ``quoted``."""
    decimals = len(quoted.split(".")[1]) if "." in quoted else 0
    sign = "+" if quoted.startswith("+") else ""
    return f"{value:{sign}.{decimals}f}"


def test_every_check_matches_the_document_once():
    assert sum(len(m) for m in matches()) > 50


@pytest.fixture(scope="module")
def quoted_values() -> dict:
    """The default study's figures the document quotes, from one full run."""
    st = vertical_study()
    res = optimize(st)
    assert res.feasible and res.success
    prob = Problem(st)
    v, v0 = res.values, res.start_values
    d, d0 = res.design, st.design_at(v0)
    an, an0 = res.analysis, res.start_analysis
    q = {
        "start_p0_bar": d0.pressure_pa / 1e5,
        "start_miss_db": -an0.worst_margin_db,
        "start_ks_kn_m": d0.single_chamber_stiffness_n_per_m / 1e3,
        "start_fn_hz": an0.stability.natural_frequency_hz,
        "start_fn_ratio": 4.0 / an0.stability.natural_frequency_hz,
        "start_v4_um_s": 1e6 * float(an0.payload_velocity_rms_m_s[
            int(np.argmin(np.abs(np.asarray(an0.bands.nominal_hz) - 4.0)))]),
        "start_n": v0["volume_ratio"],
        "start_vt_l": v0["top_volume_m3"] * 1e3,
        "start_dc_mm": v0["capillary_diameter_m"] * 1e3,
        "start_margin_db": an0.worst_margin_db,
        "start_objective_db": res.start_objective,
        "opt_n": v["volume_ratio"],
        "opt_vt_l": v["top_volume_m3"] * 1e3,
        "opt_lc_mm": v["capillary_length_m"] * 1e3,
        "opt_dc_mm": v["capillary_diameter_m"] * 1e3,
        "opt_total_l": d.total_volume_m3 * 1e3,
        "opt_ks_kn_m": d.single_chamber_stiffness_n_per_m / 1e3,
        "opt_fn_hz": an.stability.natural_frequency_hz,
        "opt_margin_analysis_db": an.worst_margin_db,
        "opt_worst_band_hz": an.worst_band_hz,
        "opt_margin_nlp_db": res.objective_value,
        "n_grid": prob.grid.omega.size,
        "n_floor": prob.grid.n_floor,
        "nx": prob.nx,
        "ng": prob.lbg.size,
        "n_eq": prob.n_eq,
        "n_starts": len(res.starts),
        "flat_dc_lo_mm": res.flat_direction["capillary_diameter_range_m"][0] * 1e3,
        "flat_dc_hi_mm": res.flat_direction["capillary_diameter_range_m"][1] * 1e3,
        "flat_lc_lo_mm": min(res.flat_direction["capillary_length_range_m"]) * 1e3,
        "flat_lc_hi_mm": max(res.flat_direction["capillary_length_range_m"]) * 1e3,
        "recheck_exponent": math.floor(-math.log10(res.recheck_max_rel_diff)),
        "final_peak_db": res.peak["peak_db"],
    }
    # the two branches of the multi-start (sampled peak grid, before any refinement)
    feasible = [s for s in res.starts if s.feasible]
    large = [s for s in feasible if s.final["volume_ratio"] > 2.0]
    small = [s for s in feasible if s.final["volume_ratio"] <= 2.0]
    for name, group in (("large", large), ("small", small)):
        best = max(group, key=lambda s: s.objective)
        q[f"{name}_n"] = best.final["volume_ratio"]
        q[f"{name}_vt_l"] = best.final["top_volume_m3"] * 1e3
        q[f"{name}_margin_db"] = best.objective
        q[f"{name}_count"] = len(group)
    assert large[0].index == 0  # the document says the study's own start is among them
    q["refine_cost_db"] = q["large_margin_db"] - res.objective_value
    # the continuous peak at the sampled optimum, before the refinement
    best = max(large, key=lambda s: s.objective)
    ev = evaluate_design(st, best.final, grid=prob.grid)
    q["first_peak_db"] = continuous_peak_db(prob, best.final, ev["sigma"], ev["tube_rms"])[0]
    # the same laminar resistance L_c / D_c^4 in a 12 mm tube
    short = dict(v, capillary_length_m=0.012,
                 capillary_diameter_m=v["capillary_diameter_m"]
                 * (0.012 / v["capillary_length_m"]) ** 0.25)
    kw = {"flow": st.models["flow"], "amplitude_mode": st.models["amplitude_mode"],
          "diaphragm": prob.dia}
    an_s = band_response(st.design_at(short), st.payload, st.floor, st.target,
                         bands=st.bands, derive_pressure=False, warn=False, **kw)
    # the Pareto front's anchor: the optimum re-solved without the tie-break (section 10)
    from isodesign.optimization.pareto import pareto_front

    pf = pareto_front(st, points=2)
    av = pf.designs[0]
    q["anchor_margin_db"] = float(pf.values[0, 0])
    q["anchor_total_l"] = float(pf.values[0, 1]) * 1e3
    q["anchor_n"] = av["volume_ratio"]
    q["anchor_vt_l"] = av["top_volume_m3"] * 1e3
    q["anchor_lc_mm"] = av["capillary_length_m"] * 1e3
    q["anchor_dc_mm"] = av["capillary_diameter_m"] * 1e3
    q["tie_cost_db"] = q["anchor_margin_db"] - res.objective_value
    # the lumped model's optimum (docs/acoustics.md: what the distributed model moved)
    res_l = optimize(st.with_changes(models={"acoustics": "lumped"}))
    q["lumped_n"] = res_l.values["volume_ratio"]
    q["lumped_vt_l"] = res_l.values["top_volume_m3"] * 1e3
    q["lumped_lc_mm"] = res_l.values["capillary_length_m"] * 1e3
    q["lumped_dc_mm"] = res_l.values["capillary_diameter_m"] * 1e3
    q["lumped_margin_db"] = res_l.objective_value
    q["short_dc_mm"] = short["capillary_diameter_m"] * 1e3
    q["short_margin_db"] = an_s.worst_margin_db
    q["short_loss_db"] = an.worst_margin_db - an_s.worst_margin_db
    return q


#: What README.md quotes about the default study.
README_CHECKS = [
    rf"The paper's spring misses VC-C by (?P<start_miss_db>{NUM}) dB; the\noptimum "
    rf"\(N = (?P<opt_n>{NUM}), V_t0 = (?P<opt_vt_l>{NUM}) L, L_c = (?P<opt_lc_mm>{NUM}) mm, "
    rf"D_c = (?P<opt_dc_mm>{NUM}) mm, (?P<opt_total_l>{NUM}) L in all\) meets it with\n"
    rf"(?P<opt_margin_analysis_db>{NUM}) dB",
]


#: Other files that quote the vertical study's run: (path, check), each check as in CHECKS.
#: (The demo runs the default study, the co-designed table: docs/cli.md's figures of it are
#: checked by tests/docs/test_default_study_numbers.py.)
ROOT = Path(__file__).resolve().parents[2]
OTHER_CHECKS = [
    (ROOT / "isodesign" / "data" / "vertical_study.toml",
     rf"it misses VC-C at 4 Hz by # (?P<start_miss_db>{NUM}) dB"),
]


def other_matches() -> list[tuple[str, dict]]:
    """(file name, named groups) of every check of :data:`OTHER_CHECKS` (each matches once)."""
    out = []
    for path, pattern in OTHER_CHECKS:
        text = " ".join(path.read_text(encoding="utf-8").split())
        found = list(re.finditer(pattern, text))
        assert len(found) == 1, f"{len(found)} matches in {path.name} for: {pattern}"
        out.append((path.name, found[0].groupdict()))
    return out


def test_other_checks_match_once():
    assert sum(len(g) for _, g in other_matches()) == 1


@pytest.mark.slow
def test_other_files_quote_the_default_run(quoted_values):
    wrong = [f"{name} {key}: file {text}, code {printed_as(quoted_values[key], text)}"
             for name, groups in other_matches() for key, text in groups.items()
             if printed_as(quoted_values[key], text) != text]
    assert not wrong, "drifted: " + "; ".join(wrong)


def readme_matches() -> list[dict]:
    """The named groups of every README check (each must match exactly once)."""
    text = " ".join(README.read_text(encoding="utf-8").split())
    out = []
    for pattern in README_CHECKS:
        found = list(re.finditer(re.sub(r"\\n *", " ", pattern), text))
        assert len(found) == 1, f"{len(found)} matches in README.md for: {pattern}"
        out.append(found[0].groupdict())
    return out


def test_readme_checks_match_once():
    assert sum(len(m) for m in readme_matches()) == 7


@pytest.mark.slow
def test_readme_numbers_match_the_default_run(quoted_values):
    wrong = [f"{name}: README {text}, code {printed_as(quoted_values[name], text)}"
             for groups in readme_matches() for name, text in groups.items()
             if printed_as(quoted_values[name], text) != text]
    assert not wrong, "README.md drifted: " + "; ".join(wrong)


@pytest.mark.slow
def test_quoted_numbers_match_the_default_run(quoted_values):
    wrong = []
    for groups in matches():
        for name, text in groups.items():
            value = quoted_values[name.split("__")[0]]
            if printed_as(value, text) != text:
                wrong.append(f"{name}: doc {text}, code {printed_as(value, text)}")
    assert not wrong, "docs/optimization.md drifted: " + "; ".join(wrong)
