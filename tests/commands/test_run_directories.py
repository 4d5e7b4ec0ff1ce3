"""Runs never lose, mix or half-write results: the run-directory contract through the real
commands (optimize, pareto), on a small study.

Regressions of: an infeasible optimize into an earlier feasible run's directory leaving
the old design beside the new record; --no-plots leaving a stale response.png; pareto into
an optimize directory replacing record.json and keeping design.json; pareto on an
infeasible study exiting with no record and saying "minimizing" for a maximized objective;
an unwritable output reported only after the computation.
"""

from __future__ import annotations

import json
import os
import shutil

import pytest

from isodesign.cli import main

FAST_STUDY = """\
name = "fast"

[models]
points_per_band = 4
peak_points = 30

[solver]
starts = 2
"""

INFEASIBLE_STUDY = FAST_STUDY.replace('name = "fast"', 'name = "infeasible"').replace(
    "starts = 2", "starts = 1") + """
[constraints]
max_total_volume_m3 = 1e-5
"""


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def record(d):
    return json.loads((d / "record.json").read_text())


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    d = tmp_path_factory.mktemp("studies")
    (d / "fast.toml").write_text(FAST_STUDY)
    (d / "infeasible.toml").write_text(INFEASIBLE_STUDY)
    return d


@pytest.fixture(scope="module")
def feasible_run(studies, tmp_path_factory):
    """One complete optimize run of the fast study (copied by the tests that change it)."""
    import contextlib
    import io

    out = tmp_path_factory.mktemp("feasible") / "run"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        status = main(["optimize", str(studies / "fast.toml"), "-o", str(out), "--quiet"])
    assert status == 0
    return out


def test_a_complete_run_records_its_status_and_every_file(feasible_run):
    rec = record(feasible_run)
    assert rec["run_status"] == "complete"
    assert rec["kind"] == "isodesign optimize"
    on_disk = sorted(p.name for p in feasible_run.iterdir())
    assert sorted([*rec["files"], "record.json"]) == on_disk
    for m in rec["manifest"]:
        assert (feasible_run / m["name"]).stat().st_size == m["bytes"] > 0
    # nothing else beside it: no staging directory left
    assert [p.name for p in feasible_run.parent.iterdir()] == ["run"]


@pytest.mark.slow
def test_infeasible_run_into_a_feasible_runs_directory(capsys, studies, feasible_run, tmp_path):
    target = tmp_path / "run"
    shutil.copytree(feasible_run, target)
    (target / "my_notes.txt").write_text("keep me")
    # refused without --overwrite: the earlier run is untouched
    status, _, err = run(capsys, "optimize", studies / "infeasible.toml", "-o", target)
    assert status == 2 and "already holds a run" in err and "--overwrite" in err
    assert record(target)["run_status"] == "complete"
    # with --overwrite: the new record, and none of the old design's files
    status, out, err = run(capsys, "optimize", studies / "infeasible.toml", "-o", target,
                           "--overwrite")
    assert status == 1
    assert "NO FEASIBLE DESIGN" in out
    assert err.strip().splitlines()[0].startswith("isodesign: error: no feasible design")
    rec = record(target)
    assert rec["run_status"] == "infeasible" and rec["feasible"] is False
    names = sorted(p.name for p in target.iterdir())
    assert names == ["my_notes.txt", "record.json", "starts.csv", "study_resolved.toml"]
    for stale in ("design.json", "design.toml", "bands.csv", "response.png"):
        assert not (target / stale).exists(), stale
    assert (target / "my_notes.txt").read_text() == "keep me"


def test_no_plots_with_overwrite_leaves_no_stale_plot(capsys, studies, feasible_run,
                                                      tmp_path):
    target = tmp_path / "run"
    shutil.copytree(feasible_run, target)
    assert (target / "response.png").exists()
    status, _, err = run(capsys, "optimize", studies / "fast.toml", "-o", target,
                         "--overwrite", "--no-plots", "--quiet")
    assert status == 0, err
    assert not (target / "response.png").exists()
    assert "response.png" not in record(target)["files"]


def test_pareto_into_an_optimize_directory(capsys, studies, feasible_run, tmp_path):
    target = tmp_path / "run"
    shutil.copytree(feasible_run, target)
    status, _, err = run(capsys, "pareto", studies / "infeasible.toml", "-o", target)
    assert status == 2 and "already holds a run (isodesign optimize, complete)" in err
    assert (target / "design.json").exists()


@pytest.mark.slow
def test_pareto_on_an_infeasible_study_writes_its_record(capsys, studies, feasible_run,
                                                         tmp_path):
    target = tmp_path / "run"
    shutil.copytree(feasible_run, target)
    status, out, err = run(capsys, "pareto", studies / "infeasible.toml", "-o", target,
                           "--points", "3", "--overwrite")
    assert status == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isodesign: error: "), err
    assert "maximizing worst_band_margin" in lines[0] and "minimizing" not in lines[0]
    assert "maximizing worst_band_margin" in out
    rec = record(target)
    assert rec["kind"] == "isodesign pareto" and rec["run_status"] == "infeasible"
    assert rec["sense"]["worst_band_margin"] == "maximize"
    # the optimize run's files are gone, the pareto run's record and study are there
    assert sorted(p.name for p in target.iterdir()) == ["record.json", "study_resolved.toml"]


def test_a_solver_failure_is_recorded_as_failed(capsys, studies, tmp_path, monkeypatch):
    from isodesign.errors import SolverError

    def boom(*a, **k):
        raise SolverError("IPOPT exploded")

    monkeypatch.setattr("isodesign.commands.optimize.optimize", boom)
    target = tmp_path / "run"
    status, _, err = run(capsys, "optimize", studies / "fast.toml", "-o", target)
    assert status == 1 and "IPOPT exploded" in err
    rec = record(target)
    assert rec["run_status"] == "failed" and "IPOPT exploded" in rec["error"]
    assert rec["study"]["name"] == "fast"  # what was known before the solve is recorded


def test_an_unwritable_output_fails_before_the_computation(capsys, studies, tmp_path,
                                                          monkeypatch):
    calls = []
    monkeypatch.setattr("isodesign.commands.optimize.optimize", lambda *a, **k: calls.append(1))
    blocker = tmp_path / "file"
    blocker.write_text("x")
    status, _, err = run(capsys, "optimize", studies / "fast.toml", "-o", blocker / "run")
    assert status == 2 and "--output" in err
    assert calls == []
    if os.geteuid() != 0:  # root writes anywhere
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        status, _, err = run(capsys, "optimize", studies / "fast.toml", "-o", ro / "run")
        assert status == 2 and "permission denied" in err
        assert calls == []
