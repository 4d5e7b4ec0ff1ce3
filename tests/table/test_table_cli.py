"""The command line with a table: isodesign modes, and response on a study with a [table]."""

from __future__ import annotations

import shutil
from importlib import resources

import pandas as pd

from isodesign.cli import main


def test_modes_command_writes_its_files(tmp_path, capsys):
    out = tmp_path / "m"
    assert main(["modes", "--builtin", "table", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "rocking stability with gravity" in text and "x+ry" in text
    for name in ("modes.csv", "stability.csv", "leveling.csv", "layout.png", "record.json"):
        assert (out / name).is_file(), name
    modes = pd.read_csv(out / "modes.csv")
    assert len(modes) == 6 and modes["frequency_hz"].is_monotonic_increasing
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
