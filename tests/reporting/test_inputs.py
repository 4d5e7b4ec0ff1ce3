"""Inputs of reports and of response/transmissibility: design, study and run directories."""

from __future__ import annotations

import pytest

from isodesign.errors import InputError
from isodesign.io.designfile import (
    design_to_toml,
    load_design,
    load_design_models,
    save_design,
)
from isodesign.optimization.study import load_study
from isodesign.reporting.inputs import input_kind, load_case
from isodesign.spring.design import SpringDesign

from .conftest import run_cli


def test_design_file_records_models_and_reads_them_back(tmp_path):
    d = SpringDesign.reference()
    models = {"flow": "womersley", "amplitude_mode": "self_consistent",
              "diaphragm": "none", "random_method": "rayleigh", "points_per_band": 4}
    p = save_design(d, tmp_path / "d.toml", models=models)
    assert load_design(p) == d  # the models table does not change the spring
    assert load_design_models(p) == {k: models[k] for k in
                                     ("flow", "amplitude_mode", "diaphragm", "random_method")}
    assert "[models]" in design_to_toml(d, models=models)
    assert load_design_models(save_design(d, tmp_path / "plain.toml")) == {}


def test_design_file_models_table_is_checked(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(design_to_toml(SpringDesign.reference()) + "\n[models]\nflw = \"womersley\"\n",
                 encoding="utf-8")
    with pytest.raises(InputError, match="flw"):
        load_design(p)


def test_optimize_writes_the_models_into_design_toml(optimize_run):
    models = load_design_models(optimize_run / "design.toml")
    study = load_study(optimize_run / "study_resolved.toml")
    assert models["flow"] == study.models["flow"] == "womersley"
    assert models["diaphragm"] == study.models["diaphragm"]
    assert models["amplitude_mode"] == study.models["amplitude_mode"]


def test_input_kinds(optimize_run, fast_study, design_file, tmp_path):
    assert input_kind(optimize_run) == "optimize"
    assert input_kind(fast_study) == "study"
    assert input_kind(design_file) == "design"
    with pytest.raises(InputError, match=r"no record\.json"):
        input_kind(tmp_path)
    with pytest.raises(InputError, match="no such file"):
        input_kind(tmp_path / "nope.toml")


def test_case_of_a_run_uses_its_study_and_models(optimize_run):
    c = load_case(optimize_run)
    assert c.kind == "optimize" and c.record is not None
    assert c.models["flow"] == "womersley"
    assert c.study.payload.mass_kg == 600.0
    assert c.judged_hz == (4.0, 80.0)
    ref = load_design(optimize_run / "design.toml")
    assert c.design.volume_ratio == pytest.approx(ref.volume_ratio, rel=1e-12)
    assert c.design.pressure_pa == pytest.approx(ref.pressure_pa, rel=1e-9)


def test_case_of_a_design_file_uses_its_recorded_models(design_file):
    c = load_case(design_file)
    assert c.kind == "design" and c.models["flow"] == "womersley"
    assert "[models]" in c.models_source
    assert "vertical study" in c.job_source


def test_response_reads_a_run_directory(optimize_run):
    status, out, err = run_cli("response", optimize_run)
    assert status == 0, err
    assert "optimum of study 'fast'" in out
    assert "payload 600 kg on 4 isolators" in out
    assert "target VC-C; bands 4-80 Hz" in out
    assert "models in force: flow=womersley" in out and "illustrative" in out
    # the same verdict as the run's own re-analysis
    import json

    design = json.loads((optimize_run / "design.json").read_text())
    assert design["verdict"] in out


def test_response_reads_a_study_file_and_options_still_win(fast_study):
    status, out, err = run_cli("response", fast_study, "--flow", "quasi_steady")
    assert status == 0, err
    assert "start design of study 'fast'" in out and "target VC-C" in out
    assert "flow=quasi_steady" in out and "--flow" in out


def test_transmissibility_reads_a_run_directory_and_plots(optimize_run, tmp_path):
    png = tmp_path / "t.png"
    status, out, err = run_cli("transmissibility", optimize_run, "--freq", "0.5:20:30",
                               "--plot", png)
    assert status == 0, err
    assert "models in force: flow=womersley" in out
    assert png.stat().st_size > 5000


def test_response_of_a_design_file_uses_its_recorded_models(design_file):
    status, out, err = run_cli("response", design_file)
    assert status == 0, err
    assert "flow=womersley" in out and "[models]" in out
