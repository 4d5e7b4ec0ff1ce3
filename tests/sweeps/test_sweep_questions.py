"""A sweep answers the question its study asks: ``isodesign sweep`` of a table study gives
the table's optimum per point (its files, its row, its design chart), a study with
``[scenarios]`` is optimized robustly, and a task that cannot answer a study is refused
before any point runs, with the API's line (issue 23)."""

from __future__ import annotations

import json

import pytest

import isodesign
from isodesign.cli import main
from isodesign.errors import InputError
from isodesign.io.record import study_toml
from isodesign.optimization.study import vertical_study


def test_the_sweep_cli_optimizes_a_table_study_with_the_table_model(tmp_path, capsys,
                                                                    small_table_study):
    st = small_table_study()
    f = tmp_path / "t.toml"
    f.write_text(study_toml(st))
    out = tmp_path / "sw"
    status = main(["sweep", str(f), "--vary", "payload.mass_kg=560,640", "--scheduler",
                   "serial", "--quiet", "-o", str(out)])
    capsys.readouterr()
    assert status == 0
    df = isodesign.sweeps.table.read_table(out)
    assert list(df["question"]) == ["table", "table"]
    for _, row in df.iterrows():
        api = isodesign.optimize(st.with_changes(payload={"mass_kg": row["payload.mass_kg"]}))
        assert row["objective_value"] == pytest.approx(api.objective_value, abs=1e-6)
        assert row["worst_band_margin_db"] == pytest.approx(api.analysis.worst_margin_db,
                                                            abs=1e-6)
        assert row["capillary_diameter_m"] == pytest.approx(api.values["capillary_diameter_m"],
                                                            rel=1e-6)
        rec = json.loads((out / row["run_dir"] / "record.json").read_text())
        assert rec["table"] is True and (out / row["run_dir"] / "modes.csv").is_file()
    # the design chart is drawn from the table's rows
    assert (out / "charts" / "worst_band_margin.png").is_file()


def test_a_task_that_cannot_answer_is_refused_with_the_api_line(tmp_path, capsys):
    st = vertical_study().with_changes(
        scenarios={"payload_mass_kg": {"min": 540.0, "max": 660.0}})
    with pytest.raises(InputError) as api:
        isodesign.pareto_front(st)
    f = tmp_path / "r.toml"
    f.write_text(study_toml(st))
    status = main(["sweep", str(f), "--vary", "payload.mass_kg=600", "--task", "pareto",
                   "--scheduler", "serial", "-o", str(tmp_path / "sw")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert err == [f"isodesign: error: {api.value}"]
    assert str(api.value).startswith("[scenarios]: ")
    assert not (tmp_path / "sw").exists()
