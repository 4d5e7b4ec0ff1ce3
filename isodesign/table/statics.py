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

Static stability (docs/table.md, section 7)
-------------------------------------------
The vertical springs and the gravity term act on ``(z, rx, ry)``; the horizontal springs
drop out once ``x, y, rz`` are condensed. With ``a_i, b_i`` each vertical-force point's
offset from the CG, ``k_i`` each spring's stiffness on the time scale that matters and
``s = (sum k_i b_i, -sum k_i a_i)`` the coupling of ``z`` with ``(rx, ry)``, the vertical
translation is condensed out::

    A = K_theta - s s^T / sum k_i,      K_theta = sum k_i [[b_i^2, -a_i b_i], [-a_i b_i, a_i^2]]

and the table is statically stable when ``A - W h I`` is positive definite: the critical CG
height is ``lambda_min(A) / W`` and the margin of each principal direction
``lambda_j(A) / (W h)``. :func:`condensed_rocking_stiffness` and :func:`tilt_margin_rows`
evaluate on NumPy numbers and CasADi symbols alike (the analysis and the NLP share them),
and :func:`sealed_stiffness` is a sealed spring's stiffness on a slow time scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_positive
from isodesign.spring.equations import air_stiffness, spring_stiffness
from isodesign.spring.flow_models import resistance_function
from isodesign.spring.gas import P_ATM
from isodesign.table.layout import Table

__all__ = [
    "QUASI_STATIC_FREQUENCY_HZ",
    "Leveling",
    "check_load_constraints",
    "check_scaled_loads",
    "condensed_rocking_stiffness",
    "level",
    "leveling_of_rows",
    "load_constraint_values",
    "load_rows",
    "payload_terms",
    "scaled_leveling",
    "sealed_stiffness",
    "supply_limited_mass_kg",
    "tilt_margin_rows",
]

#: The quasi-static time scale of the static verdict (valves off, springs sealed): 1 mHz,
#: a quarter of an hour. The default viscoelastic diaphragm has no static limit (its storage
#: stiffness falls as ``f^0.02``), so the time scale is stated with every verdict.
QUASI_STATIC_FREQUENCY_HZ = 1.0e-3


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
    group_springs : tuple of 3 dicts
        The table's per-group spring fields (``Table.group_springs``; empty: the shared
        spring).
    """

    group_of: np.ndarray
    group_pressure_pa: np.ndarray
    group_load_n: np.ndarray
    pressure_pa: np.ndarray
    load_n: np.ndarray
    piston_area_m2: float
    supply_pressure_pa: float
    g_m_s2: float
    group_springs: tuple = ({}, {}, {})

    @property
    def mass_per_isolator_kg(self) -> np.ndarray:
        """``W_i / g``: the mass each isolator carries statically, kg."""
        return self.load_n / self.g_m_s2

    def designs(self, design) -> tuple:
        """The isolators' designs: ``design`` with each isolator's own p0 and its leveling
        group's own spring fields (``group_springs``, docs/table.md section 15).

        Parameters
        ----------
        design : SpringDesign
            The isolators' shared spring; its ``pressure_pa`` is replaced.
        """
        return tuple(design.replace(pressure_pa=float(p), **self.group_springs[int(g)])
                     for p, g in zip(self.pressure_pa, self.group_of, strict=True))

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
    a_p = check_positive("piston_area_m2", piston_area_m2, unit="m^2")
    check_positive("p_atm_pa", p_atm_pa, unit="Pa")
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
                    g_m_s2=table.g_m_s2, group_springs=table.group_springs)  # fmt: skip


def scaled_leveling(leveling: Leveling, scale: float) -> Leveling:
    """The leveling of the same table with its weight scaled by ``scale`` (an inertia base
    centred under the CG, docs/table.md section 16): loads and gauge pressures scale.

    Parameters
    ----------
    leveling : Leveling
    scale : float
        ``m / m_start``.
    """
    import dataclasses

    p_atm = leveling.pressure_pa - leveling.load_n / leveling.piston_area_m2
    pa = float(np.mean(p_atm))
    return dataclasses.replace(
        leveling, group_load_n=leveling.group_load_n * scale, load_n=leveling.load_n * scale,
        group_pressure_pa=pa + (leveling.group_pressure_pa - pa) * scale,
        pressure_pa=pa + (leveling.pressure_pa - pa) * scale)


def load_rows(leveling: Leveling, constraints: dict, scale) -> list:
    """The load range and the supply as NLP rows when the loads follow a design variable
    (the inertia base's ``scale = m / m_start``, a CasADi symbol; docs/table.md, section 16).

    ``isolator_load_n``: every isolator's ``scale W_i`` in kN within ``[min, max]``
    (``min_isolator_load_n``, ``max_isolator_load_n``, when given);
    ``supply_pressure_pa``: every group's gauge p0 ``scale (p_g - p_atm)`` in bar at most
    ``p_supply - supply_margin_pa - p_atm`` (always: the supply is a physical limit).
    Linear in ``scale``: no division, no ``max``.

    Parameters
    ----------
    leveling : Leveling
        The start table's.
    constraints : dict
    scale : CasADi symbol

    Returns
    -------
    list of (name, expression, lower, upper)
    """
    import casadi as ca

    out = []
    lo, hi = constraints.get("min_isolator_load_n"), constraints.get("max_isolator_load_n")
    if lo or hi:
        out.append(("isolator_load_n", ca.vertcat(*[scale * float(w) / 1e3
                                                    for w in leveling.load_n]),
                    lo / 1e3 if lo else -np.inf, hi / 1e3 if hi else np.inf))
    p_atm = float(np.mean(leveling.pressure_pa - leveling.load_n / leveling.piston_area_m2))
    cap = leveling.supply_pressure_pa - (constraints.get("supply_margin_pa") or 0.0) - p_atm
    out.append(("supply_pressure_pa", ca.vertcat(*[scale * (float(p) - p_atm) / 1e5
                                                   for p in leveling.group_pressure_pa]),
                -np.inf, cap / 1e5))
    return out


def leveling_of_rows(prob, g) -> Leveling:
    """The leveling at an NLP solution: the start's scaled by the inertia base's load scale
    read from the ``supply_pressure_pa`` rows, or with free positions the groups' loads
    read from the ``group_load_kn`` rows (the start's without either).

    Parameters
    ----------
    prob : TableProblem
    g : ndarray
        The constraint values.
    """
    lv = prob.leveling
    for name, row, _m in prob.con_rows:
        if name == "group_load_kn":  # free positions: every group's load per isolator
            import dataclasses

            p = np.asarray(g[row: row + 3], float) * 1e3
            p_atm = lv.pressure_pa - lv.load_n / lv.piston_area_m2
            pg = float(np.mean(p_atm)) + p / lv.piston_area_m2
            return dataclasses.replace(lv, group_load_n=p, load_n=p[lv.group_of],
                                       group_pressure_pa=pg, pressure_pa=pg[lv.group_of])
    for name, row, _m in prob.con_rows:
        if name == "supply_pressure_pa":
            p_atm = float(np.mean(lv.pressure_pa - lv.load_n / lv.piston_area_m2))
            return scaled_leveling(lv, float(g[row]) * 1e5 / (float(lv.group_pressure_pa[0])
                                                              - p_atm))
    return lv


def check_scaled_loads(leveling: Leveling, constraints: dict, scale_range: tuple) -> None:
    """Refuse a study whose load and supply constraints no weight in ``scale_range`` meets
    (a free inertia base: the loads scale by ``m / m_start``), naming the key.

    Parameters
    ----------
    leveling : Leveling
        The start table's.
    constraints : dict
    scale_range : (float, float)
        ``m / m_start`` at the slab's lower and upper bounds.
    """
    s_lo, s_hi = scale_range
    lo, hi = constraints.get("min_isolator_load_n"), constraints.get("max_isolator_load_n")
    w = np.asarray(leveling.load_n, float)
    if hi and float(w.max()) * s_lo > hi:
        raise InputError(f"constraints.max_isolator_load_n: the heaviest isolator carries "
                         f"{float(w.max()) * s_lo:.5g} N with the lightest inertia base "
                         f"(variables.inertia_base_mass_kg.lower), above {hi:g} N")
    if lo and float(w.min()) * s_hi < lo:
        raise InputError(f"constraints.min_isolator_load_n: the lightest isolator carries "
                         f"{float(w.min()) * s_hi:.5g} N with the heaviest inertia base "
                         f"(variables.inertia_base_mass_kg.upper), below {lo:g} N")
    if lo and hi and float(w.min()) / lo > 0 and hi / float(w.max()) < lo / float(w.min()):
        raise InputError(f"constraints.min_isolator_load_n: no weight puts every isolator's "
                         f"load in [{lo:g}, {hi:g}] N (the loads' spread is the CG's and the "
                         "leveling groups', not the inertia base's)")
    margin = constraints.get("supply_margin_pa") or 0.0
    top = scaled_leveling(leveling, s_lo).group_pressure_pa.max()
    if top > leveling.supply_pressure_pa - margin:
        raise InputError(f"constraints.supply_margin_pa: a group needs p0 = {top:.5g} Pa with "
                         "the lightest inertia base (variables.inertia_base_mass_kg.lower), "
                         f"above the supply {leveling.supply_pressure_pa:.5g} Pa minus the "
                         f"margin {margin:g} Pa")


def load_constraint_values(leveling: Leveling, constraints: dict, supply: bool = False) -> list:
    """The load and supply constraints of a study on a leveled table, per isolator or group.

    ``min_isolator_load_n <= W_i <= max_isolator_load_n`` on every isolator's static load and
    ``p_g <= p_supply - supply_margin_pa`` on every group's absolute p0 (docs/table.md,
    section 14). Written on the leveling's arrays, so the same rows evaluate on the loads of
    any table (the layout's levers keep them: the stretch about the CG leaves the leveling's
    moment equations unchanged).

    Parameters
    ----------
    leveling : Leveling
    constraints : dict
        The study's constraints.
    supply : bool
        Report the supply without a margin too (an NLP row with a free inertia base).

    Returns
    -------
    list of (key, report name, values, lower, upper, unit)
        One per constraint the study sets; ``values`` per isolator (loads) or per group
        (pressures).
    """
    out = []
    lo, hi = constraints.get("min_isolator_load_n"), constraints.get("max_isolator_load_n")
    if lo or hi:
        key = "min_isolator_load_n" if lo else "max_isolator_load_n"
        out.append((key, "isolator_load", np.asarray(leveling.load_n, float), lo or None,
                    hi or None, "N"))
    margin = constraints.get("supply_margin_pa")
    if margin or supply:
        out.append(("supply_margin_pa", "supply_pressure",
                    np.asarray(leveling.group_pressure_pa, float), None,
                    float(leveling.supply_pressure_pa - (margin or 0.0)), "Pa"))
    return out


def check_load_constraints(leveling: Leveling, constraints: dict) -> None:
    """Refuse a study whose loads or p0 break its load and supply constraints, naming the key.

    No design variable moves an isolator's load yet (the springs do not, the layout's levers
    keep it), so a violated row is the study's, not the optimizer's to fix.

    Parameters
    ----------
    leveling : Leveling
    constraints : dict

    Raises
    ------
    InputError
    """
    for key, _, vals, lo, hi, unit in load_constraint_values(leveling, constraints):
        what = "isolator" if unit == "N" else "group"
        for i, v in enumerate(vals):
            if lo is not None and v < lo:
                raise InputError(f"constraints.min_isolator_load_n: isolator {i + 1} (from 1) "
                                 f"carries {v:.5g} N, below {lo:g} N; no design variable moves "
                                 "the loads (the CG, the mass and the leveling groups do)")
            if hi is not None and v > hi:
                k = "max_isolator_load_n" if unit == "N" else key
                raise InputError(f"constraints.{k}: {what} {i + 1} (from 1) needs {v:.5g} "
                                 f"{unit}, above {hi:.5g} {unit}"
                                 + (" (the supply pressure minus the margin); use larger "
                                    "pistons or more isolators" if unit == "Pa" else
                                    "; no design variable moves the loads"))


def _shown(groups) -> str:
    """Groups as the user writes them in a study file (one-based)."""
    return str([[i + 1 for i in g] for g in groups])


def sealed_stiffness(design, diaphragm, frequency_hz: float = QUASI_STATIC_FREQUENCY_HZ,
                     amplitude_m: float = 1e-6, flow: str = "quasi_steady"):
    """A sealed spring's storage stiffness on a slow time scale, any backend.

    ``Re [k_air(w) + k_D(w, X)]``: the spring model's air stiffness (Eq. 38, or the
    distributed network, which also counts the tube's own volume) for the flow model's
    small-amplitude resistance, plus the diaphragm's storage stiffness at ``f``. At the
    quasi-static frequency the air part is its low-frequency limit ``k_s/(N+1)`` to
    ``O((w tau)^2)``; the diaphragm keeps softening. The same functions the analysis's
    ``Re k*(f)`` evaluates (tests/table/test_stability_static.py holds them to 1e-9), on
    NumPy numbers and CasADi symbols (the NLP's ``min_tilt_margin``).

    Parameters
    ----------
    design : SpringDesign
        The spring at its own p0 (fields may be CasADi symbols).
    diaphragm : diaphragm model
        :func:`~isodesign.spring.diaphragm.diaphragm_model`'s object.
    frequency_hz : float
        The time scale, Hz (default :data:`QUASI_STATIC_FREQUENCY_HZ`).
    amplitude_m : float
        Stroke amplitude of the diaphragm, m (the linear regime, 1 um).
    flow : str
        The flow model (its resistance at zero tube velocity).
    """
    w = 2.0 * np.pi * float(frequency_hz)
    c = resistance_function(flow, design, w)(0.0)
    return spring_stiffness(air_stiffness(design, w, c, flow),
                            diaphragm.stiffness(w, amplitude_m)).re


def condensed_rocking_stiffness(k_vertical, points_m) -> tuple:
    """``A = K_theta - s s^T / sum k``: the rocking stiffness with ``z`` condensed out.

    Any backend: ``k_vertical`` may hold floats or CasADi symbols. The vertical spring of
    isolator ``i`` at ``(a_i, b_i, -h)`` from the CG has ``g = (0, 0, 1, b_i, -a_i, 0)``, so
    it couples ``z`` with ``rx`` by ``k_i b_i`` and with ``ry`` by ``-k_i a_i``; minimizing
    the energy over ``z`` at a given rotation leaves the Schur complement ``A``.

    Parameters
    ----------
    k_vertical : sequence
        Each isolator's vertical stiffness, N/m.
    points_m : ndarray (n, 3) or list of (a, b)
        The vertical-force points from the CG (:attr:`Table.vertical_points_m`), m; a list
        of plan offsets (floats or CasADi symbols) with free isolator positions.

    Returns
    -------
    (a11, a12, a22)
        The symmetric 2x2 on ``(rx, ry)``, N m/rad.
    """
    if isinstance(points_m, np.ndarray):
        r = np.asarray(points_m, dtype=float)
        a, b = r[:, 0].tolist(), r[:, 1].tolist()
    else:  # free positions (docs/table.md, section 15): offsets that may be symbols
        a, b = [p[0] for p in points_m], [p[1] for p in points_m]
    k = list(k_vertical)
    total = sum(k)
    s1 = sum(ki * bi for ki, bi in zip(k, b, strict=True))
    s2 = -sum(ki * ai for ki, ai in zip(k, a, strict=True))
    a11 = sum(ki * bi * bi for ki, bi in zip(k, b, strict=True)) - s1 * s1 / total
    a22 = sum(ki * ai * ai for ki, ai in zip(k, a, strict=True)) - s2 * s2 / total
    a12 = -sum(ki * ai * bi for ki, ai, bi in zip(k, a, b, strict=True)) - s1 * s2 / total
    return a11, a12, a22


def tilt_margin_rows(k_vertical, points_m, overturning_n_m: float, minimum: float,
                     scale_xy=(1.0, 1.0)) -> tuple:
    """The smooth tilt-margin condition ``A / (W h) - mu I`` positive semidefinite, any backend.

    Its two diagonal entries and its determinant, each ``>= 0`` (no eigenvalue, no ``min``):
    the NLP's ``min_tilt_margin`` rows, the same condensed ``A`` as the analysis.

    Parameters
    ----------
    k_vertical : sequence
        Each isolator's vertical stiffness, N/m (floats or CasADi symbols).
    points_m : ndarray (n, 3)
        Vertical-force points from the CG, m.
    overturning_n_m : float
        ``W h``, N m.
    minimum : float
        The bound ``mu`` on every principal margin.
    scale_xy : (float or symbol, float or symbol)
        The layout's stretch ``(s_x, s_y)`` about the CG (docs/table.md, section 15): the
        offsets ``a_i, b_i`` scale, so ``A`` scales as ``(s_y^2, s_x s_y, s_x^2)``.

    Returns
    -------
    (d11, d22, det)
    """
    a11, a12, a22 = condensed_rocking_stiffness(k_vertical, points_m)
    sx, sy = scale_xy
    if not (isinstance(sx, float) and isinstance(sy, float) and sx == sy == 1.0):
        a11, a12, a22 = a11 * sy * sy, a12 * sx * sy, a22 * sx * sx
    d11 = a11 / overturning_n_m - minimum
    d22 = a22 / overturning_n_m - minimum
    d12 = a12 / overturning_n_m
    return d11, d22, d11 * d22 - d12 * d12


def supply_limited_mass_kg(table, piston_area_m2: float, margin_pa: float = 0.0) -> float:
    """The heaviest slab the supply carries: every group's p0 at most ``p_supply -
    margin`` (the loads scale with the weight, docs/table.md section 16), kg.

    Parameters
    ----------
    table : Table
        With its slab.
    piston_area_m2 : float
    margin_pa : float
        ``constraints.supply_margin_pa`` (0: none).
    """
    lv = level(table, piston_area_m2)
    p_atm = float(np.mean(lv.pressure_pa - lv.load_n / lv.piston_area_m2))
    scale = (table.supply_pressure_pa - margin_pa - p_atm) / (float(lv.group_pressure_pa.max())
                                                              - p_atm)
    b = table.inertia_base
    return scale * table.mass_kg - (table.mass_kg - (b.mass_kg if b is not None else 0.0))


def group_loads_at(table: Table, xy) -> list:
    """Each leveling group's load per isolator with the isolators at ``xy``, any backend.

    The leveling's three equations (section 3) about the CG's plan position, ``sum_g n_g P_g
    = W``, ``sum_g S^a_g P_g = 0``, ``sum_g S^b_g P_g = 0`` with ``S^a_g = sum_{i in g} (x_i -
    c_x)`` (``S^b`` likewise in y), solved in closed form: with the rows ``r_0 = (n_g)``,
    ``r_1 = (S^a_g)``, ``r_2 = (S^b_g)`` and ``c = r_1 x r_2``, ``P = W c / (r_0 . c)``
    (``r_1 . c = r_2 . c = 0``): rational and smooth in the positions while the groups'
    centroids span a triangle (docs/table.md, section 15).

    Parameters
    ----------
    table : Table
        Its CG, weight and leveling groups (its own positions are not used).
    xy : sequence of (x, y)
        Each isolator's position, m (floats or CasADi symbols).

    Returns
    -------
    list of 3
        ``P_g``, N, groups in ``table.leveling_groups`` order.
    """
    cx, cy = float(table.cg_m[0]), float(table.cg_m[1])
    r0 = [float(len(g)) for g in table.leveling_groups]
    r1 = [sum(xy[i][0] - cx for i in g) for g in table.leveling_groups]
    r2 = [sum(xy[i][1] - cy for i in g) for g in table.leveling_groups]
    c = [r1[1] * r2[2] - r1[2] * r2[1], r1[2] * r2[0] - r1[0] * r2[2],
         r1[0] * r2[1] - r1[1] * r2[0]]
    det = r0[0] * c[0] + r0[1] * c[1] + r0[2] * c[2]
    w = float(table.weight_n)
    return [w * ck / det for ck in c]


def payload_terms(table: Table, mass_kg, cg_height_m, inertia_diag_kg_m2):
    """The payload's mass, CG height and principal inertia as the change of the table NLP's
    statics and rigid body from ``table`` (the one it was built on), any backend.

    At a fixed CG plan position the leveling's loads are ``m g`` times fractions set by the
    isolators' and the CG's plan positions alone (the force and the two moment balances,
    :func:`level`; the CG height does not enter them), so every isolator's load and gauge
    p0 scale by ``m / m_0``; the mass matrix is ``diag(m, m, m, I_xx, I_yy, I_zz)`` (the
    products of inertia fixed); the overturning term on rx and ry is ``-W h``
    (:func:`~isodesign.table.assembly.gravity_stiffness` at equilibrium); every body point's
    height from the CG drops by ``h - h_0`` (the elastic centres' and the instrument
    points'; the vertical forces' lines of action do not move). The same terms a free
    inertia base gives (:class:`~isodesign.table.inertia_base.BaseTerms`, docs/table.md
    section 16), so the NLP evaluates them on one path (docs/sweep.md, section 7).

    Parameters
    ----------
    table : Table
        The table the NLP's geometry was built on.
    mass_kg, cg_height_m : float or CasADi symbol
        The payload's mass (kg) and CG height above the support plane (m).
    inertia_diag_kg_m2 : sequence of 3 (float or CasADi symbol)
        ``I_xx, I_yy, I_zz`` about the CG, kg m^2.

    Returns
    -------
    BaseTerms
    """
    from isodesign.table.inertia_base import BaseTerms

    m0, h0, g = table.mass_kg, table.cg_height_m, table.g_m_s2
    i0 = np.diag(np.asarray(table.inertia_kg_m2, float))
    m, h = mass_kg, cg_height_m
    dm = m - m0
    return BaseTerms(load_scale=m / m0, dh=h - h0, mass=m,
                     d_mass=(dm, dm, dm, *(inertia_diag_kg_m2[j] - float(i0[j])
                                           for j in range(3))),
                     d_gravity=-(g * m * h - g * m0 * h0), weight_height=g * m * h)
