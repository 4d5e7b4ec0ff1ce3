"""``[models] distortion = true`` through every optimizer (docs/random-response.md section 3d):
the robust stack (vertical and table), ``yield`` and the parametric sweep NLP (vertical and
table) carry the distortion power, each answering the question the nominal optimizer and
the NumPy analysis answer (to 1e-6 dB, the re-check's tolerance)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import isodesign
from isodesign.optimization.exchange import robust_optimize, scenario_check
from isodesign.optimization.problem import Problem
from isodesign.optimization.recheck import evaluate_design
from isodesign.optimization.robust import RobustProblem, ScenarioBlock
from isodesign.optimization.study import study_from_dict, table_study, vertical_study

FAST = {"models": {"points_per_band": 3, "peak_points": 30, "distortion": True},
        "solver": {"starts": 1, "workers": 1}}
#: A design near the vertical study's optimum (inside every bound).
DESIGN = {"volume_ratio": 7.5, "top_volume_m3": 0.65e-3, "capillary_length_m": 0.16,
          "capillary_diameter_m": 2.0e-3}
BOX = {"payload_mass_kg": {"min": 540.0, "max": 660.0},
       "capillary_diameter_m": {"relative": 0.03}}


def small_vertical(**kw):
    """vertical_study(), coarse grids, one start, the distortion on."""
    return vertical_study().with_changes(**{**FAST, **kw})


def small_table(**sections):
    """table_study(), 3 points per band, bands 4-20 Hz, one start, the distortion on."""
    raw = copy.deepcopy(table_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"].update(points_per_band=3, distortion=True)
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    raw.update(sections)
    return study_from_dict(raw, source="small_table.toml", fill_defaults=False)


def test_no_entry_point_refuses_the_key():
    st = small_vertical(scenarios=BOX)
    assert st.models["distortion"] is True and st.scenarios is not None
    assert type(ScenarioBlock(st)).__name__ == "ScenarioDistortionBlock"


def test_one_scenario_stack_is_the_nominal_nlp_with_the_distortion():
    """The robust stack of the nominal scenario alone (each scenario its own terms, one
    outer fixed point over the stack) is the nominal NLP's optimum with the distortion."""
    st = small_vertical(scenarios=BOX)
    block = ScenarioBlock(st)
    prob = Problem(small_vertical())
    ref = prob.solve(prob.initial_guess(DESIGN))
    rp = RobustProblem(block, [block.space.nominal()])
    sol = rp.solve(rp.initial_guess(DESIGN))
    assert sol.feasible and ref.feasible and sol.outer_rounds >= 2
    assert sol.objective == pytest.approx(ref.objective, abs=1e-6)
    for n, v in ref.values.items():
        assert sol.values[n] == pytest.approx(v, rel=1e-5)


def test_two_scenario_stack_states_each_scenarios_numpy_figure():
    """Two scenarios: the stack's worst case is the NumPy analysis's (evaluate_design with
    the distortion, in each scenario) to 1e-6, and each scenario's epigraph bounds its
    figure; without the distortion's terms the figures differ."""
    st = small_vertical(scenarios=BOX)
    block = ScenarioBlock(st)
    thetas = [st.scenarios.nominal(), st.scenarios.upper()]
    rp = RobustProblem(block, thetas)
    sol = rp.solve(rp.initial_guess(DESIGN))
    assert sol.success and sol.outer_rounds >= 2
    plain = small_vertical(scenarios=BOX, models={**FAST["models"], "distortion": False})
    js = []
    for k, th in enumerate(thetas):
        j = scenario_check(st, sol.values, th)["j"]
        assert sol.scenario_objectives[k] >= j - 1e-6
        assert abs(scenario_check(plain, sol.values, th)["j"] - j) > 1e-4
        js.append(j)
    assert sol.objective == pytest.approx(max(js), abs=1e-6)


@pytest.mark.slow  # the exchange on the vertical body: about 35 s
def test_vertical_robust_optimum_with_the_distortion_is_checked_by_numpy():
    st = small_vertical(scenarios=BOX)
    res = robust_optimize(st)
    assert res.feasible and res.converged, res.rounds
    worst = next(r for r in res.scenarios if r["worst"])
    chk = scenario_check(st, res.values, np.array(list(worst["theta"].values())))
    assert chk["objective"] == pytest.approx(res.objective_value, abs=1e-6)
    for th in st.scenarios.corners():
        c = scenario_check(st, res.values, th)
        assert c["max_violation"] <= 1e-6 and c["objective"] >= res.objective_value - 1e-6


@pytest.mark.slow  # the table's exchange: about 25 s
def test_table_robust_optimum_with_the_distortion_holds_at_every_corner():
    from isodesign.optimization.robust_table import _Scenarios, robust_optimize_table

    st = small_table(scenarios={"payload_mass_kg": {"min": 560.0, "max": 640.0},
                                "cg_offset_y_m": {"absolute": 0.03}})
    res = robust_optimize_table(st)
    assert res.feasible and res.converged, res.rounds
    sc = _Scenarios(st)
    gaps = []
    for th in st.scenarios.corners():
        c = sc.check(th, res.values, -res.objective_value)
        assert c["max_violation"] <= 1e-6
        gaps.append(c["gap"])
    assert max(gaps) <= 1e-6 and min(abs(g) for g in gaps) <= 1e-6  # the stated worst case


def test_a_yield_draw_is_judged_with_the_distortion():
    """``yield`` of a table study: each draw's band response carries the distortion (the
    draw at the nominal scenario is the table analysis with the distortion)."""
    from isodesign.optimization.analyze import analyze
    from isodesign.optimization.yields import table_draw_response

    st = small_table(scenarios={"payload_mass_kg": {"min": 560.0, "max": 640.0}})
    start = {v.name: v.start for v in st.variables}
    r, _ = table_draw_response(st, start, st.scenarios.nominal())
    nominal = small_table()
    a = analyze(nominal, start, points_per_band=3)
    assert r.worst_margin_db == pytest.approx(a.worst_margin_db, abs=1e-6)
    off = analyze(small_table(models={**nominal.raw["models"], "distortion": False}), start,
                  points_per_band=3)
    assert abs(off.worst_margin_db - r.worst_margin_db) > 1e-4
    # the vertical body's draws: scenario_check, evaluate_design with the distortion
    sv = small_vertical(scenarios=BOX)
    chk = scenario_check(sv, DESIGN, sv.scenarios.nominal())
    ev = evaluate_design(small_vertical(), DESIGN)
    assert chk["objective"] == pytest.approx(ev["objectives"]["worst_band_margin"], abs=1e-9)


@pytest.fixture(scope="module")
def vertical_answer():
    st = small_vertical()
    return st, isodesign.optimize(st)


def test_a_one_point_sweep_is_isodesign_optimize_vertical(tmp_path, vertical_answer):
    """The parametric NLP of a sweep carries the distortion: a one-point sweep's optimum
    is isodesign.optimize's (to 1e-6 dB), and a second mass is the NumPy analysis's."""
    st, res = vertical_answer
    m = st.payload.mass_kg
    sw = isodesign.sweep(st, vary={"payload.mass_kg": [m, 1.1 * m]}, output=tmp_path / "s",
                         scheduler="serial", charts=False)
    f = sw.to_frame()
    assert (f["error"].fillna("") == "").all(), f["error"].tolist()
    assert f["objective_value"].iloc[0] == pytest.approx(res.objective_value, abs=1e-6)
    heavy = st.with_changes({"payload.mass_kg": 1.1 * m})
    vals = {n: float(f[n].iloc[1]) for n in res.values}
    ev = evaluate_design(heavy, vals)
    assert ev["objectives"]["worst_band_margin"] == pytest.approx(
        f["objective_value"].iloc[1], abs=1e-6)


def test_a_one_point_sweep_is_isodesign_optimize_table(tmp_path):
    st = small_table()
    res = isodesign.optimize(st)
    sw = isodesign.sweep(st, vary={"payload.mass_kg": [st.table.mass_kg]},
                         output=tmp_path / "s", scheduler="serial", charts=False)
    f = sw.to_frame()
    assert f["error"].fillna("").iloc[0] == "", f["error"].iloc[0]
    assert f["objective_value"].iloc[0] == pytest.approx(res.objective_value, abs=1e-6)


def test_robust_sensitivities_carry_the_terms_dependence_on_the_scenario():
    """The design-held sensitivities of the robust block (the implicit function theorem on
    its NLP, the terms' values moved with theta by their own differences) against central
    differences of the NumPy analysis with the distortion (scenario_check)."""
    from isodesign.optimization.sensitivity import design_sensitivities

    st = small_vertical(scenarios=BOX)
    block = ScenarioBlock(st)
    sp = block.space
    th = 0.5 * (sp.lower() + sp.upper()) + 0.1 * (sp.upper() - sp.lower())
    block.select(th)
    x = block.initial_guess(DESIGN)
    sens = {(s.quantity, s.parameter): s for s in design_sensitivities(block, x, th)}
    for k, p in enumerate(sp.parameters):
        h = 1e-6 * max(1.0, abs(th[k]))
        tp, tm = th.copy(), th.copy()
        tp[k] += h
        tm[k] -= h
        cp, cm = (scenario_check(st, DESIGN, t, grid=block.grid) for t in (tp, tm))
        scale = 0.01 if p.mode == "relative" else 1.0  # per percent
        fd = (cp["objective"] - cm["objective"]) / (2 * h) * scale
        assert sens[("objective", p.name)].per_unit == pytest.approx(fd, rel=1e-4, abs=1e-7)


def test_a_table_pareto_anchor_is_isodesign_optimize():
    """The table's Pareto front with the distortion: anchor A's worst margin is the
    optimum's, each point judged at the expansion it was solved with."""
    st = small_table()
    res = isodesign.pareto_front(st, points=2)
    opt = isodesign.optimize(st)
    assert res.worst_margin_db[0] == pytest.approx(opt.objective_value, abs=1e-6)


def test_the_reports_closure_peak_and_modes_are_the_optimizers_with_the_distortion():
    # the report, `isodesign transmissibility` and the optimizer's peak check linearize the
    # springs at the same tube velocity (the RMS times the minor loss's gain ratio); the
    # report measured the plain-gain springs (table_driver._with_gain, the NLP's)
    from isodesign.optimization.table_driver import band_response_and_modes, measure_peaks
    from isodesign.optimization.table_problem import PEAK_ROWS_MAX_HZ
    from isodesign.optimization.transmissibility import study_closure_peaks
    from isodesign.table.peaks import continuous_peaks, peak_search_band

    st = table_study()
    assert st.models["distortion"] is True  # the default
    d = st.start_design()
    res, modes = band_response_and_modes(st, d)
    assert res.closure_gain_ratio is not None
    assert np.max(np.abs(res.closure_gain_ratio - 1.0)) > 1e-3
    opt = measure_peaks(Problem(st), d, res.stroke_rms_m, res.tube_velocity_rms_m_s, modes)
    rep = study_closure_peaks(st, d, st.table, st.models)
    # to the closures' tolerances (the band response's rtol against the NLP terms' 1e-11)
    assert rep.max_db == pytest.approx(opt.max_db, abs=1e-4)
    plain = continuous_peaks(res.model, res.stroke_rms_m, res.tube_velocity_rms_m_s,
                             *peak_search_band(modes, PEAK_ROWS_MAX_HZ))
    assert abs(plain.max_db - opt.max_db) > 1e-3  # the gain matters here
