"""The inertia base: a slab under the payload, its mass a co-design lever (docs/table.md,
section 16).

A homogeneous rectangular slab of density ``rho`` and plan size ``L x W`` hangs under the
payload, centred under its CG, its top face ``top_height_m`` above the support plane (0: the
isolators carry the slab by brackets at its top face, so the slab lies below the support
plane and lowers the CG). Its mass ``m_s`` is the lever; its thickness ``t = m_s / (rho L W)``
and everything else follow (:func:`slab_body`, one function on NumPy numbers and CasADi
symbols)::

    m   = m_p + m_s
    z_s = top - t / 2                                   (the slab's CG height)
    h   = (m_p h_p + m_s z_s) / m                       (the combined CG height)
    I   = I_p + diag(m_s (W^2 + t^2) / 12, m_s (L^2 + t^2) / 12, m_s (L^2 + W^2) / 12)
          + (m_p m_s / m) (h_p - z_s)^2 diag(1, 1, 0)   (parallel axes to the combined CG)

The slab is centred under the payload's CG, so the CG's plan position stays; the leveling's
moment equations are then homogeneous in the weight and every isolator's load (and gauge
pressure) scales by ``m / m_start``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError

__all__ = ["BASE_KEYS", "BASE_LEVER", "DENSITY_RANGE_KG_M3", "InertiaBase", "base_from_dict",
           "base_lever_terms", "base_mass_row", "base_point_rows", "base_stiffness",
           "base_summary", "body_mass", "centre_shift", "load_scale",
           "payload_body", "scaled_pressures", "slab_body", "tilt_bound",
           "with_base_mass"]

#: The lever's name (``[variables.inertia_base_mass_kg]``).
BASE_LEVER = "inertia_base_mass_kg"
#: Keys of ``[table.inertia_base]``.
BASE_KEYS = ("mass_kg", "density_kg_m3", "size_m", "top_height_m")
#: Physical range of a slab's density, kg/m^3 (foam to tungsten).
DENSITY_RANGE_KG_M3 = (10.0, 25000.0)
#: Default density: concrete, kg/m^3.
CONCRETE_KG_M3 = 2400.0
#: Plan size range of a slab, m.
SIZE_RANGE_M = (0.05, 40.0)
#: Largest |top_height_m|, m.
TOP_LIMIT_M = 20.0
#: Largest slab mass as a multiple of the payload's.
MASS_RATIO_MAX = 50.0


def _num(key: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise InputError(f"{key}: expected a number, got {v!r:.40}")
    v = float(v)
    if not math.isfinite(v):
        raise InputError(f"{key}: must be finite, got {v!r}")
    return v


@dataclass(frozen=True)
class InertiaBase:
    """A slab under the payload (``[table.inertia_base]``).

    Parameters
    ----------
    mass_kg : float
        The slab's mass, kg (>= 0; 0: no slab). The lever ``inertia_base_mass_kg`` moves it.
    density_kg_m3 : float
        Its density, kg/m^3 (default concrete, 2400).
    size_m : (float, float)
        Its plan size ``(L, W)`` along x and y, m.
    top_height_m : float
        Height of its top face above the support plane, m (0: hung from brackets at its
        top face, below the support plane).
    """

    mass_kg: float = 0.0
    density_kg_m3: float = CONCRETE_KG_M3
    size_m: tuple = (1.0, 1.0)
    top_height_m: float = 0.0

    def __post_init__(self):
        m = _num("table.inertia_base.mass_kg", self.mass_kg)
        if m < 0:
            raise InputError(f"table.inertia_base.mass_kg: must be >= 0 kg, got {m:g}")
        rho = _num("table.inertia_base.density_kg_m3", self.density_kg_m3)
        lo, hi = DENSITY_RANGE_KG_M3
        if not lo <= rho <= hi:
            raise InputError(f"table.inertia_base.density_kg_m3: must be in [{lo:g}, {hi:g}] "
                             f"kg/m^3 (concrete 2400, granite 2700, steel 7850), got {rho:g}")
        s = self.size_m
        if isinstance(s, str) or not isinstance(s, list | tuple | np.ndarray) or len(s) != 2:
            raise InputError(f"table.inertia_base.size_m: expected the slab's plan size [L, W], "
                             f"m, got {s!r:.40}")
        size = tuple(_num("table.inertia_base.size_m", v) for v in s)
        lo, hi = SIZE_RANGE_M
        if not all(lo <= v <= hi for v in size):
            raise InputError(f"table.inertia_base.size_m: each side must be in [{lo:g}, {hi:g}] "
                             f"m, got {list(size)}")
        top = _num("table.inertia_base.top_height_m", self.top_height_m)
        if abs(top) > TOP_LIMIT_M:
            raise InputError(f"table.inertia_base.top_height_m: must be within +-{TOP_LIMIT_M:g}"
                             f" m, got {top:g}")
        for k, v in (("mass_kg", m), ("density_kg_m3", rho), ("size_m", size),
                     ("top_height_m", top)):
            object.__setattr__(self, k, v)

    @property
    def area_m2(self) -> float:
        """Plan area ``L W``, m^2."""
        return self.size_m[0] * self.size_m[1]

    def thickness_m(self, mass_kg=None):
        """Thickness ``m_s / (rho L W)``, m (any backend; default this slab's mass)."""
        return (self.mass_kg if mass_kg is None else mass_kg) / (self.density_kg_m3
                                                                 * self.area_m2)

    def to_dict(self) -> dict:
        """The study-file form (``[table.inertia_base]``)."""
        return {"mass_kg": self.mass_kg, "density_kg_m3": self.density_kg_m3,
                "size_m": list(self.size_m), "top_height_m": self.top_height_m}


def base_from_dict(d, default_size_m, where: str = "") -> InertiaBase:
    """``[table.inertia_base]`` validated (errors name ``table.inertia_base.<key>``).

    Parameters
    ----------
    d : dict
        The table as written.
    default_size_m : (float, float)
        The table's footprint (``box_m``'s plan size, else the isolators' extent).
    where : str
        The study file.
    """
    head = f"{where}: " if where else ""
    if not isinstance(d, dict):
        raise InputError(f"{head}[table.inertia_base] must be a table ({', '.join(BASE_KEYS)})")
    for k in d:
        if k not in BASE_KEYS:
            raise InputError(f"{head}unknown key {k!r} in [table.inertia_base]; valid: "
                             f"{', '.join(BASE_KEYS)}")
    try:
        return InertiaBase(mass_kg=d.get("mass_kg", 0.0),
                           density_kg_m3=d.get("density_kg_m3", CONCRETE_KG_M3),
                           size_m=d.get("size_m", tuple(default_size_m)),
                           top_height_m=d.get("top_height_m", 0.0))
    except InputError as exc:
        raise InputError(f"{head}{exc}") from None


def slab_body(payload_mass_kg, payload_cg_height_m, slab_mass_kg, base: InertiaBase):
    """The combined body of payload and slab, any backend (the lever as a CasADi symbol).

    Parameters
    ----------
    payload_mass_kg, payload_cg_height_m : float
        The payload alone: mass (kg) and CG height above the support plane (m).
    slab_mass_kg : float, ndarray or CasADi symbol
        The slab's mass, kg.
    base : InertiaBase
        Its density, plan size and top height.

    Returns
    -------
    (mass_kg, cg_height_m, d_inertia)
        The combined mass and CG height, and the inertia added to the payload's own about
        the combined CG, ``(dI_xx, dI_yy, dI_zz)`` (kg m^2; the products stay the payload's).
    """
    mp, hp, ms = payload_mass_kg, payload_cg_height_m, slab_mass_kg
    lx, ly = base.size_m
    t = base.thickness_m(ms)
    zs = base.top_height_m - 0.5 * t
    m = mp + ms
    h = (mp * hp + ms * zs) / m
    par = mp * ms / m * (hp - zs) ** 2
    return m, h, (ms * (ly * ly + t * t) / 12.0 + par, ms * (lx * lx + t * t) / 12.0 + par,
                  ms * (lx * lx + ly * ly) / 12.0)


def payload_body(table):
    """The payload alone (mass, CG height, inertia about its CG) of a table with its slab.

    Parameters
    ----------
    table : Table
        A table whose ``inertia_base`` (if any) is part of its mass, CG and inertia.

    Returns
    -------
    tuple
        ``(mass_kg, cg_height_m, inertia_kg_m2)`` of the payload without the slab.
    """
    b = table.inertia_base
    m, h = table.mass_kg, table.cg_height_m
    if b is None or b.mass_kg == 0.0:
        return m, h, np.asarray(table.inertia_kg_m2, float)
    mp = m - b.mass_kg
    zs = b.top_height_m - 0.5 * b.thickness_m()
    hp = (m * h - b.mass_kg * zs) / mp
    _, _, di = slab_body(mp, hp, b.mass_kg, b)
    return mp, hp, np.asarray(table.inertia_kg_m2, float) - np.diag(di)


def with_base_mass(table, mass_kg: float):
    """The table with its slab's mass at ``mass_kg`` (mass, CG height, inertia, instrument
    points unchanged in the table frame).

    Parameters
    ----------
    table : Table
        With ``inertia_base`` (its mass included in the body).
    mass_kg : float
        The slab's new mass, kg (>= 0).

    Returns
    -------
    Table
    """
    b = table.inertia_base
    if b is None:
        raise InputError("inertia_base_mass_kg: the table has no [table.inertia_base]")
    ms = _num("inertia_base_mass_kg", mass_kg)
    if ms < 0:
        raise InputError(f"inertia_base_mass_kg: must be >= 0 kg, got {ms:g}")
    if ms == b.mass_kg:
        return table
    mp, hp, ip = payload_body(table)
    nb = dataclasses.replace(b, mass_kg=ms)
    m, h, di = slab_body(mp, hp, ms, nb)
    cg = np.array(table.cg_m, float)
    cg[2] = h
    return dataclasses.replace(table, mass_kg=float(m), cg_m=cg,
                               inertia_kg_m2=ip + np.diag(np.asarray(di, float)),
                               inertia_base=nb)


@dataclass(frozen=True)
class BaseTerms:
    """The slab lever's effect on the NLP relative to the start table (any backend).

    Attributes
    ----------
    load_scale : float or symbol
        ``m / m_start``: every isolator's load and gauge pressure scales by it.
    dh : float or symbol
        ``h - h_start``, m: the CG rises by it (every body point's height from the CG
        drops by it).
    mass : float or symbol
        ``m``, kg.
    d_mass : list of 6
        ``diag(M) - diag(M_start)`` (the products of inertia do not move).
    d_gravity : float or symbol
        Change of the overturning term ``-W h`` on rx and ry, N m/rad.
    weight_height : float or symbol
        ``W h``, N m.
    """

    load_scale: object
    dh: object
    mass: object
    d_mass: tuple
    d_gravity: object
    weight_height: object


def base_lever_terms(table, slab_mass_kg) -> BaseTerms:
    """:class:`BaseTerms` at the slab mass ``slab_mass_kg`` (float or CasADi symbol) for the
    NLP built on ``table`` (the start table, its slab included).

    Parameters
    ----------
    table : Table
    slab_mass_kg : float or CasADi symbol
    """
    mp, hp, _ = payload_body(table)
    b = table.inertia_base
    m0, h0, di0 = slab_body(mp, hp, b.mass_kg, b)
    m, h, di = slab_body(mp, hp, slab_mass_kg, b)
    g = table.g_m_s2
    dm = m - m0
    return BaseTerms(load_scale=m / m0, dh=h - h0, mass=m,
                     d_mass=(dm, dm, dm, di[0] - di0[0], di[1] - di0[1], di[2] - di0[2]),
                     d_gravity=-(g * m * h - g * m0 * h0), weight_height=g * m * h)








def scaled_pressures(terms, pressure_pa) -> list:
    """Each isolator's p0 with the slab: ``p_atm + (m / m_start) (p0 - p_atm)`` (floats
    without a free slab, ``terms`` None).

    Parameters
    ----------
    terms : BaseTerms or None
    pressure_pa : sequence of float
        The start table's p0, Pa (absolute).
    """
    from isodesign.spring.gas import P_ATM

    if terms is None:
        return [float(p) for p in pressure_pa]
    return [P_ATM + terms.load_scale * (float(p) - P_ATM) for p in pressure_pa]


def tilt_bound(table, terms, minimum: float) -> tuple:
    """``(W h, mu)`` of the tilt-margin rows; with a free slab a fixed scale ``W_0
    max(|h_0|, 5 cm)`` and ``mu W h / scale``, so the rows read ``(A - mu W h I) / scale``:
    smooth through ``h = 0`` (a CG at the support plane needs no tilt stiffness).

    Parameters
    ----------
    table : Table
        The start table.
    terms : BaseTerms or None
    minimum : float
        ``constraints.min_tilt_margin``.
    """
    if terms is None:
        return table.weight_n * table.cg_height_m, minimum
    scale = table.weight_n * max(abs(table.cg_height_m), 0.05)
    return scale, minimum * terms.weight_height / scale


def base_point_rows(points: np.ndarray, terms) -> tuple[list, list]:
    """An instrument point's matrix ``G_r = [I, -[r]x]`` (3x6) with the CG raised by ``dh``
    (the inertia base, docs/table.md section 16): ``r_z`` drops by ``dh``, so ``G[0, 4] =
    r_z`` and ``G[1, 3] = -r_z`` move; the rest is constant.

    Parameters
    ----------
    points : ndarray, shape (3, 6)
        The start table's point matrix (``Geometry.points[p]``).
    terms : BaseTerms or None
        The slab's terms (its ``dh``, the CG's rise, m); None: no free slab.

    Returns
    -------
    (rows, nonzero)
        ``rows[b][r]`` float or symbol; ``nonzero[b][r]`` False for a constant 0.
    """
    rows = [[float(points[b, r]) for r in range(6)] for b in range(3)]
    if terms is not None:
        rows[0][4] = rows[0][4] - terms.dh
        rows[1][3] = rows[1][3] + terms.dh
    nz = [[not (isinstance(v, float) and v == 0.0) for v in row] for row in rows]
    return rows, nz


def base_mass_row(geo, base):
    """The mass matrix ``M`` flattened (1, 36) with the inertia base's change (a CasADi row
    when ``base`` holds symbols; :class:`~isodesign.table.inertia_base.BaseTerms`).

    Parameters
    ----------
    geo : Geometry
        The table's geometry (:func:`isodesign.table.assembly.geometry`), its mass matrix.
    base : BaseTerms or None
        The slab's terms at the design (None: the table's own mass matrix).
    """
    import casadi as ca

    m = list(geo.mass.reshape(36).tolist())
    if base is not None:
        for j in range(6):
            m[7 * j] = m[7 * j] + base.d_mass[j]
    return ca.horzcat(*m)


def base_stiffness(d, omega, base):
    """``D(w)`` flattened with the inertia base's change: the gravity term ``-W h`` on rx
    and ry and ``-w^2 M`` (:class:`~isodesign.table.inertia_base.BaseTerms`, relative to the
    start table the assembly was built on).

    Parameters
    ----------
    d : Cx
        ``D(w)`` of one frequency, (1, 36) (a CasADi row).
    omega : CasADi symbol
        The frequency, rad/s.
    base : BaseTerms or None
    """
    if base is None:
        return d
    import casadi as ca

    add = [0.0] * 36
    for j in range(6):
        add[7 * j] = -omega * omega * base.d_mass[j]
    add[21] = add[21] + base.d_gravity
    add[28] = add[28] + base.d_gravity
    from isodesign.numerics.cplx import Cx

    return Cx(d.re + ca.horzcat(*add), d.im)




def load_scale(terms):
    """``m / m_start`` (1.0 without a free slab).

    Parameters
    ----------
    terms : BaseTerms or None
        The slab's terms at the design (None: no free slab).
    """
    return 1.0 if terms is None else terms.load_scale


def body_mass(table, terms):
    """The body's mass, kg (the table's without a free slab).

    Parameters
    ----------
    table : Table
    terms : BaseTerms or None
        The slab's terms at the design (None: no free slab).
    """
    return table.mass_kg if terms is None else terms.mass


def centre_shift(shift, terms):
    """The elastic centres' shift with the slab: their height from the CG drops by ``dh``.

    Parameters
    ----------
    shift : float, CasADi expression or None
        The shift without the slab (the support-height lever's; None: no shift).
    terms : BaseTerms or None
        The slab's terms at the design (None: no free slab).
    """
    if terms is None:
        return shift
    return -terms.dh if shift is None else shift - terms.dh


def base_summary(table) -> str:
    """One line on a table's slab: mass, size, thickness, the combined mass and CG height
    (empty without a slab).

    Parameters
    ----------
    table : Table
        The table with its slab at the design's value (``Study.table_at``).
    """
    b = getattr(table, "inertia_base", None)
    if b is None or not b.mass_kg:
        return ""
    hp = payload_body(table)[1]
    lx, ly = b.size_m
    return (f"inertia base {b.mass_kg:.4g} kg ({lx:g} x {ly:g} x {b.thickness_m():.3g} m at "
            f"{b.density_kg_m3:g} kg/m^3, top {b.top_height_m:g} m): {table.mass_kg:.4g} kg "
            f"with the payload, CG {table.cg_height_m:.3g} m above the support plane (the "
            f"payload's {hp:.3g} m)")
