"""An interrupted ``isodesign yield`` keeps the draws it judged (issue 23): a readable
``yield_partial.csv`` (the columns of yield.csv) in ``OUTDIR.interrupted``, named in the
record and on stderr only if it exists.

The in-process tests interrupt at an event (a chunk of draws judged, or none yet) by raising
KeyboardInterrupt from the yield's own progress; the subprocess test sends SIGINT once the
run's staging directory exists. No fixed delay.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd
import pytest

import isodesign.optimization.yields as yields_mod
from isodesign.cli import main

STUDY = """\
name = "yield-interrupt"
[models]
points_per_band = 3
peak_points = 30
[solver]
workers = 1
[scenarios]
payload_mass_kg = {min = 540.0, max = 660.0}
capillary_diameter_m = {relative = 0.03}
"""

DESIGN = """\
volume_ratio = 1.851851851851852
top_volume_m3 = 0.00081
capillary_length_m = 0.012
capillary_diameter_m = 0.0009
piston_area_m2 = 0.0053
pressure_pa = 493000.0
"""


def _files(tmp_path: Path) -> tuple[Path, Path]:
    (tmp_path / "s.toml").write_text(STUDY)
    (tmp_path / "d.toml").write_text(DESIGN)
    return tmp_path / "s.toml", tmp_path / "d.toml"


def _argv(tmp_path, out, samples=200):
    study, design = _files(tmp_path)
    return ["yield", str(design), "--study", str(study), "--samples", str(samples),
            "--workers", "1", "--no-plots", "-o", str(out)]


def _interrupt_after(monkeypatch, chunks: int) -> None:
    """Ctrl-C once ``chunks`` chunks of draws are judged (0: before any)."""
    real = yields_mod.map_in_workers

    def interrupted(fn, items, *, workers=None, progress=None):
        seen = []

        def after(done, total, out):
            progress(done, total, out)
            seen.append(done)
            if len(seen) >= chunks:
                raise KeyboardInterrupt

        if chunks == 0:
            raise KeyboardInterrupt
        return real(fn, items, workers=workers, progress=after)

    monkeypatch.setattr(yields_mod, "map_in_workers", interrupted)


def test_interrupted_yield_keeps_the_finished_draws_as_in_yield_csv(tmp_path, monkeypatch,
                                                                      capsys):
    full = tmp_path / "full"
    assert main(_argv(tmp_path, full)) == 0
    complete = pd.read_csv(full / "yield.csv")
    _interrupt_after(monkeypatch, 2)
    out = tmp_path / "run"
    assert main(_argv(tmp_path, out)) == 130
    capsys.readouterr()
    assert not out.exists()
    aside = out.with_name("run.interrupted")
    part = pd.read_csv(aside / "yield_partial.csv")
    assert list(part.columns) == list(complete.columns)
    assert len(part) == 100  # two chunks of 50 of the 200 draws
    pd.testing.assert_frame_equal(part, complete.iloc[:100].reset_index(drop=True))
    rec = json.loads((aside / "record.json").read_text())
    assert rec["run_status"] == "interrupted"
    assert rec["partial_tables"] == ["yield_partial.csv"]
    assert "yield_partial.csv" in rec["files"] and "yield.csv" not in rec["files"]


def test_interrupted_before_any_draw_names_no_table(tmp_path, monkeypatch, capsys):
    _interrupt_after(monkeypatch, 0)
    out = tmp_path / "run"
    assert main(_argv(tmp_path, out)) == 130
    capsys.readouterr()
    aside = out.with_name("run.interrupted")
    assert not (aside / "yield_partial.csv").exists()
    assert "partial_tables" not in json.loads((aside / "record.json").read_text())


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups")
def test_sigint_names_the_partial_table_only_if_it_exists(tmp_path, cli_process):
    out = tmp_path / "run"
    proc = cli_process.start(*_argv(tmp_path, out, 100000))
    cli_process.wait_for(proc, lambda: [p for p in tmp_path.iterdir()
                                        if "isodesign-partial" in p.name], "the run's start")
    _stdout, stderr = cli_process.interrupt(proc)
    assert proc.returncode == 130, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isodesign: interrupted by SIGINT"), stderr
    aside = out.with_name("run.interrupted")
    table = aside / "yield_partial.csv"
    if "finished work in " in lines[0]:
        assert str(table) in lines[0] and len(pd.read_csv(table)) > 0
    else:
        assert not table.exists()
