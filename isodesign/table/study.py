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

The mass and gravity are the ``[payload]``'s; ``payload.isolators`` must match.
"""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError
from isodesign.table.layout import HorizontalElement, Table, box_inertia

__all__ = ["TABLE_KEYS", "narrowest_spacing_m", "objective_selection", "table_from_dict"]

#: Keys of ``[table]`` and ``[table.horizontal]``.
TABLE_KEYS = {
    "table": {"isolators_m", "cg_m", "inertia_kg_m2", "box_m", "leveling_groups",
              "instrument_points_m", "point_names", "supply_pressure_pa", "horizontal",
              "objective_axes", "objective_points", "leveling"},
    "table.horizontal": {"pendulum_length_m", "lateral_stiffness_n_per_m",
                         "lateral_loss_factor", "elastic_centre_height_m"},
}


def _keys(d, table: str, where: str) -> None:
    if not isinstance(d, dict):
        raise InputError(f"{where}: [{table}] must be a table")
    for k in d:
        if k not in TABLE_KEYS[table]:
            raise InputError(f"{where}: unknown key {k!r} in [{table}]; valid: "
                             f"{', '.join(sorted(TABLE_KEYS[table]))}")


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
        inertia = d["inertia_kg_m2"] if "inertia_kg_m2" in d else box_inertia(mass_kg, d["box_m"])
        groups = d.get("leveling_groups")
        if groups is not None:
            if not isinstance(groups, list) or not all(isinstance(g, list) for g in groups):
                raise InputError("leveling_groups: expected three lists of isolator numbers")
            n = len(d["isolators_m"]) if isinstance(d["isolators_m"], list) else 0
            for g in groups:
                for i in g:
                    if isinstance(i, bool) or not isinstance(i, int) or not 1 <= i <= n:
                        raise InputError(f"leveling_groups: isolator numbers run from 1 to {n}, "
                                         f"got {i!r}")
            groups = [[i - 1 for i in g] for g in groups]
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
        for k in ("supply_pressure_pa", "instrument_points_m", "point_names"):
            if k in d:
                kw[k] = d[k]
        t = Table(mass_kg=mass_kg, isolators_m=d["isolators_m"], cg_m=d["cg_m"],
                  inertia_kg_m2=inertia, leveling_groups=groups, horizontal=hor,
                  g_m_s2=g_m_s2, **kw)  # fmt: skip
        objective_selection(d, t)
    except InputError as exc:
        msg = str(exc)
        if msg.startswith(("horizontal:", "pendulum_length_m", "lateral_", "elastic_")):
            raise InputError(f"{where}: table.horizontal.{msg.removeprefix('horizontal: ')}") \
                from None
        if msg.startswith("box_m"):
            raise InputError(f"{where}: table.{msg}") from None
        raise InputError(f"{where}: table.{msg}") from None
    if "leveling" in d:  # validated here (its errors name table.leveling.<key>)
        from isodesign.table.leveling import leveling_from_dict

        leveling_from_dict(d["leveling"], t, where)
    return t


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
