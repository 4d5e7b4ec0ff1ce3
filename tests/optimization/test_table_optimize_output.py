"""What a table optimize prints and records: the constraint table, the binding sentence,
the Hessian, the continuous peak; an infeasible run's best point; a broken bound's exit."""

from __future__ import annotations

import json
import re
import shutil
from importlib import resources

import pytest

from isodesign.cli import main


def _table_toml(tmp_path, extra: str, name="t.toml"):
    src = resources.files("isodesign") / "data" / "table_study.toml"
    p = tmp_path / name
    with resources.as_file(src) as f:
        shutil.copy(f, p)
    text = p.read_text().replace("[solver]\nstarts = 4", "[solver]\nstarts = 1\nworkers = 1")
    p.write_text(text + extra)
    return p


@pytest.mark.slow
def test_builtin_table_prints_and_records_its_constraints(builtin_table_run):
    """(The run test_table_cli.py reads too: tests/table/conftest.py, with its plots.)"""
    text, out = builtin_table_run  # optimize --builtin table --starts 1 --workers 1 -o out
    assert "constraints at the optimum" in text
    assert "the design is stopped by" in text
    assert "Hessian: limited-memory" in text
    # the continuous peak starts below the y+rx mode (0.8 Hz), the grid at 0.89 Hz
    f_low = float(re.search(r"continuous from ([0-9.]+) Hz", text).group(1))
    assert f_low < 0.5 and "y +13.9" in text
    design = json.loads((out / "design.json").read_text())
    names = {c["name"]: c for c in design["constraints"]}
    assert {"total_volume", "peak_transmissibility", "continuous_peak_transmissibility",
            "tilt_margin", "damping_ratio"} <= set(names)
    assert names["total_volume"]["binding"] is True
    assert design["limited_by"] and design["hessian"] == "limited-memory"
    rec = json.loads((out / "record.json").read_text())
    assert rec["constraints"] == design["constraints"] and rec["success"] is True
    assert rec["peak_refinement"]["search_band_hz"][0] < 0.5


@pytest.mark.slow
def test_infeasible_table_prints_its_best_point_and_exits_1(tmp_path, capsys):
    study = _table_toml(tmp_path, "\n[constraints]\nmax_total_volume_m3 = 0.0002\n")
    out = tmp_path / "o"
    assert main(["optimize", str(study), "--no-plots", "-o", str(out)]) == 1
    cap = capsys.readouterr()
    assert "NO FEASIBLE DESIGN" in cap.out and "best point found (not a design)" in cap.out
    assert "max_total_volume_m3" in cap.out and "total_volume" in cap.out
    assert "no feasible design" in cap.err
    rec = json.loads((out / "record.json").read_text())
    assert rec["run_status"] == "infeasible" and not (out / "design.json").exists()
    assert "max_total_volume_m3" in dict(rec["violations"])


@pytest.mark.slow
def test_a_peak_left_above_its_bound_is_a_violation_and_exits_1(tmp_path, capsys,
                                                                 monkeypatch, held_out_toml):
    """Without refinement rounds the held-out-like table's optimum keeps a peak above
    15 dB between the grid's frequencies (below its first one): reported, exit 1, no PASS."""
    import isodesign.optimization.table_driver as topt

    monkeypatch.setattr(topt, "MAX_PEAK_ROUNDS", 0)  # no refinement round
    study = tmp_path / "five.toml"
    study.write_text(held_out_toml.replace("starts = 2", "starts = 1"))
    out = tmp_path / "o"
    assert main(["optimize", str(study), "--no-plots", "-o", str(out)]) == 1
    cap = capsys.readouterr()
    assert "WARNING: the continuous peak" in cap.out
    assert "optimum: FAIL: constraint broken: continuous_peak_transmissibility" in cap.out
    assert "breaks a constraint" in cap.err
    design = json.loads((out / "design.json").read_text())
    assert not design["verdict"].startswith("PASS") and design["success"] is False
    assert design["continuous_peak_db"] > 15.01
    rec = json.loads((out / "record.json").read_text())
    assert rec["run_status"] == "infeasible"
    # its report: one verdict, FAIL, naming the broken constraint
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 0
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    verdict = html.split('<section id="verdict">', 1)[1].split("<h3", 1)[0]
    assert verdict.count('<div class="card') == 1
    assert '<div class="word">FAIL</div>' in verdict
    assert "Constraint broken:</strong> continuous_peak_transmissibility" in verdict
