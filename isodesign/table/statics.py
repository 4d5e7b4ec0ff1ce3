"""Statics and three-valve leveling: each isolator's load and static pressure p0.

Three leveling valves, whatever the number of isolators: the isolators on one valve are
pneumatically connected and share one static pressure ``p_g``. With identical pistons
(area ``A_p``) each isolator of group ``g`` carries ``P_g = (p_g - p_atm) A_p``, and the three
unknowns follow from vertical force and moment equilibrium about the table's x and y axes
(docs/table.md, section 3)::

    sum_g n_g P_g          = W
    sum_g (sum_i x_i) P_g  = W x_cg
    sum_g (sum_i y_i) P_g  = W y_cg

a 3x3 system, statically determinate when the groups' centroids are not collinear. The
solution must carry load in every group (the CG inside the triangle of the groups'
centroids) and every p0 must stay below the supply pressure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.spring.gas import P_ATM
from isodesign.table.layout import Table

__all__ = ["Leveling", "level"]


@dataclass(frozen=True, eq=False)
class Leveling:
    """Static loads and pressures of a leveled table.

    Attributes
    ----------
    group_of : ndarray of int, shape (n,)
        Leveling group (0, 1, 2) of each isolator.
    group_pressure_pa : ndarray, shape (3,)
        Absolute static pressure of each group, Pa.
    group_load_n : ndarray, shape (3,)
        Load of one isolator of each group, N.
    pressure_pa : ndarray, shape (n,)
        Absolute static pressure p0 of each isolator, Pa.
    load_n : ndarray, shape (n,)
        Static vertical load W_i of each isolator, N (sum: the weight).
    piston_area_m2 : float
    supply_pressure_pa : float
    g_m_s2 : float
    """

    group_of: np.ndarray
    group_pressure_pa: np.ndarray
    group_load_n: np.ndarray
    pressure_pa: np.ndarray
    load_n: np.ndarray
    piston_area_m2: float
    supply_pressure_pa: float
    g_m_s2: float

    @property
    def mass_per_isolator_kg(self) -> np.ndarray:
        """``W_i / g``: the mass each isolator carries statically, kg."""
        return self.load_n / self.g_m_s2

    def designs(self, design) -> tuple:
        """The isolators' designs: ``design`` with each isolator's own p0.

        Parameters
        ----------
        design : SpringDesign
            The (identical) isolators' spring; its ``pressure_pa`` is replaced.
        """
        return tuple(design.replace(pressure_pa=float(p)) for p in self.pressure_pa)

    def to_frame(self):
        """One row per isolator: group (one-based, as in study files), load, p0."""
        import pandas as pd

        return pd.DataFrame({
            "isolator": np.arange(1, self.load_n.size + 1),
            "group": self.group_of + 1,
            "load_n": self.load_n,
            "pressure_pa": self.pressure_pa,
            "gauge_pressure_pa": self.pressure_pa - P_ATM,
        })  # fmt: skip


def level(table: Table, piston_area_m2: float, *, p_atm_pa: float = P_ATM) -> Leveling:
    """Group pressures and per-isolator loads of a table on three leveling valves.

    Parameters
    ----------
    table : Table
        Layout, CG, leveling groups, supply pressure.
    piston_area_m2 : float
        Effective piston area A_p of the (identical) isolators, m^2.
    p_atm_pa : float
        Ambient pressure, Pa.

    Returns
    -------
    Leveling

    Raises
    ------
    InputError
        ``cg_m`` outside the support polygon; ``leveling_groups`` not statically
        determinate (collinear group centroids) or a group without load;
        ``supply_pressure_pa`` below an isolator's p0.
    """
    if not isinstance(table, Table):
        raise InputError(f"table: expected an isodesign Table, got {type(table).__name__}")
    a_p = float(piston_area_m2)
    if not a_p > 0:
        raise InputError(f"piston_area_m2: must be > 0, got {piston_area_m2!r}")
    xy = table.isolators_m
    cx, cy = table.cg_m[:2]
    if not table.cg_inside_support():
        hull = table.support_polygon()
        raise InputError(
            f"cg_m: the centre of gravity (x, y) = ({cx:.4g}, {cy:.4g}) m lies outside the "
            f"support polygon of isolators_m (x {hull[:, 0].min():.4g} to "
            f"{hull[:, 0].max():.4g} m, y {hull[:, 1].min():.4g} to {hull[:, 1].max():.4g} m): "
            "the table tips over"
        )
    groups = table.leveling_groups
    a = np.array([[len(g) for g in groups],
                  [xy[list(g), 0].sum() for g in groups],
                  [xy[list(g), 1].sum() for g in groups]], dtype=float)  # fmt: skip
    w = table.weight_n
    rhs = np.array([w, w * cx, w * cy])
    scale = float(np.ptp(xy, axis=0).max())
    cent = np.array([xy[list(g)].mean(axis=0) for g in groups])
    u, v = cent[1] - cent[0], cent[2] - cent[0]
    area2 = u[0] * v[1] - u[1] * v[0]
    if abs(area2) < 1e-9 * scale * scale:
        raise InputError(
            "leveling_groups: the three groups' centroids are collinear, so the group "
            f"pressures are not statically determinate (groups {_shown(groups)})"
        )
    p = np.linalg.solve(a, rhs)
    for gi, pg in enumerate(p):
        if not pg > 1e-9 * w:
            raise InputError(
                f"leveling_groups: group {gi + 1} (isolators {_shown((groups[gi],))[1:-1]}) "
                f"would carry {pg:.4g} N per isolator: with cg_m at ({cx:.4g}, {cy:.4g}) m "
                "outside the triangle of the groups' centroids one valve has no load; "
                "regroup the valves or move the CG"
            )
    p_g = p_atm_pa + p / a_p
    load = p[table.group_of]
    pressure = p_g[table.group_of]
    worst = int(np.argmax(pressure))
    if pressure[worst] > table.supply_pressure_pa:
        raise InputError(
            f"supply_pressure_pa: isolator {worst + 1} needs p0 = {pressure[worst]:.5g} Pa "
            f"(absolute) to carry {load[worst]:.4g} N on A_p = {a_p:.4g} m^2, above the supply "
            f"pressure {table.supply_pressure_pa:.5g} Pa; use larger pistons or more isolators"
        )
    for arr in (p_g, p, pressure, load):
        arr.flags.writeable = False
    return Leveling(group_of=table.group_of, group_pressure_pa=p_g, group_load_n=p,
                    pressure_pa=pressure, load_n=load, piston_area_m2=a_p,
                    supply_pressure_pa=table.supply_pressure_pa,
                    g_m_s2=table.g_m_s2)  # fmt: skip


def _shown(groups) -> str:
    """Groups as the user writes them in a study file (one-based)."""
    return str([[i + 1 for i in g] for g in groups])
