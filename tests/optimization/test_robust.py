"""Robust design: the [scenarios] table, the stacked NLP, sensitivities, exchange, yield."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.exchange import robust_optimize, scenario_check
from isodesign.optimization.recheck import evaluate_design
from isodesign.optimization.robust import RobustProblem, ScenarioBlock
from isodesign.optimization.sensitivity import design_sensitivities
from isodesign.optimization.study import study_from_dict, vertical_study
from isodesign.optimization.uncertainty import ScenarioStudy
from isodesign.optimization.yields import clopper_pearson, estimate_yield, wilson
from isodesign.spring.gas import P_ATM

FAST = {"models": {"points_per_band": 3, "peak_points": 30},
        "solver": {"starts": 2, "workers": 1}}
#: A design near the default study's optimum (inside every bound).
DESIGN = {"volume_ratio": 7.5, "top_volume_m3": 0.65e-3, "capillary_length_m": 0.16,
          "capillary_diameter_m": 2.0e-3}
ALL = {"payload_mass_kg": {"min": 480.0, "max": 720.0},
       "ambient_pressure_pa": {"min": 9.0e4, "max": 1.03e5},
       "temperature_k": {"min": 283.0, "max": 303.0},
       "volume_ratio": {"relative": 0.02},
       "top_volume_m3": {"absolute": 1e-5},
       "capillary_length_m": {"absolute": 1e-3},
       "capillary_diameter_m": {"relative": 0.05, "distribution": "normal"},
       "diaphragm_stiffness": {"relative": 0.2}}


def _study(scen, **kw):
    return vertical_study().with_changes(scenarios=scen, **{**FAST, **kw})


# -- the [scenarios] table -----------------------------------------------------------------
def test_scenarios_are_off_by_default():
    st = vertical_study()
    assert st.scenarios is None and "scenarios" not in st.raw


def test_scenarios_table_parses_every_form():
    st = study_from_dict({"scenarios": {
        **ALL, "payload_mass_kg": {"values": [720.0, 480.0, 600.0]}, "max_rounds": 5}})
    sp = st.scenarios
    assert sp.names[0] == "payload_mass_kg" and sp.parameter("payload_mass_kg").values == (
        480.0, 600.0, 720.0)
    assert sp.settings["max_rounds"] == 5 and sp.settings["tolerance_db"] == 0.01
    assert sp.parameter("capillary_diameter_m").distribution == "normal"
    assert sp.parameter("temperature_k").nominal == 293.15
    assert sp.parameter("ambient_pressure_pa").nominal == P_ATM
    assert len(sp.corners(limit=1000)) == 3 * 2 ** 7
    assert len(sp.corners()) == 256  # a random subset beyond the limit
    # relative tolerance around an operating value
    st2 = study_from_dict({"scenarios": {"payload_mass_kg": {"relative": 0.2}}})
    p = st2.scenarios.parameter("payload_mass_kg")
    assert (p.lo, p.hi) == pytest.approx((480.0, 720.0))


@pytest.mark.parametrize("scen, words", [
    ({"payload_mass_kg": {"min": 720.0, "max": 480.0}}, ["scenarios.payload_mass_kg",
                                                         "inverted"]),
    ({"payload_mass_kg": {"min": 600.0, "max": 600.0}}, ["scenarios.payload_mass_kg", "empty"]),
    ({"payload_mass_kg": {"values": []}}, ["scenarios.payload_mass_kg.values", "non-empty"]),
    ({"capillary_diameter_m": {"relative": [-1.0, 0.05]}},
     ["scenarios.capillary_diameter_m.relative", "non-positive"]),
    ({"capillary_diameter_m": {"absolute": 0.5e-3}},
     ["scenarios.capillary_diameter_m.absolute", "non-positive", "0.0003"]),
    ({"temperature_k": {"min": -5.0, "max": 300.0}}, ["scenarios.temperature_k", "> 0"]),
    ({"capillary_diameter_m": {"relative": 0.05, "spread": 1}}, ["'spread'",
                                                                 "scenarios.capillary_diameter_m"]),
    ({"capillary_diameter_m": {"relative": 0.05, "distribution": "cauchy"}},
     ["distribution"]),
    ({"capillary_diameter_m": {"min": 1e-3, "max": 2e-3}}, ["'min'"]),
    ({"drill": {"relative": 0.05}}, ["unknown key 'drill' in [scenarios]"]),
    ({"max_rounds": 0}, ["scenarios.max_rounds"]),
    ({"capillary_diameter_m": {"relative": 0.0}}, ["scenarios.capillary_diameter_m.relative"]),
])
def test_bad_scenarios_name_the_key(scen, words):
    with pytest.raises(InputError) as e:
        study_from_dict({"scenarios": scen}, source="s.toml")
    msg = str(e.value)
    assert msg.startswith("s.toml: ")
    for w in words:
        assert w in msg, msg


def test_scenario_study_builds_the_spring_the_scenario_describes():
    st = _study(ALL)
    sp = st.scenarios
    th = sp.upper()
    sc = ScenarioStudy(st, sp, th)
    d = sc.design_at(DESIGN)
    assert d.capillary_diameter_m == pytest.approx(DESIGN["capillary_diameter_m"] * 1.05)
    assert d.capillary_length_m == pytest.approx(DESIGN["capillary_length_m"] + 1e-3)
    assert d.top_volume_m3 == pytest.approx(DESIGN["top_volume_m3"] + 1e-5)
    assert d.temperature_k == 303.0
    p0 = 1.03e5 + 720.0 * 9.80665 / (4 * d.piston_area_m2)
    assert d.pressure_pa == pytest.approx(p0)
    assert sc.payload.mass_kg == 720.0
    k = sc.models["diaphragm"].stiffness(10.0, 1e-5)
    k0 = ScenarioStudy(st, sp, sp.nominal()).models["diaphragm"].stiffness(10.0, 1e-5)
    assert k.re == pytest.approx(1.2 * k0.re)
    # at the nominal values the scenario study is the study
    a = evaluate_design(ScenarioStudy(st, sp, sp.nominal()), DESIGN)
    b = evaluate_design(st, DESIGN)
    assert a["objectives"] == pytest.approx(b["objectives"], abs=1e-12)


# -- the stacked NLP and its sensitivities -------------------------------------------------------
@pytest.fixture(scope="module")
def block():
    return ScenarioBlock(_study(ALL))


def test_one_scenario_at_nominal_values_is_the_nominal_nlp(block):
    from isodesign.optimization.problem import Problem

    st = block.nominal_study
    prob = Problem(st)
    ref = prob.solve(prob.initial_guess(DESIGN))
    rp = RobustProblem(block, [block.space.nominal()])
    sol = rp.solve(rp.initial_guess(DESIGN))
    assert sol.feasible and ref.feasible
    assert sol.objective == pytest.approx(ref.objective, abs=1e-6)
    for n, v in ref.values.items():
        assert sol.values[n] == pytest.approx(v, rel=1e-5)


def test_design_sensitivities_match_finite_differences_of_the_numpy_analysis(block):
    """Every parameter kind: CasADi (implicit function theorem) against central differences
    of the independent NumPy analysis, for the objective and two constraints."""
    st = block.nominal_study
    sp = block.space
    th = 0.5 * (sp.lower() + sp.upper()) + 0.1 * (sp.upper() - sp.lower())
    block.select(th)
    x = block.initial_guess(DESIGN)
    sens = {(s.quantity, s.parameter): s for s in design_sensitivities(block, x, th)}
    grid = block.grid
    c0 = scenario_check(st, DESIGN, th, grid=grid)
    assert c0["objective"] == pytest.approx(
        block.objective_values(x)[0] * -1.0, abs=1e-9)
    for k, p in enumerate(sp.parameters):
        h = 1e-6 * max(1.0, abs(th[k])) if p.mode != "absolute" else 1e-9
        tp, tm = th.copy(), th.copy()
        tp[k] += h
        tm[k] -= h
        cp, cm = (scenario_check(st, DESIGN, t, grid=grid) for t in (tp, tm))
        scale = 0.01 if p.mode == "relative" else 1.0  # per percent
        fd = (cp["objective"] - cm["objective"]) / (2 * h) * scale
        s = sens[("objective", p.name)]
        assert s.per_unit == pytest.approx(fd, rel=1e-4, abs=1e-7), p.name
        for cname in ("natural_frequency", "damping_ratio"):
            s = sens[(cname, p.name)]
            # lower-bound rows: signed excess = ln(lo) - ln(q), so q = lo exp(-excess)
            lo = 0.8 if cname[0] == "n" else 0.05
            qp = lo * math.exp(-cp["violations"][cname])
            qm = lo * math.exp(-cm["violations"][cname])
            assert s.per_unit == pytest.approx((qp - qm) / (2 * h) * scale, rel=1e-4,
                                               abs=1e-9), (cname, p.name)


def test_reoptimized_sensitivity_is_the_derivative_of_the_optimal_value(block):
    """lam_p of the stacked NLP against a central difference of two re-solves."""
    from isodesign.optimization.sensitivity import reoptimized_sensitivities

    sp = block.space
    th = sp.nominal()
    rp = RobustProblem(block, [th])
    sol = rp.solve(rp.initial_guess(DESIGN))
    d = reoptimized_sensitivities(rp, sol)[0]
    i = sp.names.index("payload_mass_kg")
    h = 0.5
    vals = []
    for sgn in (1, -1):
        t2 = th.copy()
        t2[i] += sgn * h
        rp.thetas = [t2]
        s2 = rp.solve(sol.x)
        assert s2.feasible
        vals.append(rp.natural(s2.objective))
    fd = (vals[0] - vals[1]) / (2 * h)
    assert d["payload_mass_kg"] == pytest.approx(fd, rel=2e-3)


# -- the exchange method ------------------------------------------------------------
def test_exchange_on_a_small_study_holds_in_the_whole_box():
    st = _study({"payload_mass_kg": {"min": 540.0, "max": 660.0},
                 "capillary_diameter_m": {"relative": 0.03}})
    res = robust_optimize(st)
    assert res.feasible and res.converged, res.rounds
    assert res.active_scenarios()
    # the stated worst case is the NumPy analysis's value at the worst scenario
    worst = next(r for r in res.scenarios if r["worst"])
    chk = scenario_check(st, res.values, np.array(list(worst["theta"].values())))
    assert chk["objective"] == pytest.approx(res.objective_value, abs=1e-6)
    # a grid of the box: nothing below the stated worst case, nothing violated
    g = np.linspace(0.0, 1.0, 5)
    sp = st.scenarios
    worst_seen = math.inf
    for a in g:
        for b in g:
            th = sp.lower() + np.array([a, b]) * (sp.upper() - sp.lower())
            c = scenario_check(st, res.values, th)
            worst_seen = min(worst_seen, c["objective"])
            assert c["max_violation"] <= 1e-6
            assert c["peak_excess_db"] <= 0.01
    assert worst_seen >= res.objective_value - 0.01
    assert res.objective_value <= res.nominal.objective_value
    rec = res.record()
    assert rec["worst_case_objective"] == res.objective_value
    assert res.scenarios_frame().shape[0] == len(res.scenarios)
    # one stacked NLP per number of scenarios: a round that adds none builds nothing
    counts = [r["scenarios"] for r in res.rounds]
    assert [r["nlp_built"] for r in res.rounds] == [
        k == 0 or counts[k] != counts[k - 1] for k in range(len(counts))]


def test_a_scenario_no_design_can_meet_is_named():
    st = _study({"payload_mass_kg": {"values": [600.0, 40.0]}})
    res = robust_optimize(st)
    assert not res.feasible
    msg = res.failure_message()
    assert "payload_mass_kg=40" in msg and "natural_frequency" in msg


#: The issue's box: +-5 % D_c and L_c, a 480-720 kg payload.
JUDGED_SCENARIOS = {"payload_mass_kg": {"min": 480.0, "max": 720.0},
                    "capillary_diameter_m": {"relative": 0.05},
                    "capillary_length_m": {"relative": 0.05}}


def _judge_at_1000_draws(st):
    """The issue's judgement of the robust optimum of ``st`` (NumPy analysis, not the NLP):
    every constraint met at 1000 draws and at every corner of the box, and the stated worst
    case no more than 0.05 dB above the worst draw. Returns the result and the yield."""
    res = robust_optimize(st)
    assert res.feasible and res.converged
    y = estimate_yield(st, res.values, samples=1000, seed=1, workers=2)
    assert y.worst("max_violation") <= 1e-6
    assert y.worst("peak_excess_db") <= 0.01
    assert y.fraction == 1.0
    assert res.objective_value - y.worst("objective", "min") <= 0.05
    # the corners too (the draws rarely reach them)
    for th in st.scenarios.corners():
        c = scenario_check(st, res.values, th)
        assert c["max_violation"] <= 1e-6 and c["objective"] >= res.objective_value - 1e-6
    return res, y


@pytest.mark.slow
def test_default_robust_optimum_holds_at_1000_draws():
    """The issue's judgement with the lumped acoustics: the worked example of
    docs/robust.md, whose numbers are checked here; the nominal optimum does not hold."""
    st = vertical_study().with_changes(scenarios=JUDGED_SCENARIOS,
                                      models={"acoustics": "lumped"})
    res, y = _judge_at_1000_draws(st)
    yn = estimate_yield(st, res.nominal.values, samples=1000, seed=1, workers=2)
    assert yn.fraction < 1.0 and yn.failure_counts()
    _check_worked_example(res, y, yn)


@pytest.mark.slow
def test_default_robust_optimum_holds_at_1000_draws_with_the_default_acoustics():
    """The issue's judgement on the study as shipped (distributed acoustics, the default)."""
    st = vertical_study().with_changes(scenarios=JUDGED_SCENARIOS)
    assert st.models["acoustics"] == "distributed"
    _judge_at_1000_draws(st)


def _check_worked_example(res, y, yn):
    """docs/robust.md's worked example: every number as this run computes it."""
    import re
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "robust.md").read_text()
    num = r"([+-]?\d+(?:\.\d+)?)"
    m = re.search(
        rf"nominal optimum: N {num}, V_t0 {num} L, L_c {num} mm, D_c {num} mm\n"
        rf"  worst_band_margin nominal {num} dB, worst case in the box {num} dB, .*?"
        rf"yield {num} %\nrobust optimum:  N {num}, V_t0 {num} L, L_c {num} mm, D_c {num} mm\n"
        rf"  worst case {num} dB \(480 kg, L_c \+5 %, D_c -5 %\), nominal {num} dB: .*?\n"
        rf"  robustness is {num} dB of nominal margin; yield {num} % \(1000 draws, CI "
        rf"{num}-100 %\)", doc, re.S)
    assert m, "the worked example of docs/robust.md is not in the expected form"
    nv, rv = res.nominal.values, res.values
    at_nom = res.nominal_at_robust()
    want = [nv["volume_ratio"], nv["top_volume_m3"] * 1e3, nv["capillary_length_m"] * 1e3,
            nv["capillary_diameter_m"] * 1e3, res.nominal.objective_value,
            res.nominal_worst_case(), 100 * yn.fraction,
            rv["volume_ratio"], rv["top_volume_m3"] * 1e3, rv["capillary_length_m"] * 1e3,
            rv["capillary_diameter_m"] * 1e3, res.objective_value, at_nom,
            res.nominal.objective_value - at_nom, 100 * y.fraction, 100 * y.interval[0]]
    for quoted, value in zip(m.groups(), want, strict=True):
        digits = len(quoted.split(".")[1]) if "." in quoted else 0
        half = 10 ** -digits / 2 + 1e-12
        assert abs(float(quoted) - value) <= half, (quoted, value)
    worst = next(r for r in res.scenarios if r["worst"])["theta"]
    assert worst == pytest.approx({"payload_mass_kg": 480.0, "capillary_length_m": 0.05,
                                   "capillary_diameter_m": -0.05})
    binding = [r["theta"] for r in res.active_scenarios() if r["binding"]]
    assert {"payload_mass_kg": 720.0, "capillary_length_m": -0.05,
            "capillary_diameter_m": 0.05} in binding
    assert f"takes {len(res.rounds)} rounds and {len(res.scenarios)} scenarios" in doc
    assert f"({rv['capillary_diameter_m'] * 1e3:.2f} mm, so that a bore" in doc
    assert f"under 15 dB; {rv['capillary_length_m'] * 1e3:.1f} mm, so" in doc


# -- yield --------------------------------------------------------------------------------
def test_intervals():
    lo, hi = clopper_pearson(10, 10, 0.95)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 10))
    lo, hi = clopper_pearson(0, 20, 0.95)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 20))
    lo, hi = wilson(50, 100, 0.95)
    assert (lo, hi) == pytest.approx((0.4038, 0.5962), abs=1e-4)
    k, n = 37, 80
    lo, hi = clopper_pearson(k, n)
    assert lo < k / n < hi


def test_yield_is_the_same_on_one_or_two_workers_and_counts_failures():
    st = _study({"payload_mass_kg": {"min": 480.0, "max": 720.0},
                 "capillary_diameter_m": {"relative": 0.1}})
    a = estimate_yield(st, DESIGN, samples=24, seed=3, workers=1)
    b = estimate_yield(st, DESIGN, samples=24, seed=3, workers=2)
    assert [v["passes"] for v in a.verdicts] == [v["passes"] for v in b.verdicts]
    assert a.samples == 24 and 0 <= a.passed <= 24
    lo, hi = a.interval
    assert lo <= a.fraction <= hi
    fails = a.failure_counts()
    assert sum(1 for v in a.verdicts if not v["passes"]) <= sum(fails.values())
    df = a.to_frame()
    assert list(df.columns[:2]) == ["payload_mass_kg", "capillary_diameter_m"]
    with pytest.raises(InputError, match="samples"):
        estimate_yield(st, DESIGN, samples=0)
    with pytest.raises(InputError, match="scenarios"):
        estimate_yield(vertical_study(), DESIGN, samples=5)


def _table_study(scen):
    import copy

    from isodesign.optimization.study import table_study

    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = scen
    raw["solver"]["starts"] = 2
    raw["models"]["points_per_band"] = 3
    return study_from_dict(raw, source="t.toml", fill_defaults=False)


def test_table_only_and_vertical_only_keys_are_named():
    with pytest.raises(InputError, match=r"scenarios.cg_offset_x_m needs a \[table\]"):
        study_from_dict({"scenarios": {"cg_offset_x_m": {"absolute": 0.05}}}, source="s.toml")
    with pytest.raises(InputError, match=r"scenarios\.ambient_pressure_pa is not available"):
        _table_study({"ambient_pressure_pa": {"min": 9e4, "max": 1e5}})


def test_table_scenarios_move_the_payload_and_the_cg():
    from isodesign.optimization.table_scenario import table_scenario

    st = _table_study({"payload_mass_kg": {"min": 540.0, "max": 660.0},
                       "cg_offset_x_m": {"absolute": 0.05},
                       "capillary_diameter_m": {"relative": 0.03}})
    sc = table_scenario(st, st.scenarios.upper())
    assert sc.payload.mass_kg == 660.0
    assert list(sc.table.cg_m)[:2] == pytest.approx([0.05, 0.0])
    d = sc.design_at(DESIGN)
    assert d.capillary_diameter_m == pytest.approx(1.03 * DESIGN["capillary_diameter_m"])


def test_robust_table_optimum_holds_at_every_corner():
    from isodesign.optimization.robust_table import _Scenarios, robust_optimize_table

    st = _table_study({"payload_mass_kg": {"min": 560.0, "max": 640.0},
                       "cg_offset_y_m": {"absolute": 0.03}})
    res = robust_optimize_table(st)
    assert res.feasible and res.converged, res.rounds
    assert res.objective_value <= res.nominal.objective_value + 1e-9
    sc = _Scenarios(st)
    j_star = -res.objective_value
    for th in st.scenarios.corners():
        c = sc.check(th, res.values, j_star)
        assert c["max_violation"] <= 1e-6
        assert c["gap"] <= 0.01
    assert any(r["worst"] for r in res.scenarios)


def test_the_table_stack_is_the_vertical_construction_and_one_scenario_is_the_nominal_nlp():
    """The robust stack is one construction for both bodies (robust.stack_scenarios): the
    table's stack of the nominal scenario alone, solved from the start design, is the
    nominal table NLP's optimum from there (the built-in table, coarse grid)."""
    from isodesign.optimization import robust
    from isodesign.optimization.robust_table import TableStack, _Scenarios
    from isodesign.optimization.table_driver import _modes_at

    st = _table_study({"payload_mass_kg": {"min": 560.0, "max": 640.0},
                       "cg_offset_y_m": {"absolute": 0.03}})
    start = {v.name: v.start for v in st.variables}
    pr = _Scenarios(st).problem(st.scenarios.nominal())
    pr.set_modes(_modes_at(pr, pr.study.design_at(start)))
    ref = pr.solve(pr.initial_guess(start))
    stack = TableStack([pr])
    assert stack.solver.name() == "isodesign_table_robust"
    sol = robust.best_solve(stack, [start], st)
    assert sol.feasible and ref.feasible
    assert sol.epigraph == pytest.approx(ref.objective, abs=1e-6)
    for n, v in ref.values.items():
        assert sol.values[n] == pytest.approx(v, rel=1e-5)
    # the stack's rows: the scenario's, its epigraph row, the epsilon row (nlp.stacked_bounds)
    assert stack.lbg.size == pr.lbg.size + 2


@pytest.mark.slow  # four exchange rounds on the built-in table, about 2 min on a loaded machine
def test_robust_table_holds_the_continuous_peak_in_every_scenario():
    """The peak refinement per scenario (the vertical exchange's): with the peak bound at
    13 dB the stacked solve's grid misses the scenarios' continuous peaks; movable
    frequencies are placed at them until every kept scenario holds the bound, checked by
    the report's continuous peak at each scenario's band-response closure (50 points per
    band against the NLP's 3: within 0.05 dB)."""
    from isodesign.optimization.robust_table import robust_optimize_table
    from isodesign.optimization.table_scenario import table_scenario
    from isodesign.optimization.transmissibility import study_closure_peaks

    st = _table_study({"payload_mass_kg": {"min": 540.0, "max": 660.0},
                       "cg_offset_y_m": {"absolute": 0.05}})
    st = st.with_changes(constraints={"max_peak_transmissibility_db": 13.0},
                         solver={"starts": 1, "workers": 1})
    res = robust_optimize_table(st)
    assert res.feasible and res.converged, res.rounds
    assert res.rounds[0]["peak_slots_moved"]  # the grid-only solve broke the bound
    assert res.rounds[0]["objective"] == pytest.approx(-6.80, abs=0.05)  # docs/robust.md
    assert res.objective_value == pytest.approx(-6.90, abs=0.05)
    assert res.rounds[-1]["peak_excess_left_db"] == 0.0
    for row in res.scenarios:
        th = np.array([row["theta"][n] for n in st.scenarios.names])
        sc = table_scenario(st, th)
        pk = study_closure_peaks(sc, sc.design_at(res.values), sc.table, sc.models)
        assert pk.max_db <= 13.0 + 0.05, row["description"]
