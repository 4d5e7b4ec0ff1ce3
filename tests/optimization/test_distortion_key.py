"""``[models] distortion``: validated like every key, and one answer through the entry points
(docs/optimization.md section 1, docs/random-response.md section 3d)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.optimization.analyze import analyze
from isodesign.optimization.problem import Problem, VerticalDistortionProblem
from isodesign.optimization.recheck import evaluate_design
from isodesign.optimization.study import study_from_dict, table_study, vertical_study


def small_vertical(**models):
    """The vertical study, one start, coarse grids."""
    return vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 30, **models},
        solver={"starts": 1, "workers": 1})


@pytest.mark.parametrize("value", ["yes", 1, 0.0, None])
def test_bad_value_names_the_key(value):
    with pytest.raises(InputError, match=r"models\.distortion must be true or false"):
        study_from_dict({"models": {"distortion": value}})


def test_default_is_on_where_the_nlp_carries_it_and_the_key_round_trips():
    """On by default with the statistical closure (vertical, table); off by default where
    it does not apply (``equivalent_amplitude``) or the NLP cannot carry it (a table with
    ``quasi_steady`` flow); an explicit value is kept."""
    assert vertical_study().models["distortion"] is True
    assert table_study().models["distortion"] is True
    assert study_from_dict({}).models["distortion"] is True
    assert study_from_dict({"models": {"random_method": "equivalent_amplitude"}}
                           ).models["distortion"] is False
    assert table_study().with_changes({"models.flow": "quasi_steady"}).models["distortion"] \
        is False
    assert vertical_study().with_changes({"models.distortion": False}).models["distortion"] \
        is False
    assert small_vertical(distortion=True).models["distortion"] is True
    assert study_from_dict({"models": {"distortion": True}}).models["distortion"] is True


def test_refusals_name_the_key():
    with pytest.raises(InputError, match=r"models\.distortion = true.*random_method"):
        study_from_dict({"models": {"distortion": True,
                                    "random_method": "equivalent_amplitude"}})
    with pytest.raises(InputError, match=r"models\.distortion = true: the table's NLP"):
        Problem(table_study().with_changes({"models.distortion": True,
                                            "models.flow": "quasi_steady"}))


def test_problem_of_the_study_carries_it(small_table_study):
    st = small_vertical(distortion=True)
    assert type(Problem(st)) is VerticalDistortionProblem
    assert type(Problem(small_vertical(distortion=False))) is Problem
    tb = Problem(small_table_study().with_changes({"models.distortion": True}))
    assert type(tb).__name__ == "TableDistortionProblem"


ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def api_result():
    st = small_vertical(distortion=True)
    return st, isodesign.optimize(st)


def test_optimize_answers_with_the_distortion(api_result):
    """isodesign.optimize, evaluate_design and analyze give one answer with the key on:
    the NLP's worst margin is evaluate_design's (the NumPy closure with the distortion on
    the NLP's grid) and the result's analysis is analyze()'s; the key changes them."""
    st, res = api_result
    res.raise_for_status()
    assert res.settings["distortion_outer_rounds"] >= 1
    ev = evaluate_design(st, res.values)
    assert abs(ev["objectives"]["worst_band_margin"] - res.objective_value) < 1e-6
    start = evaluate_design(st, {v.name: v.start for v in st.variables})
    assert abs(start["objectives"]["worst_band_margin"] - res.start_objective) < 1e-6
    a = analyze(st, res.values)
    assert abs(a.worst_margin_db - res.worst_margin_db) < 1e-9
    plain = small_vertical(distortion=False)
    assert abs(evaluate_design(plain, res.values)["objectives"]["worst_band_margin"]
               - res.objective_value) > 1e-4
    assert abs(analyze(plain, res.values).worst_margin_db - res.worst_margin_db) > 1e-4


def test_table_optimize_and_analysis_answer_with_it(small_table_study):
    """The table study: isodesign.optimize's analysis is analyze()'s with the key on."""
    st = small_table_study().with_changes({"models.distortion": True})
    res = isodesign.optimize(st)
    assert res.feasible and res.recheck_margin_db < 1e-6 and res.distortion_outer_rounds >= 1
    a = analyze(st, res.values)
    assert abs(a.worst_margin_db - res.analysis.worst_margin_db) < 1e-9
    # the NLP's figure: the table analysis with the distortion on the NLP's own grid
    coarse = analyze(st, res.values, points_per_band=st.models["points_per_band"])
    assert abs(coarse.worst_margin_db - res.objective_value) < 1e-6
    start = {v.name: v.start for v in st.variables}
    at_start = analyze(st, start, points_per_band=st.models["points_per_band"])
    assert abs(at_start.worst_margin_db - res.start_objective) < 1e-6
    plain = small_table_study().with_changes({"models.distortion": False})
    assert abs(analyze(plain, res.values).worst_margin_db - a.worst_margin_db) > 1e-5


def test_the_cli_gives_the_api_answer_and_replays_the_key(tmp_path, api_result):
    """``isodesign optimize STUDY.toml`` with the key on: the API's optimum and analysis; its
    study_resolved.toml keeps the key (a replay answers the same question)."""
    from isodesign.io.record import study_toml
    from isodesign.optimization.study import load_study

    st, api = api_result
    f = tmp_path / "d.toml"
    f.write_text(study_toml(st))
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    p = subprocess.run([sys.executable, "-m", "isodesign", "optimize", str(f), "-o",
                        str(tmp_path / "cli"), "--no-plots", "--quiet"], capture_output=True,
                       text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    rec = json.loads((tmp_path / "cli" / "record.json").read_text())
    design = json.loads((tmp_path / "cli" / "design.json").read_text())
    assert rec["objective_value"] == pytest.approx(api.objective_value, abs=1e-6)
    assert design["derived"]["worst_band_margin_db"] == pytest.approx(
        api.analysis.worst_margin_db, abs=1e-6)
    assert load_study(tmp_path / "cli" / "study_resolved.toml").models["distortion"] is True


def test_a_study_case_carries_the_key_to_the_report_and_response(tmp_path):
    """``isodesign report`` / ``isodesign response`` of a study file: its case's models say
    the closure carries the distortion (and the report's model table names it)."""
    from isodesign.io.record import study_toml
    from isodesign.reporting.analysis import model_caveats
    from isodesign.reporting.inputs import load_case

    f = tmp_path / "d.toml"
    f.write_text(study_toml(small_vertical(distortion=True)))
    case = load_case(f)
    assert case.models["distortion"] is True
    rows = {what: model for what, model, _ in model_caveats(case.models)}
    assert rows["random closure"] == "statistical with the distortion power"
    f.write_text(study_toml(small_vertical(distortion=False)))
    assert "distortion" not in load_case(f).models
