"""The run-directory contract (isodesign.io.rundir) and whole-or-nothing file writes."""

from __future__ import annotations

import json
import os
import stat

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.io.files import (
    _PENDING,
    atomic_path,
    atomic_write_text,
    discard_pending_writes,
)
from isodesign.io.rundir import (
    RUN_STATUSES,
    RunDirectory,
    check_run_target,
    interrupt_active_runs,
    read_run_record,
)


def _record(d):
    return json.loads((d / "record.json").read_text())


def _siblings(d):
    return sorted(p.name for p in d.parent.iterdir())


def test_a_run_appears_whole_with_status_and_manifest(tmp_path):
    target = tmp_path / "run"
    with RunDirectory(target, command="test") as run:
        run.write_text("a.txt", "hello\n")
        run.write_json("b.json", {"x": np.float64(1.5), "nan": float("nan"), "v": np.arange(2)})
        run.write_text("sub/c.toml", "k = 1\n")
        with run.writing("d.png") as tmp:
            assert tmp.suffix == ".png" and tmp.parent == run.path
            tmp.write_bytes(b"\x89PNG")
        # nothing at the target while the run is in progress
        assert not target.exists()
        assert _record(run.path)["run_status"] == "running"
    assert _siblings(target) == ["run"]  # the staging directory is gone
    rec = _record(target)
    assert rec["run_status"] == "complete" and rec["kind"] == "isodesign test"
    assert rec["files"] == ["a.txt", "b.json", "sub/c.toml", "d.png"]
    assert {m["name"]: m["bytes"] for m in rec["manifest"]}["a.txt"] == 6
    assert json.loads((target / "b.json").read_text()) == {"x": 1.5, "nan": None, "v": [0, 1]}
    assert oct(stat.S_IMODE(target.stat().st_mode)) != "0o700"  # not mkdtemp's mode


def test_a_target_that_holds_a_run_is_refused_without_overwrite(tmp_path):
    target = tmp_path / "run"
    with RunDirectory(target, command="optimize") as run:
        run.write_text("design.json", "{}")
    with pytest.raises(InputError, match=r"--output: .* already holds a run .*--overwrite"):
        RunDirectory(target, command="optimize")
    with pytest.raises(InputError, match=r"-o2: .*already holds a run"):
        check_run_target(target, option="-o2")


def test_overwrite_replaces_only_what_the_earlier_run_wrote(tmp_path):
    target = tmp_path / "run"
    with RunDirectory(target, command="optimize") as run:
        run.write_text("design.json", "old")
        run.write_text("response.png", "old png")
    (target / "notes.txt").write_text("mine")
    (target / "mine").mkdir()
    with RunDirectory(target, command="pareto", overwrite=True) as run:
        run.write_text("pareto.csv", "new")
    names = sorted(os.listdir(target))
    # the earlier run's design.json and response.png are gone, the user's files stay
    assert names == ["mine", "notes.txt", "pareto.csv", "record.json"]
    rec = _record(target)
    assert rec["kind"] == "isodesign pareto" and rec["files"] == ["pareto.csv"]
    assert (target / "notes.txt").read_text() == "mine"
    assert _siblings(target) == ["run"]


def test_overwrite_of_a_run_without_manifest_uses_the_known_outputs(tmp_path):
    target = tmp_path / "legacy"
    target.mkdir()
    (target / "record.json").write_text(json.dumps({"kind": "isodesign optimize"}))
    (target / "design.json").write_text("{}")
    (target / "mine.txt").write_text("keep")
    with pytest.raises(InputError, match="status not recorded"):
        RunDirectory(target, command="optimize")
    with RunDirectory(target, command="optimize", overwrite=True,
                      known_outputs=("design.json",)) as run:
        run.write_text("starts.csv", "x")
    assert sorted(os.listdir(target)) == ["mine.txt", "record.json", "starts.csv"]


def test_a_non_empty_directory_without_a_run_is_refused(tmp_path):
    target = tmp_path / "docs"
    target.mkdir()
    (target / "thesis.tex").write_text("x")
    with pytest.raises(InputError, match="not empty and holds no isodesign run"):
        RunDirectory(target, command="optimize")
    # an empty directory is a fresh target
    empty = tmp_path / "empty"
    empty.mkdir()
    with RunDirectory(empty, command="t") as run:
        run.write_text("a", "1")
    assert _record(empty)["run_status"] == "complete"


@pytest.mark.parametrize("kind", ["file", "parent_file", "empty"])
def test_bad_targets_fail_before_anything_is_written(tmp_path, kind):
    f = tmp_path / "f.txt"
    f.write_text("x")
    target = {"file": f, "parent_file": f / "sub" / "run", "empty": ""}[kind]
    with pytest.raises(InputError, match="--output"):
        RunDirectory(target, command="t")
    assert sorted(os.listdir(tmp_path)) == ["f.txt"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_an_unwritable_parent_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(InputError, match="permission denied"):
            RunDirectory(ro / "run", command="t")
    finally:
        ro.chmod(0o700)


def test_missing_parents_are_created(tmp_path):
    target = tmp_path / "a" / "b" / "run"
    with RunDirectory(target, command="t") as run:
        run.write_text("x", "1")
    assert _record(target)["run_status"] == "complete"


@pytest.mark.parametrize("status", ["infeasible", "complete"])
def test_the_status_is_recorded(tmp_path, status):
    with RunDirectory(tmp_path / "r", command="t") as run:
        run.status = status
        run.record["extra"] = 1
    rec = _record(tmp_path / "r")
    assert rec["run_status"] == status and rec["extra"] == 1
    assert set(RUN_STATUSES) == {"complete", "infeasible", "failed", "interrupted"}


def test_an_exception_marks_the_run_failed_and_moves_it_into_place(tmp_path):
    target = tmp_path / "r"
    with pytest.raises(RuntimeError), RunDirectory(target, command="t") as run:
        run.write_text("partial.csv", "a\n")
        raise RuntimeError("solver exploded")
    rec = _record(target)
    assert rec["run_status"] == "failed"
    assert "solver exploded" in rec["error"]
    assert read_run_record(target)["kind"] == "isodesign t"


def test_an_interrupt_sets_the_partial_run_aside_and_keeps_the_earlier_run(tmp_path):
    target = tmp_path / "r"
    with RunDirectory(target, command="t") as run:
        run.write_text("design.json", "good")
    with pytest.raises(KeyboardInterrupt), RunDirectory(target, command="t",
                                                        overwrite=True) as run:
        run.write_text("design.json", "half")
        raise KeyboardInterrupt
    assert (target / "design.json").read_text() == "good"
    assert _record(target)["run_status"] == "complete"
    rec = _record(tmp_path / "r.interrupted")
    assert rec["run_status"] == "interrupted"
    # a second interrupted run does not clobber the first one's remains
    with RunDirectory(tmp_path / "r", command="t", overwrite=True) as run:
        run.write_text("x", "1")
        assert interrupt_active_runs("interrupted by SIGTERM") == [tmp_path / "r.interrupted-2"]
    assert _record(tmp_path / "r.interrupted-2")["error"] == "interrupted by SIGTERM"
    assert sorted(_siblings(target)) == ["r", "r.interrupted", "r.interrupted-2"]


def test_names_outside_the_run_directory_are_refused(tmp_path):
    with RunDirectory(tmp_path / "r", command="t") as run:
        for bad in ("../x", "/etc/passwd"):
            with pytest.raises(ValueError):
                run.write_text(bad, "x")


# -- single files -----------------------------------------------------------------------------
def test_atomic_write_replaces_whole_or_leaves_the_old_file(tmp_path):
    p = tmp_path / "k.csv"
    atomic_write_text(p, "old\n")
    with pytest.raises(RuntimeError), atomic_path(p) as tmp:
        tmp.write_text("half")
        raise RuntimeError("writer failed")
    assert p.read_text() == "old\n"
    assert os.listdir(tmp_path) == ["k.csv"]  # no temporary file left


def test_discard_pending_writes_removes_cut_short_temporaries(tmp_path):
    p = tmp_path / "plot.png"
    cm = atomic_path(p)
    tmp = cm.__enter__()
    tmp.write_bytes(b"\x89PNG half")
    assert tmp in _PENDING
    discard_pending_writes()
    assert not tmp.exists() and not p.exists()
    assert tmp not in _PENDING


def test_two_runs_into_one_target_never_mix(tmp_path):
    target = tmp_path / "r"
    first = RunDirectory(target, command="t")
    second = RunDirectory(target, command="t")  # checked while the target was still free
    with first:
        first.write_text("a.csv", "first")
    with pytest.warns(RuntimeWarning, match="received another run"), second:
        second.write_text("b.csv", "second")
    assert sorted(os.listdir(target)) == ["a.csv", "record.json"]
    other = tmp_path / "r-2"
    assert sorted(os.listdir(other)) == ["b.csv", "record.json"]
    assert _record(other)["output_directory"] == str(other)
