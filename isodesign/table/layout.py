"""The table as a rigid body: mass, inertia, centre of gravity, isolators and instruments.

Coordinates (docs/table.md, section 1)
--------------------------------------
The *table frame* is right-handed, ``z`` up. Its origin is anywhere in the plane of the
isolators' vertical forces (the *support plane*, the diaphragms' plane): ``z = 0`` there.
Isolator positions are ``(x, y)`` in that plane; the centre of gravity ``cg_m`` and the
instrument points are ``(x, y, z)`` with ``z`` the height above the support plane.

The horizontal force of each isolator (pendulum plus diaphragm, :class:`HorizontalElement`)
acts at its *elastic centre*, ``elastic_centre_height_m`` above the support plane.

Body motion is described about the CG: ``q = (x, y, z, rx, ry, rz)`` (m, rad), small
rotations, so a body point at ``r`` from the CG moves by ``t + theta x r``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.domain import DESIGN_DOMAIN
from isodesign.errors import InputError, check_range
from isodesign.spring.gas import G_STANDARD, P_ATM

__all__ = [
    "DEFAULT_SUPPLY_PRESSURE_PA",
    "POSITION_LEVER",
    "SPRING_FIELDS",
    "HorizontalElement",
    "Table",
    "box_inertia",
    "check_numbers",
    "default_leveling_groups",
    "horizontal_stiffness",
    "is_position_lever",
    "layout_extent",
    "position_lever_names",
    "stretch_layout",
    "with_positions",
]

#: Default supply pressure of the leveling valves: 6 bar gauge (absolute, Pa).
DEFAULT_SUPPLY_PRESSURE_PA = P_ATM + 6.0e5

#: The spring fields a leveling group may hold of its own (``Table.group_springs``).
SPRING_FIELDS = ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m")

#: Most isolators a table may stand on.
MAX_TABLE_ISOLATORS = 64


def _real(name: str, v) -> float:
    if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real):
        raise InputError(f"{name}: expected a number, got {type(v).__name__} {v!r:.40}")
    try:
        v = float(v)
    except OverflowError:  # a 400-digit integer (Python, not TOML)
        v = math.inf
    if not math.isfinite(v):
        raise InputError(f"{name}: must be finite, got {v!r}")
    return v


def _leaf_error(key: str, v) -> InputError | None:
    """The error for one entry of a numeric key that is not a number (None: a number)."""
    if isinstance(v, bool):
        return InputError(f"{key}: expected a number, got the boolean {str(v).lower()}")
    if isinstance(v, str):
        return InputError(f"{key}: expected a number, got the string {v!r:.40} (write numbers "
                          "without quotes)")
    if isinstance(v, dict):
        return InputError(f"{key}: expected numbers, got a table {{...}} (write a list, "
                          "e.g. [0.0, 0.0, 0.35])")
    if not isinstance(v, int | float):
        return InputError(f"{key}: expected a number, got {type(v).__name__} {v!r:.40}")
    try:
        ok = math.isfinite(float(v))
    except OverflowError:
        ok = False
    if not ok:
        return InputError(f"{key}: every value must be finite, got {v!r:.40}")
    return None


def check_numbers(key: str, value) -> None:
    """Every entry of ``value`` (a number or nested lists) a finite number, not a string,
    boolean or table; the error names ``key``.

    Parameters
    ----------
    key : str
        The key as the user wrote it.
    value : object
        The value.
    """
    if isinstance(value, list | tuple):
        for v in value:
            check_numbers(key, v)
        return
    if isinstance(value, np.ndarray) and value.dtype.kind in "biufc":
        if value.dtype.kind == "b":
            raise InputError(f"{key}: expected numbers, got booleans")
        return
    err = _leaf_error(key, value)
    if err is not None:
        raise err


def _matrix(name: str, value, cols: int | tuple[int, ...], rows_min: int = 1) -> np.ndarray:
    """A float array of shape (n, cols), every entry finite; an error naming ``name``."""
    check_numbers(name, value)
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected rows of numbers, got {value!r:.60}") from None
    cols_ok = (cols,) if isinstance(cols, int) else cols
    if a.ndim == 1 and a.size in cols_ok and rows_min <= 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] not in cols_ok or a.shape[0] < rows_min:
        want = " or ".join(str(c) for c in cols_ok)
        raise InputError(f"{name}: expected at least {rows_min} rows of {want} numbers, got "
                         f"shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name}: every value must be finite")
    a.flags.writeable = False
    return a


def box_inertia(mass_kg: float, size_m) -> np.ndarray:
    """Inertia tensor about the CG of a homogeneous box, kg m^2.

    ``I_xx = m (b^2 + c^2)/12`` and cyclic, for a box of edges ``(a, b, c)`` along
    ``(x, y, z)``.

    Parameters
    ----------
    mass_kg : float
        Mass, kg.
    size_m : sequence of 3 float
        Edge lengths along x, y and z, m (> 0).

    Returns
    -------
    ndarray, shape (3, 3)
        Diagonal inertia tensor.
    """
    m = check_range("mass_kg", mass_kg, 0.0, None, lo_open=True, unit="kg")
    check_numbers("box_m", size_m)
    try:
        s = np.asarray(size_m, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"box_m: expected 3 edge lengths > 0 (x, y, z), m, got "
                         f"{size_m!r:.60}") from None
    if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise InputError(f"box_m: expected 3 edge lengths > 0 (x, y, z), m, got {size_m!r:.60}")
    a, b, c = s
    return np.diag([m * (b * b + c * c) / 12.0, m * (a * a + c * c) / 12.0,
                    m * (a * a + b * b) / 12.0])  # fmt: skip


def default_leveling_groups(isolators_xy) -> tuple[tuple[int, ...], ...]:
    """Three leveling-valve groups for ``n`` isolators (industry practice: three valves).

    ``n = 3``: one isolator a valve. ``n = 4``: the first two isolators share a valve (list
    them as neighbours, e.g. the rectangle's corners in order), the other two have one each.
    ``n > 4``: the isolators sorted by angle about their centroid, split into three
    contiguous arcs of nearly equal size.

    Parameters
    ----------
    isolators_xy : array_like, shape (n, 2)
        Isolator positions, m.

    Returns
    -------
    tuple of tuple of int
        Zero-based isolator indices per group.
    """
    xy = np.asarray(isolators_xy, dtype=float)
    n = xy.shape[0]
    if n == 3:
        return ((0,), (1,), (2,))
    if n == 4:
        return ((0, 1), (2,), (3,))
    c = xy.mean(axis=0)
    order = np.argsort(np.arctan2(xy[:, 1] - c[1], xy[:, 0] - c[0]), kind="stable")
    parts = np.array_split(order, 3)
    return tuple(tuple(sorted(int(i) for i in p)) for p in parts)


def horizontal_stiffness(omega, load_n, pendulum_length_m, lateral_stiffness_n_per_m,
                         lateral_loss_factor):
    """``W_i / L_p + k_lat (1 + j eta)`` of one isolator, any backend (levers as symbols).

    The one formula of :class:`HorizontalElement` without a lateral model; the table NLP
    evaluates it on CasADi symbols when the levers are design variables.

    Parameters
    ----------
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s (the result is constant in it).
    load_n : float
        The isolator's static load, N.
    pendulum_length_m : float, CasADi symbol or None
        Pendulum length, m (None: no pendulum).
    lateral_stiffness_n_per_m, lateral_loss_factor : float or CasADi symbol
        The diaphragm's lateral storage stiffness (N/m) and loss factor.

    Returns
    -------
    Cx
    """
    from isodesign.numerics.cplx import Cx

    k = lateral_stiffness_n_per_m
    lat = Cx(k + 0.0 * omega, k * lateral_loss_factor + 0.0 * omega)
    return lat + (0.0 if pendulum_length_m is None else load_n / pendulum_length_m)


def layout_extent(table) -> tuple[float, float]:
    """The isolators' extent along x and y, m: the layout levers' table values.

    ``max x_i - min x_i`` and ``max y_i - min y_i`` (a rectangle's spacings; two rows' length
    and the distance between the rows).

    Parameters
    ----------
    table : Table
    """
    xy = table.isolators_m
    return float(np.ptp(xy[:, 0])), float(np.ptp(xy[:, 1]))


def layout_scale(table, length_m, width_m) -> tuple:
    """The stretch ``(s_x, s_y)`` of the layout levers, any backend: ``length / extent_x``.

    Parameters
    ----------
    table : Table
        The table the stretch starts from.
    length_m, width_m : float or CasADi symbol
        The layout levers (the isolators' extent along x and y), m.
    """
    ex, ey = layout_extent(table)
    return length_m / ex, width_m / ey


def stretch_layout(table, length_m: float, width_m: float):
    """The table with its isolators stretched about the CG's plan position to an extent of
    ``length_m`` x ``width_m`` (docs/table.md, "The layout as design variables").

    ``x_i = c_x + s_x (x_i0 - c_x)``, ``y_i = c_y + s_y (y_i0 - c_y)``: the leveling groups,
    the CG, the instrument points and the inertia stay; so does every isolator's load (the
    moment equations of the leveling are homogeneous in the offsets from the CG).

    Parameters
    ----------
    table : Table
    length_m, width_m : float
        The isolators' extent along x and y, m (> 0).

    Returns
    -------
    Table
    """
    import dataclasses

    for name, v in (("layout_length_m", length_m), ("layout_width_m", width_m)):
        check_range(name, _real(name, v), 0.0, None, lo_open=True, unit="m")
    sx, sy = layout_scale(table, float(length_m), float(width_m))
    c = table.cg_m[:2]
    xy = c + (table.isolators_m - c) * np.array([sx, sy])
    return dataclasses.replace(table, isolators_m=xy)


#: The lever of free isolator positions: ``[variables.isolator_positions_m]``; each
#: isolator's x and y become the scalar levers :func:`position_lever_names`.
POSITION_LEVER = "isolator_positions_m"


def position_lever_names(n: int) -> tuple[str, ...]:
    """The scalar levers of ``n`` free isolator positions: ``isolator_<i>_x_m``,
    ``isolator_<i>_y_m`` (``i`` from 1), isolator by isolator.

    Parameters
    ----------
    n : int
        The number of isolators.
    """
    return tuple(f"isolator_{i + 1}_{ax}_m" for i in range(n) for ax in "xy")


def is_position_lever(name: str) -> bool:
    """``name`` is one of :func:`position_lever_names` (``isolator_<i>_<x|y>_m``).

    Parameters
    ----------
    name : str
    """
    parts = str(name).split("_")
    return (len(parts) == 4 and parts[0] == "isolator" and parts[1].isdigit()
            and parts[2] in ("x", "y") and parts[3] == "m")



def with_positions(table, xy):
    """The table with its isolators at ``xy`` (the free positions' lever, docs/table.md
    section 15): the leveling groups, the CG, the instrument points and the inertia stay;
    the loads follow (the leveling solves them again).

    Parameters
    ----------
    table : Table
    xy : array_like, shape (n, 2)
        Each isolator's position, m.
    """
    import dataclasses

    return dataclasses.replace(table, isolators_m=np.asarray(xy, dtype=float).reshape(-1, 2))


@dataclass(frozen=True)
class HorizontalElement:
    """Horizontal stiffness of one isolator: a pendulum in parallel with the diaphragm.

    ``k_h(w) = W_i / L_p + k_lat(w)``, the same in x and y, acting at the elastic centre,
    ``elastic_centre_height_m`` above the support plane. The pendulum gives the payload-
    independent frequency ``sqrt(g / L_p)``; the diaphragm's lateral stiffness is
    ``k_lat (1 + j eta)`` or a model. These are inputs (the vertical spring model says
    nothing about them): take them from the isolator's data sheet or a test.

    Parameters
    ----------
    pendulum_length_m : float or None
        Pendulum length L_p, m (> 0); ``None``: no pendulum.
    lateral_stiffness_n_per_m : float
        Storage stiffness of the diaphragm's lateral (shear) stiffness, N/m (>= 0).
    lateral_loss_factor : float
        Its loss factor eta (>= 0), frequency-independent (hysteretic).
    lateral_model : object or None
        Instead of the two above: any object with ``stiffness(omega, amplitude_m) -> Cx``
        (e.g. :class:`~isodesign.spring.diaphragm.PronyDiaphragm`, causal); it is evaluated
        at the reference amplitude 1 um.
    elastic_centre_height_m : float
        Height of the point where the horizontal force acts, above the support plane, m.
    """

    pendulum_length_m: float | None = 0.15
    lateral_stiffness_n_per_m: float = 10.0e3
    lateral_loss_factor: float = 0.1
    lateral_model: Any = None
    elastic_centre_height_m: float = 0.0

    def __post_init__(self):
        if self.pendulum_length_m is not None:
            object.__setattr__(self, "pendulum_length_m", check_range(
                "pendulum_length_m", _real("pendulum_length_m", self.pendulum_length_m),
                0.0, None, lo_open=True, unit="m"))  # fmt: skip
        for name in ("lateral_stiffness_n_per_m", "lateral_loss_factor"):
            object.__setattr__(self, name, check_range(name, _real(name, getattr(self, name)),
                                                       0.0, None))  # fmt: skip
        object.__setattr__(self, "elastic_centre_height_m",
                           _real("elastic_centre_height_m", self.elastic_centre_height_m))
        if self.lateral_model is not None and not callable(
                getattr(self.lateral_model, "stiffness", None)):
            raise InputError("lateral_model: expected an object with stiffness(omega, "
                             f"amplitude_m), got {type(self.lateral_model).__name__}")
        if self.pendulum_length_m is None and self.lateral_model is None \
                and self.lateral_stiffness_n_per_m == 0.0:
            raise InputError("horizontal: no pendulum_length_m and no lateral stiffness: the "
                             "table would have no horizontal stiffness")

    def pendulum_stiffness(self, load_n):
        """``W_i / L_p`` (N/m) for the isolator's static load ``load_n`` (0 without pendulum).

        Parameters
        ----------
        load_n : float or ndarray
            Static vertical load of the isolator, N.
        """
        if self.pendulum_length_m is None:
            return 0.0 * np.asarray(load_n, dtype=float)
        return np.asarray(load_n, dtype=float) / self.pendulum_length_m

    def lateral_stiffness(self, omega):
        """Diaphragm lateral stiffness ``k_lat(w)`` as a :class:`~isodesign.numerics.cplx.Cx`.

        Parameters
        ----------
        omega : float, ndarray or CasADi symbol
            Angular frequency, rad/s.
        """
        from isodesign.numerics.cplx import Cx, as_cx

        if self.lateral_model is not None:
            return as_cx(self.lateral_model.stiffness(omega, 1e-6))
        k = self.lateral_stiffness_n_per_m
        return Cx(k + 0.0 * omega, k * self.lateral_loss_factor + 0.0 * omega)

    def stiffness(self, omega, load_n):
        """Total horizontal complex stiffness ``W_i/L_p + k_lat(w)`` of one isolator (Cx).

        Parameters
        ----------
        omega : float, ndarray or CasADi symbol
            Angular frequency, rad/s.
        load_n : float
            The isolator's static load, N.
        """
        if self.lateral_model is None:
            return horizontal_stiffness(omega, float(load_n), self.pendulum_length_m,
                                        self.lateral_stiffness_n_per_m,
                                        self.lateral_loss_factor)
        return self.lateral_stiffness(omega) + float(self.pendulum_stiffness(load_n))

    def to_dict(self) -> dict:
        """The study-file form (``[table.horizontal]``)."""
        d = {"elastic_centre_height_m": self.elastic_centre_height_m}
        d["pendulum_length_m"] = False if self.pendulum_length_m is None \
            else self.pendulum_length_m
        if self.lateral_model is None:
            d["lateral_stiffness_n_per_m"] = self.lateral_stiffness_n_per_m
            d["lateral_loss_factor"] = self.lateral_loss_factor
        else:
            d["lateral_model"] = type(self.lateral_model).__name__
        return d


@dataclass(frozen=True, eq=False)
class Table:
    """A rigid table on ``n >= 3`` isolators with three leveling valves.

    Parameters
    ----------
    mass_kg : float
        Supported mass (table plus instrument), kg.
    isolators_m : array_like, shape (n, 2)
        Isolator positions ``(x, y)`` in the support plane, m (any origin).
    cg_m : sequence of 3 float
        Centre of gravity ``(x, y, z)``, ``z`` its height above the support plane, m.
    inertia_kg_m2 : array_like, shape (3,) or (3, 3)
        Inertia tensor about the CG in table axes, kg m^2: principal values (diagonal) or
        the full symmetric tensor (positive definite).
    leveling_groups : sequence of sequences of int, optional
        Zero-based isolator indices on each of the three leveling valves; default
        :func:`default_leveling_groups`.
    instrument_points_m : array_like, shape (k, 3), optional
        Points whose velocity is judged, ``(x, y, z)``; default the CG.
    point_names : sequence of str, optional
        A name per instrument point (default ``P1``, ``P2``, ...).
    horizontal : HorizontalElement
        The isolators' horizontal element (all isolators alike).
    supply_pressure_pa : float
        Absolute supply pressure of the leveling valves, Pa: every isolator's p0 must stay
        below it.
    g_m_s2 : float
        Gravity, m/s^2.
    group_springs : sequence of 3 dicts, optional
        Per leveling group, the spring fields (:data:`SPRING_FIELDS`) in which its isolators
        differ from the shared spring (docs/table.md, section 15); default none.
    inertia_base : InertiaBase, optional
        The slab under the payload whose mass is included in ``mass_kg``, ``cg_m`` and
        ``inertia_kg_m2`` (:mod:`isodesign.table.inertia_base`, docs/table.md section 16);
        None: no slab.
    """

    mass_kg: float
    isolators_m: Any
    cg_m: Any
    inertia_kg_m2: Any
    leveling_groups: Any = None
    instrument_points_m: Any = None
    point_names: Any = None
    horizontal: HorizontalElement = field(default_factory=HorizontalElement)
    supply_pressure_pa: float = DEFAULT_SUPPLY_PRESSURE_PA
    g_m_s2: float = G_STANDARD
    group_springs: Any = None
    inertia_base: Any = None

    def __post_init__(self):
        s = object.__setattr__
        s(self, "mass_kg", check_range("mass_kg", _real("mass_kg", self.mass_kg), 0.0, None,
                                       lo_open=True, unit="kg"))  # fmt: skip
        xy = _matrix("isolators_m", self.isolators_m, 2, rows_min=3)
        if xy.shape[0] > MAX_TABLE_ISOLATORS:
            raise InputError(f"isolators_m: at most {MAX_TABLE_ISOLATORS} isolators, got "
                             f"{xy.shape[0]}")
        d = np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=-1) + np.eye(xy.shape[0])
        if np.min(d) < 1e-6:
            i, j = np.unravel_index(int(np.argmin(d)), d.shape)
            raise InputError(f"isolators_m: isolators {min(i, j) + 1} and {max(i, j) + 1} (from "
                             "1) are at the same position")
        _check_not_collinear(xy)
        s(self, "isolators_m", xy)
        check_numbers("cg_m", self.cg_m)
        try:
            cg = np.array(self.cg_m, dtype=float)
        except (TypeError, ValueError):
            cg = None
        if cg is None or cg.shape != (3,) or not np.all(np.isfinite(cg)):
            raise InputError(f"cg_m: expected (x, y, z) in m, got {self.cg_m!r:.60}")
        cg.flags.writeable = False
        s(self, "cg_m", cg)
        check_numbers("inertia_kg_m2", self.inertia_kg_m2)
        try:
            inert = np.array(self.inertia_kg_m2, dtype=float)
        except (TypeError, ValueError):
            raise InputError("inertia_kg_m2: expected 3 principal values or a 3x3 tensor, kg "
                             f"m^2, got {self.inertia_kg_m2!r:.60}") from None
        if inert.shape == (3,):
            inert = np.diag(inert)
        if inert.shape != (3, 3) or not np.all(np.isfinite(inert)):
            raise InputError("inertia_kg_m2: expected 3 principal values or a 3x3 tensor, kg "
                             f"m^2, got shape {inert.shape}")
        if not np.allclose(inert, inert.T, rtol=1e-12, atol=1e-12 * np.abs(inert).max()):
            raise InputError("inertia_kg_m2: the tensor must be symmetric")
        ev = np.linalg.eigvalsh(inert)
        if not ev[0] > 0:
            raise InputError(f"inertia_kg_m2: must be positive definite (eigenvalues "
                             f"{', '.join(f'{v:.4g}' for v in ev)} kg m^2)")
        if ev[2] > ev[0] + ev[1] + 1e-9 * ev[2]:
            raise InputError("inertia_kg_m2: violates the triangle inequality of a rigid "
                             "body's principal moments (I3 <= I1 + I2)")
        inert.flags.writeable = False
        s(self, "inertia_kg_m2", inert)
        s(self, "leveling_groups", self._groups(xy))
        pts = self.instrument_points_m
        pts = cg[None, :] if pts is None else _matrix("instrument_points_m", pts, 3)
        s(self, "instrument_points_m", pts)
        names = self.point_names
        if names is None:
            names = tuple(f"P{i + 1}" for i in range(pts.shape[0]))
        else:
            if isinstance(names, str) or not isinstance(names, list | tuple | np.ndarray) or \
                    not all(isinstance(v, str) for v in names):
                raise InputError(f"point_names: expected a list of {pts.shape[0]} names "
                                 f"(strings), got {names!r:.60}")
            names = tuple(str(v) for v in names)
            if len(names) != pts.shape[0] or len(set(names)) != len(names):
                raise InputError(f"point_names: expected {pts.shape[0]} distinct names, got "
                                 f"{list(names)!r:.80}")
        s(self, "point_names", names)
        if not isinstance(self.horizontal, HorizontalElement):
            raise InputError(f"horizontal: expected a HorizontalElement, got "
                             f"{type(self.horizontal).__name__}")
        s(self, "supply_pressure_pa", check_range(
            "supply_pressure_pa", _real("supply_pressure_pa", self.supply_pressure_pa), P_ATM,
            None, lo_open=True, unit="Pa"))  # fmt: skip
        s(self, "group_springs", _group_springs(self.group_springs))
        if self.inertia_base is not None:
            from isodesign.table.inertia_base import InertiaBase

            if not isinstance(self.inertia_base, InertiaBase):
                raise InputError(f"inertia_base: expected an InertiaBase, got "
                                 f"{type(self.inertia_base).__name__}")
            if not self.inertia_base.mass_kg < self.mass_kg:
                raise InputError(f"inertia_base: the slab's {self.inertia_base.mass_kg:g} kg "
                                 f"must be part of mass_kg ({self.mass_kg:g} kg)")
        s(self, "g_m_s2", check_range("g_m_s2", _real("g_m_s2", self.g_m_s2), 0.0, 100.0,
                                      lo_open=True, unit="m/s^2"))  # fmt: skip

    def _groups(self, xy) -> tuple[tuple[int, ...], ...]:
        n = xy.shape[0]
        g = self.leveling_groups
        if g is None:
            return default_leveling_groups(xy)
        try:
            groups = tuple(tuple(int(i) for i in grp) for grp in g)
            ok_types = all(isinstance(i, numbers.Integral) and not isinstance(i, bool)
                           for grp in g for i in grp)  # fmt: skip
        except TypeError:
            raise InputError("leveling_groups: expected three lists of isolator indices") \
                from None
        if not ok_types:
            raise InputError("leveling_groups: isolator indices must be integers")
        if len(groups) != 3:
            raise InputError(f"leveling_groups: expected three groups (three leveling valves), "
                             f"got {len(groups)}")
        flat = [i for grp in groups for i in grp]
        if any(len(grp) == 0 for grp in groups):
            raise InputError("leveling_groups: a group has no isolator")
        if sorted(flat) != list(range(n)):
            raise InputError(f"leveling_groups: every isolator 0..{n - 1} (zero-based indices "
                             "here; a study file numbers them from 1) must be in exactly one "
                             f"group, got {[list(grp) for grp in groups]}")
        return tuple(tuple(sorted(grp)) for grp in groups)

    # -- derived -------------------------------------------------------------
    @property
    def n_isolators(self) -> int:
        """Number of isolators."""
        return int(self.isolators_m.shape[0])

    @property
    def weight_n(self) -> float:
        """``m g``, N."""
        return self.mass_kg * self.g_m_s2

    @property
    def cg_height_m(self) -> float:
        """Height h of the CG above the support plane, m."""
        return float(self.cg_m[2])

    @property
    def group_of(self) -> np.ndarray:
        """Leveling group (0, 1, 2) of each isolator."""
        out = np.empty(self.n_isolators, dtype=int)
        for gi, grp in enumerate(self.leveling_groups):
            out[list(grp)] = gi
        return out

    @property
    def vertical_points_m(self) -> np.ndarray:
        """Points of the vertical forces relative to the CG, shape (n, 3): ``(x-cx, y-cy, -h)``."""
        r = np.zeros((self.n_isolators, 3))
        r[:, :2] = self.isolators_m - self.cg_m[:2]
        r[:, 2] = -self.cg_m[2]
        return r

    @property
    def horizontal_points_m(self) -> np.ndarray:
        """Elastic centres (horizontal forces) relative to the CG, shape (n, 3)."""
        r = self.vertical_points_m.copy()
        r[:, 2] += self.horizontal.elastic_centre_height_m
        return r

    @property
    def instrument_points_from_cg_m(self) -> np.ndarray:
        """Instrument points relative to the CG, shape (k, 3)."""
        return self.instrument_points_m - self.cg_m

    @property
    def mass_matrix(self) -> np.ndarray:
        """6x6 rigid-body mass matrix about the CG, ``diag(m, m, m, I)``, order
        (x, y, z, rx, ry, rz)."""
        m = np.zeros((6, 6))
        m[:3, :3] = self.mass_kg * np.eye(3)
        m[3:, 3:] = self.inertia_kg_m2
        return m

    def support_polygon(self) -> np.ndarray:
        """Convex hull of the isolators, counter-clockwise vertices, shape (k, 2)."""
        return _convex_hull(self.isolators_m)

    def cg_inside_support(self) -> bool:
        """True when the CG's (x, y) lies strictly inside the support polygon."""
        return _inside(self.support_polygon(), self.cg_m[:2])

    @classmethod
    def symmetric(cls, mass_kg: float, spacing_x_m: float, spacing_y_m: float,
                  cg_height_m: float, *, size_m=None, **kwargs) -> Table:
        """Four isolators at the corners of a rectangle, CG over its centre.

        Parameters
        ----------
        mass_kg : float
            Mass, kg.
        spacing_x_m, spacing_y_m : float
            Centre-to-centre spacings along x and y, m.
        cg_height_m : float
            CG height above the support plane, m.
        size_m : sequence of 3 float, optional
            Box dimensions for the inertia (default the spacings and twice the CG height).
        **kwargs
            Further :class:`Table` fields (``inertia_kg_m2`` overrides the box).
        """
        for name, v in (("spacing_x_m", spacing_x_m), ("spacing_y_m", spacing_y_m),
                        ("cg_height_m", cg_height_m)):
            _real(name, v)
        a, b = 0.5 * spacing_x_m, 0.5 * spacing_y_m
        xy = [(-a, -b), (a, -b), (a, b), (-a, b)]
        if "inertia_kg_m2" not in kwargs:
            box = size_m if size_m is not None else (spacing_x_m, spacing_y_m,
                                                     2.0 * cg_height_m)
            kwargs["inertia_kg_m2"] = box_inertia(mass_kg, box)
        return cls(mass_kg=mass_kg, isolators_m=xy, cg_m=(0.0, 0.0, cg_height_m), **kwargs)

    def to_dict(self) -> dict:
        """The study-file form (``[table]``; leveling groups one-based as in the file)."""
        return {
            "mass_kg": self.mass_kg,
            "isolators_m": self.isolators_m.tolist(),
            "cg_m": self.cg_m.tolist(),
            "inertia_kg_m2": self.inertia_kg_m2.tolist(),
            "leveling_groups": [[i + 1 for i in g] for g in self.leveling_groups],
            "instrument_points_m": self.instrument_points_m.tolist(),
            "point_names": list(self.point_names),
            "supply_pressure_pa": self.supply_pressure_pa,
            "horizontal": self.horizontal.to_dict(),
        } | ({"group_springs": [dict(g) for g in self.group_springs]}
             if any(self.group_springs) else {}) | (
            {"inertia_base": self.inertia_base.to_dict()}
            if self.inertia_base is not None and self.inertia_base.mass_kg > 0 else {})


def _group_springs(value) -> tuple:
    """``group_springs``: three dicts of spring fields, each value a number > 0."""
    if value is None:
        return ({}, {}, {})
    if not isinstance(value, list | tuple) or len(value) != 3 or \
            not all(isinstance(g, dict) for g in value):
        raise InputError("group_springs: expected three tables (one per leveling group) of "
                         f"spring fields, got {value!r:.60}")
    out = []
    for k, g in enumerate(value):
        for name, v in g.items():
            if name not in SPRING_FIELDS:
                raise InputError(f"group_springs: group {k + 1}: unknown field {name!r}; "
                                 f"valid: {', '.join(SPRING_FIELDS)}")
            key = f"group_springs: group {k + 1}: {name}"
            lo, hi, unit = DESIGN_DOMAIN[name]
            check_range(key, _real(key, v), lo, hi, unit=unit)
        out.append({n: float(g[n]) for n in SPRING_FIELDS if n in g})
    return tuple(out)


def _check_not_collinear(xy: np.ndarray) -> None:
    """Isolators all on one line carry no moment about it: the table falls over."""
    c = xy - xy.mean(axis=0)
    sv = np.linalg.svd(c, compute_uv=False)
    if sv[1] <= 1e-9 * max(sv[0], 1e-300):
        nums = ", ".join(str(i + 1) for i in range(len(xy)))
        raise InputError(f"isolators_m: the isolators ({nums}, numbered from 1) all lie on one "
                         "line, so they cannot hold the table up about that line; place at "
                         "least one off it")


def _convex_hull(p: np.ndarray) -> np.ndarray:
    """Andrew's monotone chain, counter-clockwise, collinear points dropped."""
    pts = sorted(map(tuple, np.asarray(p, dtype=float)))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for q in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 0:
            lower.pop()
        lower.append(q)
    upper: list = []
    for q in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 0:
            upper.pop()
        upper.append(q)
    return np.array(lower[:-1] + upper[:-1])


def _inside(hull: np.ndarray, xy) -> bool:
    if hull.shape[0] < 3:
        return False
    x, y = float(xy[0]), float(xy[1])
    scale = float(np.ptp(hull, axis=0).max())
    for i in range(hull.shape[0]):
        (x0, y0), (x1, y1) = hull[i], hull[(i + 1) % hull.shape[0]]
        if (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0) <= 1e-12 * scale * scale:
            return False
    return True
