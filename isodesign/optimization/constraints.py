"""The NLP's constraints from the metrics, and their report at the optimum.

Every constraint is ``lo <= expr <= hi`` in the NLP's units: the log of the
constrained quantity, or dB. :func:`build_constraints` works on NumPy and CasADi
metrics alike, so the re-check evaluates exactly the NLP's constraints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.numerics import backend as bk
from isodesign.spring.capillary import LAMINAR_REYNOLDS_LIMIT, QUASI_STEADY_WOMERSLEY_LIMIT
from isodesign.spring.diagnostics import LUMPED_LIMIT
from isodesign.spring.flow_models import flow_model

__all__ = [
    "ACTIVE_MARGIN",
    "BINDING_TOL",
    "DISPLAY_UNITS",
    "VALIDITY_MARGIN",
    "Constraint",
    "ConstraintReport",
    "build_constraints",
    "constraint_reports",
    "flow_validity_constraints",
]

_LN10 = math.log(10.0)
#: The NLP keeps this fraction of each model-validity limit (Reynolds number,
#: acoustic compactness, Womersley number): the constraints hold at the NLP's grid
#: points, and the margin keeps the finer analysis grid inside the limits too.
VALIDITY_MARGIN = 0.98
#: A constraint whose margin (NLP units) is below this is reported as binding: within
#: 0.5 % of its bound for the constraints on a log scale (every one but the peak
#: transmissibility), within 0.022 dB (0.005 in ln |T|^2) for the peak transmissibility.
BINDING_TOL = 5e-3
#: SI unit of a constraint -> (factor, unit) it is shown in (the command line's L and mm).
DISPLAY_UNITS = {"m^3": (1e3, "L"), "m": (1e3, "mm"), "Pa": (1e-5, "bar")}
#: Former name of :data:`BINDING_TOL`.
ACTIVE_MARGIN = BINDING_TOL


@dataclass(frozen=True)
class Constraint:
    """One (vector) constraint ``lo <= expr <= hi`` in the NLP's (log) units."""

    name: str
    expr: Any
    lo: float
    hi: float
    size: int = 1
    describe: str = ""


def build_constraints(study, mt: dict, n_all: int) -> list[Constraint]:
    """The study's constraints on the metrics ``mt`` (NumPy or CasADi).

    One function for both paths: the NLP calls it on CasADi metrics, the re-check
    (:func:`isodesign.optimization.recheck.evaluate_design`) on NumPy ones, so both
    judge exactly the same expressions and bounds.

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
    validity limits (acoustically compact tube and chambers, the flow model's
    checks) are tightened by :data:`VALIDITY_MARGIN`.
    """
    c = study.constraints
    out: list[Constraint] = []
    inf = math.inf
    if c["max_total_volume_m3"]:
        out.append(Constraint("total_volume", mt["ln_total_volume"], -inf,
                              math.log(c["max_total_volume_m3"]), 1, "V_t0 (1 + N) <= V_max"))
    if c["min_tilt_margin"]:
        out.append(Constraint("tilt_margin", mt["ln_tilt"], math.log(c["min_tilt_margin"]), inf,
                              1, "tilt margin n k (s/2)^2 / (m g h) >= min"))
    if c["min_natural_frequency_hz"] or c["max_natural_frequency_hz"]:
        lo = math.log(c["min_natural_frequency_hz"]) if c["min_natural_frequency_hz"] else -inf
        hi = math.log(c["max_natural_frequency_hz"]) if c["max_natural_frequency_hz"] else inf
        out.append(Constraint("natural_frequency", mt["ln_fn"], lo, hi, 1,
                              "f_min <= natural frequency <= f_max"))
    if c["max_peak_transmissibility_db"] is not None:
        n = _size(mt["ln_T2_peak"])
        out.append(Constraint("peak_transmissibility", mt["ln_T2_peak"], -inf,
                              c["max_peak_transmissibility_db"] * _LN10 / 10.0, n,
                              "|T| <= T_max (dB) at every peak-grid frequency"))
    if c["min_damping_ratio"]:
        out.append(Constraint("damping_ratio", mt["ln_zeta"], math.log(c["min_damping_ratio"]),
                              inf, 1, "Zener damping ratio >= min"))
    if c["max_mach"]:
        out.append(Constraint("mach", mt["ln_mach"], -inf, math.log(c["max_mach"]), n_all,
                              "capillary Mach number <= max at every grid frequency"))
    if c.get("max_pressure_pa"):
        # p0 = p_atm + m g/(n A_p) is set by the payload and the piston area, not by the
        # design variables: a constant row (the study refuses a payload beyond the bound),
        # reported with its margin like every constraint
        ln_p0 = bk.log(study.start_design().pressure_pa)  # symbolic in a sweep's NLP
        # a symbol the row can hang on (the total volume is a number when V_t0 and N are
        # fixed): any symbolic scalar of the model
        sym = next((v for v in (mt["ln_total_volume"], mt["ln_fn"], mt["ln_zeta"])
                    if bk.is_casadi(v)), mt["ln_fn"])
        out.append(Constraint("chamber_pressure", ln_p0 + 0.0 * sym, -inf,
                              math.log(c["max_pressure_pa"]), 1,
                              "static chamber pressure p0 <= max (set by the payload)"))
    if c["model_validity"]:
        if study.start_design().acoustics == "lumped":
            out += _lumped_constraints(mt)
        else:
            out += _plane_wave_constraints(mt)
        out += flow_validity_constraints(study.models["flow"], mt, n_all)
    return out


def _plane_wave_constraints(mt: dict) -> list[Constraint]:
    """The distributed model's validity: plane waves in both chambers (first transverse mode
    above the grid's highest frequency)."""
    out = []
    for name, e in zip(("top_chamber", "bottom_chamber"), mt["ln_plane_wave"], strict=True):
        out.append(Constraint(f"plane_wave_{name}", e, -math.inf, math.log(VALIDITY_MARGIN), 1,
                              f"{name.replace('_', ' ')} below its first transverse mode: "
                              f"w D / (1.8412 c) <= 1"))
    return out


def _lumped_constraints(mt: dict) -> list[Constraint]:
    """Acoustic compactness of the tube and of both chambers."""
    out = []
    for name, e in zip(("tube", "top_chamber", "bottom_chamber"), mt["ln_lumped"], strict=True):
        out.append(Constraint(f"lumped_{name}", e, -math.inf,
                              math.log(VALIDITY_MARGIN * LUMPED_LIMIT), 1,
                              f"acoustically compact {name.replace('_', ' ')}: w l / c <= "
                              f"{LUMPED_LIMIT}"))
    return out


#: NLP form of the flow models' validity checks, by check name (the checks themselves are
#: registered with each model in :mod:`isodesign.spring.flow_models`).
_FLOW_CHECK_CONSTRAINTS = {
    "laminar": lambda mt, n_all: Constraint(
        "laminar", mt["ln_re"], -math.inf, math.log(VALIDITY_MARGIN * LAMINAR_REYNOLDS_LIMIT),
        n_all, "peak Reynolds number <= 2300 (laminar model)"),
    "quasi_steady_alpha": lambda mt, n_all: Constraint(
        "quasi_steady_alpha", mt["ln_alpha_max"], -math.inf,
        math.log(VALIDITY_MARGIN * QUASI_STEADY_WOMERSLEY_LIMIT), 1,
        "Womersley number <= 3.4 at the highest grid frequency"),
}
# the per-point check of quasi_steady bounds the error in k (evaluated both ways, NumPy);
# its design-space guard in the NLP stays the Womersley bound, under its former name
_FLOW_CHECK_CONSTRAINTS["quasi_steady_k"] = _FLOW_CHECK_CONSTRAINTS["quasi_steady_alpha"]


def flow_validity_constraints(flow: str, mt: dict, n_all: int) -> list[Constraint]:
    """The validity limits of a capillary flow model, from its registered checks.

    Each check a flow model registers in :mod:`isodesign.spring.flow_models` that has
    an NLP form here becomes a constraint: ``laminar`` bounds the tube's peak Reynolds
    number ``rho U D_c / mu`` at every grid frequency by ``VALIDITY_MARGIN * 2300``;
    ``quasi_steady_alpha`` bounds the Womersley number ``(D_c / 2) sqrt(w rho / mu)``
    at the highest grid frequency by ``VALIDITY_MARGIN * 3.4``. Checks without an NLP
    form are skipped.

    Parameters
    ----------
    flow : str
        Name of a registered flow model (``study.models["flow"]``).
    mt : dict
        Metrics with ``ln_re`` (per frequency) and ``ln_alpha_max`` (natural logs),
        NumPy or CasADi.
    n_all : int
        Number of NLP grid frequencies (the length of ``ln_re``).

    Returns
    -------
    list of Constraint
        Upper bounds on the logs of the numbers (no lower bounds).
    """
    return [_FLOW_CHECK_CONSTRAINTS[c.name](mt, n_all) for c in flow_model(flow).checks
            if c.name in _FLOW_CHECK_CONSTRAINTS]


def _size(x) -> int:
    return int(np.size(x)) if not bk.is_casadi(x) else int(x.numel())


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
        conv, unit = _NATURAL.get(c.name, (math.exp, ""))
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
            name=c.name, value=conv(v), lower=conv(lo) if math.isfinite(lo) else None,
            upper=conv(hi) if math.isfinite(hi) else None, unit=unit,
            margin=margin, active=margin < BINDING_TOL, description=c.describe,
        ))
    return out


def _exp(v):
    return math.exp(v)


def _db_of_ln2(v):
    return 10.0 * v / _LN10


_NATURAL = {
    "total_volume": (_exp, "m^3"),
    "tilt_margin": (_exp, "-"),
    "natural_frequency": (_exp, "Hz"),
    "peak_transmissibility": (_db_of_ln2, "dB"),
    "damping_ratio": (_exp, "-"),
    "mach": (_exp, "-"),
    "chamber_pressure": (_exp, "Pa"),
    "laminar": (_exp, "Re"),
    "quasi_steady_alpha": (_exp, "alpha"),
    "plane_wave_top_chamber": (_exp, "w D/(1.84 c)"),
    "plane_wave_bottom_chamber": (_exp, "w D/(1.84 c)"),
    "lumped_tube": (_exp, "w l/c"),
    "lumped_top_chamber": (_exp, "w l/c"),
    "lumped_bottom_chamber": (_exp, "w l/c"),
}
