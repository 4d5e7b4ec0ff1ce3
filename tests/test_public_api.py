"""The top-level public API: every name resolves, lazily, from the module that defines it."""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

import isodesign


@pytest.mark.parametrize("name", isodesign.__all__)
def test_every_public_name_resolves_from_its_defining_module(name):
    value = getattr(isodesign, name)
    module = importlib.import_module(f"isodesign.{isodesign._EXPORTS[name]}")
    assert value is getattr(module, name)
    assert name in module.__all__, f"{name} is not in {module.__name__}.__all__"
    if inspect.isfunction(value) or inspect.isclass(value):
        assert value.__module__ == module.__name__  # defined there, not re-exported


def test_all_is_sorted_and_listed_by_dir():
    assert isodesign.__all__ == sorted(set(isodesign.__all__))
    assert set(isodesign.__all__) <= set(dir(isodesign))


def test_the_issue_named_api_is_there():
    names = {
        "SpringDesign", "complex_stiffness", "StiffnessResult", "Gas", "Payload",
        "band_response", "harmonic_response", "BandResponse", "HarmonicResponse", "criterion",
        "criterion_names", "FloorSpectrum", "third_octave_bands", "load_study",
        "default_study", "Study", "optimize", "pareto_front", "simulate_stiffness",
        "InputError", "SolverError", "ModelValidityWarning", "ViscoelasticDiaphragm",
        "TableDiaphragm", "NoDiaphragm",
    }  # fmt: skip
    assert names <= set(isodesign.__all__)


def test_optimize_is_the_function_and_optimization_the_subpackage():
    assert inspect.isfunction(isodesign.optimize)
    sub = importlib.import_module("isodesign.optimization")
    assert inspect.ismodule(sub) and isodesign.optimization is sub
    assert inspect.isfunction(isodesign.optimize)  # importing the subpackage changes nothing


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'no_such_thing'"):
        isodesign.no_such_thing  # noqa: B018


def test_import_isodesign_loads_nothing_heavy():
    code = (
        "import sys, isodesign\n"
        "heavy = ('numpy', 'scipy', 'pandas', 'casadi', 'matplotlib', 'control')\n"
        "print([m for m in heavy if m in sys.modules])\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"


def test_a_spring_name_does_not_load_casadi():
    code = (
        "import sys, isodesign\n"
        "isodesign.complex_stiffness(isodesign.SpringDesign.reference(), 1.0, 1e-4, warn=False)\n"
        "print('casadi' in sys.modules)\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "False"
