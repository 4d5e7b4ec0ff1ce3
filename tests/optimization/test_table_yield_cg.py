"""``isodesign yield`` of a table study applies the CG offsets of ``[scenarios]``, through the
CLI as through the API (issue 23: a CG offset of +-5 m was judged as if the CG had not
moved, and a failing table design got the vertical payload's yield)."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from isodesign.io.designfile import design_to_toml
from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict, table_study
from isodesign.optimization.yields import estimate_yield

ROOT = Path(__file__).resolve().parents[2]


def table_with(scenarios, target):
    """The built-in table, coarse (one start, 3 points per band, bands 4-20 Hz)."""
    raw = copy.deepcopy(table_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0, criterion=target)
    raw["scenarios"] = scenarios
    return study_from_dict(raw, source="table_cg.toml", fill_defaults=False)


def cli_yield(tmp_path, st, name):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    f = tmp_path / f"{name}.toml"
    f.write_text(study_toml(st))
    d = tmp_path / "start.toml"
    d.write_text(design_to_toml(st.start_design()))
    out = tmp_path / name
    p = subprocess.run([sys.executable, "-m", "isodesign", "yield", str(d), "--study", str(f),
                        "--samples", "3", "--seed", "1", "--workers", "1", "--no-plots", "-o",
                        str(out)], capture_output=True, text=True, env=env, timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads((out / "yield.json").read_text()), pd.read_csv(out / "yield.csv")


@pytest.mark.slow  # three yield processes, about 40 s on a loaded 2-core machine
def test_cli_yield_of_a_failing_table_moves_with_the_cg_offset_as_the_api(tmp_path):
    """The start design of the built-in table fails VC-C at every draw (yield 0, the
    table's miss): the CG 0.1 m off changes its worst margin, 0.3 m off unloads an isolator
    group (every draw fails the leveling); CLI and API give the same yield and worst
    margin. (The API alone: tests/optimization/test_one_answer.py, with VC-A.)"""
    target = "VC-C"
    margins = {}
    for offset in (0.0, 0.1, 0.3):
        st = table_with({"payload_mass_kg": {"values": [600.0]},
                         "cg_offset_x_m": {"values": [offset]}}, target)
        api = estimate_yield(st, {v.name: v.start for v in st.variables}, samples=3, seed=1,
                             workers=1)
        y, draws = cli_yield(tmp_path, st, f"y{offset}".replace(".", "_"))
        assert y["fraction"] == api.fraction
        assert list(draws["cg_offset_x_m"]) == [offset] * 3  # the drawn offset, applied
        if offset == 0.3:
            assert y["fraction"] == 0.0
            assert all("leveling" in r for r in draws["reason"])
            continue
        assert y["worst_margin_db"] == pytest.approx(api.worst_margin_db(), abs=1e-6)
        margins[offset] = y["worst_margin_db"]
        assert y["fraction"] == 0.0
        assert -12.0 < y["worst_margin_db"] < -5.0  # the table's miss, not the payload's
    assert abs(margins[0.1] - margins[0.0]) > 0.1  # the CG moved the table's margin
