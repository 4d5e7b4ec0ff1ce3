"""Uncertain parameters of a study: the ``[scenarios]`` table, scenario studies, sampling.

A *scenario* is one value of every uncertain parameter: the payload mass, the ambient
pressure and the gas temperature the table will meet, and the manufacturing deviations
of the built spring (capillary bore and length, chamber volumes, diaphragm stiffness)
from the drawn design. :class:`UncertaintySpace` is the validated ``[scenarios]`` table;
:class:`ScenarioStudy` is a study seen under one scenario: ``design_at`` returns the
*built* spring (tolerances applied) with its static pressure from the scenario's payload
and ambient pressure, so the NumPy analysis (:func:`.recheck.evaluate_design`) and the
NLP (:mod:`.robust`, where the parameters are CasADi symbols) evaluate the same physics.

Parameter coordinates (``theta``): operating parameters in their SI unit
(``payload_mass_kg`` kg, ``ambient_pressure_pa`` Pa, ``temperature_k`` K); a tolerance
as its deviation: relative (the built value is ``x (1 + delta)``) or absolute (``x +
delta``, SI); ``diaphragm_stiffness`` a relative deviation of the diaphragm's complex
stiffness ``k_D* (1 + delta)``. See ``docs/robust.md``.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.optimization.variables import DESIGN_VARIABLES
from isodesign.spring.design import ACOUSTIC_MODELS, SpringDesign
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import model_design
from isodesign.spring.gas import P_ATM

__all__ = [
    "DISTRIBUTIONS",
    "OPERATING_PARAMETERS",
    "PARAMETER_UNITS",
    "SCENARIO_SETTINGS",
    "TABLE_PARAMETERS",
    "TOLERANCE_PARAMETERS",
    "ScaledDiaphragm",
    "ScenarioStudy",
    "UncertainParameter",
    "UncertaintySpace",
    "parse_scenarios",
]

#: Operating parameters (physical values) and their units.
OPERATING_PARAMETERS = {"payload_mass_kg": "kg", "ambient_pressure_pa": "Pa",
                        "temperature_k": "K", "cg_offset_x_m": "m", "cg_offset_y_m": "m"}
#: Operating parameters of a table study only (offsets of the CG from the study's, m).
TABLE_PARAMETERS = ("cg_offset_x_m", "cg_offset_y_m")
#: Manufacturing tolerances: the four design variables and the diaphragm's stiffness.
TOLERANCE_PARAMETERS = (*DESIGN_VARIABLES, "diaphragm_stiffness")
#: Unit of each parameter's coordinate (a relative deviation is "-").
PARAMETER_UNITS = {**OPERATING_PARAMETERS, "volume_ratio": "-", "top_volume_m3": "m^3",
                   "capillary_length_m": "m", "capillary_diameter_m": "m",
                   "diaphragm_stiffness": "-"}
DISTRIBUTIONS = ("uniform", "normal")
#: Settings of the exchange method in ``[scenarios]`` (key -> default).
SCENARIO_SETTINGS = {"tolerance_db": 0.01, "max_rounds": 8, "search_samples": 16, "seed": 0}
#: A normal tolerance's half-width is this many standard deviations.
NORMAL_SIGMAS = 3.0


@dataclass(frozen=True)
class UncertainParameter:
    """One uncertain parameter: its box ``[lo, hi]`` (or discrete ``values``) and law.

    ``mode`` is ``"value"`` (an operating parameter in its SI unit), ``"relative"`` or
    ``"absolute"`` (a tolerance: the deviation ``delta``). ``nominal`` is the coordinate
    of the study's own value (0 for a tolerance).
    """

    name: str
    mode: str
    lo: float
    hi: float
    nominal: float
    distribution: str = "uniform"
    values: tuple[float, ...] | None = None

    @property
    def discrete(self) -> bool:
        """True for a list of values."""
        return self.values is not None

    @property
    def unit(self) -> str:
        """Unit of the coordinate (``"-"`` for a relative deviation)."""
        return "-" if self.mode == "relative" else PARAMETER_UNITS[self.name]

    @property
    def half_width(self) -> float:
        """Half the box's width."""
        return 0.5 * (self.hi - self.lo)

    def label(self) -> str:
        """``'capillary_diameter_m +-5 %'``-style description."""
        if self.discrete:
            return f"{self.name} in {{{', '.join(f'{v:g}' for v in self.values)}}}"
        if self.mode == "relative":
            return f"{self.name} {100 * self.lo:+g} .. {100 * self.hi:+g} %"
        return f"{self.name} {self.lo:g} .. {self.hi:g} {self.unit}"

    def sample(self, rng, n: int) -> np.ndarray:
        """``n`` draws from the parameter's distribution."""
        if self.discrete:
            return rng.choice(np.asarray(self.values, float), size=n)
        if self.distribution == "normal":
            mid = 0.5 * (self.lo + self.hi)
            return rng.normal(mid, self.half_width / NORMAL_SIGMAS, size=n)
        return rng.uniform(self.lo, self.hi, size=n)


@dataclass(frozen=True)
class UncertaintySpace:
    """The validated ``[scenarios]`` table: parameters (in order) and exchange settings."""

    parameters: tuple[UncertainParameter, ...]
    settings: dict

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in the order of a ``theta`` vector."""
        return tuple(p.name for p in self.parameters)

    @property
    def size(self) -> int:
        """Number of uncertain parameters."""
        return len(self.parameters)

    def parameter(self, name: str) -> UncertainParameter:
        """The parameter ``name``."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def nominal(self) -> np.ndarray:
        """The study's own values (tolerances 0)."""
        return np.array([p.nominal for p in self.parameters])

    def center(self) -> np.ndarray:
        """The box's centre (a discrete parameter: its value nearest the centre)."""
        out = []
        for p in self.parameters:
            c = 0.5 * (p.lo + p.hi)
            out.append(min(p.values, key=lambda v, c=c: abs(v - c)) if p.discrete else c)
        return np.array(out)

    def lower(self) -> np.ndarray:
        """Lower ends of the box."""
        return np.array([p.lo for p in self.parameters])

    def upper(self) -> np.ndarray:
        """Upper ends of the box."""
        return np.array([p.hi for p in self.parameters])

    def corners(self, limit: int = 256, rng=None) -> np.ndarray:
        """The box's corners (every value of a discrete parameter), at most ``limit``
        (a random subset beyond it)."""
        axes = [p.values if p.discrete else (p.lo, p.hi) for p in self.parameters]
        n = math.prod(len(a) for a in axes)
        if n <= limit:
            return np.array(list(itertools.product(*axes)), float)
        rng = rng or np.random.default_rng(0)
        return np.array([[rng.choice(a) for a in axes] for _ in range(limit)], float)

    def box_samples(self, n: int, rng) -> np.ndarray:
        """``n`` points uniform in the box (discrete parameters: uniform over the list)."""
        cols = []
        for p in self.parameters:
            if p.discrete:
                cols.append(rng.choice(np.asarray(p.values, float), size=n))
            else:
                cols.append(rng.uniform(p.lo, p.hi, size=n))
        return np.column_stack(cols) if cols else np.zeros((n, 0))

    def draws(self, n: int, rng) -> np.ndarray:
        """``n`` draws from the tolerance distributions (the yield's population)."""
        return np.column_stack([p.sample(rng, n) for p in self.parameters])

    def describe(self, theta) -> str:
        """A scenario in words: ``payload_mass_kg=720, capillary_diameter_m=+5.0 %``."""
        parts = []
        for p, v in zip(self.parameters, np.asarray(theta, float), strict=True):
            parts.append(f"{p.name}={100 * v:+.2f} %" if p.mode == "relative"
                         else f"{p.name}={v:.6g}")
        return ", ".join(parts)

    def as_dict(self, theta) -> dict:
        """``{name: value}`` of a scenario."""
        return {n: float(v) for n, v in zip(self.names, np.asarray(theta, float), strict=True)}

    def to_unit(self, theta) -> np.ndarray:
        """A scenario's place in the box, each coordinate in [0, 1] (lower end 0, upper 1).

        A sweep point carries its neighbour's worst-case scenarios into its own box this
        way (:func:`isodesign.sweeps.continuation.robust_seeds`): a corner stays a corner
        when the ranges are swept.
        """
        th = np.asarray(theta, float)
        return np.array([(v - p.lo) / ((p.hi - p.lo) or 1.0)
                         for p, v in zip(self.parameters, th, strict=True)])

    def from_unit(self, u) -> np.ndarray:
        """The scenario at unit coordinates ``u`` (clipped to [0, 1]; a discrete
        parameter: its listed value nearest the place). Inverse of :meth:`to_unit`."""
        out = []
        for p, x in zip(self.parameters, np.clip(np.asarray(u, float), 0.0, 1.0),
                        strict=True):
            v = p.lo + float(x) * (p.hi - p.lo)
            out.append(min(p.values, key=lambda w, v=v: abs(w - v)) if p.discrete else v)
        return np.array(out, float)


def _number(where: str, key: str, value) -> float:
    try:
        ok = not isinstance(value, bool) and isinstance(value, int | float) \
            and math.isfinite(float(value))
    except OverflowError:
        ok = False
    if not ok:
        shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:36] + "..."
        raise InputError(f"{where}: scenarios.{key} must be a finite number, got {shown}")
    return float(value)


def _pair(where: str, key: str, value) -> tuple[float, float]:
    """A symmetric number ``h`` (-> ``(-h, h)``) or an explicit ``[lo, hi]``."""
    if isinstance(value, list):
        if len(value) != 2:
            raise InputError(f"{where}: scenarios.{key} must be a number or [lower, upper], "
                             f"got a list of {len(value)}")
        lo, hi = (_number(where, key, v) for v in value)
    else:
        h = _number(where, key, value)
        if h <= 0:
            raise InputError(f"{where}: scenarios.{key} must be > 0 (a +- tolerance), got {h:g}")
        lo, hi = -h, h
    return lo, hi


def _check_box(where: str, key: str, lo: float, hi: float) -> None:
    if lo > hi:
        raise InputError(f"{where}: scenarios.{key}: inverted range, lower ({lo:g}) exceeds "
                         f"upper ({hi:g})")
    if lo == hi:
        raise InputError(f"{where}: scenarios.{key}: empty range (lower = upper = {lo:g}); "
                         "give a range or a list, or remove the key")


def _nominal_operating(name: str, study) -> float:
    if name == "payload_mass_kg":
        return float(study.payload.mass_kg)
    if name == "temperature_k":
        return float(study.hardware.get("temperature_k", SpringDesign.__dataclass_fields__[
            "temperature_k"].default))
    if name in TABLE_PARAMETERS:
        return 0.0
    return P_ATM


def _parameter(where: str, name: str, spec, study) -> UncertainParameter:
    key = name
    if not isinstance(spec, dict):
        raise InputError(f"{where}: scenarios.{key} must be a table, e.g. {{min = ..., max = "
                         "...}}, {values = [...]}, {relative = 0.05} or {absolute = ...}")
    operating = name in OPERATING_PARAMETERS
    allowed = ({"min", "max", "values", "relative", "absolute", "distribution"} if operating
               else {"relative", "absolute", "distribution"})
    if name == "diaphragm_stiffness":
        allowed = {"relative", "distribution"}
    for k in spec:
        if k not in allowed:
            raise InputError(f"{where}: unknown key {k!r} in scenarios.{key}; valid: "
                             f"{', '.join(sorted(allowed))}")
    dist = spec.get("distribution", "uniform")
    if dist not in DISTRIBUTIONS:
        raise InputError(f"{where}: scenarios.{key}.distribution must be one of "
                         f"{', '.join(DISTRIBUTIONS)}, got {dist!r:.40}")
    forms = [k for k in ("min", "values", "relative", "absolute") if k in spec]
    if "max" in spec and "min" not in spec:
        forms.append("max")
    if len(forms) != 1:
        raise InputError(f"{where}: scenarios.{key} needs exactly one of "
                         + ("min + max, values, relative, absolute" if operating
                            else "relative, absolute") + f"; got {', '.join(forms) or 'none'}")
    form = forms[0]
    values = None
    if form in ("min", "max"):
        if "min" not in spec or "max" not in spec:
            raise InputError(f"{where}: scenarios.{key} needs both min and max")
        lo, hi = _number(where, f"{key}.min", spec["min"]), _number(where, f"{key}.max",
                                                                     spec["max"])
        _check_box(where, key, lo, hi)
        mode = "value"
    elif form == "values":
        vals = spec["values"]
        if not isinstance(vals, list) or not vals:
            raise InputError(f"{where}: scenarios.{key}.values must be a non-empty list of "
                             "numbers (an empty list gives no scenario)")
        values = tuple(sorted({_number(where, f"{key}.values", v) for v in vals}))
        if dist != "uniform":
            raise InputError(f"{where}: scenarios.{key}: a list of values is drawn uniformly; "
                             "distribution does not apply")
        lo, hi, mode = values[0], values[-1], "value"
    else:
        lo, hi = _pair(where, f"{key}.{form}", spec[form])
        _check_box(where, f"{key}.{form}", lo, hi)
        mode = form
        if operating:  # around the study's own value
            nom = _nominal_operating(name, study)
            lo, hi = (nom * (1 + lo), nom * (1 + hi)) if form == "relative" else (nom + lo,
                                                                                  nom + hi)
            mode = "value"
    if dist == "normal" and values is None and mode == "value" and not operating:
        pass
    nominal = _nominal_operating(name, study) if operating else 0.0
    if name in TABLE_PARAMETERS and form == "relative":
        raise InputError(f"{where}: scenarios.{key}.relative: an offset of the CG has no "
                         "relative form (its nominal value is 0); give min + max, values or "
                         "absolute, in m")
    p = UncertainParameter(name, mode, lo, hi, nominal, dist, values)
    _check_positive(where, p, study)
    _check_plausible(where, p, study, form)
    return p


#: Physical (error) and plausible (warning) ranges of the operating parameters' values, with
#: the unit slips to name: (unit, factor to SI) tried when the range is outside.
_OPERATING_RANGES = {
    "ambient_pressure_pa": ((1e4, 1e6), (5e4, 1.2e5), (("kPa", 1e3), ("bar", 1e5),
                                                       ("hPa", 1e2))),
    "temperature_k": ((150.0, 1000.0), (230.0, 350.0), (("degC", None),)),
}


def _slip_hint(lo: float, hi: float, slips, ok: tuple[float, float], si: str) -> str:
    """``"; a unit slip? 95 .. 105 kPa would be 95000 .. 105000 Pa"`` (or "")."""
    for unit, factor in slips:
        a, b = (lo + 273.15, hi + 273.15) if factor is None else (lo * factor, hi * factor)
        if ok[0] <= a and b <= ok[1]:
            return f"; a unit slip? {lo:g} .. {hi:g} {unit} would be {a:g} .. {b:g} {si}"
    return ""


def _check_plausible(where: str, p: UncertainParameter, study, form: str) -> None:
    """Ranges in another unit (kPa, degC, tonnes, per cent, mm) refused or warned, by key."""
    import warnings

    from isodesign.io.plausible import UnitWarning

    key = f"scenarios.{p.name}"
    if p.name in _OPERATING_RANGES:
        (elo, ehi), (wlo, whi), slips = _OPERATING_RANGES[p.name]
        unit = PARAMETER_UNITS[p.name]
        if p.lo < elo or p.hi > ehi:
            raise InputError(f"{where}: {key}: the range {p.lo:g} .. {p.hi:g} {unit} is outside "
                             f"[{elo:g}, {ehi:g}] {unit} (in {unit}: "
                             f"{'absolute, ' if unit == 'Pa' else ''}SI)"
                             + _slip_hint(p.lo, p.hi, slips, (wlo, whi), unit))
        if p.lo < wlo or p.hi > whi:
            warnings.warn(f"{where}: {key}: the range {p.lo:g} .. {p.hi:g} {unit} is outside the "
                          f"plausible range [{wlo:g}, {whi:g}] {unit} of a laboratory",
                          UnitWarning, stacklevel=5)
    elif p.name == "payload_mass_kg":
        m = float(study.payload.mass_kg)
        if p.hi < m / 10.0 or p.lo > 10.0 * m:
            hint = ""
            if p.hi < m / 10.0 and 0.1 <= p.lo and p.hi <= 10.0:
                hint = (f"; a fraction of the payload? write relative = [{p.lo - 1:g}, "
                        f"{p.hi - 1:g}] (or min/max in kg); in tonnes it would be "
                        f"{1e3 * p.lo:g} .. {1e3 * p.hi:g} kg")
            elif p.hi < m / 10.0:
                hint = (f"; in tonnes? {p.lo:g} .. {p.hi:g} t would be {1e3 * p.lo:g} .. "
                        f"{1e3 * p.hi:g} kg")
            elif p.lo > 10.0 * m:
                hint = (f"; in grams? it would be {1e-3 * p.lo:g} .. {1e-3 * p.hi:g} kg")
            raise InputError(f"{where}: {key}: the range {p.lo:g} .. {p.hi:g} kg lies more than a "
                             f"factor 10 from payload.mass_kg = {m:g} kg (allowed "
                             f"[{m / 10:g}, {10 * m:g}] kg){hint}")
    elif p.name in TABLE_PARAMETERS:
        t = study.table
        axis = 0 if p.name.endswith("x_m") else 1
        for v in (p.lo, p.hi):
            cg = np.array(t.cg_m[:2], float)
            cg[axis] += v
            from isodesign.table.layout import _inside

            if not _inside(t.support_polygon(), cg):
                hull = t.support_polygon()[:, axis]
                c = t.cg_m[axis]
                mm = (f"; a unit slip? {v:g} mm would be {v * 1e-3:g} m"
                      if abs(v) >= 1.0 and hull.min() < c + 1e-3 * v < hull.max() else "")
                raise InputError(f"{where}: {key}: an offset of {v:g} m moves the CG to "
                                 f"{'xy'[axis]} = {cg[axis]:g} m, outside the support polygon "
                                 f"({'xy'[axis]} {hull.min():g} to {hull.max():g} m): the table "
                                 f"tips over{mm}")
    if form == "relative":
        big = max(abs(p.lo), abs(p.hi)) if p.mode == "relative" else \
            max(abs(p.lo / p.nominal - 1), abs(p.hi / p.nominal - 1))
        if big > 2.0:
            raise InputError(f"{where}: {key}.relative: a deviation of {100 * big:g} % (relative "
                             f"is a fraction: 0.05 is 5 %); the range is [-1, 2] (-100 % to "
                             f"+200 %)")
        if big > 0.5:
            warnings.warn(f"{where}: {key}.relative: a deviation of {100 * big:g} % is far above "
                          "a tolerance (relative is a fraction: 0.05 is 5 %)", UnitWarning,
                          stacklevel=5)
    if form == "absolute" and p.name in DESIGN_VARIABLES:
        var = study.variable(p.name)
        top = var.upper
        big = max(abs(p.lo), abs(p.hi))
        if big > top:
            raise InputError(f"{where}: {key}.absolute: a deviation of {big:g} "
                             f"{PARAMETER_UNITS[p.name]} exceeds the variable's own upper bound "
                             f"({top:g} {PARAMETER_UNITS[p.name]}); a unit slip (mm typed as "
                             "m)? a relative tolerance is relative = 0.05")


def _check_positive(where: str, p: UncertainParameter, study) -> None:
    """No value in the box (or within 4 sigma of a normal law) may be non-positive."""
    lo = p.lo
    if p.distribution == "normal" and not p.discrete:
        lo = 0.5 * (p.lo + p.hi) - (4.0 / NORMAL_SIGMAS) * p.half_width
    key = f"scenarios.{p.name}"
    if p.name in TABLE_PARAMETERS:
        return  # an offset: any sign
    if p.mode == "value":
        if lo <= 0:
            raise InputError(f"{where}: {key}: the range reaches {lo:g} "
                             f"{PARAMETER_UNITS[p.name]}; {p.name} must stay > 0")
        return
    if p.mode == "relative" and lo <= -1.0:
        raise InputError(f"{where}: {key}.relative: a deviation of {100 * lo:g} % makes "
                         f"{p.name} non-positive; it must stay above -100 %")
    if p.mode == "absolute":
        smallest = study.variable(p.name).lower if p.name in DESIGN_VARIABLES else math.inf
        if smallest + lo <= 0:
            raise InputError(f"{where}: {key}.absolute: a deviation of {lo:g} "
                             f"{PARAMETER_UNITS[p.name]} makes {p.name} non-positive at its "
                             f"lower bound {smallest:g}; use a smaller tolerance, a relative "
                             "one, or raise variables." + p.name + ".lower")


def parse_scenarios(table, where: str, study) -> UncertaintySpace | None:
    """Validate a ``[scenarios]`` table (``None`` or empty: no scenarios).

    Parameters
    ----------
    table : dict or None
        The table as read from TOML (see ``docs/robust.md``): one entry per uncertain
        parameter (``payload_mass_kg``, ``ambient_pressure_pa``, ``temperature_k``:
        ``{min, max}``, ``{values = [...]}``, or ``{relative}`` / ``{absolute}`` around the
        study's value; ``volume_ratio``, ``top_volume_m3``, ``capillary_length_m``,
        ``capillary_diameter_m``: ``{relative}`` or ``{absolute}``; ``diaphragm_stiffness``:
        ``{relative}``; each optionally ``distribution = "uniform" | "normal"``), plus the
        exchange settings ``tolerance_db``, ``max_rounds``, ``search_samples``, ``seed``.
    where : str
        The study's source, to start error messages.
    study : Study
        The nominal study (its payload, temperature and variable bounds).

    Returns
    -------
    UncertaintySpace or None

    Raises
    ------
    InputError
        An unknown key, an empty or inverted range, a tolerance that makes a quantity
        non-positive, or a scenario whose spring is not valid; the message names the key.
    """
    if not table:
        return None
    if not isinstance(table, dict):
        raise InputError(f"{where}: [scenarios] must be a table")
    valid = set(OPERATING_PARAMETERS) | set(TOLERANCE_PARAMETERS) | set(SCENARIO_SETTINGS)
    for k in table:
        if k not in valid:
            raise InputError(f"{where}: unknown key {k!r} in [scenarios]; valid: "
                             f"{', '.join(sorted(valid))}")
    is_table = getattr(study, "table", None) is not None
    for k in table:
        if k in TABLE_PARAMETERS and not is_table:
            raise InputError(f"{where}: scenarios.{k} needs a [table] study (the vertical "
                             "study has no centre of gravity to move)")
        if k == "ambient_pressure_pa" and is_table:
            raise InputError(f"{where}: scenarios.{k} is not available with a [table] study "
                             "yet (its leveling sets the pressures from the supply)")
    params = tuple(_parameter(where, n, table[n], study)
                   for n in (*OPERATING_PARAMETERS, *TOLERANCE_PARAMETERS) if n in table)
    settings = dict(SCENARIO_SETTINGS)
    for k, default in SCENARIO_SETTINGS.items():
        if k not in table:
            continue
        v = table[k]
        if isinstance(default, int):
            hi = {"max_rounds": 50, "search_samples": 4096, "seed": 2**32 - 1}[k]
            lo = 0 if k in ("seed", "search_samples") else 1  # 0 samples: corners, centre
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise InputError(f"{where}: scenarios.{k} must be an integer in [{lo}, {hi}]")
        else:
            v = _number(where, k, v)
            if not 0 < v <= 10:
                raise InputError(f"{where}: scenarios.{k} must be in (0, 10] dB, got {v:g}")
        settings[k] = v
    if not params:
        raise InputError(f"{where}: [scenarios] names no uncertain parameter; valid: "
                         f"{', '.join((*OPERATING_PARAMETERS, *TOLERANCE_PARAMETERS))}")
    space = UncertaintySpace(params, settings)
    for theta in space.corners(limit=64):
        try:
            ScenarioStudy(study, space, theta).start_design()
        except InputError as exc:
            raise InputError(f"{where}: [scenarios] the scenario {space.describe(theta)} "
                             f"gives no valid spring at the start design: {exc}") from None
    return space


def cg_corner_problem(where: str, space: UncertaintySpace, study) -> str | None:
    """The message if a corner of the scenarios cannot be leveled (a table study).

    Inside the support polygon (checked per key when the study is read) is not enough: a
    CG outside the triangle of the three groups' centroids leaves one valve without load,
    and the heaviest payload of ``payload_mass_kg`` may need a p0 above
    ``table.supply_pressure_pa``. A yield answers them (those draws fail the leveling); the
    robust table optimizer refuses them before any solve
    (:func:`.robust_table.check_robust_table`), naming the keys and each one's valid range.
    None for a free layout or inertia base (their levers move the centroids and the loads).

    Parameters
    ----------
    where : str
        The study's source, to start the message.
    space : UncertaintySpace
        The study's scenarios.
    study : Study
        The nominal study, with ``table``.

    Returns
    -------
    str or None
    """
    t = getattr(study, "table", None)
    keys = [n for n in (*TABLE_PARAMETERS, "payload_mass_kg") if n in space.names]
    if t is None or not keys or t.leveling_groups is None:
        return None
    if any(not v.fixed and v.name.startswith(("layout_", "isolator_", "inertia_base"))
           for v in getattr(study, "levers", ())):
        return None
    import dataclasses

    from isodesign.table.statics import group_loads_at, supply_limited_mass_kg

    xy = np.asarray(t.isolators_m, float)
    c0 = np.array(t.cg_m, float)
    a_p = float(study.hardware["piston_area_m2"])
    m_p = float(study.payload.mass_kg)
    slab = float(t.mass_kg) - m_p

    def at(dx: float, dy: float, m: float = m_p):
        cg = c0.copy()
        cg[0] += dx
        cg[1] += dy
        return dataclasses.replace(t, cg_m=cg, mass_kg=slab + m)

    def loads(dx: float, dy: float) -> np.ndarray:
        return np.array(group_loads_at(at(dx, dy), xy), float)

    par = {p.name: p for p in space.parameters}
    axes = {n: (par[n].values if par[n].discrete else (par[n].lo, par[n].hi)) for n in keys}
    w = float(t.weight_n)
    for dx in axes.get("cg_offset_x_m", (0.0,)):
        for dy in axes.get("cg_offset_y_m", (0.0,)):
            p = loads(dx, dy)
            g = int(np.argmin(p))
            if p[g] <= 1e-9 * w:
                cg_keys = [n for n in keys if n != "payload_mass_kg"]
                ranges = []
                for n in cg_keys:  # each key's valid range with the other offset at 0
                    e = (1.0, 0.0) if n.endswith("x_m") else (0.0, 1.0)
                    a, slope = loads(0.0, 0.0), loads(*e) - loads(0.0, 0.0)  # linear
                    lo = max([-a[k] / slope[k] for k in range(3) if slope[k] > 0],
                             default=-np.inf)
                    hi = min([-a[k] / slope[k] for k in range(3) if slope[k] < 0],
                             default=np.inf)
                    ranges.append(f"scenarios.{n} within ({lo:.4g}, {hi:.4g}) m")
                named = " and ".join(f"scenarios.{n}" for n in cg_keys)
                return (f"{where}: {named}: the offset ({dx:g}, {dy:g}) m moves the CG to "
                        f"({c0[0] + dx:.4g}, {c0[1] + dy:.4g}) m, outside the triangle of the "
                        f"leveling groups' centroids: group {g + 1} (from 1) would carry "
                        f"{p[g]:.4g} N per isolator, its valve no load; valid: "
                        f"{'; '.join(ranges)} (alone), or regroup table.leveling_groups")
            if "payload_mass_kg" not in axes:
                continue
            heaviest = supply_limited_mass_kg(at(dx, dy), a_p) + m_p - slab
            m = max(axes["payload_mass_kg"])
            if m > heaviest:
                off = f" with the CG offset ({dx:g}, {dy:g}) m" if dx or dy else ""
                return (f"{where}: scenarios.payload_mass_kg: a payload of {m:g} kg{off} needs "
                        f"a p0 above table.supply_pressure_pa ({t.supply_pressure_pa:g} Pa), "
                        f"so no valve can level it; valid: up to {heaviest:.5g} kg at this "
                        "supply (or raise the supply, larger pistons, more isolators)")
    return None


class ScaledDiaphragm:
    """A diaphragm model whose complex stiffness is scaled by ``1 + delta`` (any backend)."""

    def __init__(self, base, delta):
        self.base = base
        self.delta = delta
        self.name = getattr(base, "name", "diaphragm")

    def stiffness(self, omega, amplitude_m) -> Cx:
        """``(1 + delta) k_D*(X, w)``."""
        k = self.base.stiffness(omega, amplitude_m)
        f = 1.0 + self.delta
        return Cx(k.re * f, k.im * f)

    def in_range(self, omega, amplitude_m) -> dict:
        """The base model's validity checks."""
        return self.base.in_range(omega, amplitude_m)


class ScenarioStudy:
    """A study under one scenario (numbers, or CasADi symbols inside the NLP).

    Every attribute of the nominal study is passed through, except ``payload`` (the
    scenario's mass), ``hardware`` (its temperature), ``models["diaphragm"]`` (scaled
    by the diaphragm spread) and :meth:`design_at`, which returns the built spring:
    tolerances applied to the drawn design, ``p0 = p_amb + m g / (n A_p)``.

    Parameters
    ----------
    study : Study
        The nominal study.
    space : UncertaintySpace
    theta : sequence
        The scenario's coordinates, in ``space.names`` order (numbers or symbols).
    """

    def __init__(self, study, space: UncertaintySpace, theta):
        self.base = study
        self.space = space
        self.theta = {n: theta[i] for i, n in enumerate(space.names)}
        self.symbolic = any(bk.is_casadi(v) for v in self.theta.values())
        mass = self.theta.get("payload_mass_kg", study.payload.mass_kg)
        p = study.payload
        if bk.is_casadi(mass):
            self.payload = SimpleNamespace(
                mass_kg=mass, isolators=p.isolators, spacing_m=p.spacing_m,
                cg_height_m=p.cg_height_m, g_m_s2=p.g_m_s2,
                mass_per_isolator_kg=mass / p.isolators,
                load_per_isolator_n=mass * p.g_m_s2 / p.isolators)
        else:
            self.payload = dataclasses.replace(p, mass_kg=float(mass)) if mass != p.mass_kg \
                else p
        self.hardware = dict(study.hardware)
        if "temperature_k" in self.theta:
            self.hardware["temperature_k"] = self.theta["temperature_k"]
        self.models = dict(study.models)
        if "diaphragm_stiffness" in self.theta:
            self.models["diaphragm"] = ScaledDiaphragm(diaphragm_model(study.models["diaphragm"]),
                                                       self.theta["diaphragm_stiffness"])

    def __getattr__(self, name: str) -> Any:
        return getattr(self.base, name)

    def built_values(self, values: dict) -> dict:
        """The built design variables: the drawn ``values`` with the tolerances applied."""
        vals = {v.name: (v.start if v.fixed else values.get(v.name, v.start))
                for v in self.base.variables}
        for n in DESIGN_VARIABLES:
            if n in self.theta:
                p = self.space.parameter(n)
                delta = self.theta[n]
                vals[n] = vals[n] * (1.0 + delta) if p.mode == "relative" else vals[n] + delta
        return vals

    def design_at(self, values: dict):
        """The built spring of the drawn design ``values`` under this scenario."""
        vals = self.built_values(values)
        d = model_design(self.models["flow"], SpringDesign(
            pressure_pa=2e5, **vals, **self.hardware,
            acoustics=self.models.get("acoustics", ACOUSTIC_MODELS[0])))
        p_amb = self.theta.get("ambient_pressure_pa", P_ATM)
        pl = self.payload
        p0 = p_amb + pl.mass_kg * pl.g_m_s2 / (pl.isolators * d.piston_area_m2)
        if not self.symbolic and not p0 > P_ATM:
            raise InputError(f"scenario {self.space.describe(list(self.theta.values()))}: "
                             f"static pressure {p0:.4g} Pa is not above atmospheric")
        return dataclasses.replace(d, pressure_pa=p0)

    def start_design(self):
        """The built start design under this scenario."""
        return self.design_at({v.name: v.start for v in self.base.variables})
