"""The vertical body's constraints from the metrics, and every constraint's report.

Every constraint is ``lo <= expr <= hi`` in the NLP's units: the log of the
constrained quantity, or dB. The rows are the registry's
(:mod:`.constraint_registry`); :func:`build_constraints` works on NumPy and CasADi
metrics alike, so the re-check evaluates exactly the NLP's constraints, and
:func:`constraint_reports` reads the constraint table of either body from its rows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.optimization.constraint_registry import (
    VALIDITY_MARGIN,
    Constraint,
    natural_value,
    vertical_rows,
)

__all__ = [
    "ACTIVE_MARGIN",
    "BINDING_TOL",
    "DISPLAY_UNITS",
    "VALIDITY_MARGIN",
    "Constraint",
    "ConstraintReport",
    "build_constraints",
    "constraint_reports",
]

#: A constraint whose margin (NLP units) is below this is reported as binding: within
#: 0.5 % of its bound for the constraints on a log scale (every one but the peak
#: transmissibility), within 0.022 dB (0.005 in ln |T|^2) for the peak transmissibility.
BINDING_TOL = 5e-3
#: SI unit of a constraint -> (factor, unit) it is shown in (the command line's L and mm).
DISPLAY_UNITS = {"m^3": (1e3, "L"), "m": (1e3, "mm"), "Pa": (1e-5, "bar")}
#: Former name of :data:`BINDING_TOL`.
ACTIVE_MARGIN = BINDING_TOL


def build_constraints(study, mt: dict, n_all: int) -> list[Constraint]:
    """The vertical body's constraints on the metrics ``mt`` (NumPy or CasADi).

    One function for both paths: the NLP calls it on CasADi metrics, the re-check
    (:func:`isodesign.optimization.recheck.evaluate_design`) on NumPy ones, so both
    judge exactly the same expressions and bounds. The rows are the registry's
    (:data:`~.constraint_registry.CONSTRAINTS`, the kinds :data:`~.constraint_registry.
    VERTICAL_ROWS` requests), the table body's shared kinds the same entries.

    Parameters
    ----------
    study : Study
        Its ``constraints`` table decides which constraints exist (``None``
        switches one off) and gives their bounds; ``models["flow"]`` selects the
        flow model's validity limits.
    mt : dict
        Metrics of one design, from :func:`isodesign.optimization.metrics.metrics`
        (or :func:`~isodesign.optimization.metrics.combine`), on NumPy arrays or
        CasADi expressions; the ``ln_*`` entries are natural logs.
    n_all : int
        Number of NLP grid frequencies (floor quadrature, peak grid and any point
        of a one-frequency objective): the length of the per-frequency
        constraints (Mach number, Reynolds number).

    Returns
    -------
    list of Constraint
        In the NLP's units: ``expr`` is the natural log of the constrained quantity
        (volume, tilt margin, natural frequency, damping ratio, Mach, Reynolds and
        Womersley numbers, acoustic compactness ``w l / c``) and the bounds are the
        logs of the study's limits; the peak transmissibility is ``ln |T|^2`` at
        every peak-grid frequency against ``T_max[dB] ln(10) / 10``.

    Notes
    -----
    Working in logs makes every row well scaled whatever the quantity's size, and
    turns ratios into differences. With ``constraints.model_validity`` on, the
    validity limits (acoustically compact tube and chambers or plane waves in the
    chambers, the flow model's checks with an NLP form: ``laminar``, the Womersley
    number of ``quasi_steady``) are tightened by :data:`VALIDITY_MARGIN`.
    """
    return vertical_rows(study, mt, n_all)


@dataclass(frozen=True)
class ConstraintReport:
    """A constraint at the optimum (its worst row for vector constraints).

    ``value``, ``lower`` and ``upper`` are in natural units (``unit``);
    ``margin`` is the NLP's margin in its internal units (the log of the ratio
    to the bound, or ``ln |T|^2``), which is what ``active`` (binding: margin <
    :data:`BINDING_TOL`, i.e. within 0.5 % of the bound) is judged on;
    :attr:`margin_natural` is the distance to the nearest bound in ``unit``.
    """

    name: str
    value: float
    lower: float | None
    upper: float | None
    unit: str
    margin: float
    active: bool
    description: str

    def display(self) -> dict:
        """The constraint in the units the command line shows (L, mm; :data:`DISPLAY_UNITS`).

        Returns
        -------
        dict
            ``name``, ``value``, ``lower``, ``upper``, ``margin`` (distance to the nearest
            bound, >= 0 when met), ``unit`` (``-`` for a ratio), ``binding`` (within
            :data:`BINDING_TOL` of a bound) and ``description``.
        """
        scale, unit = DISPLAY_UNITS.get(self.unit, (1.0, self.unit))

        def sc(x):
            return None if x is None else x * scale

        m = self.margin_natural
        return {"name": self.name, "value": sc(self.value), "lower": sc(self.lower),
                "upper": sc(self.upper), "margin": None if math.isinf(m) else m * scale,
                "unit": unit, "binding": bool(self.active), "description": self.description}

    @property
    def margin_natural(self) -> float:
        """Distance to the nearest bound in the constraint's own unit (>= 0: satisfied)."""
        m = [self.value - self.lower] if self.lower is not None else []
        m += [self.upper - self.value] if self.upper is not None else []
        return min(m) if m else math.inf


def constraint_reports(con_rows, g: np.ndarray) -> list[ConstraintReport]:
    """Constraints in natural units with margins; epigraph rows are skipped.

    Parameters
    ----------
    con_rows : sequence of (Constraint, int, int)
        :attr:`isodesign.optimization.problem.Problem.con_rows`: each constraint,
        its first row in ``g`` and its number of rows. Rows of the objectives'
        epigraph constraints (``epigraph_*``) and epsilon bounds (``bound_*``) are
        not reported.
    g : ndarray
        The NLP's constraint values at a point (``Solution.g``, implicit equations
        first), in the NLP's (log or dB) units.

    Returns
    -------
    list of ConstraintReport
        One per reported constraint, at its worst row for a vector constraint
        (the largest value against an upper bound, the smallest against a lower
        one, the smallest distance to either bound when both are finite).
        ``value``, ``lower`` and ``upper`` are converted to natural units (``exp``
        of the log; ``ln |T|^2`` to dB); ``margin`` stays in NLP units and
        ``active`` (binding) is ``margin < BINDING_TOL``.
    """
    out = []
    for c, row, n in con_rows:
        if c.name.startswith(("epigraph_", "bound_")):
            continue
        gi = g[row: row + n]
        lo, hi = c.lo, c.hi
        # the worst row of a vector constraint
        if math.isfinite(hi) and not math.isfinite(lo):
            k = int(np.argmax(gi))
        elif math.isfinite(lo) and not math.isfinite(hi):
            k = int(np.argmin(gi))
        else:
            k = int(np.argmin(np.minimum(gi - lo, hi - gi)))
        v = float(gi[k])
        margin = min(v - lo if math.isfinite(lo) else math.inf,
                     hi - v if math.isfinite(hi) else math.inf)
        out.append(ConstraintReport(
            name=c.name, value=natural_value(c.name, v)[0],
            lower=natural_value(c.name, lo)[0] if math.isfinite(lo) else None,
            upper=natural_value(c.name, hi)[0] if math.isfinite(hi) else None,
            unit=natural_value(c.name, v)[1],
            margin=margin, active=margin < BINDING_TOL, description=c.describe,
        ))
    return out
