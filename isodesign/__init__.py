"""isodesign: design optimizer for vibration-isolation tables on dual-chamber air springs.

The package is imported lazily: light commands (``isodesign --help``) load
neither SciPy, CasADi nor pandas. Public names are resolved on first use.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_EXPORTS = {
    "SpringDesign": "design",
    "piston_area_from_diaphragm": "design",
    "Gas": "gas",
    "AIR": "gas",
    "pressure_from_load": "gas",
    "complex_stiffness": "spring",
    "stiffness_function": "spring",
    "StiffnessResult": "spring",
    "InputError": "errors",
    "SolverError": "errors",
    "ModelValidityWarning": "errors",
    "ViscoelasticDiaphragm": "diaphragm",
    "TableDiaphragm": "diaphragm",
    "NoDiaphragm": "diaphragm",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    mod = _EXPORTS.get(name)
    if mod is None:
        raise AttributeError(f"module 'isodesign' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"isodesign.{mod}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
