"""``isodesign response`` and the sweep's ``response`` task of a study with ``[scenarios]``:
both refuse with one line naming ``[scenarios]`` and pointing at ``isodesign yield`` (the
nominal response of the design would not be the question asked; issue 23)."""

from __future__ import annotations

import copy
import os
import subprocess
import sys
from pathlib import Path

import pytest

import isodesign
from isodesign.commands.response import refuse_robust_response
from isodesign.errors import InputError
from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict, table_study, vertical_study

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = {"payload_mass_kg": {"min": 540.0, "max": 660.0},
             "capillary_diameter_m": {"relative": 0.03}}


def robust_vertical():
    return vertical_study().with_changes(scenarios=copy.deepcopy(SCENARIOS))


def robust_table():
    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = copy.deepcopy(SCENARIOS)
    return study_from_dict(raw, source="table_scenarios.toml", fill_defaults=False)


def cli(*argv):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "isodesign", *argv], capture_output=True,
                          text=True, env=env, timeout=300)


@pytest.mark.parametrize("make", [robust_vertical, robust_table], ids=["vertical", "table"])
def test_response_of_a_robust_study_is_refused_by_one_line_everywhere(make, tmp_path):
    st = make()
    with pytest.raises(InputError) as api:
        refuse_robust_response(st)
    line = str(api.value)
    assert line.startswith("[scenarios]: isodesign response does not answer a robust study")
    assert "isodesign yield" in line and "\n" not in line
    # the CLI: the same line, exit 2, nothing written
    f = tmp_path / "s.toml"
    f.write_text(study_toml(st))
    out = tmp_path / "bands.csv"
    p = cli("response", str(f), "-o", str(out))
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == [f"isodesign: error: {line}"]
    assert p.stdout == "" and not out.exists()
    # the sweep's response task: refused before any point runs, by the same line
    with pytest.raises(InputError) as sw:
        isodesign.sweep(st, vary={"payload.mass_kg": [600.0]}, output=tmp_path / "sw",
                        task="response", scheduler="serial", charts=False)
    assert str(sw.value) == line
    assert not (tmp_path / "sw").exists()


def test_the_response_task_of_a_point_refuses_scenarios_too(tmp_path):
    """The task's own function refuses (a point reached without the sweep's check)."""
    from isodesign.io.rundir import RunDirectory
    from isodesign.sweeps.tasks import get_task

    task = get_task("response")
    assert task.check is not None
    with pytest.raises(InputError, match=r"^\[scenarios\]: isodesign response "):
        task.run(robust_vertical(), RunDirectory.__new__(RunDirectory), {})


def test_a_nominal_study_still_has_its_response():
    refuse_robust_response(vertical_study())  # no [scenarios]: nothing refused
    refuse_robust_response(table_study())
    refuse_robust_response(None)  # a design file: no study
