"""The symmetric table of a ``[payload]``: every study's physics is the table model.

A study without ``[table]`` is the symmetric table its ``[payload]`` describes
(docs/table.md, section 14): :func:`payload_table` (the one constructor) on
:func:`symmetric_layout`; :func:`study_table` and :func:`study_floor_axes` give any
study's table and floor per axis.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from isodesign.errors import InputError
from isodesign.table.layout import (
    DEFAULT_SUPPLY_PRESSURE_PA,
    MAX_TABLE_ISOLATORS,
    Table,
    box_inertia,
)

__all__ = ["DEFAULT_PAYLOAD_CG_HEIGHT_M", "DEFAULT_PAYLOAD_SPACING_M", "payload_table",
           "study_floor_axes", "study_table", "symmetric_layout"]

#: The symmetric table's isolator spacing when a ``Payload`` gives none, m (the built-in
#: vertical study's ``payload.spacing_m``; the vertical answer does not depend on it).
DEFAULT_PAYLOAD_SPACING_M = 1.2
#: Its CG height when a ``Payload`` gives none, m (the built-in study's ``cg_height_m``).
DEFAULT_PAYLOAD_CG_HEIGHT_M = 0.35


def symmetric_layout(n: int, spacing_m: float) -> np.ndarray:
    """Positions of ``n`` isolators ``spacing_m`` apart, centroid at the origin, shape (n, 2).

    Even ``n``: two rows (``y = +-s/2``) of ``n/2`` isolators a pitch ``s`` apart along x
    (``n = 2``: one isolator on each side of the CG along y; ``n = 4``: the square of side
    ``s``; 6: 2 x 3; 8: 2 x 4). Odd ``n``: the regular ``n``-gon of side ``s`` (``n = 1``:
    one isolator under the CG; 3: the equilateral triangle with one side parallel to x).
    Every layout has its centroid at the origin and is symmetric about the y axis, and
    about the x axis or (odd ``n >= 3``) isotropic: its second moments ``sum x y = 0``, so
    its principal axes are x and y. The narrowest distance between two isolators is ``s``.

    Parameters
    ----------
    n : int
        Number of isolators (>= 1).
    spacing_m : float
        Narrowest centre-to-centre spacing, m.

    Returns
    -------
    ndarray (n, 2)
    """
    s = float(spacing_m)
    if n % 2 == 0:
        cols = n // 2
        x = (np.arange(cols) - 0.5 * (cols - 1)) * s
        xy = np.array([(xi, -0.5 * s) for xi in x] + [(xi, 0.5 * s) for xi in x[::-1]])
    elif n == 1:
        xy = np.zeros((1, 2))
    else:  # the regular n-gon of side s, a vertex on -y (one side parallel to x)
        r = s / (2.0 * math.sin(math.pi / n))
        ang = -0.5 * math.pi + 2.0 * math.pi * np.arange(n) / n
        xy = r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        xy -= xy.mean(axis=0)  # exactly centred (rounding)
    xy[np.abs(xy) < 1e-15 * max(s, 1.0)] = 0.0
    return xy


def payload_table(payload, *, piston_area_m2: float | None = None, horizontal=None,
                  instrument_points_m=None, point_names=None,
                  supply_pressure_pa: float | None = None) -> Table:
    """The symmetric table a ``[payload]`` describes (the one constructor).

    Its isolators stand on :func:`symmetric_layout` (``payload.isolators`` isolators
    ``payload.spacing_m`` apart, centroid under the CG), its CG ``payload.cg_height_m``
    above the support plane, its mass and gravity the payload's, its inertia that of a
    homogeneous box over the isolators' span (x and y) and twice the CG height (z), the
    default leveling groups (every isolator carries ``m g / n``: the leveling gives every
    isolator the vertical model's ``p0``), the default horizontal element and its
    instrument point the CG. A payload without ``spacing_m`` or ``cg_height_m`` takes
    :data:`DEFAULT_PAYLOAD_SPACING_M` and :data:`DEFAULT_PAYLOAD_CG_HEIGHT_M`. Its
    vertical (z) motion under a vertical floor is the vertical model's exactly
    (docs/table.md, section 14).

    Parameters
    ----------
    payload : Payload
        Mass, isolators, spacing, CG height, gravity.
    piston_area_m2 : float, optional
        The isolators' piston area: the supply pressure is raised to the leveled ``p0``
        when the default supply (6 bar gauge) would not carry it (the vertical study has
        no supply: its limit is ``constraints.max_pressure_pa``).
    horizontal : HorizontalElement, optional
        Default :class:`~isodesign.table.layout.HorizontalElement` (it moves nothing under
        a vertical floor).
    instrument_points_m, point_names : optional
        Default the CG.
    supply_pressure_pa : float, optional
        Default :data:`~isodesign.table.layout.DEFAULT_SUPPLY_PRESSURE_PA` (raised as above).

    Returns
    -------
    Table

    Raises
    ------
    InputError
        ``payload.isolators`` below 3 (one or two isolators are on one line: a rigid table
        on them has no rocking stiffness about it) or above the table's limit.
    """
    from isodesign.response.isolator import Payload

    if not isinstance(payload, Payload):
        raise InputError(f"payload: expected an isodesign Payload, got {type(payload).__name__}")
    if horizontal is None and instrument_points_m is None and point_names is None:
        return _payload_table(payload, piston_area_m2, supply_pressure_pa)
    return _build_payload_table(payload, piston_area_m2, horizontal, instrument_points_m,
                                point_names, supply_pressure_pa)


@functools.lru_cache(maxsize=64)
def _payload_table(payload, piston_area_m2, supply_pressure_pa) -> Table:
    """:func:`payload_table` of the defaults, built once per payload (a Table is immutable)."""
    return _build_payload_table(payload, piston_area_m2, None, None, None, supply_pressure_pa)


def _build_payload_table(payload, piston_area_m2, horizontal, instrument_points_m, point_names,
                         supply_pressure_pa) -> Table:
    from isodesign.spring.gas import P_ATM

    n = payload.isolators
    if n < 3:
        raise InputError(f"payload.isolators = {n}: a rigid table needs at least 3 isolators "
                         "off one line (on one or two it has no rocking stiffness about their "
                         "line); the vertical analysis of 1 or 2 isolators is the table's z "
                         "DOF alone (docs/table.md, section 14)")
    if n > MAX_TABLE_ISOLATORS:
        raise InputError(f"payload.isolators = {n}: the table model takes at most "
                         f"{MAX_TABLE_ISOLATORS} isolators")
    s = DEFAULT_PAYLOAD_SPACING_M if payload.spacing_m is None else payload.spacing_m
    h = DEFAULT_PAYLOAD_CG_HEIGHT_M if payload.cg_height_m is None else payload.cg_height_m
    xy = symmetric_layout(n, s)
    span = np.ptp(xy, axis=0)
    supply = DEFAULT_SUPPLY_PRESSURE_PA if supply_pressure_pa is None else supply_pressure_pa
    if piston_area_m2 is not None:
        p0 = P_ATM + payload.load_per_isolator_n / float(piston_area_m2)
        supply = max(supply, p0 * (1.0 + 1e-9))
    kw = {"horizontal": horizontal} if horizontal is not None else {}
    return Table(mass_kg=payload.mass_kg, isolators_m=xy, cg_m=(0.0, 0.0, h),
                 inertia_kg_m2=box_inertia(payload.mass_kg, (span[0], span[1], 2.0 * h)),
                 instrument_points_m=instrument_points_m, point_names=point_names,
                 supply_pressure_pa=supply, g_m_s2=payload.g_m_s2, **kw)  # fmt: skip


def study_table(study, values: dict | None = None) -> Table:
    """The table a study's physics is: its ``[table]`` (levers at ``values``), or the
    symmetric table of its ``[payload]`` (:func:`payload_table`).

    Parameters
    ----------
    study : Study
    values : dict, optional
        Lever values of a ``[table]`` study (:meth:`Study.table_at`).

    Returns
    -------
    Table
    """
    if study.table is not None:
        return study.table_at(values)
    return payload_table(study.payload, piston_area_m2=study.hardware["piston_area_m2"])


def study_floor_axes(study):
    """The floor per axis of a study: its ``[floor]`` with ``[floor.x]``/``[floor.y]``, or
    for a study without ``[table]`` its vertical floor alone (horizontal floors off: a
    study without ``[table]`` cannot give them).

    Parameters
    ----------
    study : Study

    Returns
    -------
    TableFloor
    """
    from isodesign.table.floor import table_floor

    if study.floor_axes is not None:
        return study.floor_axes
    return table_floor(study.floor, x=False, y=False)
