"""Durability of run directories: files are written without a per-file fsync and synced
together (:func:`isodesign.io.files.make_durable`) before the run is moved into place."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

import isodesign.io.files as files
import isodesign.io.rundir as rundir
from isodesign.io.files import atomic_write_text, make_durable
from isodesign.io.rundir import RunDirectory

linux = pytest.mark.skipif(not sys.platform.startswith("linux"),
                           reason="names synced descriptors through /proc/self/fd")


def _record_fsyncs(monkeypatch) -> list[Path]:
    """Replace os.fsync (as the io modules see it) by one recording the synced paths."""
    synced: list[Path] = []
    real = os.fsync

    def fsync(fd):
        synced.append(Path(os.readlink(f"/proc/self/fd/{fd}")))
        real(fd)

    monkeypatch.setattr(files.os, "fsync", fsync)
    return synced


@linux
def test_make_durable_syncs_every_file_and_directory(monkeypatch, tmp_path):
    root = tmp_path / "stage"
    (root / "sub" / "deeper").mkdir(parents=True)
    written = [root / "a.json", root / "b.csv", root / "sub" / "c.png",
               root / "sub" / "deeper" / "d.toml"]
    for p in written:
        p.write_text(p.name, encoding="utf-8")
    synced = _record_fsyncs(monkeypatch)
    make_durable(root)
    dirs = [root, root / "sub", root / "sub" / "deeper"]
    assert sorted(synced) == sorted(written + dirs)
    assert len(synced) == len(written) + len(dirs)  # each once


@linux
def test_non_durable_write_skips_fsync_and_durable_write_syncs(monkeypatch, tmp_path):
    synced = _record_fsyncs(monkeypatch)
    atomic_write_text(tmp_path / "staged.txt", "x", durable=False)
    assert synced == []
    assert (tmp_path / "staged.txt").read_text(encoding="utf-8") == "x"
    atomic_write_text(tmp_path / "final.txt", "y")
    assert tmp_path in synced  # the rename made durable
    assert len(synced) == 2  # the file (under its temporary name) and the directory
    assert not list(tmp_path.glob(".*.tmp*"))  # no temporary file left


def test_run_is_synced_whole_before_it_is_moved_into_place(monkeypatch, tmp_path):
    seen = []
    real = rundir.make_durable

    def spy(directory):
        d = Path(directory)
        # the staging directory, holding the final record, the target not yet there
        rec = json.loads((d / "record.json").read_text(encoding="utf-8"))
        seen.append((d.name.startswith(".run.isodesign-partial-"), rec["run_status"],
                     sorted(p.name for p in d.iterdir()), (tmp_path / "run").exists()))
        real(directory)

    monkeypatch.setattr(rundir, "make_durable", spy)
    with RunDirectory(tmp_path / "run", command="test") as run:
        run.write_text("a.txt", "a")
        with run.writing("b.bin") as tmp:
            tmp.write_bytes(b"b")
    assert seen == [(True, "complete", ["a.txt", "b.bin", "record.json"], False)]
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == [
        "a.txt", "b.bin", "record.json"]
