"""``isodesign response STUDY --verify-monte-carlo`` on a study with a [table] (6 DOF)."""

from __future__ import annotations

import re
import shutil
from importlib import resources

import pytest

from isodesign.cli import main


@pytest.fixture
def table_study(tmp_path):
    study = tmp_path / "table.toml"
    with resources.as_file(resources.files("isodesign") / "data" / "table_study.toml") as p:
        shutil.copy(p, study)
    return study


def test_table_verify_prints_errors_per_point_and_axis(table_study, capsys):
    rc = main(["response", str(table_study), "--flow", "quasi_steady", "--diaphragm", "none",
               "--points-per-band", "8", "--bands", "4:20", "--verify-monte-carlo", "1",
               "--mc-duration-s", "20"])  # fmt: skip
    out, _ = capsys.readouterr()
    assert rc == 0
    assert "Monte Carlo (6 DOF): 1 seeds x 20 s" in out and "lateral element as a Prony" in out
    head = [ln for ln in out.splitlines() if ln.strip().startswith("band ")][-1]
    assert head.split()[1:] == ["centre", "x", "centre", "y", "centre", "z", "corner", "x",
                                "corner", "y", "corner", "z"]  # fmt: skip
    band = re.compile(r"^\s+(4|5|6\.3|8|10|12\.5|16|20)\s+[+-]")
    rows = [ln for ln in out.splitlines() if band.match(ln)]
    assert len(rows) == 8 and all(len(r.split()) == 7 for r in rows)
    strokes = re.findall(r"^\s+[1-4]\s+\S+\s+\S+\s+([+-]\d+\.\d) %$", out, re.M)
    assert len(strokes) == 4 and all(abs(float(s)) < 10 for s in strokes)
    assert "one seed: no standard error" in out


def test_table_verify_bad_input_is_one_line(table_study, capsys):
    rc = main(["response", str(table_study), "--flow", "quasi_steady", "--diaphragm", "none",
               "--verify-monte-carlo", "1", "--mc-duration-s", "5"])  # fmt: skip
    _, err = capsys.readouterr()
    errors = [ln for ln in err.splitlines() if ln.startswith("isodesign: error")]
    assert rc == 2 and len(errors) == 1 and "Traceback" not in err
    assert errors[0].startswith("isodesign: error: --verify-monte-carlo: duration_s:")


def test_table_verify_compares_like_with_like(table_study, capsys):
    """The 6-DOF simulator integrates the lumped acoustics: with the distributed default in
    force the table printed is the lumped closure's (the same as with --acoustics lumped), and
    one line states how far the distributed closure is from it."""
    argv = ["response", str(table_study), "--flow", "quasi_steady", "--diaphragm", "none",
            "--points-per-band", "8", "--bands", "4:20", "--verify-monte-carlo", "1",
            "--mc-duration-s", "20"]
    assert main(argv) == 0
    out, _ = capsys.readouterr()
    m = re.search(r"the distributed acoustics in force differ from it by at most "
                  r"([+-]\d+\.\d+) dB \((centre|corner) [xyz], \S+ Hz", out)
    assert m, out
    assert main([*argv, "--acoustics", "lumped"]) == 0
    out_l, _ = capsys.readouterr()
    assert "in force differ" not in out_l
    band = re.compile(r"^\s+(4|5|6\.3|8|10|12\.5|16|20)\s+[+-]")
    rows = [ln for ln in out.splitlines() if band.match(ln)]
    assert rows == [ln for ln in out_l.splitlines() if band.match(ln)] and len(rows) == 8
