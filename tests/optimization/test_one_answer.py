"""One study, one answer: ``isodesign optimize`` (CLI), :func:`isodesign.optimize` and a
one-point ``isodesign.sweep`` answer the question the study asks (a table study with the
table's optimum, a study with ``[scenarios]`` robustly), and the entry points that cannot
answer refuse with the same line through the API and the CLI (issue 23)."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict, vertical_study

ROOT = Path(__file__).resolve().parents[2]
DESIGN_KEYS = ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m")


def small_robust():
    """The default study with a small payload and drill tolerance box (coarse grids)."""
    return vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 30}, solver={"starts": 2, "workers": 1},
        scenarios={"payload_mass_kg": {"min": 540.0, "max": 660.0},
                   "capillary_diameter_m": {"relative": 0.03}})


def cli(*argv, cwd=None):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "isodesign", *argv], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


def one_point_sweep(study, out, **kw):
    return isodesign.sweep(study, vary={"payload.mass_kg": [study.payload.mass_kg]},
                           output=out, scheduler="serial", charts=False, **kw)


def test_the_public_optimize_is_the_dispatcher(small_table_study):
    from isodesign.optimization import dispatch

    assert isodesign.optimize is dispatch.optimize
    assert isodesign.optimization.optimize is dispatch.optimize
    assert dispatch.study_kind(vertical_study()) == "vertical"
    assert dispatch.study_kind(small_table_study()) == "table"
    assert dispatch.study_kind(small_robust()) == "robust"


def test_the_vertical_optimizer_refuses_a_table_or_robust_study(small_table_study):
    """The internal vertical solve is never reached with a table or robust study by
    accident: it refuses them by name."""
    from isodesign.optimization.driver import optimize_vertical

    with pytest.raises(InputError, match=r"^\[table\]: "):
        optimize_vertical(small_table_study())
    with pytest.raises(InputError, match=r"^\[scenarios\]: "):
        optimize_vertical(small_robust())


def test_a_table_study_has_one_answer_through_cli_api_and_sweep(tmp_path, small_table_study):
    st = small_table_study()
    api = isodesign.optimize(st)
    assert type(api).__name__ == "TableOptimizationResult" and api.feasible
    # the CLI, in its own process
    f = tmp_path / "t.toml"
    f.write_text(study_toml(st))
    p = cli("optimize", str(f), "-o", str(tmp_path / "cli"), "--no-plots")
    assert p.returncode in (0, 1), p.stderr
    rec = json.loads((tmp_path / "cli" / "record.json").read_text())
    design = json.loads((tmp_path / "cli" / "design.json").read_text())
    assert rec["table"] is True
    assert rec["objective_value"] == pytest.approx(api.objective_value, abs=1e-6)
    assert design["derived"]["worst_band_margin_db"] == pytest.approx(
        api.analysis.worst_margin_db, abs=1e-6)
    for k in DESIGN_KEYS:
        assert rec["design"][k] == pytest.approx(api.values[k], rel=1e-6), k
    # a one-point sweep: the table's answer, the table's files
    res = one_point_sweep(st, tmp_path / "sw")
    row = res.table.iloc[0]
    assert row["status"] == "complete" and row["question"] == "table"
    assert row["objective_value"] == pytest.approx(api.objective_value, abs=1e-6)
    assert row["worst_band_margin_db"] == pytest.approx(api.analysis.worst_margin_db, abs=1e-6)
    assert row["worst_axis"] == api.analysis.worst[1]
    for k in DESIGN_KEYS:
        assert row[k] == pytest.approx(api.values[k], rel=1e-6), k
    point = tmp_path / "sw" / row["run_dir"]
    for name in ("design.json", "design.toml", "bands.csv", "modes.csv", "starts.csv",
                 "study_resolved.toml"):
        assert (point / name).is_file(), name
    bands = __import__("pandas").read_csv(point / "bands.csv")
    assert {"point", "axis"} <= set(bands.columns)  # the table's bands, not the vertical's


@pytest.mark.slow
def test_a_robust_sweep_point_is_the_robust_optimum_of_the_cli(tmp_path):
    st = small_robust()
    f = tmp_path / "r.toml"
    f.write_text(study_toml(st))
    p = cli("optimize", str(f), "-o", str(tmp_path / "cli"), "--no-plots",
            "--yield-samples", "0")
    assert p.returncode == 0, p.stderr
    rob_cli = json.loads((tmp_path / "cli" / "robust.json").read_text())
    res = one_point_sweep(st, tmp_path / "sw", options={"yield_samples": 0})
    row = res.table.iloc[0]
    assert row["status"] == "complete" and row["question"] == "robust"
    point = tmp_path / "sw" / row["run_dir"]
    rob = json.loads((point / "robust.json").read_text())
    assert rob["worst_case_objective"] == pytest.approx(rob_cli["worst_case_objective"],
                                                        abs=1e-6)
    assert row["objective_value"] == pytest.approx(rob_cli["worst_case_objective"], abs=1e-6)
    assert row["nominal_objective_value"] == pytest.approx(
        rob_cli["nominal_optimum"]["objective"], abs=1e-6)
    for k in DESIGN_KEYS:
        assert row[k] == pytest.approx(rob_cli["values"][k], rel=1e-6), k
    assert (point / "nominal" / "design.json").is_file()
    # the API's answer is the robust one too
    api = isodesign.optimize(st)
    assert type(api).__name__ == "RobustResult" and api.raise_for_status() is api
    assert api.objective_value == pytest.approx(rob_cli["worst_case_objective"], abs=1e-6)


def table_with_scenarios(small_table, scenarios, target="VC-C"):
    raw = copy.deepcopy(small_table().raw)
    raw["scenarios"] = scenarios
    raw["target"]["criterion"] = target
    return study_from_dict(raw, source="table_scenarios.toml", fill_defaults=False)


def test_table_yield_of_a_failing_design_is_zero_through_api_cli_and_sweep(tmp_path,
                                                                          small_table_study):
    """The start design of the built-in table misses VC-C by about 8 dB at every draw: the
    table's yield is 0 %, the same through the API, ``isodesign yield`` and the sweep's
    ``yield`` task (the vertical analysis would judge the 1-DOF payload instead)."""
    from isodesign.io.designfile import design_to_toml
    from isodesign.optimization.yields import estimate_yield

    st = table_with_scenarios(small_table_study,
                              {"payload_mass_kg": {"min": 540.0, "max": 660.0},
                               "cg_offset_x_m": {"absolute": 0.05},
                               "capillary_diameter_m": {"relative": 0.03}})
    start = {v.name: v.start for v in st.variables}
    api = estimate_yield(st, start, samples=12, seed=3, workers=1)
    assert api.fraction == 0.0
    assert all(v["reason"].startswith("criterion") for v in api.verdicts)
    assert -12.0 < api.worst_margin_db() < -5.0  # the table's miss, not the payload's
    # the table's analysis of the nominal draw is the table's band response
    from isodesign.table.response import table_band_response

    m = st.models
    nominal = table_band_response(st.start_design(), st.table, st.floor_axes, st.target,
                                  bands=st.bands, points_per_band=m["points_per_band"],
                                  flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                                  diaphragm=m["diaphragm"], warn=False)
    assert api.worst("margin_db", "max") > nominal.worst_margin_db - 3.0
    # the CLI
    f = tmp_path / "t.toml"
    f.write_text(study_toml(st))
    d = tmp_path / "start.toml"
    d.write_text(design_to_toml(st.start_design()))
    p = cli("yield", str(d), "--study", str(f), "--samples", "12", "--seed", "3",
            "--workers", "1", "--no-plots", "-o", str(tmp_path / "y"))
    assert p.returncode == 0, p.stderr
    y = json.loads((tmp_path / "y" / "yield.json").read_text())
    assert y["fraction"] == 0.0 and y["samples"] == 12
    assert y["worst_margin_db"] == pytest.approx(api.worst_margin_db(), abs=1e-6)
    # the sweep's yield task (the study's start design)
    res = isodesign.sweep(st, vary={"payload.mass_kg": [600.0]}, output=tmp_path / "sw",
                          scheduler="serial", charts=False, task="yield",
                          options={"samples": 12, "seed": 3})
    row = res.table.iloc[0]
    assert row["status"] == "complete", row["error"]
    assert row["objective_value"] == 0.0
    assert row["worst_band_margin_db"] == pytest.approx(api.worst_margin_db(), abs=1e-6)


def test_table_yield_responds_to_a_cg_offset(small_table_study):
    """VC-A at the instrument: the start design passes with the CG over the centroid; the
    CG 0.1 m off changes every margin; 0.3 m off leaves isolator 4 unloaded: no draw
    passes (the vertical analysis ignores the CG)."""
    from isodesign.optimization.yields import estimate_yield

    def y(offset):
        st = table_with_scenarios(small_table_study,
                                  {"payload_mass_kg": {"values": [600.0]},
                                   "cg_offset_x_m": {"values": [offset]}}, target="VC-A")
        return estimate_yield(st, {v.name: v.start for v in st.variables}, samples=3,
                              workers=1)

    centred, off, far = y(0.0), y(0.1), y(0.3)
    assert centred.fraction == 1.0 and off.fraction == 1.0
    assert abs(off.worst_margin_db() - centred.worst_margin_db()) > 0.1
    assert far.fraction == 0.0
    assert all("leveling" in v["reason"] for v in far.verdicts)


def test_pareto_of_a_table_study_is_the_table_front(small_table_study):
    st = small_table_study()
    res = isodesign.pareto_front(st, points=2)
    assert type(res).__name__ == "TableParetoResult"
    # anchor A is the table's optimum (the worst margin over every point and axis)
    opt = isodesign.optimize(st)
    assert res.worst_margin_db[0] == pytest.approx(opt.objective_value, abs=1e-6)
    with pytest.raises(InputError, match=r"^objectives: a study with a \[table\]"):
        isodesign.pareto_front(st, ("total_volume", "worst_band_margin"), 2)


def refusal_line(exc_info) -> str:
    return f"isodesign: error: {exc_info.value}"


def test_pareto_of_a_robust_study_is_refused_with_the_same_line_in_api_and_cli(tmp_path):
    st = small_robust()
    with pytest.raises(InputError) as api:
        isodesign.pareto_front(st)
    assert str(api.value).startswith("[scenarios]: ")
    f = tmp_path / "r.toml"
    f.write_text(study_toml(st))
    p = cli("pareto", str(f), "-o", str(tmp_path / "p"))
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == [refusal_line(api)]
    assert not (tmp_path / "p").exists()
    # a sweep of it is refused before any point runs, by the same line
    with pytest.raises(InputError) as sw:
        isodesign.sweep(st, vary={"payload.mass_kg": [600.0]}, output=tmp_path / "sw",
                        task="pareto", scheduler="serial")
    assert str(sw.value) == str(api.value)
    assert not (tmp_path / "sw").exists()


def test_a_table_sweep_response_point_is_the_tables_band_response(tmp_path, small_table_study):
    st = small_table_study()
    res = isodesign.sweep(st, vary={"payload.mass_kg": [600.0]}, output=tmp_path / "sw",
                          scheduler="serial", charts=False, task="response")
    row = res.table.iloc[0]
    assert row["status"] == "complete", row["error"]
    from isodesign.optimization.table_driver import _analyze

    a, _, _ = _analyze(st, st.start_design())
    assert row["objective_value"] == pytest.approx(a.worst_margin_db, abs=1e-9)
    assert row["worst_axis"] == a.worst[1]
    bands = __import__("pandas").read_csv(tmp_path / "sw" / row["run_dir"] / "bands.csv")
    assert set(bands["axis"]) == {"x", "y", "z"}


@pytest.mark.slow
def test_a_robust_table_study_has_one_answer_through_api_and_sweep(tmp_path, small_table_study):
    st = table_with_scenarios(small_table_study,
                              {"payload_mass_kg": {"min": 560.0, "max": 640.0},
                               "cg_offset_y_m": {"absolute": 0.03}})
    api = isodesign.optimize(st)
    assert type(api).__name__ == "TableRobustResult" and api.feasible
    assert api.raise_for_status() is api  # every answer has the same check
    assert api.objective_value <= api.nominal.objective_value + 1e-9
    res = one_point_sweep(st, tmp_path / "sw")
    row = res.table.iloc[0]
    assert row["status"] == "complete" and row["question"] == "robust table"
    rob = json.loads((tmp_path / "sw" / row["run_dir"] / "robust.json").read_text())
    assert rob["table"] is True
    assert rob["worst_case_objective"] == pytest.approx(api.objective_value, abs=1e-6)
    assert row["objective_value"] == pytest.approx(api.objective_value, abs=1e-6)
    for k in DESIGN_KEYS:
        assert row[k] == pytest.approx(api.values[k], rel=1e-6), k
    # the CLI: the same worst case, and the table yields when asked for
    from isodesign.optimization.yields import estimate_yield

    f = tmp_path / "tr.toml"
    f.write_text(study_toml(st))
    p = cli("optimize", str(f), "-o", str(tmp_path / "cli"), "--no-plots", "--yield-samples",
            "6")
    assert p.returncode == 0, p.stderr
    rob_cli = json.loads((tmp_path / "cli" / "robust.json").read_text())
    assert rob_cli["worst_case_objective"] == pytest.approx(api.objective_value, abs=1e-6)
    y = estimate_yield(st, api.values, samples=6, seed=st.scenarios.settings["seed"])
    assert rob_cli["yields"][1]["fraction"] == y.fraction
    assert rob_cli["yields"][1]["worst_margin_db"] == pytest.approx(y.worst_margin_db(),
                                                                    abs=1e-6)
    assert "(table analysis)" in p.stdout
