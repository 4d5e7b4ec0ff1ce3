"""Design variables of the optimizer: names, units, specs, bounds and log scaling.

The NLP works in a scaled log space: a free variable x with effective bounds
[lo, hi] is ``ln x = c + h z`` with ``c`` the log-midpoint, ``h`` the log
half-range and ``z`` in [-1, 1].
"""

from __future__ import annotations

import difflib
import math
import numbers
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.table.layout import (
    MAX_TABLE_ISOLATORS,
    POSITION_LEVER,
    is_position_lever,
    position_lever_names,
)

__all__ = [
    "CODESIGN_LEVERS",
    "DESIGN_VARIABLES",
    "DESIGN_VARIABLE_UNITS",
    "GROUP_SPRING_LEVERS",
    "LAYOUT_CONSTRAINTS",
    "LAYOUT_LEVERS",
    "LAYOUT_LEVER_RANGE",
    "TABLE_LEVERS",
    "TABLE_LEVER_BOUNDS",
    "TABLE_LEVER_UNITS",
    "LinearScaling",
    "LogScaling",
    "VariableSpec",
    "check_layout_feasible",
    "check_load_range",
    "effective_bounds",
    "fixed_lever_changes",
    "footprint_bounds",
    "group_lever",
    "lever_scaling",
    "log_scaling",
    "parse_levers",
    "refuse_free_levers",
    "refuse_group_number",
    "table_with_levers",
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


#: The horizontal element's levers: optional design variables of a table study
#: (docs/table.md, section "Co-design levers"), each fixed at the table's value unless its
#: ``[variables.<name>]`` says ``fixed = false``.
TABLE_LEVERS = ("pendulum_length_m", "elastic_centre_height_m", "lateral_stiffness_n_per_m",
                "lateral_loss_factor")
#: Unit of each lever (SI).
#: The layout's levers (docs/table.md, "The layout as design variables"): the isolators'
#: extent along x and y, the layout stretched about the CG's plan position.
LAYOUT_LEVERS = ("layout_length_m", "layout_width_m")
#: The inertia base's lever (docs/table.md, section 16): the slab's mass under the payload.
BASE_LEVERS = ("inertia_base_mass_kg",)
#: Every co-design lever of a table study, in the order of ``Study.levers`` and the NLP.
CODESIGN_LEVERS = TABLE_LEVERS + LAYOUT_LEVERS + BASE_LEVERS
#: Per-group spring levers (docs/table.md, section 15): ``<variable>_group<k>``, the design
#: variable of leveling group ``k`` (1..3); a group the study does not name shares the spring.
GROUP_SPRING_LEVERS = tuple(f"{v}_group{k}" for k in (1, 2, 3) for v in DESIGN_VARIABLES)
#: A table study's constraints on its layout, loads and supply (docs/table.md, section 15).
LAYOUT_CONSTRAINTS = ("footprint_m", "min_isolator_distance_m", "min_isolator_load_n",
                      "max_isolator_load_n", "supply_margin_pa")
#: Plausible half-size of a table, m (``isodesign.table.study.LENGTH_PLAUSIBLE_M``): a
#: footprint coordinate beyond it, or a layout lever beyond twice it, is a unit slip.
LAYOUT_PLAUSIBLE_M = 20.0
#: Smallest plausible extent of a layout, m (``isodesign.table.study.SPAN_PLAUSIBLE_M``).
SPAN_PLAUSIBLE_M = 0.05
#: Tolerance of a fixed layout's footprint and distance check when the study is read, m (a
#: co-designed optimum on its bound, within the solver's tolerance, is inside).
LAYOUT_TOL_M = 1e-6
#: Default bounds of a free layout lever, as fractions of the table's own extent.
LAYOUT_LEVER_RANGE = (0.5, 1.5)
TABLE_LEVER_UNITS = {"pendulum_length_m": "m", "elastic_centre_height_m": "m",
                     "lateral_stiffness_n_per_m": "N/m", "lateral_loss_factor": "-",
                     "layout_length_m": "m", "layout_width_m": "m",
                     "inertia_base_mass_kg": "kg",
                     **{f"{v}_group{k}": DESIGN_VARIABLE_UNITS[v] for k in (1, 2, 3)
                        for v in DESIGN_VARIABLES},
                     **dict.fromkeys(position_lever_names(MAX_TABLE_ISOLATORS), "m")}
#: Practical bounds of each lever (the defaults of a free lever's lower and upper): a
#: pendulum of 5-60 cm, an elastic centre 0.2 m below to 0.5 m above the support plane
#: (re-entrant or pedestal mounts), a diaphragm shear stiffness of 1-100 kN/m and loss
#: factor 0.01-0.5.
TABLE_LEVER_BOUNDS = {"pendulum_length_m": (0.05, 0.6), "elastic_centre_height_m": (-0.2, 0.5),
                      "lateral_stiffness_n_per_m": (1.0e3, 1.0e5),
                      "lateral_loss_factor": (0.01, 0.5)}


@dataclass(frozen=True)
class LinearScaling:
    """Linear scaling of the free levers: ``x = c + h z``, z in [-1, 1]; a per-group spring
    lever (``log`` true) is log-scaled like the spring's variables, ``ln x = c + h z``."""

    names: tuple[str, ...]
    center: np.ndarray
    half: np.ndarray
    log: tuple[bool, ...] = ()

    def is_log(self, i: int) -> bool:
        """Lever ``i`` is log-scaled."""
        return bool(self.log[i]) if self.log else False

    def to_values(self, z) -> dict:
        """Lever values (SI) at scaled coordinates ``z``."""
        out = {}
        for i, (n, c, h, zi) in enumerate(zip(self.names, self.center, self.half,
                                              np.asarray(z, float), strict=True)):
            out[n] = float(math.exp(c + h * zi) if self.is_log(i) else c + h * zi)
        return out

    def to_z(self, values: dict) -> np.ndarray:
        """Scaled coordinates of lever values (SI)."""
        return np.array([((math.log(values[n]) if self.is_log(i) else values[n]) - c) / h
                         for i, (n, c, h) in enumerate(zip(self.names, self.center, self.half,
                                                           strict=True))])


def lever_scaling(study) -> LinearScaling:
    """The linear scaling of a study's free levers (``study.levers``) over their bounds.

    Parameters
    ----------
    study : Study

    Returns
    -------
    LinearScaling
        Names in ``study.levers`` order; ``z = -1`` and ``z = 1`` are the bounds (a
        per-group capillary diameter's lower bound raised to
        ``constraints.min_capillary_diameter_m``, as the shared one's).
    """
    free = [v for v in getattr(study, "levers", ()) if v.free]
    dmin = (getattr(study, "constraints", None) or {}).get("min_capillary_diameter_m")
    lo, hi, log = [], [], []
    for v in free:
        is_log = v.name in GROUP_SPRING_LEVERS
        low = v.lower
        if is_log and dmin and v.name.startswith("capillary_diameter_m"):
            low = max(low, dmin)
        lo.append(math.log(low) if is_log else low)
        hi.append(math.log(v.upper) if is_log else v.upper)
        log.append(is_log)
    lo_a, hi_a = np.array(lo), np.array(hi)
    return LinearScaling(names=tuple(v.name for v in free), center=0.5 * (lo_a + hi_a),
                         half=0.5 * (hi_a - lo_a), log=tuple(log))


def parse_levers(variables: dict, table, where: str, constraints: dict | None = None,
                 hardware: dict | None = None) -> tuple[VariableSpec, ...]:
    """``[variables.<lever>]`` of a table study: one spec per :data:`CODESIGN_LEVERS` entry.

    A lever the study does not name, or names with ``fixed = true``, is fixed at the
    table's value (``[table.horizontal]``; for a layout lever the isolators' extent) or its
    own ``start``. A free lever takes ``lower``/``upper`` (default
    :data:`TABLE_LEVER_BOUNDS`; a layout lever :data:`LAYOUT_LEVER_RANGE` times the table's
    extent) and ``start`` (default the table's value).

    Parameters
    ----------
    variables : dict
        The study's ``[variables]`` table.
    table : Table or None
        The study's table (None: a vertical study, which may name no lever).
    where : str
        The study's source, for errors.
    constraints : dict, optional
        The parsed constraints: a free layout's are checked reachable
        (:func:`check_layout_feasible`), the loads and p0 of the leveled table against
        the load and supply constraints (no variable moves them).
    hardware : dict, optional
        The study's hardware (its ``piston_area_m2`` levels the table).

    Returns
    -------
    tuple of VariableSpec
        Empty for a vertical study.

    Raises
    ------
    InputError
        A lever in a study without ``[table]``, or bounds that do not hold the start.
    """
    named = [n for n in (*CODESIGN_LEVERS, *GROUP_SPRING_LEVERS, POSITION_LEVER)
             if n in (variables or {})]
    if table is None:
        if named:
            raise InputError(f"{where}: variables.{named[0]} is a lever of a table study; this "
                             "study has no [table] (docs/table.md)")
        return ()
    from isodesign.table.layout import layout_extent

    h = table.horizontal
    extent = dict(zip(LAYOUT_LEVERS, layout_extent(table), strict=True))
    out = []
    for name in CODESIGN_LEVERS:
        spec = (variables or {}).get(name) or {}
        if not isinstance(spec, dict):
            raise InputError(f"{where}: [variables.{name}] must be a table (start, lower, "
                             f"upper, fixed), got {spec!r:.40}")
        key = f"{where}: variables.{name}"
        if name in BASE_LEVERS:  # the slab's mass (isodesign.table.inertia_base)
            from isodesign.table.study import parse_base_lever

            out.append(VariableSpec(name, *parse_base_lever(spec, table, key, hardware,
                                                            constraints)))
            continue
        fixed = spec.get("fixed", True)
        if not isinstance(fixed, bool):
            raise InputError(f"{key}.fixed: expected true or false, got {fixed!r:.40}")
        table_value = extent[name] if name in extent else getattr(h, name)
        if not fixed and name in ("lateral_stiffness_n_per_m", "lateral_loss_factor") \
                and h.lateral_model is not None:
            raise InputError(f"{key}: the table's horizontal element has a lateral_model; "
                             "its lateral stiffness and loss factor are not levers")
        vals = {}
        for k in ("start", "lower", "upper"):
            if k in spec:
                v = spec[k]
                if not _finite_number(v):
                    raise InputError(f"{key}.{k}: expected a finite number, got {_short(v)}")
                vals[k] = float(v)
        start = vals.get("start", table_value)
        if start is None:
            raise InputError(f"{key}.start: the table has no pendulum "
                             "(table.horizontal.pendulum_length_m = false); give a start")
        if name in extent:
            lo_d, hi_d = (f * table_value for f in LAYOUT_LEVER_RANGE)
            if not start > 0:
                raise InputError(f"{key}.start: the isolators' extent must be > 0 m, got "
                                 f"{start:g}")
            for k, v in vals.items():
                if not SPAN_PLAUSIBLE_M <= v <= 2 * LAYOUT_PLAUSIBLE_M:
                    hint = (f"; a unit slip? {name} is in m, and {v:g} mm would be "
                            f"{v * 1e-3:g} m") if v > 1 else f"; {name} is in m"
                    raise InputError(
                        f"{key}.{k} = {v:g} m is outside the plausible extent of a table's "
                        f"isolators [{SPAN_PLAUSIBLE_M:g}, {2 * LAYOUT_PLAUSIBLE_M:g}] m{hint}")
        else:
            lo_d, hi_d = TABLE_LEVER_BOUNDS[name]
            _plausible_horizontal(key, name, vals)
            _horizontal_sign(f"{key}.start", name, start)
        if fixed and not vals.get("lower", start) <= start <= vals.get("upper", start):
            raise InputError(f"{key}.start ({start:g}) is fixed outside its own bounds [lower, "
                             f"upper] = [{vals.get('lower', start):g}, "
                             f"{vals.get('upper', start):g}]")
        if fixed:
            out.append(VariableSpec(name, float(start), float(start), float(start), True))
            continue
        lo, hi = vals.get("lower", lo_d), vals.get("upper", hi_d)
        pos_lo = 0.0 if name != "elastic_centre_height_m" else -math.inf
        if not pos_lo < lo < hi:
            raise InputError(f"{key}: need {'0 < ' if pos_lo == 0 else ''}lower < upper, got "
                             f"lower = {lo:g}, upper = {hi:g}")
        if not lo <= start <= hi:
            raise InputError(f"{key}.start ({start:g}) must lie in [lower, upper] = "
                             f"[{lo:g}, {hi:g}]")
        out.append(VariableSpec(name, float(start), float(lo), float(hi), False))
    out = tuple(out) + _group_levers(variables or {}, table, where)
    if POSITION_LEVER in (variables or {}):  # free positions in a footprint polygon
        from isodesign.table.study import parse_position_lever

        out += tuple(VariableSpec(*p) for p in parse_position_lever(
            variables[POSITION_LEVER], table, f"{where}: variables.{POSITION_LEVER}",
            constraints, any(v.free for v in out if v.name in LAYOUT_LEVERS)))
    _check_group_diameters(table, out, constraints or {}, where)
    check_layout_feasible(table, out, constraints or {}, where)
    _check_loads(table, constraints or {}, hardware, where, out)
    return out


def _check_loads(table, constraints: dict, hardware: dict | None, where: str,
                 levers=()) -> None:
    """The leveled table's loads and group p0 against ``min_isolator_load_n``,
    ``max_isolator_load_n`` and ``supply_margin_pa`` (refused when no variable can meet
    them, as the problem refuses them)."""
    margin = constraints.get("supply_margin_pa")
    if margin and margin >= table.supply_pressure_pa:
        raise InputError(f"{where}: constraints.supply_margin_pa ({margin:g} Pa) must be below "
                         f"table.supply_pressure_pa ({table.supply_pressure_pa:g} Pa, "
                         "absolute); a margin is a few 1e4 Pa")
    keys = ("min_isolator_load_n", "max_isolator_load_n", "supply_margin_pa")
    if hardware is None or not any(constraints.get(k) for k in keys):
        return
    from isodesign.table.statics import check_load_constraints, check_scaled_loads, level

    base = next((v for v in levers if v.name in BASE_LEVERS and v.free), None)
    if any(is_position_lever(v.name) for v in levers):
        return  # free positions: the loads and p0 are NLP rows (docs/table.md, section 15)
    try:
        if base is not None:  # the loads follow the slab: some mass in its bounds must do
            m0 = table.mass_kg - base.start
            check_scaled_loads(level(table, hardware["piston_area_m2"]), constraints, (
                (m0 + base.lower) / table.mass_kg, (m0 + base.upper) / table.mass_kg))
            return
        check_load_constraints(level(table, hardware["piston_area_m2"]), constraints)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def _horizontal_sign(key: str, name: str, start: float) -> None:
    """A horizontal lever's start (its fixed value) where the element is physical: a
    pendulum longer than 0 m, a lateral stiffness and loss factor not negative (the
    ``[table.horizontal]`` numbers' own ranges)."""
    if name == "pendulum_length_m" and not start > 0:
        raise InputError(f"{key} = {start:g} m: a pendulum's length must be > 0 m "
                         "(table.horizontal.pendulum_length_m = false: no pendulum)")
    if name in ("lateral_stiffness_n_per_m", "lateral_loss_factor") and start < 0:
        raise InputError(f"{key} = {start:g}: must be >= 0 (as "
                         f"table.horizontal.{name})")


def refuse_group_number(key, table: str, where: str) -> None:
    """Refuse a per-group lever ``<variable>_group<k>`` whose ``k`` is no leveling group.

    Parameters
    ----------
    key : str
        An unknown key of the study.
    table : str
        The study table it is in (only ``variables`` is checked).
    where : str
        The study's source, for errors.

    Raises
    ------
    InputError
        Naming ``variables.<key>`` and the groups 1, 2, 3 (numbered from 1).
    """
    base, sep, k = str(key).rpartition("_group")
    if table == "variables" and sep and base in DESIGN_VARIABLES:
        raise InputError(f"{where}: variables.{key}: group {k!r} is not a leveling group; "
                         f"<variable>_group<k> takes k = 1, 2 or 3 (numbered from 1, as "
                         "table.leveling_groups lists them)")


def _plausible_horizontal(key: str, name: str, vals: dict) -> None:
    """A horizontal lever's given values within the plausible range of its
    ``[table.horizontal]`` number (``isodesign.table.study``): beyond it a bound lets the
    optimizer design an element no table has (a unit slip: cm, %, N/mm)."""
    from isodesign.table.study import _HORIZONTAL

    _lo, hi, _hard, slip = _HORIZONTAL[name]
    for k, v in vals.items():
        if abs(v) > hi:
            hint = f"; a unit slip? {name} is in m, and {v:g} mm would be {v * 1e-3:g} m" \
                if slip is not None else ""
            raise InputError(f"{key}.{k} = {v:g} is outside the plausible range of "
                             f"table.horizontal.{name}, |value| <= {hi:g}{hint}")


def group_lever(name: str) -> tuple[int, str]:
    """``(group, variable)`` of a per-group spring lever (group zero-based).

    Parameters
    ----------
    name : str
        A :data:`GROUP_SPRING_LEVERS` name, ``<variable>_group<k>`` (``k`` one-based).

    Returns
    -------
    tuple of (int, str)
        The zero-based group and the design variable's name.
    """
    base, k = name.rsplit("_group", 1)
    return int(k) - 1, base


def _group_levers(variables: dict, table, where: str) -> tuple[VariableSpec, ...]:
    """The per-group spring levers the study names (:data:`GROUP_SPRING_LEVERS`)."""
    from isodesign.domain import DESIGN_DOMAIN

    out = []
    for name in GROUP_SPRING_LEVERS:
        if name not in variables:
            continue
        spec, key = variables[name], f"{where}: variables.{name}"
        if not isinstance(spec, dict):
            raise InputError(f"{key}: must be a table (start, lower, upper, fixed), got "
                             f"{spec!r:.40}")
        g, base = group_lever(name)
        shared = variables.get(base) if isinstance(variables.get(base), dict) else {}
        fixed = spec.get("fixed", True)
        if not isinstance(fixed, bool):
            raise InputError(f"{key}.fixed: expected true or false, got {fixed!r:.40}")
        vals = {}
        for k in ("start", "lower", "upper"):
            v = spec.get(k, table.group_springs[g].get(base, shared.get("start"))
                         if k == "start" else shared.get(k))
            if v is None:
                raise InputError(f"{key}.{k}: give it (variables.{base} has no {k}: it is "
                                 "fixed)")
            if not _finite_number(v) or v <= 0:
                raise InputError(f"{key}.{k}: expected a number > 0, got {_short(v)}")
            vals[k] = float(v)
        dlo, dhi, unit = DESIGN_DOMAIN[base]
        for k in ("start",) if fixed else ("start", "lower", "upper"):
            if not dlo <= vals[k] <= dhi:
                raise InputError(f"{key}.{k} = {vals[k]:g} is outside the models' domain "
                                 f"[{dlo:g}, {dhi:g}]{' ' + unit if unit else ''}")
        if fixed and not vals["lower"] <= vals["start"] <= vals["upper"] and \
                ("lower" in spec or "upper" in spec):
            raise InputError(f"{key}.start ({vals['start']:g}) is fixed outside its own bounds "
                             f"[lower, upper] = [{vals['lower']:g}, {vals['upper']:g}]")
        if fixed:
            out.append(VariableSpec(name, vals["start"], vals["start"], vals["start"], True))
            continue
        if not vals["lower"] < vals["upper"]:
            raise InputError(f"{key}: lower ({vals['lower']:g}) must be below upper "
                             f"({vals['upper']:g})")
        if not vals["lower"] <= vals["start"] <= vals["upper"]:
            raise InputError(f"{key}.start ({vals['start']:g}) must lie in [lower, upper] = "
                             f"[{vals['lower']:g}, {vals['upper']:g}]")
        out.append(VariableSpec(name, vals["start"], vals["lower"], vals["upper"], False))
    return tuple(out)


def _check_group_diameters(table, levers, constraints: dict, where: str) -> None:
    """Every group's own capillary diameter against ``constraints.min_capillary_diameter_m``,
    as the shared one's: a fixed one (a lever or ``table.group_springs``) at or above it, a
    free one's upper bound above it."""
    dmin = constraints.get("min_capillary_diameter_m")
    if not dmin:
        return
    spec = {v.name: v for v in levers}
    for g, own in enumerate(table.group_springs):
        name = f"capillary_diameter_m_group{g + 1}"
        v = spec.get(name)
        if v is not None and not v.fixed:
            if v.upper <= dmin:
                raise InputError(f"{where}: variables.{name}.upper ({v.upper:g} m) must exceed "
                                 f"constraints.min_capillary_diameter_m ({dmin:g} m)")
            continue
        value, key = ((v.start, f"variables.{name}") if v is not None else
                      (own.get("capillary_diameter_m"),
                       f"table.group_springs: group {g + 1}: capillary_diameter_m"))
        if value is not None and value < dmin * (1 - 1e-6):  # an optimum on it, fixed, holds
            raise InputError(f"{where}: {key} is fixed at {value:g} m, below "
                             f"constraints.min_capillary_diameter_m ({dmin:g} m)")


def table_with_levers(table, levers, values: dict | None = None):
    """The table with its levers at ``values`` (fixed or missing ones at their start).

    Parameters
    ----------
    table : Table
    levers : sequence of VariableSpec
        ``Study.levers``.
    values : dict, optional
        Lever values by name, SI.

    Returns
    -------
    Table
        ``table`` itself when every lever keeps the table's value; else the horizontal
        element's levers replaced and the layout stretched about the CG
        (:func:`~isodesign.table.layout.stretch_layout`).
    """
    import dataclasses

    from isodesign.table.layout import layout_extent, stretch_layout

    _check_lever_values(levers, values)
    h = table.horizontal
    vals = {v.name: (v.start if v.fixed else (values or {}).get(v.name, v.start))
            for v in levers}
    change = {k: float(v) for k, v in vals.items() if k in TABLE_LEVERS and getattr(h, k) != v}
    out = table
    if change:
        out = dataclasses.replace(table, horizontal=dataclasses.replace(h, **change))
    ext = layout_extent(table)
    lay = [float(vals.get(k, e)) for k, e in zip(LAYOUT_LEVERS, ext, strict=True)]
    if any(abs(v - e) > 1e-12 * e for v, e in zip(lay, ext, strict=True)):
        out = stretch_layout(out, *lay)
    if any(is_position_lever(k) for k in vals):  # free positions (docs/table.md, s. 15)
        from isodesign.table.layout import with_positions

        xy = [[vals[n] for n in position_lever_names(table.n_isolators)[2 * i: 2 * i + 2]]
              for i in range(table.n_isolators)]
        if not np.array_equal(np.asarray(xy, float), table.isolators_m):
            out = with_positions(out, xy)
    groups = [dict(g) for g in table.group_springs]
    for k, v in vals.items():
        if k in GROUP_SPRING_LEVERS:
            g, base = group_lever(k)
            groups[g][base] = float(v)
    if groups != list(table.group_springs):
        out = dataclasses.replace(out, group_springs=groups)
    base = vals.get("inertia_base_mass_kg")
    if base is not None and table.inertia_base is not None and base != table.inertia_base.mass_kg:
        from isodesign.table.inertia_base import with_base_mass

        out = with_base_mass(out, float(base))
    return out


def _check_lever_values(levers, values, require=()) -> None:
    """``values`` a dict whose levers (the other names are the spring's) are finite numbers,
    holding every name of ``require``: InputError naming ``values[name]``."""
    if values is None and not require:
        return
    if not isinstance(values, dict):
        raise InputError(f"values: expected a dict of lever values by name (SI), got "
                         f"{type(values).__name__} {values!r:.40}")
    missing = [n for n in require if n not in values]
    if missing:
        raise InputError(f"values: the free lever {missing[0]} has no value; give every free "
                         f"lever ({', '.join(require)})")
    known = {v.name for v in levers}
    for k in values:  # a lever's name this study lacks, or a typo of one: not ignored
        if k not in known and k not in DESIGN_VARIABLES and (
                k in CODESIGN_LEVERS or k in GROUP_SPRING_LEVERS or difflib.get_close_matches(
                    str(k), (*CODESIGN_LEVERS, *GROUP_SPRING_LEVERS), n=1, cutoff=0.8)):
            raise InputError(f"values: unknown name {k!r}; this study's levers: "
                             f"{', '.join(sorted(known)) or 'none'}")
    for v in levers:
        x = values.get(v.name)
        if x is not None and not _finite_number(x):
            raise InputError(f"values[{v.name!r}]: expected a finite number, got {_short(x)}")
        if x is None:
            continue
        if not v.fixed:  # a fixed lever keeps its start (table_at's contract)
            _check_lever_value(v.name, float(x))


def _check_lever_value(name: str, x: float) -> None:
    """One lever's value where its element is physical and plausible (named
    ``values[name]``): a horizontal lever's sign and plausible range, a group's spring
    field in the models' domain."""
    from isodesign.domain import DESIGN_DOMAIN
    from isodesign.table.study import _HORIZONTAL

    key = f"values[{name!r}]"
    if name in TABLE_LEVERS:
        _horizontal_sign(key, name, x)
        hi, slip = _HORIZONTAL[name][1], _HORIZONTAL[name][3]
        if abs(x) > hi:
            hint = f"; a unit slip? {name} is in m, and {x:g} mm would be {x * 1e-3:g} m" \
                if slip is not None else ""
            raise InputError(f"{key} = {x:g} is outside the plausible range of "
                             f"table.horizontal.{name}, |value| <= {hi:g}{hint}")
    elif is_position_lever(name) and abs(x) > LAYOUT_PLAUSIBLE_M:  # an isolator's x or y
        raise InputError(f"{key} = {x:g} m is outside the plausible range of a table's "
                         f"footprint (+-{LAYOUT_PLAUSIBLE_M:g} m); a unit slip? {x:g} mm "
                         f"would be {x * 1e-3:g} m")
    elif name in GROUP_SPRING_LEVERS:
        lo, hi, unit = DESIGN_DOMAIN[group_lever(name)[1]]
        if not lo <= x <= hi:
            raise InputError(f"{key} = {x:g} is outside the models' domain [{lo:g}, {hi:g}]"
                             f"{' ' + unit if unit else ''}")


def fixed_lever_changes(table, levers, values: dict) -> dict:
    """The ``Study.with_changes`` tables that fix the free levers at ``values``: the
    horizontal element's in ``[table.horizontal]``, a stretched layout's isolators in
    ``table.isolators_m`` (and ``payload.spacing_m``), every free lever ``fixed = true``.

    Parameters
    ----------
    table : Table
    levers : sequence of VariableSpec
    values : dict
        Lever values by name, SI.
    """
    from isodesign.table.study import narrowest_spacing_m

    free = [v.name for v in levers if v.free]
    _check_lever_values(levers, values, require=free)
    t = table_with_levers(table, levers, values)
    out = {"table": {"horizontal": {k: float(values[k]) for k in free if k in TABLE_LEVERS}},
           "variables": {k: {"fixed": True, "start": float(values[k])} for k in free
                         if not is_position_lever(k)}}
    if any(is_position_lever(k) for k in free):  # the positions: the table's isolators
        out["variables"][POSITION_LEVER] = {"fixed": True, "start": t.isolators_m.tolist()}
    if t.group_springs != table.group_springs:  # each group's own spring
        out["table"]["group_springs"] = [dict(g) for g in t.group_springs]
    if "inertia_base_mass_kg" in free:
        out["table"]["inertia_base"] = {"mass_kg": float(values["inertia_base_mass_kg"])}
    if t.isolators_m is not table.isolators_m:
        out["table"]["isolators_m"] = t.isolators_m.tolist()
        out["payload"] = {"spacing_m": narrowest_spacing_m(t)}
    return out


def check_load_range(where: str, constraints: dict) -> None:
    """``constraints.min_isolator_load_n`` below ``max_isolator_load_n`` when both are given.

    Parameters
    ----------
    where : str
    constraints : dict
        The parsed constraints.
    """
    lo, hi = constraints.get("min_isolator_load_n"), constraints.get("max_isolator_load_n")
    if lo and hi and not lo < hi:
        raise InputError(f"{where}: constraints.min_isolator_load_n ({lo:g} N) must be below "
                         f"max_isolator_load_n ({hi:g} N)")


def footprint_bounds(where: str, value):
    """``constraints.footprint_m``: the rectangle ``[[x_min, y_min], [x_max, y_max]]`` (m,
    table frame) every isolator stands in; false or absent: none.

    Parameters
    ----------
    where : str
        The study's source, for errors.
    value : object
        The key's value.

    Returns
    -------
    tuple of 4 float or None
        ``(x_min, y_min, x_max, y_max)``.
    """
    if value is False or value is None:
        return None
    key = f"{where}: constraints.footprint_m"
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        a = None
    if isinstance(value, str) or a is None or a.shape != (2, 2) or \
            not np.all(np.isfinite(a)) or _has_bool(value) or _has_str(value):
        raise InputError(f"{key}: expected [[x_min, y_min], [x_max, y_max]] in m (the "
                         f"rectangle the isolators stand in), got {value!r:.60}")
    if not (a[0, 0] < a[1, 0] and a[0, 1] < a[1, 1]):
        raise InputError(f"{key}: need x_min < x_max and y_min < y_max, got {a.tolist()}")
    big = float(np.max(np.abs(a)))
    if big > LAYOUT_PLAUSIBLE_M:
        raise InputError(f"{key}: a coordinate of {big:g} m is outside the plausible range of "
                         f"a table's footprint (+-{LAYOUT_PLAUSIBLE_M:g} m); a unit slip? "
                         f"footprint_m is in m, and {big:g} mm would be {big * 1e-3:g} m")
    return tuple(float(v) for v in a.ravel())


def _has_bool(value) -> bool:
    """A boolean anywhere in a nested list (TOML true/false where a number belongs)."""
    if isinstance(value, bool | np.bool_):
        return True
    return isinstance(value, list | tuple) and any(_has_bool(v) for v in value)


def _finite_number(v) -> bool:
    """A finite real number (not a boolean; a 400-digit integer is not finite as a float)."""
    if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real):
        return False
    try:
        return math.isfinite(float(v))
    except OverflowError:
        return False


def _short(v) -> str:
    """``repr(v)`` for a message, at most 40 characters (a huge integer by its size)."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) > 10**15:
        return f"an integer of {len(str(abs(v)))} digits"
    return f"{v!r:.40}"


def _has_str(value) -> bool:
    """A string anywhere in a nested list (a TOML string where a number belongs)."""
    if isinstance(value, str | bytes):
        return True
    return isinstance(value, list | tuple) and any(_has_str(v) for v in value)


def check_layout_feasible(table, levers, constraints: dict, where: str) -> None:
    """A free layout's constraints must be reachable within its levers' bounds.

    The layout is stretched about the CG (``x_i = c_x + s_x a_i``), so each axis's stretch
    ``s`` that keeps every isolator in ``constraints.footprint_m`` is an interval; with the
    levers' bounds it must not be empty, and at its largest stretch the closest two
    isolators must be ``constraints.min_isolator_distance_m`` apart (the distances grow with
    the stretch). A fixed layout is checked as it stands (``lever_geometry.layout_rows``),
    when the study is read, so every entry point refuses it.

    Parameters
    ----------
    table : Table
    levers : sequence of VariableSpec
        ``Study.levers``.
    constraints : dict
        The parsed constraints.
    where : str
        The study's source, for errors.

    Raises
    ------
    InputError
        Naming ``constraints.footprint_m`` or ``constraints.min_isolator_distance_m``.
    """
    from isodesign.table.layout import layout_extent

    spec = {v.name: v for v in levers if v.name in LAYOUT_LEVERS}
    if any(is_position_lever(v.name) for v in levers):
        return  # free positions: their rows (table.study.parse_position_lever checked them)
    if not any(v.free for v in spec.values()):  # a fixed layout: checked as it stands
        if constraints.get("footprint_m") or constraints.get("min_isolator_distance_m"):
            from isodesign.table.lever_geometry import layout_rows

            c = dict(constraints)  # within a solver's tolerance: a co-designed optimum on
            if c.get("footprint_m"):  # its bound, fixed by Study.with_levers_fixed, stays
                x0, y0, x1, y1 = c["footprint_m"]
                c["footprint_m"] = (x0 - LAYOUT_TOL_M, y0 - LAYOUT_TOL_M, x1 + LAYOUT_TOL_M,
                                    y1 + LAYOUT_TOL_M)
            if c.get("min_isolator_distance_m"):
                c["min_isolator_distance_m"] = c["min_isolator_distance_m"] - LAYOUT_TOL_M
            t = table_with_levers(table, levers)
            try:
                layout_rows(t, c, (1.0, 1.0), False)
            except InputError:
                try:  # the message of the study's own bounds
                    layout_rows(t, constraints, (1.0, 1.0), False)
                except InputError as exc:
                    raise InputError(f"{where}: {exc}") from None
        return
    fp, dmin = constraints.get("footprint_m"), constraints.get("min_isolator_distance_m")
    c = np.asarray(table.cg_m[:2], float)
    off = np.asarray(table.isolators_m, float) - c
    smax = []
    for ax, (name, e0) in enumerate(zip(LAYOUT_LEVERS, layout_extent(table), strict=True)):
        v = spec[name]
        lo, hi = v.lower / e0, v.upper / e0
        if fp:
            b0, b1 = fp[ax], fp[ax + 2]
            for a in off[:, ax]:
                if a > 0:
                    lo, hi = max(lo, (b0 - c[ax]) / a), min(hi, (b1 - c[ax]) / a)
                elif a < 0:
                    lo, hi = max(lo, (b1 - c[ax]) / a), min(hi, (b0 - c[ax]) / a)
                elif not b0 <= c[ax] <= b1:
                    lo, hi = 1.0, 0.0
            if not lo <= hi:
                raise InputError(
                    f"{where}: constraints.footprint_m: no {name} in its bounds "
                    f"[{v.lower:g}, {v.upper:g}] m keeps every isolator inside "
                    f"{'xy'[ax]} {b0:g}..{b1:g} m (the layout is stretched about the CG at "
                    f"{'xy'[ax]} = {c[ax]:g} m); widen the footprint or the lever's bounds")
        smax.append(hi)
    if dmin:
        n = off.shape[0]
        d = min(float(np.hypot(smax[0] * (off[i, 0] - off[j, 0]),
                               smax[1] * (off[i, 1] - off[j, 1])))
                for i in range(n) for j in range(i + 1, n))
        if d < dmin:
            raise InputError(
                f"{where}: constraints.min_isolator_distance_m = {dmin:g} m, but the closest "
                f"two isolators are at most {d:.4g} m apart with the layout levers' bounds"
                f"{' and constraints.footprint_m' if fp else ''}; lower it or widen them")


def refuse_free_levers(study, what: str) -> None:
    """Refuse a question not yet answered with a table's levers free (one line, the key).

    Parameters
    ----------
    study : Study
    what : str
        The entry point (``"yield"``, ``"robust design"``).

    Raises
    ------
    InputError
        Naming the first free lever's ``variables.<name>.fixed``.
    """
    free = [POSITION_LEVER if is_position_lever(v.name) else v.name  # as typed
            for v in getattr(study, "levers", ()) if v.free]
    if free:
        raise InputError(f"variables.{free[0]}.fixed: {what} of a table with free co-design "
                         "levers is not available yet (docs/table.md, section 13); fix the "
                         "levers at the co-designed values (fixed = true, start = value)")
