"""Fixtures shared by the whole suite (tests mirror the package: tests/<discipline>/)."""

from __future__ import annotations

import copy
import importlib.util
from pathlib import Path

import pytest

from isodesign.optimization.study import study_from_dict, table_study
from isodesign.spring.design import SpringDesign


@pytest.fixture(scope="session")
def ref() -> SpringDesign:
    """The paper's Table 1 spring (SI units), the suite's common starting point."""
    return SpringDesign.reference()


@pytest.fixture(scope="session")
def study_script():
    """``load(name)``: the script ``studies/<name>.py`` imported as a module (the studies are
    scripts, not a package), so that a test runs the very code a study prints."""
    root = Path(__file__).parents[1] / "studies"

    def load(name: str):
        spec = importlib.util.spec_from_file_location(name, root / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod

    return load


@pytest.fixture(scope="session")
def small_table_study():
    """``make(**sections)``: the built-in table study, reduced (one start, one worker, 3 points
    per band, bands 4-20 Hz), with the given top-level sections of the study replaced."""

    def make(**sections):
        raw = copy.deepcopy(table_study().raw)
        raw["solver"].update(starts=1, workers=1)
        raw["models"]["points_per_band"] = 3
        raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
        raw.update(sections)
        return study_from_dict(raw, source="small_table.toml", fill_defaults=False)

    return make
