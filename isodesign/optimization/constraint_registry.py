"""One registry of the NLP's constraints, for every body (docs/optimization.md, "One NLP
builder").

Each kind of constraint is written once, as a :class:`ConstraintKind`: its name in the
constraint table, the study key that switches it on and bounds it, its unit, the form of its
rows (the log of the quantity, ``ln |T|^2`` against a bound in dB, or a smooth surrogate
``>= 0`` reported from the exact quantity), the words of the binding explanation, and the
quantity its rows are written on. A body (:class:`~.problem.Problem`, the exact z reduction
of a symmetric payload; :class:`~.table_problem.TableProblem`, the six-degree-of-freedom
table) does not write constraint rows: it measures the quantities (a dict ``q``, on CasADi
symbols in the NLP, on NumPy arrays in the re-check) and requests the kinds it has, in its
order (:data:`VERTICAL_ROWS`, :data:`TABLE_ROWS`); :func:`constraint_rows_of` turns them into
:class:`~.constraints.Constraint` rows. The same call on NumPy quantities is the re-check:
the rows' values are the same expressions (:meth:`ConstraintKind.values`).

A vertical study is the symmetric special case: the rows both bodies share (total volume,
vertical natural frequency, peak |T| per point and axis, tilt margin, damping, the model's
validity: Mach, Reynolds and Womersley numbers, acoustic compactness or plane waves) are the
same entries; the table's own (stroke, rocking frequencies, layout, loads, the leveling
loop) are entries the vertical body does not request, and the vertical's constant chamber
pressure row one the table body does not (its leveling's supply rows hold p0).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from isodesign.numerics import backend as bk
from isodesign.spring.capillary import LAMINAR_REYNOLDS_LIMIT, QUASI_STEADY_WOMERSLEY_LIMIT
from isodesign.spring.diagnostics import LUMPED_LIMIT, TUBE_END_MIN_LENGTH_RADII
from isodesign.spring.flow_models import flow_model

__all__ = [
    "CONSTRAINTS",
    "REPORTED_KEYS",
    "TABLE_ROWS",
    "VALIDITY_MARGIN",
    "VERTICAL_ROWS",
    "Constraint",
    "ConstraintKind",
    "constraint_rows_of",
    "kind_of",
    "model_validity_names",
    "natural_value",
    "study_keys",
    "vertical_rows",
]

_LN10 = math.log(10.0)
_INF = math.inf
#: The NLP keeps this fraction of each model-validity limit (Reynolds number,
#: acoustic compactness, Womersley number): the constraints hold at the NLP's grid
#: points, and the margin keeps the finer analysis grid inside the limits too.
VALIDITY_MARGIN = 0.98


@dataclass(frozen=True)
class Constraint:
    """One (vector) constraint ``lo <= expr <= hi`` in the NLP's (log) units.

    ``key`` is the study key it bounds (the table body's row name), ``kind`` its
    :class:`ConstraintKind` in :data:`CONSTRAINTS` (empty for an objective's epigraph and
    epsilon rows).
    """

    name: str
    expr: Any
    lo: float
    hi: float
    size: int = 1
    describe: str = ""
    key: str = ""
    kind: str = ""


def _given(c: dict, key: str) -> bool:
    v = c.get(key)
    return v is not None and v is not False


@dataclass(frozen=True)
class ConstraintKind:
    """One kind of constraint, for every body.

    Attributes
    ----------
    name : str
        Its name in the constraint table (:class:`~.constraints.ConstraintReport`) and in
        the binding explanation (:mod:`.explain`).
    key : str
        The study key it bounds (``constraints.<key>``; ``natural_frequency_hz`` for the
        pair ``min_``/``max_natural_frequency_hz``; ``model_validity`` for the limits it
        switches on), and the table body's row key (:attr:`row_key`).
    unit : str
        SI unit of its value in the constraint table (``-`` for a ratio).
    form : {'log', 'db', 'surrogate', 'given'}
        Its rows: ``log``, the natural log of the quantity against the logs of the bounds;
        ``db``, ``ln |T|^2`` against ``T_max[dB] ln(10) / 10``; ``surrogate``, smooth rows
        ``>= 0`` (a determinant, a frozen mode's Rayleigh quotient), reported from the exact
        quantity; ``given``, rows a body's own module builds with their bounds (the
        table's layout, loads, leveling loop), ``(key, expr, lo, hi)`` each.
    quantity : str
        The key of ``q`` (the body's measured quantities) its rows are written on.
    describe : str
        The limit in words (``str.format`` fields: the study's constraints).
    bounds : callable or None
        ``constraints -> (lower, upper)`` in natural units (None: no bound), or None when
        the kind is off for the study; ``log``/``db`` forms only.
    when : callable
        ``study -> bool``: further conditions (the acoustics, the flow model's checks).
    scale : float
        The kept fraction of a model-validity limit (:data:`VALIDITY_MARGIN`), 1 otherwise.
    validity : bool
        A limit of the model's validity (not a requirement of the study; the binding
        explanation says so, :mod:`.explain`).
    exact : callable or None
        A surrogate's rows back in its exact quantity, ``(rows, constraints) -> values``
        (a frozen mode's damping ratio or frequency): with the modes frozen at the design's
        own, equal to the exact modes' (the re-check of the frozen-mode rows). The other
        forms are re-checked by :meth:`values` on the NumPy path's quantities.
    """

    name: str
    key: str
    unit: str
    form: str
    quantity: str
    describe: str
    bounds: Callable | None = None
    when: Callable = field(default=lambda study: True)
    scale: float = 1.0
    validity: bool = False
    exact: Callable | None = None

    @property
    def row_key(self) -> str:
        """The table body's row name: :attr:`key`, or :attr:`name` for the limits
        ``model_validity`` switches on together."""
        return self.name if self.key == "model_validity" else self.key

    def on(self, study) -> bool:
        """Whether the study asks for this constraint (its bound is set).

        Parameters
        ----------
        study : Study
        """
        c = study.constraints
        if self.form in ("log", "db"):
            return self.bounds(c) is not None and self.when(study)
        return self.when(study)

    def nlp_bounds(self, study) -> tuple[float, float]:
        """The rows' bounds in the NLP's units (``log``/``db``: logs of the bounds;
        ``surrogate``: ``(0, inf)``).

        Parameters
        ----------
        study : Study
        """
        if self.form == "surrogate":
            return 0.0, _INF
        lo, hi = self.bounds(study.constraints)
        if self.form == "db":
            return (-_INF if lo is None else lo * _LN10 / 10.0,
                    _INF if hi is None else hi * _LN10 / 10.0)
        return (-_INF if lo is None else math.log(lo * self.scale),
                _INF if hi is None else math.log(hi * self.scale))

    def values(self, q: dict):
        """The rows' values from a body's quantities (NumPy or CasADi: the NLP and its
        NumPy re-check evaluate this same expression).

        Parameters
        ----------
        q : dict
            The body's measured quantities.
        """
        return q[self.quantity]

    def natural(self, v: float) -> float:
        """A row's value in :attr:`unit` (``exp`` of a log, dB of ``ln |T|^2``).

        Parameters
        ----------
        v : float
        """
        return 10.0 * v / _LN10 if self.form == "db" else math.exp(v)

    def words(self, study) -> str:
        """:attr:`describe` with the study's values.

        Parameters
        ----------
        study : Study
        """
        return self.describe.format(**study.constraints)


def _upper(key):
    return lambda c: (None, c[key]) if c.get(key) else None


def _lower(key):
    return lambda c: (c[key], None) if c.get(key) else None


def _pair(lo_key, hi_key):
    def bounds(c):
        lo, hi = c.get(lo_key) or None, c.get(hi_key) or None
        return None if lo is None and hi is None else (lo, hi)
    return bounds


def _validity(study) -> bool:
    return bool(study.constraints["model_validity"])


def _lumped(study) -> bool:
    return _validity(study) and study.start_design().acoustics == "lumped"


def _end_corrected(study) -> bool:
    """True when the study's springs carry the tube's end correction (the models whose
    ``tube_end_correction`` check applies, :func:`isodesign.spring.diagnostics`)."""
    return bool(study.start_design().tube_end_correction) and \
        study.models["flow"] in ("quasi_steady", "womersley")


def _box_admits_bore_per_length(study, limit: float) -> bool:
    """True when the variables' box admits a spring with ``D_c / L_c`` above ``limit``
    (the shared spring's or a leveling group's, ``_group2``/``_group3``), with at least one
    of the two free: a box that keeps the tube long needs no row, and two fixed values are
    the user's design (the analysis flags it)."""
    specs = {v.name: v for v in (*study.variables, *study.levers)}
    for suffix in ("", "_group2", "_group3"):
        length = specs.get("capillary_length_m" + suffix)
        bore = specs.get("capillary_diameter_m" + suffix)
        if length is None or bore is None or (length.fixed and bore.fixed):
            continue
        lo_l = length.start if length.fixed else length.lower
        hi_d = bore.start if bore.fixed else bore.upper
        if hi_d > limit * VALIDITY_MARGIN * lo_l:
            return True
    return False


#: ``D_c / L_c`` at most this with the tube's end correction: the tube at least
#: :data:`~isodesign.spring.diagnostics.TUBE_END_MIN_LENGTH_RADII` bore radii long.
END_CORRECTED_BORE_PER_LENGTH = 2.0 / TUBE_END_MIN_LENGTH_RADII


def _tube_length_check(end_corrected: bool):
    limit = END_CORRECTED_BORE_PER_LENGTH if end_corrected else 1.0
    return lambda study: (_validity(study) and _end_corrected(study) == end_corrected
                          and _box_admits_bore_per_length(study, limit))


def _flow_check(*names):
    return lambda study: _validity(study) and any(
        c.name in names for c in flow_model(study.models["flow"]).checks)


#: Every constraint kind, by name. A new constraint: an entry here, its quantity measured by
#: each body that can hold it (``q``), its name in that body's rows (:data:`VERTICAL_ROWS`,
#: :data:`TABLE_ROWS`).
CONSTRAINTS: dict[str, ConstraintKind] = {k.name: k for k in (
    # the rows every body shares
    ConstraintKind("total_volume", "max_total_volume_m3", "m^3", "log", "ln_total_volume",
                   "V_t0 (1 + N) of one isolator <= V_max", _upper("max_total_volume_m3")),
    ConstraintKind("natural_frequency", "natural_frequency_hz", "Hz", "log", "ln_fn",
                   "f_min <= vertical mode sqrt(sum K0_i / m) <= f_max",
                   _pair("min_natural_frequency_hz", "max_natural_frequency_hz")),
    ConstraintKind("peak_transmissibility", "max_peak_transmissibility_db", "dB", "db",
                   "ln_T2_peak", "|T_p,aa| <= T_max (dB) at every point, axis and peak-grid "
                   "frequency",
                   lambda c: (None, c["max_peak_transmissibility_db"])
                   if _given(c, "max_peak_transmissibility_db") else None),
    ConstraintKind("tilt_margin", "min_tilt_margin", "-", "log", "ln_tilt",
                   "tilt margin n k (s/2)^2 / (m g h) >= min", _lower("min_tilt_margin")),
    ConstraintKind("damping_ratio", "min_damping_ratio", "-", "log", "ln_zeta",
                   "Zener damping ratio >= min", _lower("min_damping_ratio")),
    ConstraintKind("stroke", "max_stroke_m", "m", "log", "ln_stroke",
                   "{stroke_peak_factor:g} x RMS vertical stroke, worst isolator, against "
                   "its travel", _upper("max_stroke_m")),
    # the table's smooth forms of shared kinds (reported from the exact quantity,
    # isodesign.optimization.table_constraints)
    ConstraintKind("tilt_margin_rows", "min_tilt_margin", "-", "surrogate", "tilt_rows",
                   "A / (W h) - mu I positive semidefinite (its diagonal and determinant)",
                   when=lambda st: bool(st.constraints.get("min_tilt_margin"))),
    ConstraintKind("damping_rows", "min_damping_ratio", "-", "surrogate", "damping_rows",
                   "frozen modes below 5 Hz: phi^H K'' phi >= 2 zeta_min phi^H K' phi",
                   when=lambda st: bool(st.constraints.get("min_damping_ratio")),
                   # row = eta - 2 zeta_min, the loss factor eta = 2 zeta of the mode
                   exact=lambda r, c: 0.5 * r + c["min_damping_ratio"]),
    # the table's own
    ConstraintKind("min_rocking_frequency", "min_rocking_frequency_hz", "Hz", "surrogate",
                   "rocking_lo_rows", "frozen rocking modes: phi^H K' phi >= (2 pi f_min)^2",
                   when=lambda st: bool(st.constraints.get("min_rocking_frequency_hz")),
                   # row = w^2 / w_min^2 - 1
                   exact=lambda r, c: c["min_rocking_frequency_hz"] * (1.0 + r) ** 0.5),
    ConstraintKind("max_rocking_frequency", "max_rocking_frequency_hz", "Hz", "surrogate",
                   "rocking_hi_rows", "frozen rocking modes: phi^H K' phi <= (2 pi f_max)^2",
                   when=lambda st: bool(st.constraints.get("max_rocking_frequency_hz")),
                   # row = 1 - w^2 / w_max^2
                   exact=lambda r, c: c["max_rocking_frequency_hz"] * (1.0 - r) ** 0.5),
    ConstraintKind("layout", "footprint_m", "m", "given", "layout_rows",
                   "isolators inside the footprint and apart by the minimum distance"),
    ConstraintKind("loads", "isolator_load", "N", "given", "load_rows",
                   "static loads and p0 of the leveled table with a free slab"),
    ConstraintKind("leveling_loop", "min_leveling_gain_margin_db", "-", "given", "loop_rows",
                   "the leveling loop's frozen poles at the raised gain stay stable"),
    # the vertical body's model validity
    ConstraintKind("mach", "max_mach", "-", "log", "ln_mach",
                   "capillary Mach number <= max at every grid frequency", _upper("max_mach"),
                   validity=True),
    ConstraintKind("chamber_pressure", "max_pressure_pa", "Pa", "log", "ln_chamber_pressure",
                   "static chamber pressure p0 <= max (set by the payload)",
                   _upper("max_pressure_pa")),
    *(ConstraintKind(f"plane_wave_{ch}", "model_validity", "w D/(1.84 c)", "log",
                     f"ln_plane_wave_{ch}", f"{ch.replace('_', ' ')} below its first "
                     "transverse mode: w D / (1.8412 c) <= 1", lambda c: (None, 1.0),
                     lambda st: _validity(st) and st.start_design().acoustics != "lumped",
                     VALIDITY_MARGIN, True)
      for ch in ("top_chamber", "bottom_chamber")),
    *(ConstraintKind(f"lumped_{part}", "model_validity", "w l/c", "log", f"ln_lumped_{part}",
                     f"acoustically compact {part.replace('_', ' ')}: w l / c <= "
                     f"{LUMPED_LIMIT}", lambda c: (None, LUMPED_LIMIT),
                     _lumped, VALIDITY_MARGIN, True)
      for part in ("tube", "top_chamber", "bottom_chamber")),
    # the tube a tube (the models' D_c < L_c), long enough for its ends' correction where
    # the springs carry it: rows only where the variables' box admits a shorter tube
    ConstraintKind("tube_end_length", "model_validity", "D_c/L_c", "log",
                   "ln_bore_per_length", "tube at least "
                   f"{TUBE_END_MIN_LENGTH_RADII:g} bore radii long (D_c / L_c <= "
                   f"{END_CORRECTED_BORE_PER_LENGTH:g}): the two ends' correction independent "
                   "of each other", lambda c: (None, END_CORRECTED_BORE_PER_LENGTH),
                   _tube_length_check(True), VALIDITY_MARGIN, True),
    ConstraintKind("tube_length", "model_validity", "D_c/L_c", "log", "ln_bore_per_length",
                   "a tube, not an orifice: D_c / L_c < 1", lambda c: (None, 1.0),
                   _tube_length_check(False), VALIDITY_MARGIN, True),
    ConstraintKind("laminar", "model_validity", "Re", "log", "ln_re",
                   "peak Reynolds number <= 2300 (laminar model)",
                   lambda c: (None, LAMINAR_REYNOLDS_LIMIT), _flow_check("laminar"),
                   VALIDITY_MARGIN, True),
    # the per-point check of quasi_steady bounds the error in k (evaluated both ways, NumPy);
    # its design-space guard in the NLP is the Womersley bound, under its former name
    ConstraintKind("quasi_steady_alpha", "model_validity", "alpha", "log", "ln_alpha_max",
                   "Womersley number <= 3.4 at the highest grid frequency",
                   lambda c: (None, QUASI_STEADY_WOMERSLEY_LIMIT),
                   _flow_check("quasi_steady_alpha", "quasi_steady_k"), VALIDITY_MARGIN, True),
)}

#: The rows the vertical body (the exact z reduction) requests, in the order of its ``g``.
VERTICAL_ROWS = ("total_volume", "tilt_margin", "natural_frequency", "peak_transmissibility",
                 "damping_ratio", "mach", "chamber_pressure", "plane_wave_top_chamber",
                 "plane_wave_bottom_chamber", "lumped_tube", "lumped_top_chamber",
                 "lumped_bottom_chamber", "laminar", "quasi_steady_alpha", "tube_end_length",
                 "tube_length")
#: The rows the table body requests, in the order of its ``g`` (after the objectives'
#: epigraph rows): the shared kinds, its smooth forms of tilt and damping, its own.
TABLE_ROWS = ("total_volume", "natural_frequency", "stroke", "tilt_margin_rows", "layout",
              "loads", "peak_transmissibility", "mach", "plane_wave_top_chamber",
              "plane_wave_bottom_chamber", "lumped_tube", "lumped_top_chamber",
              "lumped_bottom_chamber", "laminar", "quasi_steady_alpha", "damping_rows",
              "min_rocking_frequency", "max_rocking_frequency", "leveling_loop",
              "tube_end_length", "tube_length")


#: The table's constraints reported from exact quantities rather than from a kind's rows
#: (:func:`~.table_constraints.table_constraint_reports`), by report name: the study key
#: that bounds each.
REPORTED_KEYS = {
    "continuous_peak_transmissibility": "max_peak_transmissibility_db",
    "rocking_frequency": "min/max_rocking_frequency_hz",
    "leveling_gain_margin": "min_leveling_gain_margin_db",
    "leveling_phase_margin": "min_leveling_phase_margin_deg",
    "footprint": "footprint_m",
    "isolator_distance": "min_isolator_distance_m",
    "isolator_load": "min/max_isolator_load_n",
    "supply_pressure": "supply_margin_pa",
}


def study_keys() -> dict[str, str]:
    """The study key (``constraints.<key>``) that sets the bound of each reported
    constraint, by name: the registry's kinds with a key of their own (not the limits
    ``model_validity`` switches on) and the table's exactly reported constraints
    (:data:`REPORTED_KEYS`).

    Returns
    -------
    dict
    """
    out = {}
    for k in CONSTRAINTS.values():
        if k.form in ("log", "db") and k.key != "model_validity":
            key = "min/max_natural_frequency_hz" if k.key == "natural_frequency_hz" else k.key
            out[k.name] = f"constraints.{key}"
    out.update({n: f"constraints.{key}" for n, key in REPORTED_KEYS.items()})
    return out


def model_validity_names() -> frozenset:
    """The names of the registry's model-validity limits (:attr:`ConstraintKind.validity`).

    Returns
    -------
    frozenset of str
    """
    return frozenset(k.name for k in CONSTRAINTS.values() if k.validity)


def kind_of(name: str) -> ConstraintKind | None:
    """The registry's entry of a constraint name (a row's or a report's), or None.

    Parameters
    ----------
    name : str
    """
    return CONSTRAINTS.get(name)


def natural_value(name: str, v: float) -> tuple[float, str]:
    """A row's value in natural units and the unit, from its kind (``exp`` when unknown).

    Parameters
    ----------
    name : str
        The constraint's name.
    v : float
        The row's value in the NLP's units.
    """
    k = CONSTRAINTS.get(name)
    if k is None or k.form in ("surrogate", "given"):
        return math.exp(v), ""
    return k.natural(v), k.unit


def _size(x) -> int:
    return int(x.numel()) if bk.is_casadi(x) else int(getattr(x, "size", 1))


def constraint_rows_of(study, q: dict, kinds) -> list:
    """The constraint rows a body requests, from its measured quantities.

    Parameters
    ----------
    study : Study
        Which constraints are on and their bounds.
    q : dict
        The body's quantities (CasADi in the NLP, NumPy in the re-check), keyed by each
        kind's :attr:`~ConstraintKind.quantity`; a kind whose quantity the body does not
        measure for this study (a table without overturning has no tilt rows) has no rows.
    kinds : sequence of str
        The kinds the body requests, in the order of its rows.

    Returns
    -------
    list of Constraint
        ``key`` the study key (the table body's row name), ``name`` the kind's.
    """
    out = []
    for name in kinds:
        k = CONSTRAINTS[name]
        if k.quantity not in q or q[k.quantity] is None or not k.on(study):
            continue
        if k.form == "given":  # rows with their own keys and bounds
            for key, expr, lo, hi in q[k.quantity]:
                out.append(Constraint(key, expr, lo, hi, _size(expr), k.describe, key=key,
                                      kind=name))
            continue
        v = k.values(q)
        lo, hi = k.nlp_bounds(study)
        out.append(Constraint(k.name, v, lo, hi, _size(v), k.words(study), key=k.row_key,
                              kind=name))
    return out


def vertical_rows(study, mt: dict, n_all: int) -> list:
    """The vertical body's rows on its metrics (:func:`.metrics.metrics`, NumPy or CasADi).

    Parameters
    ----------
    study : Study
    mt : dict
        The metrics of one design.
    n_all : int
        The NLP's grid frequencies (unused: the per-frequency rows have the metrics' size).

    Returns
    -------
    list of Constraint
    """
    q = dict(mt)
    for i, ch in enumerate(("top_chamber", "bottom_chamber")):
        q[f"ln_plane_wave_{ch}"] = mt["ln_plane_wave"][i]
    for i, part in enumerate(("tube", "top_chamber", "bottom_chamber")):
        q[f"ln_lumped_{part}"] = mt["ln_lumped"][i]
    if study.constraints.get("max_pressure_pa"):
        # p0 = p_atm + m g/(n A_p) is set by the payload and the piston area, not by the
        # design variables: a constant row (the study refuses a payload beyond the bound),
        # hung on any symbolic scalar of the model (the total volume is a number when V_t0
        # and N are fixed)
        ln_p0 = bk.log(study.start_design().pressure_pa)  # symbolic in a sweep's NLP
        sym = next((v for v in (mt["ln_total_volume"], mt["ln_fn"], mt["ln_zeta"])
                    if bk.is_casadi(v)), mt["ln_fn"])
        q["ln_chamber_pressure"] = ln_p0 + 0.0 * sym
    return constraint_rows_of(study, q, VERTICAL_ROWS)
