"""The built-in studies by name (issue 24): ``default`` (the built-in table co-designed, what
no study file runs), ``table`` (its horizontal element fixed) and ``vertical`` (the
one-degree-of-freedom payload), the same in Python and on every command taking --builtin."""

from __future__ import annotations

import json

import pytest

from isodesign.cli import main


def test_the_builtin_names_are_the_python_functions():
    from isodesign.commands import BUILTIN_CHOICES
    from isodesign.optimization.dispatch import study_kind
    from isodesign.optimization.study import (
        BUILTIN_STUDIES,
        default_study,
        table_study,
        vertical_study,
    )

    assert set(BUILTIN_STUDIES) == set(BUILTIN_CHOICES)
    assert BUILTIN_STUDIES["default"] is default_study
    assert BUILTIN_STUDIES["table"] is table_study
    assert BUILTIN_STUDIES["vertical"] is vertical_study
    assert study_kind(default_study()) == study_kind(table_study()) == "table"
    assert study_kind(vertical_study()) == "vertical"
    assert any(v.free for v in default_study().levers)  # co-designed
    assert not any(v.free for v in table_study().levers)


def test_optimize_without_a_study_is_the_default_study(monkeypatch, tmp_path):
    """No STUDY.toml and --builtin default load the same study (the co-designed table)."""
    import argparse

    from isodesign.commands.optimize import load_study_from_args
    from isodesign.optimization.study import default_study

    ns = argparse.Namespace(study=None, builtin=None, starts=None, workers=None, seed=None,
                            acoustics=None)
    st = load_study_from_args(ns)
    assert st.raw == default_study().raw and st.table is not None
    st2 = load_study_from_args(argparse.Namespace(**{**vars(ns), "builtin": "default"}))
    assert st2.raw == st.raw
    st3 = load_study_from_args(argparse.Namespace(**{**vars(ns), "builtin": "vertical"}))
    assert st3.table is None and st3.name == "vertical"


def test_optimize_builtin_vertical_answers_the_vertical_question(tmp_path, capsys):
    out = tmp_path / "v"
    assert main(["optimize", "--builtin", "vertical", "--starts", "1", "--workers", "1",
                 "--no-plots", "--quiet", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("vertical: worst_band_margin")
    rec = json.loads((out / "record.json").read_text())
    assert rec["study"]["name"] == "vertical" and "table" not in rec["study"]
    assert rec["command_line"][1:4] == ["optimize", "--builtin", "vertical"]  # replayable


@pytest.mark.parametrize("command", ["modes", "stability"])
def test_table_commands_refuse_the_vertical_study_in_one_line(tmp_path, capsys, command):
    out = tmp_path / "o"
    assert main([command, "--builtin", "vertical", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("isodesign: error: --builtin vertical"), err
    assert "[table]" in err[0]
    assert not out.exists()


def test_modes_of_the_default_study_is_the_co_designed_tables_start(tmp_path, capsys):
    out = tmp_path / "m"
    assert main(["modes", "--builtin", "default", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "start design of the built-in default study" in text
    assert (out / "modes.csv").is_file()
