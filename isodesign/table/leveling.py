"""The leveling system as a dynamic model: sensors, valves, lines, chambers and the table.

Three leveling valves hold the table's height at three sensors (docs/table.md, section 12).
Each valve ``g`` reads a height sensor at its location ``(x_g, y_g)`` on the table (default
its group's centroid), feeds one chamber (``top``, the piston's, by default) of the first
isolator of its group, and lines of resistance ``R_l`` connect that chamber to the same
chamber of every other isolator of the group (slaved isolators trade air through them).

The valve's flow law (:func:`valve_flow`): outside a dead band ``d`` the opening grows
linearly with the height error ``e`` (the sensor below its reference: ``e > 0`` fills from
the supply, ``e < 0`` exhausts to the atmosphere) up to full opening at
``e = d + q_sat / G``; the mass flow is the opening times an orifice's flow per unit area
``Phi(p_up, p_down)``, choked below the critical pressure ratio and unchoked above
(isentropic nozzle). The port areas are set so that at the leveled state the linear region's
gain is ``G`` (kg/s per m) and the full-open flow ``q_sat`` in both directions: the study
gives what a data sheet gives, the orifice law how the flow changes with the pressures.

The chambers and the capillary are the spring model's lumped equations (Eq. 38 in the time
domain, :mod:`isodesign.spring.equations`): polytropic chambers ``p = p0 (m V0 / (m0 V))^n``
(``n`` the design's process index), the capillary's small-amplitude resistance ``C`` of the
flow model (its zero-velocity value, :func:`~isodesign.spring.flow_models.resistance_function`),
the top chamber's volume ``V_t0 + A_p u`` with ``u`` the isolator's stroke. The diaphragm
and the horizontal elements enter as springs with viscous damping matched at
:data:`REFERENCE_FREQUENCY_HZ` (their storage and loss there, at 1 um). The table is the
6x6 rigid body of :mod:`isodesign.table.assembly` (small motions, gravity term included).

:func:`leveling_plant` gives the linearized state-space matrices (valve flows in, sensor
heights out); :func:`simulate_leveling` integrates the nonlinear model (scipy ``solve_ivp``).
The loop analysis is :mod:`isodesign.table.leveling_loop`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_instance, check_positive
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import resistance_function
from isodesign.spring.gas import P_ATM
from isodesign.table.assembly import element_vectors
from isodesign.table.layout import Table
from isodesign.table.model import TableModel

__all__ = [
    "DEFAULT_MIN_GAIN_MARGIN_DB",
    "DEFAULT_MIN_PHASE_MARGIN_DEG",
    "LEVELING_KEYS",
    "REFERENCE_FREQUENCY_HZ",
    "LevelingPlant",
    "LevelingSimulation",
    "LevelingSystem",
    "isolator_constants",
    "leveling_from_dict",
    "leveling_margin_bounds",
    "leveling_of_study",
    "leveling_plant",
    "orifice_flux",
    "plant_matrix",
    "simulate_leveling",
    "valve_flow",
    "valve_gain_bounds",
]

#: The diaphragm's and the horizontal element's storage and loss are matched here (Hz).
REFERENCE_FREQUENCY_HZ = 1.0
#: Keys of ``[table.leveling]``.
LEVELING_KEYS = {"gain_kg_s_per_m", "dead_band_m", "saturation_flow_kg_s",
                 "line_resistance_pa_s_per_kg", "sensor_positions_m", "fed_chamber"}
_CHAMBERS = ("top", "bottom")
#: The optimizer's default bounds on the leveling loop's margins when the study has a
#: ``[table.leveling]`` (``constraints.min_leveling_gain_margin_db`` and
#: ``constraints.min_leveling_phase_margin_deg``; docs/table.md, section 12).
DEFAULT_MIN_GAIN_MARGIN_DB = 6.0
DEFAULT_MIN_PHASE_MARGIN_DEG = 45.0
#: The study keys of the two bounds and their defaults.
MARGIN_KEYS = (("min_leveling_gain_margin_db", DEFAULT_MIN_GAIN_MARGIN_DB),
               ("min_leveling_phase_margin_deg", DEFAULT_MIN_PHASE_MARGIN_DEG))


@dataclass(frozen=True)
class LevelingSystem:
    """The three leveling valves, their sensors and the lines of each group.

    Parameters
    ----------
    gain_kg_s_per_m : float
        The valve's mass flow per metre of height error in its linear region, kg/s/m (> 0).
    dead_band_m : float
        Half-width of the dead band (no flow while ``|e| <= d``), m (>= 0).
    saturation_flow_kg_s : float
        Full-open mass flow at the leveled state, kg/s (> 0).
    line_resistance_pa_s_per_kg : float
        Laminar resistance of the line from a valve's chamber to each slaved isolator's,
        Pa s/kg (> 0).
    sensor_positions_m : ndarray (3, 2) or None
        Height sensors (x, y) in the table frame, one per valve; None: the groups'
        centroids.
    fed_chamber : {'top', 'bottom'}
        The chamber the valve and the lines connect.
    """

    gain_kg_s_per_m: float = 0.02
    dead_band_m: float = 10e-6
    saturation_flow_kg_s: float = 1.0e-3
    line_resistance_pa_s_per_kg: float = 1.0e6
    sensor_positions_m: np.ndarray | None = None
    fed_chamber: str = "top"

    def __post_init__(self):
        for name, lo, closed in (("gain_kg_s_per_m", 0.0, False), ("dead_band_m", 0.0, True),
                                 ("saturation_flow_kg_s", 0.0, False),
                                 ("line_resistance_pa_s_per_kg", 0.0, False)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) \
                    or not (v >= lo if closed else v > lo):
                raise InputError(f"{name}: must be a number {'>=' if closed else '>'} {lo:g}, "
                                 f"got {v!r:.40}")
            object.__setattr__(self, name, float(v))
        if self.fed_chamber not in _CHAMBERS:
            raise InputError(f"fed_chamber: one of {', '.join(_CHAMBERS)}, got "
                             f"{self.fed_chamber!r:.40}")
        if self.sensor_positions_m is not None:
            try:
                s = np.array(self.sensor_positions_m, dtype=float)
            except (TypeError, ValueError):
                raise InputError("sensor_positions_m: expected three [x, y] pairs, m") from None
            if s.shape != (3, 2) or not np.all(np.isfinite(s)):
                raise InputError(f"sensor_positions_m: expected three [x, y] pairs (one per "
                                 f"valve), m, got shape {s.shape}")
            s.flags.writeable = False
            object.__setattr__(self, "sensor_positions_m", s)

    @property
    def linear_range_m(self) -> float:
        """Height error from the dead band's edge to full opening, ``q_sat / G``, m."""
        return self.saturation_flow_kg_s / self.gain_kg_s_per_m

    def replace(self, **kw) -> LevelingSystem:
        """A copy with some fields changed (validated again).

        Parameters
        ----------
        **kw
            Fields to change.
        """
        import dataclasses

        return dataclasses.replace(self, **kw)

    def sensors(self, table) -> np.ndarray:
        """The sensors' (x, y), m: given, or each group's centroid.

        Parameters
        ----------
        table : Table
        """
        if self.sensor_positions_m is not None:
            return np.asarray(self.sensor_positions_m)
        xy = table.isolators_m
        return np.array([xy[list(g)].mean(axis=0) for g in table.leveling_groups])


def leveling_from_dict(d, table=None, where: str = "<dict>") -> LevelingSystem:
    """A :class:`LevelingSystem` from a study's ``[table.leveling]`` (validated).

    Parameters
    ----------
    d : dict
        The table (missing keys take the defaults).
    table : Table, optional
        The table (sensors outside the support polygon's bounding box are refused).
    where : str
        The study file (errors start with it).

    Raises
    ------
    InputError
        Naming ``table.leveling.<key>`` and its valid range.
    """
    if table is not None:
        check_instance("table", table, Table, "an isodesign Table or None")
    if not isinstance(d, dict):
        raise InputError(f"{where}: [table.leveling] must be a table")
    for k in d:
        if k not in LEVELING_KEYS:
            raise InputError(f"{where}: unknown key {k!r} in [table.leveling]; valid: "
                             f"{', '.join(sorted(LEVELING_KEYS))}")
    d = dict(d)
    if isinstance(d.get("gain_kg_s_per_m"), dict):  # the valve gain as a design variable
        spec = _gain_variable(d["gain_kg_s_per_m"], where)
        d["gain_kg_s_per_m"] = spec["start"]
    try:
        lv = LevelingSystem(**d)
    except InputError as exc:
        raise InputError(f"{where}: table.leveling.{exc}") from None
    except TypeError as exc:  # pragma: no cover - keys are checked above
        raise InputError(f"{where}: [table.leveling]: {exc}") from None
    if table is not None and lv.sensor_positions_m is not None:
        xy = table.isolators_m
        lo, hi = xy.min(axis=0) - 0.5, xy.max(axis=0) + 0.5
        s = lv.sensor_positions_m
        if np.any(s < lo) or np.any(s > hi):
            raise InputError(f"{where}: table.leveling.sensor_positions_m: every sensor within "
                             f"0.5 m of the isolators (x {lo[0]:.3g} to {hi[0]:.3g}, y "
                             f"{lo[1]:.3g} to {hi[1]:.3g} m)")
    return lv


_GAIN_VARIABLE_KEYS = ("start", "lower", "upper", "fixed")


def _gain_variable(spec: dict, where: str) -> dict:
    """``table.leveling.gain_kg_s_per_m`` written as a variable: start, lower, upper, fixed."""
    key = "table.leveling.gain_kg_s_per_m"
    for k in spec:
        if k not in _GAIN_VARIABLE_KEYS:
            raise InputError(f"{where}: unknown key {k!r} in {key}; valid: "
                             f"{', '.join(_GAIN_VARIABLE_KEYS)}")
    fixed = spec.get("fixed", False)
    if not isinstance(fixed, bool):
        raise InputError(f"{where}: {key}.fixed must be true or false, got {fixed!r:.40}")
    out: dict = {"fixed": fixed}
    for k in ("start", "lower", "upper"):
        v = spec.get(k)
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) \
                or not v > 0:
            raise InputError(f"{where}: {key}.{k} must be a number > 0 (kg/s per m), got "
                             f"{v!r:.40}")
        out[k] = float(v)
    if not fixed:
        for k in ("lower", "upper"):
            if k not in out:
                raise InputError(f"{where}: {key}.{k} is required (a free valve gain needs "
                                 "lower and upper, or fixed = true)")
        if not out["lower"] < out["upper"]:
            raise InputError(f"{where}: {key}.lower must be below {key}.upper")
    start = out.get("start", LevelingSystem.gain_kg_s_per_m)
    if not fixed and "start" not in out:
        start = min(max(start, out["lower"]), out["upper"])
    if not fixed and not out["lower"] <= start <= out["upper"]:
        raise InputError(f"{where}: {key}.start ({start:g}) must lie within lower and upper")
    out["start"] = start
    return out


def valve_gain_bounds(study) -> tuple[float, float] | None:
    """``(lower, upper)`` of the valve gain when the study makes it a design variable
    (``[table.leveling] gain_kg_s_per_m = {lower, upper}``, kg/s/m); None when it is fixed.

    Parameters
    ----------
    study : Study
    """
    if not (hasattr(study, "raw") and hasattr(study, "table")):
        raise InputError(f"study: expected a Study (load_study(path)), got "
                         f"{type(study).__name__} {study!r:.40}")
    raw = ((getattr(study, "raw", None) or {}).get("table") or {}).get("leveling") or {}
    spec = raw.get("gain_kg_s_per_m")
    if not isinstance(spec, dict):
        return None
    v = _gain_variable(spec, "study")
    return None if v["fixed"] else (v["lower"], v["upper"])


def leveling_of_study(study) -> LevelingSystem:
    """The valves of a study with a ``[table]``: its ``[table.leveling]`` (or the defaults).

    The one reading every entry point uses (``isodesign stability``, the Python API).

    Parameters
    ----------
    study : Study
        With ``table`` (and ``raw``, the study file's tables).
    """
    if not (hasattr(study, "raw") and hasattr(study, "table")):
        raise InputError(f"study: expected a Study (load_study(path)), got "
                         f"{type(study).__name__} {study!r:.40}")
    if getattr(study, "table", None) is None:
        raise InputError("study: has no [table]; the leveling valves belong to a table study")
    raw = (getattr(study, "raw", None) or {}).get("table", {})
    return leveling_from_dict(raw.get("leveling", {}), study.table,
                              getattr(study, "source", None) or getattr(study, "name", "study"))


def leveling_margin_bounds(study) -> tuple[float | None, float | None]:
    """The bounds the optimizer enforces on the leveling loop's gain and phase margins.

    ``constraints.min_leveling_gain_margin_db`` and ``min_leveling_phase_margin_deg`` as the
    study gives them (validated when it was loaded); ``false`` switches a bound off. A key
    the study leaves out takes :data:`DEFAULT_MIN_GAIN_MARGIN_DB` (6 dB) and
    :data:`DEFAULT_MIN_PHASE_MARGIN_DEG` (45 deg) when the study has a ``[table.leveling]``
    (the valves are the study's), and no bound otherwise: the margins of the default valves
    are then reported, not enforced (a table whose valves nobody described is not refused
    for them).

    Parameters
    ----------
    study : Study
        With ``table`` and ``raw``.

    Returns
    -------
    (gain_db, phase_deg)
        Each a float, or None (reported, not enforced).
    """
    if not (hasattr(study, "raw") and hasattr(study, "table")):
        raise InputError(f"study: expected a Study (load_study(path)), got "
                         f"{type(study).__name__} {study!r:.40}")
    raw = getattr(study, "raw", None) or {}
    cons = raw.get("constraints") or {}
    has_valves = "leveling" in (raw.get("table") or {})
    out = []
    for key, default in MARGIN_KEYS:
        v = cons.get(key)
        if v is False:
            out.append(None)
        elif v is None:
            out.append(default if has_valves else None)
        else:
            out.append(float(v))
    return out[0], out[1]


# ---------------------------------------------------------------------------
# the valve's flow law
# ---------------------------------------------------------------------------
def orifice_flux(p_up, p_down, kappa: float, r_gas: float, t_k: float):
    """Isentropic nozzle mass flux per unit area, kg/(s m^2), choked or not (NumPy).

    ``r = p_down / p_up``; below the critical ratio ``(2/(kappa+1))^(kappa/(kappa-1))`` the
    flow is choked, ``p_up sqrt(kappa/(R T) (2/(kappa+1))^((kappa+1)/(kappa-1)))``; above it
    ``p_up sqrt(2 kappa/((kappa-1) R T) (r^(2/kappa) - r^((kappa+1)/kappa)))``; zero for
    ``r >= 1``.

    Parameters
    ----------
    p_up, p_down : float or ndarray
        Upstream and downstream absolute pressures, Pa.
    kappa : float
        Heat-capacity ratio.
    r_gas : float
        Gas constant, J/(kg K).
    t_k : float
        Upstream temperature, K.
    """
    p_up = np.asarray(p_up, dtype=float)
    r = np.clip(np.asarray(p_down, dtype=float) / p_up, 0.0, 1.0)
    r_c = (2.0 / (kappa + 1.0)) ** (kappa / (kappa - 1.0))
    choked = p_up * math.sqrt(kappa / (r_gas * t_k)
                              * (2.0 / (kappa + 1.0)) ** ((kappa + 1.0) / (kappa - 1.0)))
    rr = np.maximum(r, r_c)
    sub = p_up * np.sqrt(np.maximum(2.0 * kappa / ((kappa - 1.0) * r_gas * t_k)
                                    * (rr ** (2.0 / kappa) - rr ** ((kappa + 1.0) / kappa)), 0.0))
    return np.where(r <= r_c, choked, sub)


def valve_flow(error_m, opening_fill_m2, opening_exhaust_m2, system: LevelingSystem,
               p_chamber_pa, p_supply_pa, kappa, r_gas, t_k):
    """Mass flow of one valve into its chamber, kg/s (NumPy).

    Opening ``s = clip((|e| - d) / (q_sat / G), 0, 1)``; ``e > d`` fills through the port
    ``opening_fill_m2`` from the supply, ``e < -d`` exhausts through ``opening_exhaust_m2``
    to the atmosphere, each at :func:`orifice_flux`.

    Parameters
    ----------
    error_m : float
        Height error (reference minus sensor), m.
    opening_fill_m2, opening_exhaust_m2 : float
        Full-open port areas, m^2.
    system : LevelingSystem
    p_chamber_pa, p_supply_pa : float
        Chamber and supply pressures, Pa.
    kappa, r_gas, t_k : float
        Gas data and the supply temperature.
    """
    e = float(error_m)
    s = min(max((abs(e) - system.dead_band_m) / system.linear_range_m, 0.0), 1.0)
    if s == 0.0:
        return 0.0
    if e > 0:
        return s * opening_fill_m2 * float(orifice_flux(p_supply_pa, p_chamber_pa, kappa, r_gas,
                                                        t_k))
    return -s * opening_exhaust_m2 * float(orifice_flux(p_chamber_pa, P_ATM, kappa, r_gas, t_k))


# ---------------------------------------------------------------------------
# the plant
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LevelingPlant:
    """The table, its springs' chambers and the valves' paths, linearized (and the data
    the nonlinear simulation needs).

    States ``x = (q (6), q' (6), dm_t (n), dm_b (n))``: the body about the CG, and each
    isolator's chamber gas masses (deviations). Inputs: the three valves' mass flows
    (``B``, kg/s) and an external force and moment on the body about the CG (``E``, N and
    N m). Outputs: the three sensors' heights (``C``, m).

    Attributes
    ----------
    a, b, e, c : ndarray
        ``x' = A x + B u + E f``, ``y = C x``.
    model : TableModel
    system : LevelingSystem
    sensors_m : ndarray (3, 2)
    fed : ndarray of int (3,)
        The isolator each valve feeds.
    lines : tuple of (int, int)
        Pairs of isolators whose fed chambers a line connects.
    data : dict
        Constants of the nonlinear model.
    """

    a: np.ndarray
    b: np.ndarray
    e: np.ndarray
    c: np.ndarray
    model: TableModel
    system: LevelingSystem
    sensors_m: np.ndarray
    fed: np.ndarray
    lines: tuple
    data: dict

    @property
    def n_states(self) -> int:
        """Number of states."""
        return self.a.shape[0]

    def closed_loop(self, gain_kg_s_per_m: float | None = None) -> np.ndarray:
        """``A - B G C``: the loop closed by the three valves' linear regions."""
        g = self.system.gain_kg_s_per_m if gain_kg_s_per_m is None else gain_kg_s_per_m
        return self.a - g * self.b @ self.c

    def state_space(self):
        """The plant as a ``control.StateSpace`` (valve flows in, sensor heights out)."""
        import control

        return control.ss(self.a, self.b, self.c, np.zeros((3, 3)))


def isolator_constants(design, diaphragm, flow: str) -> tuple:
    """One isolator's constants of the plant, any backend (the design may be symbolic).

    Parameters
    ----------
    design : SpringDesign
        The spring at its own p0 (fields may be CasADi symbols).
    diaphragm : diaphragm model
        :func:`~isodesign.spring.diaphragm.diaphragm_model`'s object.
    flow : str
        The flow model (the capillary's resistance at zero tube velocity).

    Returns
    -------
    tuple
        ``(p0, V_t0, V_b0, m_t0, m_b0, A_p, n, C, k_D, c_D)``: the diaphragm's storage
        stiffness and its loss as a viscous damper, both at :data:`REFERENCE_FREQUENCY_HZ`.
    """
    w_ref = 2.0 * math.pi * REFERENCE_FREQUENCY_HZ
    c = resistance_function(flow, design, w_ref)(0.0)
    kd = diaphragm.stiffness(w_ref, 1e-6)
    rho = design.density_kg_m3
    vt0, vb0 = design.top_volume_m3, design.bottom_volume_m3
    return (design.pressure_pa, vt0, vb0, rho * vt0, rho * vb0, design.piston_area_m2,
            design.process_index, c.re, kd.re, kd.im / w_ref)


def _isolator_constants(model: TableModel, flow: str):
    """Per isolator: p0, V_t0, V_b0, m_t0, m_b0, A_p, n, C, k_D, c_D (NumPy)."""
    dia = diaphragm_model(model.diaphragm)
    return np.array([[float(np.asarray(x)) for x in isolator_constants(d, dia, flow)]
                     for d in model.designs])


def plant_matrix(model: TableModel, system: LevelingSystem, consts) -> np.ndarray:
    """The plant's ``A`` (valves closed) from the isolators' constants, any backend.

    Parameters
    ----------
    model : TableModel
        The table's geometry, gravity term and horizontal elements (independent of the
        springs' design).
    system : LevelingSystem
        The lines' resistance and the fed chamber.
    consts : array (n, 10)
        :func:`isolator_constants` per isolator: floats (a float array back) or CasADi
        symbols (an object array of symbols back).

    Returns
    -------
    ndarray (12 + 2n, 12 + 2n)
    """
    t = model.table
    n = t.n_isolators
    k = np.asarray(consts, dtype=object if np.asarray(consts).dtype == object else float)
    p0, vt0, _, mt0, mb0, ap, nidx, cres, kd, cd = k.T
    geo = model.geometry
    gz = geo.gz  # (n, 6)
    w_ref = 2.0 * math.pi * REFERENCE_FREQUENCY_HZ
    hs = model.horizontal_stiffness(np.array([w_ref]))
    kh = np.array([float(np.asarray(c.re).ravel()[0]) for c in hs])
    ch = np.array([float(np.asarray(c.im).ravel()[0]) / w_ref for c in hs])
    gxy = np.concatenate([geo.gh[0], geo.gh[1]])  # (2n, 6)
    khh = np.concatenate([kh, kh])
    chh = np.concatenate([ch, ch])
    # linear pressures: dp_t = at dm_t - bt u, dp_b = ab dm_b
    at, ab = nidx * p0 / mt0, nidx * p0 / mb0
    bt = nidx * p0 * ap / vt0
    ns = 12 + 2 * n
    a = np.zeros((ns, ns), dtype=k.dtype)
    a[:6, 6:12] = np.eye(6)
    minv = np.linalg.inv(geo.mass)
    # forces: F_i = A_p dp_t - k_D u - c_D u', u = gz q
    # D q = (sum k g g^T + K_g) q is the restoring force's negative (section 2)
    k_q = -(gz.T * (ap * bt + kd)) @ gz - (gxy.T * khh) @ gxy - geo.gravity
    c_v = -(gz.T * cd) @ gz - (gxy.T * chh) @ gxy
    k_mt = gz.T * (ap * at)  # (6, n)
    a[6:12, :6] = minv @ k_q
    a[6:12, 6:12] = minv @ c_v
    a[6:12, 12:12 + n] = minv @ k_mt
    # chambers: m_c = (dp_t - dp_b)/C; dm_t' = -m_c (+ valve, lines), dm_b' = m_c
    it, ib = np.arange(12, 12 + n), np.arange(12 + n, 12 + 2 * n)
    for i in range(n):
        row_c = np.zeros(ns, dtype=k.dtype)
        row_c[it[i]] = at[i]
        row_c[:6] = -bt[i: i + 1] * gz[i]  # array ops only: a symbol times an array
        row_c[ib[i]] = -ab[i]  # would be a CasADi matrix, not elementwise
        row_c = row_c / cres[i: i + 1]
        a[it[i]] -= row_c
        a[ib[i]] += row_c
    fed_rows = it if system.fed_chamber == "top" else ib
    for i, j in _lines(t):  # m_l = (p_i - p_j) / R_l from i to j (the fed chambers)
        row = np.zeros(ns, dtype=k.dtype)
        if system.fed_chamber == "top":
            row[it[i]], row[:6] = at[i], -bt[i: i + 1] * gz[i]
            row[it[j]], row[:6] = -at[j], row[:6] + bt[j: j + 1] * gz[j]
        else:
            row[ib[i]], row[ib[j]] = ab[i], -ab[j]
        row = row / system.line_resistance_pa_s_per_kg
        a[fed_rows[i]] -= row
        a[fed_rows[j]] += row
    return a


def _lines(table) -> tuple:
    """Pairs (valve's isolator, slaved isolator) a line connects."""
    return tuple((g[0], j) for g in table.leveling_groups for j in g[1:])


def check_model_and_system(model, system) -> None:
    """Refuse a ``model`` that is not a :class:`TableModel` or a ``system`` that is neither
    a :class:`LevelingSystem` nor None (an InputError naming the parameter).

    Parameters
    ----------
    model : object
    system : object
    """
    check_instance("model", model, TableModel,
                   "a TableModel (isodesign.table.model.table_model(design, table))")
    if system is not None:
        check_instance("system", system, LevelingSystem,
                       "a LevelingSystem (leveling_of_study(study)) or None")


def leveling_plant(model: TableModel, system: LevelingSystem | None = None) -> LevelingPlant:
    """The linearized table with its chambers and valve paths (see :class:`LevelingPlant`).

    Parameters
    ----------
    model : TableModel
        The table bound to its springs (leveled).
    system : LevelingSystem, optional
        Default :class:`LevelingSystem`.

    Returns
    -------
    LevelingPlant
    """
    check_model_and_system(model, system)
    system = LevelingSystem() if system is None else system
    if not isinstance(system, LevelingSystem):
        raise InputError(f"system: expected a LevelingSystem, got {type(system).__name__}")
    t = model.table
    n = t.n_isolators
    k = _isolator_constants(model, model.flow)
    p0, vt0, vb0, mt0, mb0, ap, nidx, cres, kd, cd = k.T
    geo = model.geometry
    gz = geo.gz
    a = plant_matrix(model, system, k)
    ns = a.shape[0]
    w_ref = 2.0 * math.pi * REFERENCE_FREQUENCY_HZ
    hs = model.horizontal_stiffness(np.array([w_ref]))
    kh = np.array([float(np.asarray(c.re).ravel()[0]) for c in hs])
    ch = np.array([float(np.asarray(c.im).ravel()[0]) / w_ref for c in hs])
    gxy = np.concatenate([geo.gh[0], geo.gh[1]])
    khh, chh = np.concatenate([kh, kh]), np.concatenate([ch, ch])
    minv = np.linalg.inv(geo.mass)
    it, ib = np.arange(12, 12 + n), np.arange(12 + n, 12 + 2 * n)
    fed_rows = it if system.fed_chamber == "top" else ib
    groups = t.leveling_groups
    fed = np.array([g[0] for g in groups])
    lines = _lines(t)
    b = np.zeros((ns, 3))
    for g, i in enumerate(fed):
        b[fed_rows[i], g] = 1.0
    e = np.zeros((ns, 6))
    e[6:12] = minv
    sensors = system.sensors(t)
    pts = np.column_stack([sensors - t.cg_m[:2], np.full(3, -t.cg_height_m)])
    c = np.zeros((3, ns))
    c[:, :6] = element_vectors(pts, 2)
    data = {"p0": p0, "vt0": vt0, "vb0": vb0, "mt0": mt0, "mb0": mb0, "ap": ap, "n": nidx,
            "c": cres, "kd": kd, "cd": cd, "k_q_springless": (-(gxy.T * khh) @ gxy
                                                            - geo.gravity),
            "c_h": -(gxy.T * chh) @ gxy, "minv": minv, "gz": gz}  # fmt: skip
    return LevelingPlant(a=a, b=b, e=e, c=c, model=model, system=system, sensors_m=sensors,
                         fed=fed, lines=lines, data=data)


# ---------------------------------------------------------------------------
# the nonlinear simulation
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LevelingSimulation:
    """A time-domain run of the nonlinear leveling model.

    Attributes
    ----------
    time_s : ndarray
    heights_m : ndarray (n_t, 3)
        The three sensors' heights.
    body : ndarray (n_t, 6)
        The body's DOFs about the CG.
    valve_flow_kg_s : ndarray (n_t, 3)
    pressure_pa : ndarray (n_t, n)
        Each isolator's fed chamber's pressure.
    status : str
        The integrator's message.
    """

    time_s: np.ndarray
    heights_m: np.ndarray
    body: np.ndarray
    valve_flow_kg_s: np.ndarray
    pressure_pa: np.ndarray
    status: str

    def to_frame(self):
        """One row per time step: sensor heights and valve flows."""
        import pandas as pd

        cols = {"time_s": self.time_s}
        for g in range(3):
            cols[f"height_{g + 1}_m"] = self.heights_m[:, g]
        for g in range(3):
            cols[f"valve_{g + 1}_kg_s"] = self.valve_flow_kg_s[:, g]
        return pd.DataFrame(cols)


def simulate_leveling(plant: LevelingPlant, duration_s: float, *, x0=None, force=None,
                      samples: int = 2000, gain_kg_s_per_m: float | None = None,
                      linear_valves: bool = False, rtol: float = 1e-7) -> LevelingSimulation:
    """Integrate the nonlinear model: polytropic chambers, the valves' law, the lines.

    Parameters
    ----------
    plant : LevelingPlant
    duration_s : float
        Simulated time, s.
    x0 : ndarray, optional
        Initial deviation (the linear state's layout); default the leveled state.
    force : ndarray (6,) or callable, optional
        External force and moment on the body about the CG, constant or ``t -> (6,)``.
    samples : int
        Output samples.
    gain_kg_s_per_m : float, optional
        The valves' gain (default the system's).
    linear_valves : bool
        Replace the valve law by its linear region (no dead band, saturation or orifice).
    rtol : float
        Relative tolerance of ``solve_ivp`` (LSODA).

    Returns
    -------
    LevelingSimulation
    """
    check_instance("plant", plant, LevelingPlant,
                   "a LevelingPlant (leveling_plant(model, system))")
    check_positive("duration_s", duration_s, unit="s")
    from scipy.integrate import solve_ivp

    sysm = plant.system if gain_kg_s_per_m is None else plant.system.replace(
        gain_kg_s_per_m=float(gain_kg_s_per_m))
    d = plant.data
    model = plant.model
    n = model.n_isolators
    des = model.designs[0]
    kappa = float(des.gas.heat_capacity_ratio)
    r_gas = float(des.gas.gas_constant_j_per_kg_k)
    t_k = float(des.temperature_k)
    p_s = float(model.table.supply_pressure_pa)
    fed, top = plant.fed, sysm.fed_chamber == "top"
    p_fed0 = d["p0"][fed]
    a_fill = sysm.saturation_flow_kg_s / orifice_flux(p_s, p_fed0, kappa, r_gas, t_k)
    a_exh = sysm.saturation_flow_kg_s / orifice_flux(p_fed0, P_ATM, kappa, r_gas, t_k)
    gz, minv = d["gz"], d["minv"]
    ap = d["ap"]
    c_sens = plant.c[:, :6]
    f_const = np.zeros(6) if force is None or callable(force) else np.asarray(force, float)

    def f_of(tt):
        return force(tt) if callable(force) else f_const

    def pressures(x):
        u = gz @ x[:6]
        mt, mb = d["mt0"] + x[12:12 + n], d["mb0"] + x[12 + n:]
        pt = d["p0"] * (mt / d["mt0"] * d["vt0"] / (d["vt0"] + ap * u)) ** d["n"]
        pb = d["p0"] * (mb / d["mb0"]) ** d["n"]
        return u, pt, pb

    def flows(x, pt, pb):
        y = c_sens @ x[:6]
        pf = pt if top else pb
        out = np.zeros(3)
        for g in range(3):
            if linear_valves:
                out[g] = -sysm.gain_kg_s_per_m * y[g]
            else:
                out[g] = valve_flow(-y[g], a_fill[g], a_exh[g], sysm, pf[fed[g]], p_s,
                                    kappa, r_gas, t_k)
        return y, out

    def rhs(tt, x):
        u, pt, pb = pressures(x)
        ud = gz @ x[6:12]
        force_i = ap * (pt - d["p0"]) - d["kd"] * u - d["cd"] * ud
        acc = minv @ (gz.T @ force_i + d["k_q_springless"] @ x[:6] + d["c_h"] @ x[6:12]
                      + f_of(tt))
        mc = (pt - pb) / d["c"]
        dmt, dmb = -mc, mc.copy()
        _, q = flows(x, pt, pb)
        dfed = dmt if top else dmb
        pf = pt if top else pb
        for i, j in plant.lines:
            ml = (pf[i] - pf[j]) / sysm.line_resistance_pa_s_per_kg
            dfed[i] -= ml
            dfed[j] += ml
        for g in range(3):
            dfed[fed[g]] += q[g]
        return np.concatenate([x[6:12], acc, dmt, dmb])

    x_init = np.zeros(plant.n_states) if x0 is None else np.asarray(x0, float)
    ts = np.linspace(0.0, float(duration_s), int(samples))
    sol = solve_ivp(rhs, (0.0, float(duration_s)), x_init, method="LSODA", t_eval=ts,
                    rtol=rtol, atol=1e-12)
    if not sol.success:
        from isodesign.errors import SolverError

        raise SolverError(f"leveling simulation: solve_ivp failed ({sol.message})")
    xs = sol.y.T
    hs, qs, ps = [], [], []
    for x in xs:
        _, pt, pb = pressures(x)
        y, q = flows(x, pt, pb)
        hs.append(y)
        qs.append(q)
        ps.append(pt if top else pb)
    return LevelingSimulation(time_s=sol.t, heights_m=np.array(hs), body=xs[:, :6],
                              valve_flow_kg_s=np.array(qs), pressure_pa=np.array(ps),
                              status=str(sol.message))
