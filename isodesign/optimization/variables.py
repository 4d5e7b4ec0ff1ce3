"""Design variables of the optimizer: names, units, specs, bounds and log scaling.

The NLP works in a scaled log space: a free variable x with effective bounds
[lo, hi] is ``ln x = c + h z`` with ``c`` the log-midpoint, ``h`` the log
half-range and ``z`` in [-1, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError

__all__ = [
    "DESIGN_VARIABLES",
    "DESIGN_VARIABLE_UNITS",
    "LogScaling",
    "VariableSpec",
    "effective_bounds",
    "log_scaling",
]

#: Design variables of the optimizer, in order.
DESIGN_VARIABLES = ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m")
#: Unit of each design variable (SI).
DESIGN_VARIABLE_UNITS = {"volume_ratio": "-", "top_volume_m3": "m^3", "capillary_length_m": "m",
                         "capillary_diameter_m": "m"}


@dataclass(frozen=True)
class VariableSpec:
    """Bounds and start of one design variable (SI units)."""

    name: str
    start: float
    lower: float
    upper: float
    fixed: bool = False

    @property
    def free(self) -> bool:
        """True when the optimizer may change it."""
        return not self.fixed


@dataclass(frozen=True)
class LogScaling:
    """Log scaling of the free design variables: ``ln x = c + h z``, z in [-1, 1]."""

    names: tuple[str, ...]
    center: np.ndarray
    half: np.ndarray

    def to_values(self, z) -> dict:
        """Variable values (SI) at scaled coordinates ``z``."""
        return {n: math.exp(c + h * zi) for n, c, h, zi in
                zip(self.names, self.center, self.half, np.asarray(z, float), strict=True)}

    def to_z(self, values: dict) -> np.ndarray:
        """Scaled coordinates of variable values (SI)."""
        return np.array([(math.log(values[n]) - c) / h for n, c, h in
                         zip(self.names, self.center, self.half, strict=True)])


def effective_bounds(study) -> dict:
    """Effective (lower, upper) of each variable, with D_c >= the manufacturable minimum.

    Parameters
    ----------
    study : Study

    Returns
    -------
    dict
        Variable name -> (lower, upper), SI units.
    """
    out = {}
    dmin = study.constraints.get("min_capillary_diameter_m")
    for v in study.variables:
        lo, hi = v.lower, v.upper
        if v.name == "capillary_diameter_m" and dmin and not v.fixed:
            lo = max(lo, dmin)
            if lo >= hi:
                raise InputError(
                    f"variables.capillary_diameter_m: upper ({hi:g}) must exceed "
                    f"constraints.min_capillary_diameter_m ({dmin:g})"
                )
        if v.name == "capillary_diameter_m" and dmin and v.fixed and v.start < dmin:
            raise InputError(
                f"variables.capillary_diameter_m: fixed at {v.start:g} m, below "
                f"constraints.min_capillary_diameter_m ({dmin:g} m)"
            )
        out[v.name] = (lo, hi)
    return out


def log_scaling(study) -> LogScaling:
    """The log scaling of a study's free variables over their effective bounds.

    Parameters
    ----------
    study : Study
        Its variables (fixed ones are left out) and, through
        :func:`effective_bounds`, ``constraints.min_capillary_diameter_m``.

    Returns
    -------
    LogScaling
        ``names`` of the free variables in :data:`DESIGN_VARIABLES` order,
        ``center`` ``c = (ln lo + ln hi) / 2`` and ``half`` ``h = (ln hi - ln lo) / 2``.

    Notes
    -----
    The NLP's variable is ``z`` in [-1, 1] with ``x = exp(c + h z)``, so
    ``z = -1`` and ``z = 1`` are the bounds ``lo`` and ``hi``: variables spanning
    decades (L_c from 2 mm to 0.5 m) get the same unit range in ``z``, relative
    changes of ``x`` are uniform steps in ``z``, and ``x`` stays positive.
    """
    bnds = effective_bounds(study)
    free = [v for v in study.variables if v.free]
    return LogScaling(
        names=tuple(v.name for v in free),
        center=np.array([0.5 * (math.log(bnds[v.name][0]) + math.log(bnds[v.name][1]))
                         for v in free]),
        half=np.array([0.5 * (math.log(bnds[v.name][1]) - math.log(bnds[v.name][0]))
                       for v in free]),
    )
