"""isodesign: design optimizer for vibration-isolation tables on dual-chamber air springs.

The package is imported lazily: light commands (``isodesign --help``) load
neither SciPy, CasADi nor pandas. Public names are resolved on first use.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_EXPORTS = {
    "SpringDesign": "spring.design",
    "piston_area_from_diaphragm": "spring.design",
    "Gas": "spring.gas",
    "AIR": "spring.gas",
    "pressure_from_load": "spring.gas",
    "complex_stiffness": "spring.stiffness",
    "stiffness_function": "spring.stiffness",
    "StiffnessResult": "spring.stiffness",
    "InputError": "errors",
    "SolverError": "errors",
    "ModelValidityWarning": "errors",
    "ViscoelasticDiaphragm": "spring.diaphragm",
    "TableDiaphragm": "spring.diaphragm",
    "NoDiaphragm": "spring.diaphragm",
    "simulate_random_response": "simulation.monte_carlo",
    "MonteCarloResult": "simulation.monte_carlo",
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
