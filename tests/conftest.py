"""Fixtures shared by the whole suite (tests mirror the package: tests/<discipline>/)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

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
