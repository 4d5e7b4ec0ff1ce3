"""One default for the yields of a robust ``isodesign optimize``: the same number of draws
for a vertical and a table study, through the CLI (``--yield-samples``), a sweep's
``optimize`` task (``yield_samples``) and the API (:func:`optimum_yields`; issue 23)."""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict, table_study, vertical_study
from isodesign.optimization.yields import DEFAULT_YIELD_SAMPLES, estimate_yield, optimum_yields

ROOT = Path(__file__).resolve().parents[2]


def test_the_help_states_the_one_default():
    from isodesign.commands import optimize as cmd

    assert cmd.YIELD_SAMPLES_DEFAULT == DEFAULT_YIELD_SAMPLES
    parser = argparse.ArgumentParser()
    cmd.add_arguments(parser)
    text = " ".join(parser.format_help().split())
    assert f"default {DEFAULT_YIELD_SAMPLES}; 0: none" in text
    assert "with a [table] 0" not in text
    from isodesign.commands import sweep as sweep_cmd

    parser = argparse.ArgumentParser()
    sweep_cmd.add_arguments(parser)
    text = " ".join(parser.format_help().split())
    assert (f"the robust yield's draws (0..; default {DEFAULT_YIELD_SAMPLES}, vertical or "
            "[table], as isodesign optimize)") in text


def small_robust():
    return vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 30}, solver={"starts": 2, "workers": 1},
        scenarios={"payload_mass_kg": {"min": 540.0, "max": 660.0},
                   "capillary_diameter_m": {"relative": 0.03}})


def test_optimum_yields_default_is_both_optima_at_the_study_seed():
    """The API's yields are the two estimates the CLI writes: nominal then robust optimum,
    DEFAULT_YIELD_SAMPLES draws each, seeded with the study's [scenarios] seed."""
    st = small_robust()
    start = {v.name: v.start for v in st.variables}
    other = dict(start, capillary_diameter_m=start["capillary_diameter_m"] * 1.1)
    res = SimpleNamespace(feasible=True, values=other, nominal=SimpleNamespace(values=start))
    nominal, robust = optimum_yields(st, res, workers=1)
    seed = st.scenarios.settings["seed"]
    assert nominal.samples == robust.samples == DEFAULT_YIELD_SAMPLES
    assert (nominal.label, robust.label) == ("nominal optimum", "robust optimum")
    ref = estimate_yield(st, other, samples=DEFAULT_YIELD_SAMPLES, seed=seed, workers=1)
    assert robust.passed == ref.passed
    assert robust.worst_margin_db() == pytest.approx(ref.worst_margin_db(), abs=1e-12)
    assert optimum_yields(st, res, 0) == []
    assert optimum_yields(st, SimpleNamespace(feasible=False), None) == []
    for bad in (-1, 2.5, True, 10**7):
        with pytest.raises(InputError, match=r"^yield_samples: "):
            optimum_yields(st, res, bad)


def cli(*argv):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "isodesign", *argv], capture_output=True,
                          text=True, env=env, timeout=900)


@pytest.mark.slow
def test_a_robust_table_run_computes_the_default_yields_through_cli_sweep_and_api(tmp_path):
    raw = copy.deepcopy(table_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0, criterion="VC-C")
    raw["scenarios"] = {"payload_mass_kg": {"min": 560.0, "max": 640.0},
                        "cg_offset_y_m": {"absolute": 0.03}}
    st = study_from_dict(raw, source="tr.toml", fill_defaults=False)
    f = tmp_path / "tr.toml"
    f.write_text(study_toml(st))
    p = cli("optimize", str(f), "-o", str(tmp_path / "cli"), "--no-plots")
    assert p.returncode == 0, p.stderr
    rob_cli = json.loads((tmp_path / "cli" / "robust.json").read_text())
    assert [y["samples"] for y in rob_cli["yields"]] == [DEFAULT_YIELD_SAMPLES] * 2
    assert (tmp_path / "cli" / "yield.csv").is_file()
    # a one-point sweep without options: the same yields
    res = isodesign.sweep(st, vary={"payload.mass_kg": [600.0]}, output=tmp_path / "sw",
                          scheduler="serial", charts=False)
    row = res.table.iloc[0]
    assert row["status"] == "complete", row["error"]
    rob_sw = json.loads((tmp_path / "sw" / row["run_dir"] / "robust.json").read_text())
    assert row["yield"] == rob_cli["yields"][1]["fraction"]
    assert row["yield_nominal"] == rob_cli["yields"][0]["fraction"]
    for y, rec in zip(rob_sw["yields"], rob_cli["yields"], strict=True):
        assert (y["samples"], y["fraction"]) == (rec["samples"], rec["fraction"])
        assert y["worst_margin_db"] == pytest.approx(rec["worst_margin_db"], abs=1e-6)
    # the API: the same two estimates
    api = isodesign.optimize(st)
    ys = optimum_yields(st, api)
    assert [y.samples for y in ys] == [DEFAULT_YIELD_SAMPLES] * 2
    for y, rec in zip(ys, rob_cli["yields"], strict=True):
        assert y.fraction == rec["fraction"]
        assert y.worst_margin_db() == pytest.approx(rec["worst_margin_db"], abs=1e-6)


@pytest.mark.slow
def test_the_sweep_yield_task_draws_what_isodesign_yield_draws(tmp_path):
    """The yield of a design: the same default number of draws through isodesign yield,
    estimate_yield and the sweep's yield task (it had 200, the others 1,000)."""
    import inspect

    from isodesign.commands import yield_ as yield_cmd

    default = inspect.signature(estimate_yield).parameters["samples"].default
    parser = argparse.ArgumentParser()
    yield_cmd.add_arguments(parser)
    assert parser.get_default("samples") == default
    st = small_robust()
    res = isodesign.sweep(st, vary={"payload.mass_kg": [600.0]}, output=tmp_path / "sw",
                          scheduler="serial", charts=False, task="yield")
    row = res.table.iloc[0]
    assert row["status"] == "complete", row["error"]
    assert row["samples"] == default
    api = estimate_yield(st, {v.name: v.start for v in st.variables}, workers=1)
    assert row["objective_value"] == api.fraction
    assert row["worst_band_margin_db"] == pytest.approx(api.worst_margin_db(), abs=1e-9)
