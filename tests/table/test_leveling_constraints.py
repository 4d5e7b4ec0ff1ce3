"""The leveling loop's margins as constraints of the table optimizer (docs/table.md, s. 12):
the study keys, their defaults, the constraint table's rows, and a design whose loop misses
its margins is a violation (FAIL, exit 1), with the margins ``isodesign stability`` prints."""

from __future__ import annotations

import json
import math
import shutil
from importlib import resources

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import study_from_dict, table_study


def _table_dict(**constraints):
    import tomllib

    with resources.as_file(resources.files("isodesign") / "data" / "table_study.toml") as p:
        d = tomllib.loads(p.read_text())
    if constraints:
        d["constraints"] = dict(constraints)
    return d


def _high_cg_toml(tmp_path, height_m: float, leveling: bool = True, name="hi.toml"):
    """The built-in table with its CG (and its instrument points) raised to ``height_m``,
    one start, bands to 20 Hz (a reduced study)."""
    src = resources.files("isodesign") / "data" / "table_study.toml"
    p = tmp_path / name
    with resources.as_file(src) as f:
        shutil.copy(f, p)
    h, top = height_m, 2 * height_m
    text = (p.read_text()
            .replace("[solver]\nstarts = 4", "[solver]\nstarts = 1\nworkers = 1")
            .replace("cg_height_m = 0.35", f"cg_height_m = {h}")
            .replace("cg_m = [0.0, 0.0, 0.35]", f"cg_m = [0.0, 0.0, {h}]")
            .replace("box_m = [1.5, 1.0, 0.7]", f"box_m = [1.5, 1.0, {top}]")
            .replace("[[0.0, 0.0, 0.7], [0.5, 0.3, 0.7]]",
                     f"[[0.0, 0.0, {top}], [0.5, 0.3, {top}]]")
            .replace("band_max_hz = 80.0", "band_max_hz = 20.0"))
    if leveling:
        text += "\n[table.leveling]\ngain_kg_s_per_m = 0.02\n"
    p.write_text(text)
    return p


@pytest.mark.parametrize("key,value", [
    ("min_leveling_gain_margin_db", -3.0), ("min_leveling_gain_margin_db", "6"),
    ("min_leveling_gain_margin_db", 500.0), ("min_leveling_phase_margin_deg", 0.0),
    ("min_leveling_phase_margin_deg", 200.0), ("min_leveling_phase_margin_deg", True)])
def test_bad_margin_bounds_are_refused_naming_the_key(key, value):
    with pytest.raises(InputError, match=f"constraints.{key}"):
        study_from_dict(_table_dict(**{key: value}))


def test_margin_bounds_belong_to_a_table_study():
    with pytest.raises(InputError, match="min_leveling_gain_margin_db applies only to a "
                                         "study with a \\[table\\]"):
        study_from_dict({"constraints": {"min_leveling_gain_margin_db": 6.0}})


def test_margin_bounds_defaults_and_switches():
    from isodesign.table.leveling import leveling_margin_bounds

    # no [table.leveling]: the default valves' margins are reported, not enforced
    assert leveling_margin_bounds(table_study()) == (None, None)
    d = _table_dict()
    d["table"]["leveling"] = {"gain_kg_s_per_m": 0.03}
    assert leveling_margin_bounds(study_from_dict(d)) == (6.0, 45.0)
    d["constraints"] = {"min_leveling_gain_margin_db": 10.0,
                        "min_leveling_phase_margin_deg": False}
    assert leveling_margin_bounds(study_from_dict(d)) == (10.0, None)
    d = _table_dict(min_leveling_phase_margin_deg=30.0)  # without valves: as written
    assert leveling_margin_bounds(study_from_dict(d)) == (None, 30.0)


def test_constraint_rows_are_the_loops_margins():
    """The rows hold the smallest gain margin (MIMO and per valve) and the smallest phase
    margin of python-control's loop, against their bounds; without a bound, no binding."""
    from isodesign.optimization.table_constraints import leveling_reports
    from isodesign.table.leveling_loop import leveling_loop
    from isodesign.table.model import table_model

    st = table_study()
    m = st.models
    model = table_model(st.start_design(), st.table, flow=m["flow"],
                        amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])
    loop = leveling_loop(model)
    gm = min(20 * math.log10(loop.critical_gain_kg_s_per_m / loop.gain_kg_s_per_m),
             float(np.min(loop.gain_margin_db)))
    pm = float(np.min(loop.phase_margin_deg))
    g_row, p_row = leveling_reports(loop, 6.0, 45.0)
    assert g_row.name == "leveling_gain_margin" and p_row.name == "leveling_phase_margin"
    assert g_row.value == pytest.approx(gm, abs=1e-12)
    assert p_row.value == pytest.approx(pm, abs=1e-12)
    # the built-in table: MIMO +10.5 dB (section 12), phase about 90 deg
    assert g_row.value == pytest.approx(10.49, abs=0.02) and 85.0 < p_row.value < 95.0
    assert g_row.lower == 6.0 and p_row.lower == 45.0 and not g_row.active
    assert g_row.margin_natural == pytest.approx(gm - 6.0)
    # at its own margin the bound binds; far below it is a violation, not binding
    assert leveling_reports(loop, gm, None)[0].active
    low = leveling_reports(loop, gm + 5.0, pm + 10.0)
    assert low[0].margin_natural < 0 and not low[0].active and not low[1].active
    free = leveling_reports(loop)
    assert free[0].lower is None and "not enforced" in free[0].description


def test_the_explanation_names_the_study_keys():
    from isodesign.optimization.explain import STUDY_KEYS

    assert STUDY_KEYS["leveling_gain_margin"] == "constraints.min_leveling_gain_margin_db"
    assert STUDY_KEYS["leveling_phase_margin"] == "constraints.min_leveling_phase_margin_deg"


@pytest.mark.slow
def test_high_cg_table_below_its_loop_margin_is_a_violation(tmp_path, capsys, monkeypatch):
    """At h = 0.8 m the built-in table's optimum on its springs alone (no loop round: the
    NLP's gain-margin rows never switched on) keeps a leveling loop within 1 dB of its onset:
    the run breaks leveling_gain_margin, exits 1 and is no PASS; its constraint table holds
    the margins `isodesign stability` prints for the same design."""
    import isodesign.optimization.table_driver as topt
    from isodesign.cli import main

    monkeypatch.setattr(topt, "LOOP_ROUNDS", 0)
    study = _high_cg_toml(tmp_path, 0.8)
    out = tmp_path / "o"
    assert main(["optimize", str(study), "--no-plots", "-o", str(out)]) == 1
    cap = capsys.readouterr()
    assert "optimum: FAIL: constraint broken: leveling_gain_margin" in cap.out
    assert "WARNING: the leveling loop's leveling_gain_margin" in cap.out
    assert "breaks a constraint: leveling_gain_margin" in cap.err
    design = json.loads((out / "design.json").read_text())
    assert design["success"] is False and not design["verdict"].startswith("PASS")
    rows = {c["name"]: c for c in design["constraints"]}
    g, p = rows["leveling_gain_margin"], rows["leveling_phase_margin"]
    assert g["lower"] == 6.0 and p["lower"] == 45.0 and g["value"] < 6.0
    # docs/table.md, section 12: within 1 dB of the onset, phase margins about 21 deg
    assert 0.0 < g["value"] < 1.0 and p["value"] < 30.0
    assert dict(design["violations"])["leveling_gain_margin"] == pytest.approx(6.0 - g["value"])
    rec = json.loads((out / "record.json").read_text())
    assert rec["run_status"] == "infeasible"
    # the same design through `isodesign stability RUN`
    st_out = tmp_path / "s"
    assert main(["stability", str(out), "-o", str(st_out)]) == 0
    capsys.readouterr()
    import pandas as pd

    loop = pd.read_csv(st_out / "loop.csv")
    rec_s = json.loads((st_out / "record.json").read_text())
    mimo = 20 * math.log10(rec_s["critical_gain_kg_s_per_m"] / 0.02)
    assert g["value"] == pytest.approx(min(mimo, loop["gain_margin_db"].min()), abs=1e-9)
    assert p["value"] == pytest.approx(loop["phase_margin_deg"].min(), abs=1e-9)
    assert rec_s["critical_gain_kg_s_per_m"] == pytest.approx(0.0208, rel=0.02)
    assert loop["oscillation_frequency_hz"].iloc[0] == pytest.approx(0.40, abs=0.01)
    # the valve gain that would meet both bounds on these springs, checked on its loop
    import re

    from isodesign.optimization.study import load_study
    from isodesign.optimization.table_driver import _model
    from isodesign.table.leveling import leveling_of_study
    from isodesign.table.leveling_loop import leveling_loop

    g_hint = float(re.search(r"at gains up to ([0-9.e-]+) kg/s/m", cap.out).group(1))
    assert g_hint == pytest.approx(0.0104, rel=0.02)  # docs/table.md, section 12
    st = load_study(study)
    model = _model(st, st.design_at({k: v["value"] for k, v in design["variables"].items()}))
    system = leveling_of_study(st)
    below = leveling_loop(model, system.replace(gain_kg_s_per_m=g_hint * 0.999))
    above = leveling_loop(model, system.replace(gain_kg_s_per_m=g_hint * 1.01))
    assert below.worst_gain_margin_db >= 6.0 and below.worst_phase_margin_deg >= 45.0
    assert above.worst_gain_margin_db < 6.0 or above.worst_phase_margin_deg < 45.0


@pytest.mark.slow
def test_the_optimizer_moves_a_high_cg_table_to_its_loop_margin(tmp_path):
    """With the frozen-pole rows refreshed in rounds, the same table's optimum meets the
    6 dB gain margin (python-control's, within the 0.01 dB tolerance and 0.05 dB above),
    the row binds and names its study key, at some cost in the worst band margin against
    the same study without [table.leveling] (whose margins are reported, not enforced)."""
    from isodesign.optimization.explain import limiting_factors
    from isodesign.optimization.study import load_study
    from isodesign.optimization.table_driver import _model, optimize_table
    from isodesign.table.leveling_loop import leveling_loop

    st = load_study(_high_cg_toml(tmp_path, 0.8))
    res = optimize_table(st, workers=1, analyze=False)
    gm = res.leveling.worst_gain_margin_db
    assert 6.0 - 0.01 <= gm <= 6.05, gm
    assert res.peak["leveling_rounds"] >= 1 and res.peak["resolve_failed"] is None
    assert not res.violations and res.success
    rows = {c.name: c for c in res.constraints}
    assert rows["leveling_gain_margin"].active
    assert any("constraints.min_leveling_gain_margin_db" in t for t in limiting_factors(res))
    # an independent loop of the returned design (its own plant and python-control)
    again = leveling_loop(_model(st, res.design), res.leveling.plant.system)
    assert again.mimo_gain_margin_db == pytest.approx(res.leveling.mimo_gain_margin_db,
                                                      abs=1e-9)
    free = optimize_table(load_study(_high_cg_toml(tmp_path, 0.8, leveling=False,
                                                   name="free.toml")),
                          workers=1, analyze=False)
    frows = {c.name: c for c in free.constraints}
    assert frows["leveling_gain_margin"].lower is None
    assert frows["leveling_gain_margin"].value < 1.0
    assert not [n for n, _ in free.violations if n.startswith("leveling_")]
    assert free.success, free.violations
    assert free.objective_value >= res.objective_value - 1e-6  # the margin costs
    # docs/table.md, section 12
    assert res.values["top_volume_m3"] == pytest.approx(2e-4, rel=1e-6)
    assert res.values["capillary_diameter_m"] == pytest.approx(1.78e-3, rel=0.01)
    assert res.objective_value == pytest.approx(-9.51, abs=0.02)
    assert free.objective_value == pytest.approx(-9.28, abs=0.02)


@pytest.mark.slow
def test_a_phase_margin_out_of_reach_is_a_violation(tmp_path):
    """The phase margin has no NLP row: a bound above every valve's (about 92 deg at the
    built-in table's optimum) is a violation naming leveling_phase_margin, never a PASS."""
    from isodesign.optimization.study import load_study
    from isodesign.optimization.table_driver import optimize_table

    p = _high_cg_toml(tmp_path, 0.35)
    p.write_text(p.read_text() + "\n[constraints]\nmin_leveling_phase_margin_deg = 120.0\n")
    res = optimize_table(load_study(p), workers=1, analyze=False)
    v = dict(res.violations)
    assert "leveling_phase_margin" in v and not res.success
    assert v["leveling_phase_margin"] == pytest.approx(120.0 - res.leveling.worst_phase_margin_deg)
    assert "FAIL: constraint broken: leveling_phase_margin" in res.verdict()


def test_nlp_loop_rows_are_the_poles_of_the_analysis_plant(tmp_path):
    """The NLP's plant A (CasADi, the analysis' plant_matrix) equals leveling_plant's; each
    frozen-pole row at its own design is the exact Re lambda / s + eps of the loop closed
    at G 10^(6/20) (every valve, and each alone), and first-order exact about it."""
    import casadi as ca

    from isodesign.optimization.loop_rows import plant_function
    from isodesign.optimization.study import load_study
    from isodesign.optimization.table_driver import _model
    from isodesign.optimization.table_problem import LOOP_MARGIN_EPS, LOOP_POLES_MIMO, TableProblem
    from isodesign.optimization.variables import DESIGN_VARIABLES
    from isodesign.table.leveling import leveling_plant

    st = load_study(_high_cg_toml(tmp_path, 0.8))
    prob = TableProblem(st)
    assert prob.n_loop == LOOP_POLES_MIMO + 3 and not np.any(prob.loop_params)
    vals = {"volume_ratio": 8.0, "top_volume_m3": 4e-4, "capillary_length_m": 0.5,
            "capillary_diameter_m": 2.7e-3}
    d = st.design_at(vals)
    plant = leveling_plant(_model(st, d), prob.loop_system)
    a_nlp = np.array(plant_function(prob, ca)([vals[k] for k in DESIGN_VARIABLES]))
    a_nlp = a_nlp.reshape(prob.n_states, prob.n_states, order="F")
    assert np.max(np.abs(a_nlp - plant.a)) <= 1e-12 * np.max(np.abs(plant.a))
    prob.set_loop(d)
    rows = next((r, m) for n, r, m in prob.con_rows if n == "min_leveling_gain_margin_db")

    def row_values(values):
        _, g = prob.eval_fn(prob.initial_guess(values), prob.params())
        return np.asarray(g).ravel()[rows[0]: rows[0] + rows[1]]

    g_up = 0.02 * 10 ** (6.0 / 20.0)
    want = []
    for gains, count in [(np.full(3, g_up), LOOP_POLES_MIMO)] + [
            (np.where(np.arange(3) == k, g_up, 0.02), 1) for k in range(3)]:
        lam = np.linalg.eigvals(plant.a - plant.b @ np.diag(gains) @ plant.c)
        lam = lam[lam.imag >= -1e-12 * np.abs(lam)]
        lam = lam[np.argsort(-lam.real)][:count]
        want += [l.real / max(abs(l), 2 * math.pi * 0.01) + LOOP_MARGIN_EPS for l in lam]
    got = row_values(vals)
    assert got == pytest.approx(np.array(want), abs=1e-9)
    assert got[0] > 0  # the loop at the raised gain is unstable: the row is violated
    # first order: a 1 % step in V_t0 moves the leading pole as the rows predict, to 5 %
    vals2 = dict(vals, top_volume_m3=4.04e-4)
    plant2 = leveling_plant(_model(st, st.design_at(vals2)), prob.loop_system)
    lam2 = np.linalg.eigvals(plant2.a - g_up * plant2.b @ plant2.c)
    lam2 = lam2[np.argmax(lam2.real)]
    lam1 = np.linalg.eigvals(plant.a - g_up * plant.b @ plant.c)
    lam1 = lam1[np.argmax(lam1.real)]
    scale = max(abs(lam1), 2 * math.pi * 0.01)  # the row's frozen scale
    assert row_values(vals2)[0] - got[0] == pytest.approx((lam2.real - lam1.real) / scale,
                                                          rel=0.05)


@pytest.mark.slow
def test_pareto_points_below_the_loop_margin_are_not_on_the_front(tmp_path, monkeypatch):
    """The Pareto front of a table study is judged like its optimum: without loop rounds the
    high-CG table's anchor keeps its loop below 6 dB; such a point names the margin in its
    status and is not on the front; a point on the front meets both bounds."""
    import isodesign.optimization.table_driver as topt
    from isodesign.optimization.study import load_study
    from isodesign.optimization.table_pareto import table_pareto_front

    monkeypatch.setattr(topt, "LOOP_ROUNDS", 0)
    st = load_study(_high_cg_toml(tmp_path, 0.8))
    res = table_pareto_front(st, points=2)
    for dsg, status, on in zip(res.designs, res.statuses, res.front, strict=True):
        loop, gm_min, pm_min = topt.leveling_check(st, st.design_at(dsg))
        meets = (loop.worst_gain_margin_db >= gm_min - topt.LOOP_TOLERANCE
                 and loop.worst_phase_margin_deg >= pm_min - topt.LOOP_TOLERANCE)
        assert ("leveling_gain_margin" in status) == (loop.worst_gain_margin_db
                                                      < gm_min - topt.LOOP_TOLERANCE)
        if on:
            assert meets
    assert "leveling_gain_margin" in res.statuses[0] and not res.front[0]


@pytest.mark.parametrize("spec,match", [
    ({"lower": 0.002}, "gain_kg_s_per_m.upper is required"),
    ({"lower": 0.05, "upper": 0.002}, "gain_kg_s_per_m.lower must be below"),
    ({"lower": -1.0, "upper": 0.05}, "gain_kg_s_per_m.lower must be a number > 0"),
    ({"lower": 0.002, "upper": 0.05, "start": 0.1}, "gain_kg_s_per_m.start"),
    ({"lower": 0.002, "upper": 0.05, "fixed": "no"}, "gain_kg_s_per_m.fixed"),
    ({"low": 0.002}, "unknown key 'low' in table.leveling.gain_kg_s_per_m")])
def test_a_bad_valve_gain_variable_is_refused_naming_the_key(spec, match):
    d = _table_dict()
    d["table"]["leveling"] = {"gain_kg_s_per_m": spec}
    with pytest.raises(InputError, match=match):
        study_from_dict(d)


def test_valve_gain_variable_declaration():
    from isodesign.table.leveling import leveling_of_study, valve_gain_bounds

    d = _table_dict()
    d["table"]["leveling"] = {"gain_kg_s_per_m": {"lower": 0.002, "upper": 0.01}}
    st = study_from_dict(d)
    assert valve_gain_bounds(st) == (0.002, 0.01)
    assert leveling_of_study(st).gain_kg_s_per_m == 0.01  # the default start, clipped
    d["table"]["leveling"] = {"gain_kg_s_per_m": {"start": 0.03, "fixed": True}}
    st = study_from_dict(d)
    assert valve_gain_bounds(st) is None and leveling_of_study(st).gain_kg_s_per_m == 0.03
    assert valve_gain_bounds(table_study()) is None


@pytest.mark.slow
def test_a_free_valve_gain_meets_the_margin_on_the_springs_optimum(tmp_path, capsys):
    """With the valve gain a design variable the problem separates: the springs stay at
    their optimum (the worst margin of the fixed-gain run before its loop rounds) and the
    gain is the largest within its bounds whose loop meets both bounds; `isodesign stability
    RUN` makes the same choice and prints the same margins."""
    from isodesign.cli import main

    study = _high_cg_toml(tmp_path, 0.8, leveling=False)
    study.write_text(study.read_text() + "\n[table.leveling]\n"
                     "gain_kg_s_per_m = {lower = 0.002, upper = 0.05}\n")
    out = tmp_path / "o"
    assert main(["optimize", str(study), "--no-plots", "-o", str(out)]) == 0
    cap = capsys.readouterr()
    assert "valve gain: a design variable within 0.002 to 0.05 kg/s/m; chosen" in cap.out
    design = json.loads((out / "design.json").read_text())
    assert design["success"] is True
    g = design["valve_gain_kg_s_per_m"]
    assert g == pytest.approx(0.0104, rel=0.02)  # the fixed-gain run's hint, same springs
    assert design["variables"]["top_volume_m3"]["value"] == pytest.approx(3.8e-4, rel=0.01)
    rows = {c["name"]: c for c in design["constraints"]}
    assert 6.0 <= rows["leveling_gain_margin"]["value"] <= 6.05
    assert rows["leveling_phase_margin"]["value"] >= 45.0
    st_out = tmp_path / "s"
    assert main(["stability", str(out), "-o", str(st_out)]) == 0
    text = capsys.readouterr().out
    assert f"valve gain {g:.4g} kg/s/m" in text
    import pandas as pd

    loop = pd.read_csv(st_out / "loop.csv")
    rec_s = json.loads((st_out / "record.json").read_text())
    mimo = 20 * math.log10(rec_s["critical_gain_kg_s_per_m"] / g)
    assert rows["leveling_gain_margin"]["value"] == pytest.approx(
        min(mimo, loop["gain_margin_db"].min()), abs=1e-9)
    assert rows["leveling_phase_margin"]["value"] == pytest.approx(
        loop["phase_margin_deg"].min(), abs=1e-9)


def test_the_robust_table_optimizer_refuses_loop_margins():
    """The robust table optimizer does not hold the loop's margins over its scenarios: a
    study that bounds them is refused with one line naming the key, not answered without."""
    import copy

    from isodesign.optimization.robust_table import robust_optimize_table

    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = {"payload_mass_kg": {"min": 560.0, "max": 640.0}}
    raw["table"]["leveling"] = {"gain_kg_s_per_m": 0.02}
    st = study_from_dict(raw, source="t.toml", fill_defaults=False)
    with pytest.raises(InputError, match=r"constraints\.min_leveling_gain_margin_db: the robust"):
        robust_optimize_table(st)
