"""The ``[table]`` of a study file.

Schema (docs/table.md, section 8)::

    [table]
    isolators_m = [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]]   # (x, y), m
    cg_m = [0.0, 0.0, 0.35]            # z: height above the support plane, m
    inertia_kg_m2 = [100.0, 150.0, 200.0]   # principal values, or a 3x3 tensor
    # box_m = [1.5, 1.0, 0.7]          # instead: a homogeneous box's edges
    leveling_groups = [[1, 2], [3], [4]]    # isolator numbers (from 1) per valve
    instrument_points_m = [[0.0, 0.0, 0.6]]
    point_names = ["column"]
    supply_pressure_pa = 701325.0      # absolute
    objective_axes = ["x", "y", "z"]   # the axes and points the worst-margin objective
    objective_points = ["column"]      # judges (default all; the verdict is over all)
    [table.horizontal]
    pendulum_length_m = 0.15           # false: no pendulum
    lateral_stiffness_n_per_m = 1.0e4
    lateral_loss_factor = 0.1
    elastic_centre_height_m = 0.0
    [table.leveling]                   # the valves as a dynamic model (docs/table.md, s. 12)
    gain_kg_s_per_m = 0.02             # linear region: mass flow per metre of height error
    dead_band_m = 1.0e-5
    saturation_flow_kg_s = 1.0e-3
    line_resistance_pa_s_per_kg = 1.0e6
    sensor_positions_m = [[0.0, -0.4], [0.6, 0.4], [-0.6, 0.4]]   # default the centroids
    fed_chamber = "top"
    [table.inertia_base]               # a slab under the payload (docs/table.md, s. 16)
    mass_kg = 0.0                      # its mass (the lever variables.inertia_base_mass_kg)
    density_kg_m3 = 2400.0             # concrete
    size_m = [1.5, 1.0]                # plan size; default box_m's, else the isolators' extent
    top_height_m = 0.0                 # its top face above the support plane

The mass and gravity are the ``[payload]``'s; ``payload.isolators`` must match.
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.errors import InputError, did_you_mean
from isodesign.table.layout import HorizontalElement, Table, box_inertia, check_numbers

__all__ = [
    "POSITION_KEYS",
    "TABLE_KEYS",
    "narrowest_spacing_m",
    "objective_selection",
    "parse_base_lever",
    "parse_position_lever",
    "payload_from_table",
    "position_polygon",
    "table_from_dict",
    "table_unit_slips",
]

#: Keys of ``[table]`` and ``[table.horizontal]``.
TABLE_KEYS = {
    "table": {"isolators_m", "cg_m", "inertia_kg_m2", "box_m", "leveling_groups",
              "instrument_points_m", "point_names", "supply_pressure_pa", "horizontal",
              "objective_axes", "objective_points", "leveling", "group_springs",
              "inertia_base"},
    "table.horizontal": {"pendulum_length_m", "lateral_stiffness_n_per_m",
                         "lateral_loss_factor", "elastic_centre_height_m"},
}


def _keys(d, table: str, where: str) -> None:
    if not isinstance(d, dict):
        raise InputError(f"{where}: [{table}] must be a table")
    for k in d:
        if k not in TABLE_KEYS[table]:
            raise InputError(f"{where}: unknown key {k!r} in [{table}]"
                             f"{did_you_mean(k, TABLE_KEYS[table])}; valid: "
                             f"{', '.join(sorted(TABLE_KEYS[table]))}")


#: Keys of ``[table]`` that hold numbers (nested lists of them).
_NUMERIC = ("isolators_m", "cg_m", "inertia_kg_m2", "box_m", "instrument_points_m")

#: Physical limits of a table's lengths, m: beyond them no table exists (an error); within
#: them but above the plausible limit, a warning names the likely unit slip (mm typed as m).
LENGTH_LIMIT_M = 1000.0
LENGTH_PLAUSIBLE_M = 20.0
#: Smallest plausible span of a table's isolators, m.
SPAN_PLAUSIBLE_M = 0.05
#: Plausible and physical ranges of the ``[table.horizontal]`` numbers (low, high,
#: hard high, the unit slip's name and factor).
_HORIZONTAL = {
    "pendulum_length_m": (1e-3, 3.0, LENGTH_LIMIT_M, ("mm", 1e-3, "m")),
    "lateral_stiffness_n_per_m": (1.0, 1e8, 1e12, None),
    "lateral_loss_factor": (0.0, 2.0, 100.0, None),
    "elastic_centre_height_m": (0.0, LENGTH_PLAUSIBLE_M, LENGTH_LIMIT_M, ("mm", 1e-3, "m")),
}
#: Supply pressure: plausible absolute range, Pa, and the physical limit.
_SUPPLY_PLAUSIBLE_PA = (1.5e5, 2.5e6)
_SUPPLY_LIMIT_PA = 1e8


def _check_types(d: dict) -> None:
    """Strings, booleans and tables where numbers or names belong (before any use)."""
    if "isolators_m" in d:
        v = d["isolators_m"]
        check_numbers("isolators_m", v)
        if not isinstance(v, list | tuple | np.ndarray):
            raise InputError(f"isolators_m: expected a list of (x, y) positions, m, got {v!r:.40}")
        if len(v) < 3 or not all(isinstance(r, list | tuple | np.ndarray) for r in v):
            # before leveling_groups reads its length: [] or a flat list is this key's error
            raise InputError(f"isolators_m: expected at least 3 [x, y] positions, m (one per "
                             f"isolator), got {v!r:.60}")
    for k in _NUMERIC[1:]:
        if k in d:
            check_numbers(k, d[k])
    for k in ("isolators_m", "cg_m", "instrument_points_m"):
        big = _largest(d.get(k))
        if big > LENGTH_LIMIT_M:
            raise InputError(f"{k}: every coordinate must be within +-{LENGTH_LIMIT_M:g} m (no "
                             f"table is larger), got {big:g} m")
    if "supply_pressure_pa" in d:
        v = d["supply_pressure_pa"]
        check_numbers("supply_pressure_pa", v)
        if isinstance(v, int | float) and 1.0 <= v <= 100.0:
            raise InputError(f"supply_pressure_pa: must be in (101325, {_SUPPLY_LIMIT_PA:g}] Pa "
                             f"(absolute), got {v:g}; a unit slip? {v:g} bar gauge would be "
                             f"{101325 + v * 1e5:g} Pa")
    names = d.get("point_names")
    if names is not None and (not isinstance(names, list | tuple)
                              or not all(isinstance(n, str) and n.strip() for n in names)):
        raise InputError(f"point_names: expected a list of names (non-empty strings), one per "
                         f"instrument point, got {names!r:.60}")


def _largest(v) -> float:
    """The largest magnitude in nested lists of numbers (0 for anything else)."""
    if isinstance(v, list | tuple):
        return max((_largest(x) for x in v), default=0.0)
    if isinstance(v, int | float) and not isinstance(v, bool):
        try:
            return abs(float(v))
        except OverflowError:
            return math.inf
    return 0.0


def _leveling_groups_1based(groups, n: int) -> list:
    """``leveling_groups`` as written (1-based): three lists covering 1..n once each."""
    if not isinstance(groups, list) or not all(isinstance(g, list) for g in groups):
        raise InputError("leveling_groups: expected three lists of isolator numbers (from 1), "
                         f"got {groups!r:.60}")
    for g in groups:
        for i in g:
            if isinstance(i, bool) or not isinstance(i, int) or not 1 <= i <= n:
                raise InputError(f"leveling_groups: isolator numbers run from 1 to {n}, "
                                 f"got {i!r:.40}")
    if len(groups) != 3:
        raise InputError(f"leveling_groups: expected three groups (three leveling valves), got "
                         f"{len(groups)}")
    if any(not g for g in groups):
        raise InputError("leveling_groups: a group has no isolator")
    flat = sorted(i for g in groups for i in g)
    if flat != list(range(1, n + 1)):
        missing = sorted(set(range(1, n + 1)) - set(flat))
        twice = sorted({i for i in flat if flat.count(i) > 1})
        what = "; ".join(s for s in (
            f"missing {', '.join(map(str, missing))}" if missing else "",
            f"listed twice {', '.join(map(str, twice))}" if twice else "") if s)
        raise InputError(f"leveling_groups: every isolator 1..{n} must be in exactly one "
                         f"group ({what}), got {groups}")
    return [[i - 1 for i in g] for g in groups]


def _check_limits(t: Table, h: dict, inertia_key: str = "inertia_kg_m2") -> None:
    """Hard errors beyond any real table (a length of a kilometre, a loss factor of 1e30)."""
    lengths = (("isolators_m", t.isolators_m), ("cg_m", t.cg_m),
               ("instrument_points_m", t.instrument_points_m))
    for key, a in lengths:
        big = float(np.max(np.abs(a)))
        if big > LENGTH_LIMIT_M:
            raise InputError(f"{key}: every coordinate must be within +-{LENGTH_LIMIT_M:g} m "
                             f"(no table is larger), got {big:g} m")
    r_g = float(np.sqrt(np.linalg.eigvalsh(t.inertia_kg_m2)[-1] / t.mass_kg))
    if r_g > LENGTH_LIMIT_M:
        raise InputError(f"{inertia_key}: the radius of gyration sqrt(I/m) = {r_g:.3g} m is "
                         f"beyond any table (at most {LENGTH_LIMIT_M:g} m); box_m or "
                         "inertia_kg_m2 in another unit?")
    for k, (_lo, _hi, hard, _slip) in _HORIZONTAL.items():
        v = h.get(k)
        if isinstance(v, int | float) and not isinstance(v, bool) and abs(v) > hard:
            raise InputError(f"horizontal.{k}: must be within +-{hard:g} (no isolator's is "
                             f"larger), got {v:g}")
    if t.supply_pressure_pa > _SUPPLY_LIMIT_PA:
        raise InputError(f"supply_pressure_pa: must be in ({101325:g}, {_SUPPLY_LIMIT_PA:g}] Pa "
                         f"(absolute), got {t.supply_pressure_pa:g}")


def table_unit_slips(t: Table, raw: dict | None = None, where: str = "") -> list[str]:
    """Messages for the table geometry that is valid but implausible (a unit slip, named).

    Lengths above 20 m (millimetres typed as metres: a CG 350 m high), an inertia whose
    radius of gyration does not fit the table's size, a pendulum metres long, a supply
    pressure in bar or above any compressor's.

    Parameters
    ----------
    t : Table
        The validated table.
    raw : dict, optional
        The ``[table]`` table as written (for ``[table.horizontal]``).
    where : str
        Prefix of each message (the study file).

    Returns
    -------
    list of str
        One message per implausible key, naming it as ``table.<key>``.
    """
    head = f"{where}: " if where else ""
    out = []
    for key, a in (("isolators_m", t.isolators_m), ("cg_m", t.cg_m),
                   ("instrument_points_m", t.instrument_points_m)):
        if raw is not None and key not in raw:
            continue
        big = float(np.max(np.abs(a)))
        if big > LENGTH_PLAUSIBLE_M:
            out.append(f"{head}table.{key} has a coordinate of {big:g} m, outside the plausible "
                       f"range of a table (+-{LENGTH_PLAUSIBLE_M:g} m); a unit slip? {key} is in "
                       f"m, and {big:g} mm would be {big * 1e-3:g} m")
    iso_span = float(np.ptp(t.isolators_m, axis=0).max())
    if (raw is None or "isolators_m" in raw) and iso_span < SPAN_PLAUSIBLE_M:
        out.append(f"{head}table.isolators_m spans {iso_span:g} m, below the plausible span of "
                   f"a table's isolators ({SPAN_PLAUSIBLE_M:g} m); isolators_m is in m")
    span = max(iso_span, abs(t.cg_height_m), 1e-3)
    # the radius of gyration of any body about its CG is within its size; a table's is
    # about a third of its span: far below (kg mm^2? grams?) or far above is a slip
    r_g = float(np.sqrt(np.linalg.eigvalsh(t.inertia_kg_m2)[-1] / t.mass_kg))
    if raw is None or "inertia_kg_m2" in raw or "box_m" in raw:
        key = "inertia_kg_m2" if raw is None or "inertia_kg_m2" in raw else "box_m"
        if r_g > 5.0 * span or r_g < span / 300.0:
            out.append(f"{head}table.{key} gives a radius of gyration sqrt(I/m) = {r_g:.3g} m "
                       f"for a table whose isolators span {span:.3g} m (plausible "
                       f"{span / 300:.3g} to {5 * span:.3g} m); a unit slip (mm, kg mm^2) or "
                       "the inertia of another mass?")
    h = (raw or {}).get("horizontal", {}) if raw is not None else t.horizontal.to_dict()
    for k, (lo, hi, _hard, slip) in _HORIZONTAL.items():
        v = h.get(k) if isinstance(h, dict) else None
        if isinstance(v, bool) or not isinstance(v, int | float):
            continue
        if (abs(v) > hi) or (0 < abs(v) < lo):
            msg = (f"{head}table.horizontal.{k} = {v:g} is outside its plausible range "
                   f"[{lo:g}, {hi:g}]")
            if slip is not None and abs(v) > hi:
                msg += f"; a unit slip? {k} is in m, and {v:g} mm would be {v * 1e-3:g} m"
            out.append(msg)
    if raw is None or "supply_pressure_pa" in raw:
        p = t.supply_pressure_pa
        lo, hi = _SUPPLY_PLAUSIBLE_PA
        if not lo <= p <= hi:
            out.append(f"{head}table.supply_pressure_pa = {p:g} Pa is outside the plausible "
                       f"range of a leveling valve's supply [{lo:g}, {hi:g}] Pa (absolute)")
    return out


def table_from_dict(d: dict, mass_kg: float, g_m_s2: float, where: str = "<dict>") -> Table:
    """A :class:`~isodesign.table.layout.Table` from a study's ``[table]``.

    Parameters
    ----------
    d : dict
        The ``[table]`` table (leveling groups one-based).
    mass_kg : float
        The payload's mass, kg.
    g_m_s2 : float
        Gravity.
    where : str
        The study file (errors start with it).

    Raises
    ------
    InputError
        Naming ``table.<key>``.
    """
    _keys(d, "table", where)
    h = d.get("horizontal", {})
    _keys(h, "table.horizontal", where)
    for req in ("isolators_m", "cg_m"):
        if req not in d:
            raise InputError(f"{where}: table.{req} is required")
    if ("inertia_kg_m2" in d) == ("box_m" in d):
        raise InputError(f"{where}: [table] give inertia_kg_m2 or box_m (exactly one)")
    try:
        _check_types(d)
        inertia = d["inertia_kg_m2"] if "inertia_kg_m2" in d else box_inertia(mass_kg, d["box_m"])
        groups = d.get("leveling_groups")
        if groups is not None:
            groups = _leveling_groups_1based(groups, len(d["isolators_m"]))
        pend = h.get("pendulum_length_m", 0.15)
        if pend is False:
            pend = None
        hor = HorizontalElement(
            pendulum_length_m=pend,
            lateral_stiffness_n_per_m=h.get("lateral_stiffness_n_per_m", 1.0e4),
            lateral_loss_factor=h.get("lateral_loss_factor", 0.1),
            elastic_centre_height_m=h.get("elastic_centre_height_m", 0.0),
        )
        kw = {}
        for k in ("supply_pressure_pa", "instrument_points_m", "point_names", "group_springs"):
            if k in d:
                kw[k] = d[k]
        t = Table(mass_kg=mass_kg, isolators_m=d["isolators_m"], cg_m=d["cg_m"],
                  inertia_kg_m2=inertia, leveling_groups=groups, horizontal=hor,
                  g_m_s2=g_m_s2, **kw)  # fmt: skip
        objective_selection(d, t)
        _check_limits(t, h, "box_m" if "box_m" in d else "inertia_kg_m2")
    except InputError as exc:
        msg = str(exc)
        if msg.startswith(("horizontal:", "pendulum_length_m", "lateral_", "elastic_")):
            raise InputError(f"{where}: table.horizontal.{msg.removeprefix('horizontal: ')}") \
                from None
        if msg.startswith("box_m"):
            raise InputError(f"{where}: table.{msg}") from None
        raise InputError(f"{where}: table.{msg}") from None
    t = _with_base(d, t, where)
    if "leveling" in d:  # validated here (its errors name table.leveling.<key>)
        from isodesign.table.leveling import leveling_from_dict

        leveling_from_dict(d["leveling"], t, where)
    return t


def _with_base(d: dict, t: Table, where: str) -> Table:
    """The table with its inertia base (``[table.inertia_base]``; a slab of 0 kg when the
    study has none, so the lever ``inertia_base_mass_kg`` can free it): default plan size
    ``box_m``'s, else the isolators' extent (docs/table.md, section 16)."""
    import dataclasses

    from isodesign.table.inertia_base import (
        MASS_RATIO_MAX,
        SIZE_RANGE_M,
        base_from_dict,
        with_base_mass,
    )
    from isodesign.table.layout import layout_extent

    size = tuple(float(v) for v in d["box_m"][:2]) if "box_m" in d else layout_extent(t)
    lo, hi = SIZE_RANGE_M
    if "inertia_base" not in d and not all(lo <= v <= hi for v in size):
        return t  # no slab declared and no slab's plan size to default to (a unit slip?)
    base = base_from_dict(d.get("inertia_base", {}), size, where)
    if base.mass_kg > MASS_RATIO_MAX * t.mass_kg:
        raise InputError(f"{where}: table.inertia_base.mass_kg = {base.mass_kg:g} kg is outside "
                         f"[0, {MASS_RATIO_MAX * t.mass_kg:g}] kg (0 to {MASS_RATIO_MAX:g} "
                         f"times the payload's {t.mass_kg:g} kg)")
    t = dataclasses.replace(t, inertia_base=dataclasses.replace(base, mass_kg=0.0))
    return with_base_mass(t, base.mass_kg) if base.mass_kg else t


def objective_selection(d: dict, table: Table) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """``(axes, points)`` indices the worst-margin objective judges (``[table]``'s
    ``objective_axes`` and ``objective_points``; default every axis and point).

    Parameters
    ----------
    d : dict
        The ``[table]`` table.
    table : Table
        Its points' names.
    """
    axes = d.get("objective_axes", ["x", "y", "z"])
    pts = d.get("objective_points", list(table.point_names))
    if not isinstance(axes, list) or not axes or any(a not in ("x", "y", "z") for a in axes):
        raise InputError(f"objective_axes: a non-empty list of x, y, z; got {axes!r:.60}")
    if not isinstance(pts, list) or not pts or any(p not in table.point_names for p in pts):
        raise InputError(f"objective_points: a non-empty list of point_names "
                         f"({', '.join(table.point_names)}); got {pts!r:.60}")
    return (tuple(sorted({"xyz".index(a) for a in axes})),
            tuple(sorted({table.point_names.index(p) for p in pts})))


def narrowest_spacing_m(table: Table) -> float:
    """Smallest distance between two isolators, m (the 1-DOF payload's ``spacing_m``).

    Parameters
    ----------
    table : Table
    """
    xy = table.isolators_m
    d = np.linalg.norm(xy[:, None] - xy[None], axis=-1)
    return float(np.min(d[np.triu_indices(len(xy), 1)]))


#: Relative tolerance within which a ``[payload]`` length agrees with the ``[table]``'s.
PAYLOAD_AGREEMENT = 0.01


def payload_from_table(payload: dict, given, table: Table, where: str = "") -> dict:
    """The ``[payload]``'s geometry keys checked against the ``[table]``, or taken from it.

    The table model uses the ``[table]``'s geometry (and the ``[payload]``'s mass and
    gravity). A ``[payload]`` geometry key the user gave must agree with it:
    ``isolators`` with the number of ``table.isolators_m``, ``cg_height_m`` with the height
    in ``table.cg_m`` and ``spacing_m`` with a distance between two isolators (within 1 %).
    A key not given (a default) never conflicts: it takes the table's value (``spacing_m``
    the narrowest distance between two isolators). A table whose lengths are implausible
    (a unit slip, warned by :func:`table_unit_slips`) is not compared on its lengths.

    Parameters
    ----------
    payload : dict
        The resolved ``[payload]`` table.
    given : collection of str
        The ``[payload]`` keys the user gave.
    table : Table
        The validated table.
    where : str
        Prefix of the error (the study file).

    Returns
    -------
    dict
        ``payload`` with ``isolators``, ``spacing_m`` and ``cg_height_m`` set.

    Raises
    ------
    InputError
        A given key that disagrees with the table, naming both keys.
    """
    head = f"{where}: " if where else ""
    out = dict(payload)
    xy = table.isolators_m
    dist = np.linalg.norm(xy[:, None] - xy[None], axis=-1)[np.triu_indices(len(xy), 1)]
    slipped = (float(np.max(np.abs(xy))) > LENGTH_PLAUSIBLE_M
               or float(np.ptp(xy, axis=0).max()) < SPAN_PLAUSIBLE_M)
    n = payload.get("isolators")
    if "isolators" in given and n != table.n_isolators:
        raise InputError(f"{head}payload.isolators = {n} but table.isolators_m lists "
                         f"{table.n_isolators} isolators: [payload] and [table] disagree "
                         "(the table model uses table.isolators_m; drop payload.isolators "
                         "or make them agree)")
    out["isolators"] = table.n_isolators
    h = payload.get("cg_height_m")
    tz = float(table.cg_height_m)
    if table.inertia_base is not None and table.inertia_base.mass_kg:  # table.cg_m as written
        from isodesign.table.inertia_base import payload_body

        tz = float(payload_body(table)[1])
    if ("cg_height_m" in given and h is not None and abs(tz) <= LENGTH_PLAUSIBLE_M
            and _num_ok(h) and abs(h - tz) > PAYLOAD_AGREEMENT * max(abs(tz), 1e-3)):
        raise InputError(f"{head}payload.cg_height_m = {h:g} m but table.cg_m puts the centre "
                         f"of gravity {tz:g} m above the support plane: [payload] and [table] "
                         "disagree (the table model uses table.cg_m; drop "
                         "payload.cg_height_m or make them agree)")
    if "cg_height_m" not in given and tz > 0:
        out["cg_height_m"] = tz
    s = payload.get("spacing_m")
    if ("spacing_m" in given and s is not None and not slipped and _num_ok(s)
            and not np.any(np.abs(dist - s) <= PAYLOAD_AGREEMENT * dist)):
        raise InputError(f"{head}payload.spacing_m = {s:g} m is no distance between two "
                         f"isolators of table.isolators_m (narrowest {float(dist.min()):.4g} m, "
                         f"widest {float(dist.max()):.4g} m): [payload] and [table] disagree "
                         "(the table model uses table.isolators_m; drop payload.spacing_m "
                         "or make them agree)")
    if "spacing_m" not in given:
        out["spacing_m"] = float(dist.min())
    return out


def _num_ok(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def parse_base_lever(spec: dict, table, key: str, hardware: dict | None = None,
                     constraints: dict | None = None) -> tuple:
    """``[variables.inertia_base_mass_kg]``: ``(start, lower, upper, fixed)``.

    Fixed unless ``fixed = false``, at ``table.inertia_base.mass_kg`` (default 0: no slab)
    or its own ``start``; free within ``lower`` (default 0) and ``upper`` (default twice
    the payload's mass, or the heaviest slab the supply carries if lighter:
    :func:`~isodesign.table.statics.supply_limited_mass_kg`), both in ``[0, 50 m_payload]``;
    an ``upper`` above the supply's limit is refused (a drawn start there could not be
    leveled).

    Parameters
    ----------
    spec : dict
        The table as written (``fixed``, ``start``, ``lower``, ``upper``).
    table : Table
        The study's table (its slab at its start).
    key : str
        ``<file>: variables.inertia_base_mass_kg``, for errors.
    hardware : dict, optional
        The study's ``[hardware]`` (the piston area the supply limit follows from).
    constraints : dict, optional
        The study's ``[constraints]`` (``supply_margin_pa``).
    """
    from isodesign.table.inertia_base import MASS_RATIO_MAX
    from isodesign.table.statics import supply_limited_mass_kg

    fixed = spec.get("fixed", True)
    if not isinstance(fixed, bool):
        raise InputError(f"{key}.fixed: expected true or false, got {fixed!r:.40}")
    b = table.inertia_base
    if b is None and fixed and not spec.get("start"):
        return 0.0, 0.0, 0.0, True  # no slab (the table has no slab's plan size)
    if b is None:
        raise InputError(f"{key}: the table has no [table.inertia_base] and its box_m (or "
                         "its isolators' extent) is no slab's plan size; give "
                         "table.inertia_base.size_m")
    mp = table.mass_kg - b.mass_kg
    hi_max = MASS_RATIO_MAX * mp
    vals = {}
    for k in ("start", "lower", "upper"):
        if k in spec:
            v = spec[k]
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise InputError(f"{key}.{k}: expected a finite number, got {v!r:.40}")
            if not 0.0 <= v <= hi_max:
                raise InputError(f"{key}.{k} = {v:g} kg is outside [0, {hi_max:g}] kg (0 to "
                                 f"{MASS_RATIO_MAX:g} times the payload's {mp:g} kg)")
            vals[k] = float(v)
    start = vals.get("start", b.mass_kg)
    cap = math.inf
    if hardware is not None and not fixed:
        margin = (constraints or {}).get("supply_margin_pa") or 0.0
        cap = supply_limited_mass_kg(table, hardware["piston_area_m2"], margin)
        if "upper" in vals and vals["upper"] > cap:
            raise InputError(f"{key}.upper = {vals['upper']:g} kg is above {cap:.5g} kg, the "
                             "heaviest slab the supply carries (table.supply_pressure_pa minus "
                             "constraints.supply_margin_pa, every group's p0 on its pistons)")
    if fixed:
        if start != b.mass_kg:  # the table holds a fixed slab (every entry point reads it)
            raise InputError(f"{key}.start ({start:g} kg) differs from the fixed slab's "
                             f"table.inertia_base.mass_kg ({b.mass_kg:g} kg): set the mass "
                             "there, or free the lever (fixed = false)")
        if not vals.get("lower", start) <= start <= vals.get("upper", start):
            raise InputError(f"{key}.start ({start:g}) is fixed outside its own bounds [lower, "
                             f"upper] = [{vals.get('lower', start):g}, "
                             f"{vals.get('upper', start):g}] kg")
        return start, start, start, True
    lo, hi = vals.get("lower", 0.0), vals.get("upper", min(2.0 * mp, cap))
    if not lo < hi:
        raise InputError(f"{key}: need 0 <= lower < upper, got lower = {lo:g}, upper = {hi:g} kg")
    if not lo <= start <= hi:
        raise InputError(f"{key}.start ({start:g}) must lie in [lower, upper] = [{lo:g}, "
                         f"{hi:g}] kg")
    return start, lo, hi, False


#: Keys of ``[variables.isolator_positions_m]`` (docs/table.md, section 15).
POSITION_KEYS = ("fixed", "start", "polygon_m")
#: A fixed layout is inside its footprint and its minimum distance within this, m (an
#: optimum on a row, within the solver's tolerance, written back by ``with_levers_fixed``).
POSITION_TOL_M = 1e-6
#: The free positions' variable boxes: the polygon's bounding box widened by this fraction
#: of its span on each side (the polygon's rows bind, not the boxes).
POSITION_BOX_MARGIN = 0.01


def position_polygon(spec: dict, constraints: dict, key: str):
    """The footprint polygon of the free positions: ``polygon_m`` of
    ``[variables.isolator_positions_m]``, else ``constraints.footprint_m``'s rectangle, else
    None (checked by :func:`~isodesign.table.lever_geometry.footprint_polygon`).

    Parameters
    ----------
    spec : dict
        ``[variables.isolator_positions_m]`` as written.
    constraints : dict
        The parsed constraints.
    key : str
        ``<file>: variables.isolator_positions_m``, for errors.
    """
    from isodesign.table.lever_geometry import footprint_polygon

    if spec.get("polygon_m") is not None:
        return footprint_polygon(f"{key}.polygon_m", spec["polygon_m"], LENGTH_PLAUSIBLE_M)
    fp = (constraints or {}).get("footprint_m")
    if fp:
        x0, y0, x1, y1 = fp
        return footprint_polygon("constraints.footprint_m",
                                 [[x0, y0], [x1, y0], [x1, y1], [x0, y1]], LENGTH_PLAUSIBLE_M)
    return None


def parse_position_lever(spec: dict, table, key: str, constraints: dict | None = None,
                         layout_free: bool = False) -> tuple:
    """``[variables.isolator_positions_m]``: free isolator positions inside a footprint
    polygon with a minimum distance between isolators (docs/table.md, section 15).

    Fixed unless ``fixed = false`` (at ``table.isolators_m``); free, every isolator's x and
    y is a lever (:func:`~isodesign.table.lever_geometry.position_lever_names`) bounded by
    the polygon's bounding box, started at ``start`` (default ``table.isolators_m``), and the
    NLP keeps each isolator inside ``polygon_m`` (a convex polygon, m; default
    ``constraints.footprint_m``'s rectangle) and ``constraints.min_isolator_distance_m``
    from every other.

    Parameters
    ----------
    spec : dict
        The table as written (``fixed``, ``start``, ``polygon_m``).
    table : Table
    key : str
        ``<file>: variables.isolator_positions_m``, for errors.
    constraints : dict, optional
        The parsed constraints (``footprint_m``, ``min_isolator_distance_m``).
    layout_free : bool
        A layout lever (``layout_length_m``, ``layout_width_m``) is free: refused with free
        positions (the positions already hold the layout).

    Returns
    -------
    tuple of (name, start, lower, upper, fixed)
        Empty with the positions fixed (the table's own, checked against the polygon and
        the distance).

    Raises
    ------
    InputError
        Naming the key as typed and its valid range.
    """
    from isodesign.table.lever_geometry import (
        max_spacing_bound_m,
        point_in_polygon,
        position_lever_names,
    )

    if not isinstance(spec, dict):
        raise InputError(f"{key}: expected a table (fixed, start, polygon_m), got {spec!r:.40}")
    for k in spec:
        if k not in POSITION_KEYS:
            raise InputError(f"{key}: unknown key {k!r}{did_you_mean(k, POSITION_KEYS)}; valid: "
                             f"{', '.join(POSITION_KEYS)}")
    fixed = spec.get("fixed", True)
    if not isinstance(fixed, bool):
        raise InputError(f"{key}.fixed: expected true or false, got {fixed!r:.40}")
    c = constraints or {}
    n = table.n_isolators
    xy0 = np.asarray(table.isolators_m, float)
    xy = xy0
    if "start" in spec:
        s = spec["start"]
        ok = isinstance(s, list | tuple) and len(s) == n and all(
            isinstance(p, list | tuple) and len(p) == 2 and all(_num_ok(v) for v in p)
            for p in s)
        if not ok:
            raise InputError(f"{key}.start: expected {n} [x, y] positions in m (one per "
                             f"isolator of table.isolators_m), got {s!r:.60}")
        xy = np.array(s, dtype=float)
    poly = position_polygon(spec, c, key)
    where = f"{key.split(': ')[-1]}.polygon_m" if spec.get("polygon_m") is not None else \
        "constraints.footprint_m"
    dmin = c.get("min_isolator_distance_m")
    if fixed:
        if not np.allclose(xy, xy0, rtol=0.0, atol=1e-12):
            raise InputError(f"{key}.start differs from table.isolators_m with the positions "
                             "fixed: set them there, or free the lever (fixed = false)")
        if poly is not None:
            clear = point_in_polygon(poly, xy)
            i = int(np.argmin(clear))
            if clear[i] < -POSITION_TOL_M:
                raise InputError(f"{where}: isolator {i + 1} (from 1) at ({xy[i, 0]:.4g}, "
                                 f"{xy[i, 1]:.4g}) m lies {-clear[i]:.3g} m outside the footprint "
                                 "polygon, and the positions are fixed (free them: "
                                 f"{key.split(': ')[-1]}.fixed = false)")
        if dmin and n > 1:
            pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
            d = [float(np.hypot(*(xy[i] - xy[j]))) for i, j in pairs]
            k = int(np.argmin(d))
            if d[k] < dmin - POSITION_TOL_M:
                raise InputError(f"constraints.min_isolator_distance_m: isolators "
                                 f"{pairs[k][0] + 1} and {pairs[k][1] + 1} (from 1) are "
                                 f"{d[k]:.4g} m apart, below {dmin:g} m, and the positions "
                                 "are fixed")
        return ()
    if layout_free:
        raise InputError(f"{key}: free positions already hold the layout; fix "
                         "variables.layout_length_m and layout_width_m")
    if poly is None:
        raise InputError(f"{key}.polygon_m: free positions need a footprint: give polygon_m "
                         "(a convex polygon's [x, y] vertices in m) or constraints.footprint_m")
    cg = np.asarray(table.cg_m[:2], float)
    if point_in_polygon(poly, cg[None, :])[0] <= 0.0:
        raise InputError(f"{where}: the CG's plan position ({cg[0]:g}, {cg[1]:g}) m lies "
                         "outside the footprint polygon: no layout inside it carries the table")
    if dmin:
        top = max_spacing_bound_m(poly, n)
        if dmin >= top:
            raise InputError(f"constraints.min_isolator_distance_m = {dmin:g} m cannot be met "
                             f"by {n} isolators inside {where}: valid (0, {top:.4g}) m (Oler's "
                             "bound for points in a convex polygon; docs/table.md section 15)")
    # the boxes of the scaled levers: the polygon's bounding box widened by
    # POSITION_BOX_MARGIN of its span, so the polygon's rows alone bind (their multipliers
    # are the footprint's sensitivities, lever_nlp.position_sensitivities)
    span = np.ptp(poly, axis=0)
    lo, hi = poly.min(axis=0) - POSITION_BOX_MARGIN * span, \
        poly.max(axis=0) + POSITION_BOX_MARGIN * span
    out = []
    for name, v, ax in zip(position_lever_names(n), xy.ravel(), [0, 1] * n, strict=True):
        if not lo[ax] <= v <= hi[ax]:
            raise InputError(f"{key}.start: {name} = {v:g} m lies outside the footprint's "
                             f"{'xy'[ax]} range [{lo[ax]:g}, {hi[ax]:g}] m")
        out.append((name, float(v), float(lo[ax]), float(hi[ax]), False))
    return tuple(out)


def study_footprint(study) -> tuple:
    """The footprint polygon (counter-clockwise, m; None without one) and the minimum
    distance (m or None) a study's isolators keep, for the layout's figure: the free
    positions' ``polygon_m`` (kept when a co-designed run fixes them), else
    ``constraints.footprint_m``'s rectangle.

    Parameters
    ----------
    study : Study
    """
    from isodesign.table.layout import POSITION_LEVER

    spec = ((getattr(study, "raw", None) or {}).get("variables") or {}).get(POSITION_LEVER)
    c = study.constraints or {}
    poly = position_polygon(spec if isinstance(spec, dict) else {}, c,
                            f"variables.{POSITION_LEVER}")
    return poly, c.get("min_isolator_distance_m") or None
