"""The command line with a table: isodesign modes, and response on a study with a [table]."""

from __future__ import annotations

import re
import shutil
from importlib import resources

import pandas as pd
import pytest

from isodesign.cli import main


def test_modes_command_writes_its_files(tmp_path, capsys):
    out = tmp_path / "m"
    assert main(["modes", "--builtin", "table", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "static stability with gravity" in text and "x+ry" in text
    assert "critical CG height 1.497 m -> stable" in text
    # the self-consistent solution printed is the mode the modes table holds (not a digit
    # measured once: the spring model's refinements move it in the last place)
    m = re.search(r"mode 1: self-consistent solutions ([0-9.]+) Hz", text)
    assert m is not None, text
    for name in ("modes.csv", "stability.csv", "leveling.csv", "layout.png", "record.json"):
        assert (out / name).is_file(), name
    modes = pd.read_csv(out / "modes.csv")
    assert len(modes) == 6 and modes["frequency_hz"].is_monotonic_increasing
    assert float(m.group(1)) == pytest.approx(modes["frequency_hz"].iloc[0], abs=6e-4)
    assert set(modes["name"]) >= {"z", "rz", "x+ry", "y+rx"}
    assert (pd.read_csv(out / "leveling.csv")["group"].tolist() == [1, 1, 2, 3])


def test_response_on_a_table_study_has_point_and_axis_columns(tmp_path, capsys):
    study = tmp_path / "table.toml"
    src = resources.files("isodesign") / "data" / "table_study.toml"
    with resources.as_file(src) as p:
        shutil.copy(p, study)
    csv = tmp_path / "bands.csv"
    assert main(["response", str(study), "--points-per-band", "6", "-o", str(csv)]) == 0
    text = capsys.readouterr().out
    assert "the vertical floor 'VC-A floor' is applied to x and y" in text
    df = pd.read_csv(csv)
    assert list(df.columns[:2]) == ["point", "axis"]
    assert set(df["axis"]) == {"x", "y", "z"} and set(df["point"]) == {"centre", "corner"}
    assert len(df) == 2 * 3 * 14
    assert text.strip().splitlines()[-2].startswith(("PASS", "FAIL"))


@pytest.mark.slow
def test_optimize_builtin_table_and_its_run_directory(builtin_table_run, tmp_path, capsys):
    text, out = builtin_table_run  # optimize --builtin table --starts 1 --workers 1 -o out
    assert "re-check: NumPy closure = NLP" in text and "optimum: " in text
    for name in ("design.toml", "design.json", "bands.csv", "modes.csv", "starts.csv",
                 "record.json", "study_resolved.toml", "response.png", "layout.png"):
        assert (out / name).is_file(), name
    df = pd.read_csv(out / "bands.csv")
    assert {"point", "axis", "start_margin_db"} <= set(df.columns)
    # the run directory is an input of modes and response (its optimum, its table)
    assert main(["modes", str(out), "-o", str(tmp_path / "m")]) == 0
    assert "optimum of" in capsys.readouterr().out
    assert main(["response", str(out), "--points-per-band", "6"]) == 0
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 0
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "The table in six degrees of freedom" in html and "upper" in html  # N at its bound


@pytest.mark.slow
def test_pareto_of_the_table_study(tmp_path, capsys):
    """The built-in table study's front on a coarse grid (3 points per band, 30 peak
    points; the assertions are the front's shape and files, no quoted figure): about a
    third of the built-in grid's time (it was the suite's second-longest test)."""
    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text("utf-8")
    study = tmp_path / "table.toml"
    study.write_text(src + "\n[models]\npoints_per_band = 3\npeak_points = 30\n", "utf-8")
    out = tmp_path / "p"
    assert main(["pareto", str(study), "--points", "3", "--starts", "1",
                 "--workers", "1", "-o", str(out)]) == 0
    df = pd.read_csv(out / "pareto.csv")
    assert len(df) == 3 and df["nondominated"].all()
    # less volume, less margin: a front
    assert df["total_volume_m3"].is_monotonic_decreasing
    assert df["worst_margin_db"].is_monotonic_decreasing
    assert (out / "pareto.png").is_file()
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 0
