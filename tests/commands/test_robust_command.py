"""``isodesign optimize`` with [scenarios], ``isodesign yield`` and the report's robustness
section, on a fast study (coarse grids, 2 starts)."""

from __future__ import annotations

import json

import pytest

from isodesign.cli import main

ROBUST_STUDY = """\
name = "fast-robust"

[models]
points_per_band = 3
peak_points = 30

[solver]
starts = 2
workers = 1

# the worked example of docs/robust.md, smaller
[scenarios]
payload_mass_kg = {min = 540.0, max = 660.0}
capillary_diameter_m = {relative = 0.03}
"""


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture(scope="module")
def robust_run(tmp_path_factory):
    import contextlib
    import io

    d = tmp_path_factory.mktemp("robust")
    study = d / "robust.toml"
    study.write_text(ROBUST_STUDY)
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        status = main(["optimize", str(study), "-o", str(d / "run"), "--yield-samples", "20",
                       "--no-plots"])
    return status, o.getvalue(), e.getvalue(), d


def test_optimize_with_scenarios_writes_the_robust_run(robust_run):
    status, out, err, d = robust_run
    assert status == 0, err
    run = d / "run"
    for name in ("robust.json", "scenarios.csv", "rounds.csv", "sensitivities.csv",
                 "yield.csv", "design.toml", "record.json",
                 "study_resolved.toml", "nominal/design.json"):
        assert (run / name).is_file(), name
    rob = json.loads((run / "robust.json").read_text())
    assert rob["feasible"] and rob["converged"]
    assert rob["worst_case_objective"] <= rob["nominal_optimum"]["objective"]
    assert [y["label"] for y in rob["yields"]] == ["nominal optimum", "robust optimum"]
    assert rob["yields"][1]["fraction"] == 1.0
    assert "active scenarios" in out and "price in nominal" in out
    assert "yield of the robust optimum: 100.0 %" in out
    assert not (run / "robustness.png").exists()  # --no-plots
    # replay: the resolved study keeps the scenarios
    from isodesign.optimization.study import load_study

    assert load_study(run / "study_resolved.toml").scenarios.names == (
        "payload_mass_kg", "capillary_diameter_m")


def test_yield_command_on_the_run_and_on_a_design_file(robust_run, tmp_path, capsys):
    _, _, _, d = robust_run
    status, out, err = run(capsys, "yield", str(d / "run"), "--samples", "30", "--workers", "1",
                           "-o", str(tmp_path / "y"))
    assert status == 0, err
    assert "30 of 30 draws pass" in out and "Clopper-Pearson" in out
    rec = json.loads((tmp_path / "y" / "yield.json").read_text())
    assert rec["samples"] == 30 and rec["clopper_pearson"][1] == 1.0
    status, out, err = run(capsys, "yield", str(d / "run" / "nominal" / "design.toml"),
                           "--study", str(d / "robust.toml"), "--samples", "30", "--workers",
                           "1", "--no-plots", "-o", str(tmp_path / "y2"))
    assert status == 0, err and "draws pass" in out


@pytest.mark.parametrize("extra, words", [
    (["--samples", "0"], ["--samples", "[1, 1000000]"]),
    (["--confidence", "1.5"], ["--confidence"]),
])
def test_yield_bad_options(robust_run, tmp_path, capsys, extra, words):
    _, _, _, d = robust_run
    status, _, err = run(capsys, "yield", str(d / "run"), *extra, "-o", str(tmp_path / "y"))
    assert status == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isodesign: error: ")
    for w in words:
        assert w in err


def test_yield_needs_a_study_with_scenarios(robust_run, tmp_path, capsys):
    _, _, _, d = robust_run
    design = d / "run" / "nominal" / "design.toml"
    status, _, err = run(capsys, "yield", str(design), "-o", str(tmp_path / "y"))
    assert status == 2 and "--study" in err
    plain = tmp_path / "plain.toml"
    plain.write_text('name = "plain"\n')
    status, _, err = run(capsys, "yield", str(design), "--study", str(plain), "-o",
                         str(tmp_path / "y"))
    assert status == 2 and "[scenarios]" in err


def test_bad_scenarios_exit_2_naming_the_key(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenarios]\npayload_mass_kg = {min = 720.0, max = 480.0}\n")
    status, _, err = run(capsys, "optimize", str(bad), "-o", str(tmp_path / "o"))
    assert status == 2
    assert "scenarios.payload_mass_kg" in err and "inverted" in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_infeasible_scenario_exits_1_naming_it(tmp_path, capsys):
    st = tmp_path / "inf.toml"
    st.write_text(ROBUST_STUDY.replace("payload_mass_kg = {min = 540.0, max = 660.0}",
                                       "payload_mass_kg = {values = [600.0, 40.0]}"))
    status, _out, err = run(capsys, "optimize", str(st), "-o", str(tmp_path / "o"),
                           "--yield-samples", "0")
    assert status == 1
    assert "payload_mass_kg=40" in err and "natural_frequency" in err
    rob = json.loads((tmp_path / "o" / "robust.json").read_text())
    assert rob["infeasible_scenario"]["theta"]["payload_mass_kg"] == 40.0


def test_report_has_the_robustness_section(robust_run, tmp_path):
    import isodesign

    _, _, _, d = robust_run
    html = isodesign.report(d / "run", tmp_path / "r.html").read_text()
    for words in ("Robustness", "Worst case per scenario", "Sensitivities", "Yield",
                  "Clopper-Pearson", "robust optimum", "Price of robustness"):
        assert words in html, words
    assert html.count("<svg") >= 5


def test_optimize_a_table_study_with_scenarios(tmp_path, capsys):
    import copy

    from isodesign.io.record import study_toml
    from isodesign.optimization.study import study_from_dict, table_study

    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = {"payload_mass_kg": {"min": 560.0, "max": 640.0},
                        "cg_offset_y_m": {"absolute": 0.03}}
    raw["solver"]["starts"] = 2
    raw["models"]["points_per_band"] = 3
    f = tmp_path / "table_robust.toml"
    f.write_text(study_toml(study_from_dict(raw, source="x", fill_defaults=False)))
    status, out, err = run(capsys, "optimize", str(f), "-o", str(tmp_path / "o"))
    assert status == 0, err
    rob = json.loads((tmp_path / "o" / "robust.json").read_text())
    assert rob["table"] and rob["feasible"] and rob["converged"]
    assert rob["worst_case_objective"] <= rob["nominal_objective"]
    assert "cg_offset_y_m" in out and "(worst)" in out
    assert (tmp_path / "o" / "design.toml").is_file()
