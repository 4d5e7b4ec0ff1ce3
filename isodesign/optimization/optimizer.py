"""Design optimization with CasADi and IPOPT: N, V_t0, L_c, D_c.

The NLP
-------
Decision variables, scaled to [-1, 1] in log space (``z = (ln x - c)/h``):
volume ratio N, top-chamber volume V_t0, capillary length L_c and diameter D_c
(fixed ones are constants). Implicit unknowns, solved inside the NLP as
equality constraints:

* ``y_j = ln U_j``: the self-consistent tube velocity amplitude at every grid
  frequency (:func:`isodesign.spring.equations.amplitude_residual` = 0);
* ``s = ln sigma``: the RMS stroke of the spring under the random floor input,
  ``sigma^2 = integral |T - 1|^2 S_x df`` with the spring's amplitude taken as
  ``A* = 1.880 sigma`` (:mod:`isodesign.response`).

Every objective and constraint is computed by :func:`metrics`, the same
backend-agnostic function that evaluates them on NumPy arrays for the re-check
(one source of physics). Max-over-bands and max-over-frequency quantities are
written in epigraph form, so the NLP has no max or abs.

Trust
-----
* Multi-start: space-filling starts (Latin hypercube in the scaled log space)
  plus the study's start; the report says how many reached the best design.
* Re-check: the optimum is re-evaluated with the NumPy analysis path (its own
  solvers for U and sigma); objective and constraints must agree to 1e-6
  relative, else :class:`~isodesign.errors.SolverError`.
* Flat directions: in the laminar limit L_c and D_c act only through
  ``L_c / D_c^4`` (physics notes, section 5). After the optimum, a second stage
  finds the range of D_c over which the objective stays within a tolerance of
  the optimum and returns the largest D_c in it (the most manufacturable:
  larger bores clog less and are easier to make to tolerance).
* The peak of |T| is a semi-infinite constraint (every frequency): after a
  solve the continuous peak is measured and, if it lies above the bound between
  the sampled frequencies, movable grid frequencies (NLP parameters) are placed
  around it and the NLP is solved again (an exchange method; see
  :func:`continuous_peak_db`).
* Failure is explicit: infeasible, iteration limit and restoration failure are
  reported with IPOPT's status, the most violated constraints and the best
  point found.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.optimization.study import DESIGN_VARIABLES, OBJECTIVES, Study
from isodesign.response.isolator import (
    natural_frequency_hz,
    relative_transmissibility,
    static_stiffness,
    tilt_margin,
    transmissibility,
    zener_damping_ratio,
)
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    band_mean_square,
    response_grid,
    stroke_variance,
)
from isodesign.response.random_input import band_response, solve_stroke_rms
from isodesign.spring.amplitude import solve_velocity_amplitude
from isodesign.spring.capillary import (
    LAMINAR_REYNOLDS_LIMIT,
    QUASI_STEADY_WOMERSLEY_LIMIT,
    resistance_function,
)
from isodesign.spring.diagnostics import LUMPED_LIMIT
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, amplitude_residual, kinematic_velocity
from isodesign.spring.stiffness import complex_stiffness

__all__ = [
    "ConstraintReport",
    "OptimizationResult",
    "StartRecord",
    "metrics",
    "optimize",
]

LN10 = math.log(10.0)
#: The NLP keeps this fraction of each model-validity limit (Reynolds number,
#: acoustic compactness, Womersley number): the constraints hold at the NLP's grid
#: points, and the margin keeps the finer analysis grid inside the limits too.
VALIDITY_MARGIN = 0.98
#: Relative agreement required between the NLP and the NumPy re-check.
RECHECK_RTOL = 1e-6
#: Objective tolerance of the flat-direction tie-break: designs whose objective is
#: within this of the optimum (dB for dB objectives, relative otherwise) count as
#: equivalent.
FLAT_TOLERANCE_DB = 0.01
FLAT_TOLERANCE_REL = 1e-3
#: Slack on ``J <= J* + tolerance`` when accepting the tie-break point: IPOPT meets
#: the bound to its constraint tolerance, not exactly.
TIE_BREAK_SLACK = 1e-6


# ---------------------------------------------------------------------------
# the evaluation grid
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Grid:
    """Frequencies at which the NLP evaluates the spring, and their roles.

    ``omega`` concatenates the floor quadrature grid (``n_floor`` points, for
    sigma and the band mean squares), the peak grid (``n_peak`` log-spaced
    points for the resonance peak) and, for ``transmissibility_at``, one point.
    """

    omega: np.ndarray
    n_floor: int
    n_peak: int
    response: Any  # isodesign.response.linearization.ResponseGrid of the floor part
    target_band_rows: np.ndarray  # rows of the response grid's bands that are target bands
    target_limit_m_s: np.ndarray
    point_index: int | None = None
    n_slots: int = 0  # the last n_slots peak-grid points: movable (NLP parameters)

    @property
    def slot_slice(self) -> slice:
        end = self.n_floor + self.n_peak
        return slice(end - self.n_slots, end)

    def with_slots(self, slot_hz) -> Grid:
        """The same grid with the movable peak frequencies set (Hz)."""
        w = self.omega.copy()
        w[self.slot_slice] = 2.0 * math.pi * np.asarray(slot_hz, float)
        return dataclasses.replace(self, omega=w)

    @property
    def floor_slice(self) -> slice:
        return slice(0, self.n_floor)

    @property
    def peak_slice(self) -> slice:
        return slice(self.n_floor, self.n_floor + self.n_peak)


def build_grid(study: Study, *, points_per_band: int | None = None,
               objectives: tuple = (), extra_peak_hz: tuple = (), slots: int = 0) -> Grid:
    """The NLP's frequency grid for a study (NumPy).

    ``extra_peak_hz`` adds fixed peak-grid frequencies; ``slots`` appends that many
    movable ones (the exchange method of :func:`optimize`; initially copies of the
    first peak frequencies, which changes nothing)."""

    ppb = points_per_band or study.models["points_per_band"]
    rg = response_grid(study.floor, study.bands, target=study.target, points_per_band=ppb)
    rows = np.arange(len(rg.bands), dtype=int)
    limits = np.asarray(rg.limit_velocity_m_s, float)
    d0 = study.start_design()
    # peak grid: from a quarter of the lowest to six times the highest plausible
    # natural frequency
    m_i = study.payload.mass_per_isolator_kg
    fn0 = natural_frequency_hz(d0.static_stiffness_n_per_m, m_i)
    f_lo = max(0.05, 0.25 * min(fn0, study.constraints.get("min_natural_frequency_hz") or fn0))
    f_hi = 6.0 * max(fn0, study.constraints.get("max_natural_frequency_hz") or fn0)
    peak = np.geomspace(f_lo, f_hi, study.models["peak_points"])
    if extra_peak_hz:
        peak = np.unique(np.concatenate([peak, np.asarray(extra_peak_hz, float)]))
    if slots:
        peak = np.concatenate([peak, peak[:slots]])
    parts = [rg.omega, 2.0 * math.pi * peak]
    point = None
    if "transmissibility_at" in (study.objective["kind"], *objectives):
        point = rg.omega.size + peak.size
        f_pt = study.objective.get("frequency_hz", DEFAULT_POINT_FREQUENCY_HZ)
        parts.append(np.array([2.0 * math.pi * f_pt]))
    return Grid(omega=np.concatenate(parts), n_floor=rg.omega.size, n_peak=peak.size,
                response=rg, target_band_rows=rows, target_limit_m_s=limits,
                point_index=point, n_slots=slots)


#: Frequency of the ``transmissibility_at`` objective when the study names none.
DEFAULT_POINT_FREQUENCY_HZ = 10.0


def _take(c: Cx, sl) -> Cx:
    return Cx(c.re[sl], c.im[sl])


# ---------------------------------------------------------------------------
# metrics: every objective and constraint quantity, any backend
# ---------------------------------------------------------------------------
def point_quantities(study: Study, d, omega, velocity, sigma, dia) -> dict:
    """Per-frequency quantities (elementwise in ``omega``), any backend.

    ``T`` and ``R`` (absolute and relative transmissibility at the spring
    amplitude ``A* = 1.880 sigma``), ``ln_mach`` and ``ln_re`` of the tube flow.
    """

    m_i = study.payload.mass_per_isolator_kg
    a_star = EQUIVALENT_AMPLITUDE_FACTOR * sigma
    c = resistance_function(study.models["flow"], d, omega)(velocity)
    k = air_stiffness(d, omega, c) + dia.stiffness(omega, a_star)
    return {
        "T": transmissibility(k, m_i, omega),
        "R": relative_transmissibility(k, m_i, omega),
        "ln_mach": bk.log(velocity / d.speed_of_sound_m_s),
        "ln_re": bk.log(d.density_kg_m3 * velocity * d.capillary_diameter_m / d.viscosity_pa_s),
    }


def design_quantities(study: Study, grid: Grid, d, dia) -> dict:
    """Design-level quantities (volume, stability, validity), any backend."""
    m_i = study.payload.mass_per_isolator_kg
    k0 = static_stiffness(d, dia, m_i)
    out = {"ln_total_volume": bk.log(d.total_volume_m3)}
    if study.payload.spacing_m is not None and study.payload.cg_height_m is not None:
        out["ln_tilt"] = bk.log(tilt_margin(k0, study.payload))
    out["ln_fn"] = bk.log(natural_frequency_hz(k0, m_i))
    out["ln_zeta"] = bk.log(zener_damping_ratio(d, m_i))
    w_max = float(np.max(grid.omega))
    # acoustic compactness of the lumped model (diagnostics.LUMPED_LIMIT), one
    # smooth constraint per length instead of a max
    c = d.speed_of_sound_m_s
    out["ln_lumped"] = [
        bk.log(w_max * d.capillary_length_m / c),
        bk.log(w_max * bk.power(d.top_volume_m3, 1.0 / 3.0) / c),
        bk.log(w_max * bk.power(d.bottom_volume_m3, 1.0 / 3.0) / c),
    ]
    out["ln_alpha_max"] = 0.5 * bk.log(
        d.density_kg_m3 * w_max * d.capillary_diameter_m**2 / d.viscosity_pa_s
    ) - math.log(2.0)
    return out


def combine(study: Study, grid: Grid, pq: dict, dq: dict) -> dict:
    """Grid-level quantities from the per-point and design-level ones, any backend.

    The quadratures of sigma^2 and of the band mean squares are
    :func:`isodesign.response.linearization.stroke_variance` and
    :func:`~isodesign.response.linearization.band_mean_square`, the same functions the
    band response uses.
    """

    fl, pk = grid.floor_slice, grid.peak_slice
    var = stroke_variance(_take(pq["R"], fl), grid.response)
    ms = band_mean_square(_take(pq["T"], fl), grid.response)
    out = dict(dq)
    out.update({
        "stroke_variance": var,
        "ms_all": ms,
        "ln_ms_band": bk.log(ms),
        "ln_limit2": 2.0 * np.log(grid.target_limit_m_s),
        "ln_T2_peak": bk.log(_take(pq["T"], pk).abs2()),
        "ln_mach": pq["ln_mach"],
        "ln_re": pq["ln_re"],
    })
    if grid.point_index is not None:
        i = grid.point_index
        out["ln_T2_point"] = bk.log(Cx(pq["T"].re[i], pq["T"].im[i]).abs2())
    return out


def metrics(study: Study, grid: Grid, d, velocity, sigma, *, diaphragm=None) -> dict:
    """Objective and constraint quantities of a design (NumPy or CasADi).

    :func:`point_quantities` on every grid frequency, :func:`design_quantities`
    and :func:`combine`: the NLP evaluates the same three functions (the first
    mapped over the grid as a CasADi Function).

    Parameters
    ----------
    study : Study
    grid : Grid
    d : SpringDesign
        Design, possibly with CasADi symbols for the free variables.
    velocity : array or symbol vector
        Tube velocity amplitude at every grid frequency, m/s.
    sigma : float or symbol
        RMS stroke of the spring, m.

    Returns
    -------
    dict
        ``stroke_variance``, ``ms_all`` and ``ln_ms_band`` (target bands),
        ``ln_limit2``, ``ln_T2_peak`` (vector), ``ln_total_volume``, ``ln_tilt``,
        ``ln_fn``, ``ln_zeta``, ``ln_mach`` and ``ln_re`` (vectors),
        ``ln_alpha_max`` and ``ln_T2_point`` (for ``transmissibility_at``).
    """
    dia = diaphragm or diaphragm_model(study.models["diaphragm"])
    pq = point_quantities(study, d, grid.omega, velocity, sigma, dia)
    return combine(study, grid, pq, design_quantities(study, grid, d, dia))


# ---------------------------------------------------------------------------
# constraints and objectives from metrics
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Con:
    """One (vector) constraint ``lo <= expr <= hi`` in the NLP's (log) units."""

    name: str
    expr: Any
    lo: float
    hi: float
    size: int = 1
    describe: str = ""


def _constraints(study: Study, mt: dict, n_all: int) -> list[_Con]:
    c = study.constraints
    out: list[_Con] = []
    inf = math.inf
    if c["max_total_volume_m3"]:
        out.append(_Con("total_volume", mt["ln_total_volume"], -inf,
                        math.log(c["max_total_volume_m3"]), 1, "V_t0 (1 + N) <= V_max"))
    if c["min_tilt_margin"]:
        out.append(_Con("tilt_margin", mt["ln_tilt"], math.log(c["min_tilt_margin"]), inf, 1,
                        "tilt margin n k (s/2)^2 / (m g h) >= min"))
    if c["min_natural_frequency_hz"] or c["max_natural_frequency_hz"]:
        lo = math.log(c["min_natural_frequency_hz"]) if c["min_natural_frequency_hz"] else -inf
        hi = math.log(c["max_natural_frequency_hz"]) if c["max_natural_frequency_hz"] else inf
        out.append(_Con("natural_frequency", mt["ln_fn"], lo, hi, 1,
                        "f_min <= natural frequency <= f_max"))
    if c["max_peak_transmissibility_db"] is not None:
        n = _size(mt["ln_T2_peak"])
        out.append(_Con("peak_transmissibility", mt["ln_T2_peak"], -inf,
                        c["max_peak_transmissibility_db"] * LN10 / 10.0, n,
                        "|T| <= T_max (dB) at every peak-grid frequency"))
    if c["min_damping_ratio"]:
        out.append(_Con("damping_ratio", mt["ln_zeta"], math.log(c["min_damping_ratio"]), inf,
                        1, "Zener damping ratio >= min"))
    if c["max_mach"]:
        out.append(_Con("mach", mt["ln_mach"], -inf, math.log(c["max_mach"]), n_all,
                        "capillary Mach number <= max at every grid frequency"))
    if c["model_validity"]:

        for name, e in zip(("tube", "top_chamber", "bottom_chamber"), mt["ln_lumped"],
                           strict=True):
            out.append(_Con(f"lumped_{name}", e, -inf,
                            math.log(VALIDITY_MARGIN * LUMPED_LIMIT), 1,
                            f"acoustically compact {name.replace('_', ' ')}: w l / c <= "
                            f"{LUMPED_LIMIT}"))
        flow = study.models["flow"]
        if flow in ("womersley", "poiseuille"):
            out.append(_Con("laminar", mt["ln_re"], -inf,
                            math.log(VALIDITY_MARGIN * LAMINAR_REYNOLDS_LIMIT),
                            n_all, "peak Reynolds number <= 2300 (laminar model)"))
        if flow == "quasi_steady":
            out.append(_Con("quasi_steady_alpha", mt["ln_alpha_max"], -inf,
                            math.log(VALIDITY_MARGIN * QUASI_STEADY_WOMERSLEY_LIMIT), 1,
                            "Womersley number <= 3.4 at the highest grid frequency"))
    return out


def _size(x) -> int:
    return int(np.size(x)) if not bk.is_casadi(x) else int(x.numel())


# ---------------------------------------------------------------------------
# objectives
# ---------------------------------------------------------------------------
def objective_value_to_natural(kind: str, j: float) -> float:
    """Convert the NLP's internal objective J to the reported value."""
    if kind == "worst_band_margin":
        return -j  # dB
    if kind in ("peak_transmissibility", "transmissibility_at"):
        return j  # dB
    if kind in ("rms_velocity", "total_volume"):
        return math.exp(j)  # m/s, m^3
    if kind in ("capillary_diameter_max", "capillary_diameter_min"):
        return math.exp(abs(j))
    raise KeyError(kind)


def natural_to_objective_value(kind: str, v: float) -> float:
    """Inverse of :func:`objective_value_to_natural` (for epsilon bounds)."""
    if kind == "worst_band_margin":
        return -v
    if kind in ("peak_transmissibility", "transmissibility_at"):
        return v
    if kind in ("rms_velocity", "total_volume"):
        if v <= 0:
            raise InputError(f"epsilon bound for {kind} must be > 0, got {v!r}")
        return math.log(v)
    raise KeyError(kind)


OBJECTIVE_UNITS = {
    "worst_band_margin": "dB",
    "peak_transmissibility": "dB",
    "transmissibility_at": "dB",
    "rms_velocity": "m/s",
    "total_volume": "m^3",
}


def _objective(kind: str, mt: dict, study: Study, grid: Grid, sym) -> tuple:
    """(J, aux variables, constraints) of one objective for the NLP; J is minimized.

    ``sym(name, n)`` makes a fresh auxiliary (epigraph) variable. Every
    constraint is separable over the grid points (no log of a sum): a log of a
    sum would couple all points in the Hessian of the Lagrangian and make it
    dense.
    """
    db = 10.0 / LN10
    if kind == "worst_band_margin":
        t = sym(f"t_{kind}", 1)  # worst margin, dB: ms_b / lim_b^2 <= 10^(-t/10)
        lim2 = np.exp(np.asarray(mt["ln_limit2"], float))
        con = _Con(f"epigraph_{kind}", mt["ms_all"] / lim2 - bk.exp(-t / db),
                   -math.inf, 0.0, len(grid.target_band_rows), "band margin >= t")
        return -t, [t], [con]
    if kind == "peak_transmissibility":
        t = sym(f"t_{kind}", 1)  # peak |T|, dB
        con = _Con(f"epigraph_{kind}", db * mt["ln_T2_peak"] - t, -math.inf, 0.0, grid.n_peak,
                   "|T|^2 (dB) <= t at every peak-grid frequency")
        return t, [t], [con]
    if kind == "transmissibility_at":
        return db * mt["ln_T2_point"], [], []
    if kind == "rms_velocity":
        rows = rms_rows(study, grid)
        t = sym(f"t_{kind}", 1)  # ln of the RMS velocity
        v_ref2 = float(np.sum(np.asarray(grid.response.floor_velocity_rms_m_s)[rows] ** 2))
        con = _Con(f"epigraph_{kind}",
                   _sum_rows(mt["ms_all"], rows) / v_ref2 - bk.exp(2.0 * t) / v_ref2,
                   -math.inf, 0.0, 1, "RMS velocity <= e^t")
        return t, [t], [con]
    if kind == "total_volume":
        return mt["ln_total_volume"], [], []
    raise InputError(f"objective.kind: unknown {kind!r}; valid: {', '.join(OBJECTIVES)}")


def rms_rows(study: Study, grid: Grid) -> list[int]:
    """Rows of the response grid's bands inside the rms_velocity objective's range."""
    o = study.objective
    lo = o.get("band_min_hz", study.raw["target"].get("band_min_hz", 1.0))
    hi = o.get("band_max_hz", study.raw["target"].get("band_max_hz", 80.0))
    nominal = np.asarray(grid.response.bands.nominal_hz, float)
    rows = [r for r, fn in enumerate(nominal) if lo * 0.99 <= fn <= hi * 1.01]
    if not rows:
        raise InputError(f"objective: no target band between {lo:g} and {hi:g} Hz")
    return rows


def _sum_rows(ms, rows):
    if bk.is_casadi(ms):
        out = 0
        for r in rows:
            out = out + ms[int(r)]
        return out
    return float(np.sum(np.asarray(ms)[rows]))


# ---------------------------------------------------------------------------
# the NLP
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Scaling:
    """Log scaling of the free design variables: ``ln x = c + h z``, z in [-1, 1]."""

    names: tuple[str, ...]
    center: np.ndarray
    half: np.ndarray

    def to_values(self, z) -> dict:
        return {n: math.exp(c + h * zi) for n, c, h, zi in
                zip(self.names, self.center, self.half, np.asarray(z, float), strict=True)}

    def to_z(self, values: dict) -> np.ndarray:
        return np.array([(math.log(values[n]) - c) / h for n, c, h in
                         zip(self.names, self.center, self.half, strict=True)])


def _bounds(study: Study) -> dict:
    """Effective (lower, upper) of each variable, with D_c >= the manufacturable minimum."""
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


#: IPOPT options beyond max_iter and tol. Every start is consistent (the implicit
#: unknowns solved by the NumPy path), so IPOPT must not push it off its bounds nor
#: start with a large barrier parameter: a monotone barrier from mu = 1e-3 and
#: tiny bound pushes converged from every start where the adaptive default often
#: wandered off (measured on the default study, benchmarks/bench_optimize.py).
IPOPT_OPTIONS = {
    "ipopt.mu_strategy": "monotone",
    "ipopt.mu_init": 1e-3,
    "ipopt.bound_push": 1e-9,
    "ipopt.bound_frac": 1e-9,
    "ipopt.slack_bound_push": 1e-9,
    "ipopt.slack_bound_frac": 1e-9,
}
#: Boxes on the implicit unknowns of the NLP (far outside any physical solution).
SIGMA_BOUNDS_M = (1e-13, 1e-1)
VELOCITY_BOUNDS_M_S = (1e-12, 1e3)
EPIGRAPH_BOUND = 300.0  # dB, or ln(m/s) for rms_velocity


class Problem:
    """The NLP of a study, built once and solved from many starts.

    The objective is parametric, so that one built solver serves the main
    solve, the flat-direction tie-break and a Pareto sweep::

        minimize   sum_k w_k J_k + w_D ln D_c
        subject to J_k <= eps_k  (k in objectives), physics, constraints

    with parameters ``p = [w_1..w_K, w_D, eps_1..eps_K]`` (see
    :meth:`params`). The per-frequency physics (:func:`point_quantities` and the
    amplitude residual) is one small SX Function mapped over the grid, so the
    exact Hessian is cheap to build and to evaluate.

    Parameters
    ----------
    study : Study
    objectives : tuple of str
        Objective kinds present in the NLP (default: the study's objective).
    """

    def __init__(self, study: Study, objectives: tuple | None = None,
                 extra_peak_hz: tuple = ()):
        import casadi as ca

        self.study = study
        self.objectives = tuple(objectives or (study.objective["kind"],))
        self.objective = self.objectives[0]
        self.extra_peak_hz = tuple(extra_peak_hz)
        self.grid = build_grid(study, objectives=self.objectives, extra_peak_hz=extra_peak_hz,
                               slots=PEAK_SLOTS)
        self.slot_hz = self.grid.omega[self.grid.slot_slice] / (2.0 * math.pi)
        self.dia = diaphragm_model(study.models["diaphragm"])
        bnds = _bounds(study)
        free = [v for v in study.variables if v.free]
        self.scaling = _Scaling(
            names=tuple(v.name for v in free),
            center=np.array([0.5 * (math.log(bnds[v.name][0]) + math.log(bnds[v.name][1]))
                             for v in free]),
            half=np.array([0.5 * (math.log(bnds[v.name][1]) - math.log(bnds[v.name][0]))
                           for v in free]),
        )
        self.self_consistent = study.models["amplitude_mode"] == "self_consistent"
        flow = study.models["flow"]

        # -- the per-point physics as one SX function, mapped over the grid --------
        dv = ca.SX.sym("design", len(DESIGN_VARIABLES))
        d_sx = study.design_at({n: dv[i] for i, n in enumerate(DESIGN_VARIABLES)})
        s_sx, y_sx, w_sx = ca.SX.sym("s"), ca.SX.sym("y"), ca.SX.sym("w")
        sig_sx = ca.exp(s_sx)
        a_sx = EQUIVALENT_AMPLITUDE_FACTOR * sig_sx
        if self.self_consistent:
            u_sx = ca.exp(y_sx)
            res_sx = amplitude_residual(flow, d_sx, w_sx, a_sx, y_sx)
        else:
            u_sx = kinematic_velocity(d_sx, w_sx, a_sx)
            res_sx = ca.SX(0)
        pq = point_quantities(study, d_sx, w_sx, u_sx, sig_sx, self.dia)
        point = ca.Function("point", [dv, s_sx, y_sx, w_sx],
                            [res_sx, pq["T"].re, pq["T"].im, pq["R"].re, pq["R"].im,
                             pq["ln_mach"], pq["ln_re"]])
        w = self.grid.omega
        n_all = w.size
        mapped = point.map(n_all, "unroll")

        # -- decision variables (MX) ------------------------------------------------
        nz = len(free)
        # SX throughout: with MX the Jacobian's colouring needed one sweep per grid point
        # (measured 50-70 ms per Jacobian against ~1 ms for the expanded SX graph)
        X = ca.SX
        z = X.sym("z", nz)
        s = X.sym("s")
        y = X.sym("y", n_all if self.self_consistent else 0)
        vals = []
        for n in DESIGN_VARIABLES:
            if n in self.scaling.names:
                k = self.scaling.names.index(n)
                vals.append(ca.exp(self.scaling.center[k] + self.scaling.half[k] * z[k]))
            else:
                vals.append(X(study.variable(n).start))
        v = ca.vertcat(*vals)
        y_row = y.T if self.self_consistent else X.zeros(1, n_all)
        # the movable peak frequencies are parameters: refining the peak grid needs no
        # rebuild of the NLP
        sl = self.grid.slot_slice
        p_slot = X.sym("slot_omega", self.grid.n_slots)
        w_sym = ca.vertcat(ca.DM(w[: sl.start]), p_slot, ca.DM(w[sl.stop:]))
        # v and s keep their shape: map broadcasts them (and sums their derivatives)
        outs = mapped(v, s, y_row, w_sym.T)
        res_u, t_re, t_im, r_re, r_im, ln_mach, ln_re = (o.T for o in outs)
        pq_mx = {"T": Cx(t_re, t_im), "R": Cx(r_re, r_im), "ln_mach": ln_mach, "ln_re": ln_re}
        d_mx = study.design_at({n: vals[i] for i, n in enumerate(DESIGN_VARIABLES)})
        mt = combine(study, self.grid, pq_mx, design_quantities(study, self.grid, d_mx,
                                                                 self.dia))
        self.sigma_ref = self._reference_sigma()
        # sigma^2 = sum_j stroke_weight_j |R_j|^2 (linearization.stroke_variance), written
        # as a chain of partial sums c_j (in units of sigma_ref^2) so that no constraint
        # row couples all grid points: a dense row would make the Jacobian's colouring
        # need one sweep per point.
        sw = np.asarray(self.grid.response.stroke_weight, float)
        inc = sw / self.sigma_ref**2 * _take(pq_mx["R"], self.grid.floor_slice).abs2()
        nf = self.grid.n_floor
        c = X.sym("stroke_partial_sums", nf)
        res_chain = c - ca.vertcat(X(0), c[: nf - 1]) - inc
        res_s = ca.vertcat(res_chain, ca.exp(2.0 * s) / self.sigma_ref**2 - c[nf - 1])
        self._chain_weights = sw / self.sigma_ref**2
        if not self.self_consistent:
            res_u = X(0, 1)

        aux: list = []

        def sym(name, n):
            a = X.sym(name, n)
            aux.append(a)
            return a

        cons = _constraints(study, mt, n_all)
        nk = len(self.objectives)
        p_w = X.sym("weights", nk)
        p_wd = X.sym("w_diameter")
        p_eps = X.sym("eps", nk)
        j_total = p_wd * ca.log(d_mx.capillary_diameter_m)
        self.j_funcs = {}
        js = []
        for k, kind in enumerate(self.objectives):
            jk, _, ocons = _objective(kind, mt, study, self.grid, sym)
            cons += ocons
            cons.append(_Con(f"bound_{kind}", jk - p_eps[k], -math.inf, 0.0, 1,
                             f"{kind} <= epsilon"))
            j_total = j_total + p_w[k] * jk
            js.append(jk)
        self.constraints = cons
        x = ca.vertcat(z, s, y, c, *aux)
        p = ca.vertcat(p_w, p_wd, p_eps, p_slot)
        g = ca.vertcat(res_u, res_s, *[c.expr for c in cons])
        self.n_eq = int(res_u.numel()) + int(res_s.numel())
        self.nc = nf
        lbg = [0.0] * self.n_eq
        ubg = [0.0] * self.n_eq
        self.con_rows = []
        row = self.n_eq
        for c in cons:
            n = int(c.expr.numel())
            lbg += [c.lo] * n
            ubg += [c.hi] * n
            self.con_rows.append((c, row, n))
            row += n
        self.lbg, self.ubg = np.array(lbg), np.array(ubg)
        self.nz, self.ny = nz, int(y.numel())
        self.naux = int(sum(int(a.numel()) for a in aux))
        self.nx = int(x.numel())
        # bounds: the scaled design in [-1, 1]; generous physical boxes on the
        # implicit unknowns keep IPOPT's trial steps away from overflow
        lbx = np.full(self.nx, -np.inf)
        ubx = np.full(self.nx, np.inf)
        lbx[:nz], ubx[:nz] = -1.0, 1.0
        lbx[nz], ubx[nz] = math.log(SIGMA_BOUNDS_M[0]), math.log(SIGMA_BOUNDS_M[1])
        i0 = nz + 1
        lbx[i0: i0 + self.ny] = math.log(VELOCITY_BOUNDS_M_S[0])
        ubx[i0: i0 + self.ny] = math.log(VELOCITY_BOUNDS_M_S[1])
        i0 += self.ny + nf  # partial sums: free (a bound would be pushed off its zeros)
        lbx[i0:], ubx[i0:] = -EPIGRAPH_BOUND, EPIGRAPH_BOUND
        self.lbx, self.ubx = lbx, ubx
        self.np = int(p.numel())
        self.eval_fn = ca.Function("eval", [x, p], [j_total, g])
        self._j_fn_p = ca.Function("objectives", [x, p_slot], [ca.vertcat(*js)])
        x_core = ca.vertcat(z, s, y)
        self._chain_fn_p = ca.Function("chain", [x_core, p_slot], [ca.cumsum(inc)])
        self._aux_fn_p = ca.Function("aux_quantities", [x_core, p_slot],
                                   [mt["ln_ms_band"] - mt["ln_limit2"], mt["ln_T2_peak"],
                                    mt["ms_all"]])
        opts = {
            "ipopt.print_level": 0,
            "print_time": False,
            "ipopt.sb": "yes",
            "ipopt.max_iter": study.solver["max_iter"],
            "ipopt.tol": study.solver["tol"],
            "ipopt.constr_viol_tol": 1e-9,
            **IPOPT_OPTIONS,
            "error_on_fail": False,
        }
        self.solver = ca.nlpsol("isodesign", "ipopt",
                                {"x": x, "f": j_total, "g": g, "p": p}, opts)

    def params(self, weights=None, diameter_weight: float = 0.0, eps=None) -> np.ndarray:
        """Parameter vector: objective weights (default: minimize the first objective),
        the weight of ln D_c and the epsilon bounds (default: none)."""
        nk = len(self.objectives)
        w = np.zeros(nk)
        if weights is None:
            w[0] = 1.0
        else:
            w[:] = weights
        e = np.full(nk, 1e20) if eps is None else np.asarray(
            [1e20 if v is None else v for v in eps], float)
        return np.concatenate([w, [diameter_weight], e, 2.0 * math.pi * self.slot_hz])

    def set_slots(self, frequencies_hz) -> None:
        """Move the movable peak-grid frequencies (Hz); the grid follows."""
        f = np.asarray(frequencies_hz, float)
        if f.size != self.grid.n_slots:
            raise ValueError(f"set_slots: need {self.grid.n_slots} frequencies, got {f.size}")
        self.slot_hz = f.copy()
        self.grid = self.grid.with_slots(f)

    def _slot_omega(self) -> np.ndarray:
        return 2.0 * math.pi * self.slot_hz

    def objective_values(self, x: np.ndarray) -> np.ndarray:
        """Internal values J_k of every objective at x."""
        return np.asarray(self._j_fn_p(x, self._slot_omega())).ravel()

    def _aux_fn(self, x_core):
        return self._aux_fn_p(x_core, self._slot_omega())

    def _chain_fn(self, x_core):
        return self._chain_fn_p(x_core, self._slot_omega())

    def _reference_sigma(self) -> float:

        st = self.study
        sigma, _ = solve_stroke_rms(st.start_design(), st.payload, self.grid.response,
                                    flow=st.models["flow"],
                                    amplitude_mode=st.models["amplitude_mode"],
                                    diaphragm=self.dia)
        return sigma

    # -- starting points ---------------------------------------------------
    def initial_guess(self, values: dict) -> np.ndarray:
        """A consistent x0 at a design: implicit unknowns from the NumPy solvers."""

        st = self.study
        d = st.design_at(values)
        sigma, _ = solve_stroke_rms(d, st.payload, self.grid.response, flow=st.models["flow"],
                                    amplitude_mode=st.models["amplitude_mode"],
                                    diaphragm=self.dia)
        x0 = np.zeros(self.nx)
        x0[: self.nz] = np.clip(self.scaling.to_z(values), -1.0, 1.0)
        x0[self.nz] = math.log(sigma)
        u = self._velocity(d, sigma)
        if self.self_consistent:
            x0[self.nz + 1: self.nz + 1 + self.ny] = np.log(u)
        self.fill_dependent(x0)
        return x0

    def retighten(self, sol: dict) -> dict:
        """A solution with its epigraph variables made tight and J, g re-evaluated."""
        x = sol["x"].copy()
        x[self.nx - self.naux:] = self.aux_guess(x)
        _, g = self.eval_fn(x, self.params())
        g = np.asarray(g).ravel()
        viol = self.violations(g)
        out = dict(sol)
        out.update(x=x, g=g, J=float(self.objective_values(x)[0]),
                   J_all=self.objective_values(x), violations=viol,
                   max_violation=float(max((v for _, v in viol), default=0.0)))
        return out

    def fill_dependent(self, x: np.ndarray) -> np.ndarray:
        """Set the partial sums and the epigraph variables consistent with x (in place)."""
        n_core = self.nz + 1 + self.ny
        x[n_core: n_core + self.nc] = np.asarray(self._chain_fn(x[:n_core])).ravel()
        x[self.nx - self.naux:] = self.aux_guess(x)
        return x

    def aux_guess(self, x: np.ndarray) -> np.ndarray:
        """Epigraph variables on their boundary at x (worst margin, peak |T|, in dB)."""
        if not self.naux:
            return np.zeros(0)
        n_core = self.nz + 1 + self.ny
        margins, t2, ms = (np.asarray(v).ravel() for v in self._aux_fn(x[:n_core]))
        db = 10.0 / LN10
        vals = []
        for kind in self.objectives:
            if kind == "worst_band_margin":
                vals.append(float(np.min(-db * margins)))
            elif kind == "peak_transmissibility":
                vals.append(float(np.max(db * t2)))
            elif kind == "rms_velocity":
                vals.append(0.5 * math.log(float(np.sum(ms[rms_rows(self.study, self.grid)]))))
        return np.asarray(vals[: self.naux], float)

    def _velocity(self, d, sigma) -> np.ndarray:

        a = EQUIVALENT_AMPLITUDE_FACTOR * sigma
        w = self.grid.omega
        if self.self_consistent:
            sol = solve_velocity_amplitude(self.study.models["flow"], d, w, a)
            if not np.all(sol.converged):
                raise SolverError("velocity amplitude did not converge at the initial guess")
            return sol.velocity
        return kinematic_velocity(d, w, a)

    # -- solving -------------------------------------------------------------
    def solve(self, x0: np.ndarray, p=None) -> dict:
        """Run IPOPT from x0 (parameters from :meth:`params`, default: minimize the
        first objective); return x, J (the first objective's value), g, status,
        iterations, time and violations."""
        t0 = time.perf_counter()
        p = self.params() if p is None else np.asarray(p, float)
        res = self.solver(x0=x0, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg, p=p)
        wall = time.perf_counter() - t0
        stats = self.solver.stats()
        x = np.asarray(res["x"]).ravel()
        g = np.asarray(res["g"]).ravel()
        viol = self.violations(g)
        return {
            "x": x,
            "J": float(self.objective_values(x)[0]),
            "J_all": self.objective_values(x),
            "g": g,
            "status": stats.get("return_status", "unknown"),
            "success": bool(stats.get("success", False)),
            "iterations": int(stats.get("iter_count", -1)),
            "wall_s": wall,
            "max_violation": float(max((v for _, v in viol), default=0.0)),
            "violations": viol,
        }

    def violations(self, g: np.ndarray) -> list[tuple[str, float]]:
        """Worst violation of each constraint group (equalities as 'residual ...')."""
        out = []
        eq = np.abs(g[: self.n_eq])
        if eq.size:
            out.append(("implicit_equations", float(np.max(eq))))
        for c, row, n in self.con_rows:
            gi = g[row: row + n]
            v = np.maximum(np.maximum(self.lbg[row: row + n] - gi, gi - self.ubg[row: row + n]),
                           0.0)
            out.append((c.name, float(np.max(v)) if v.size else 0.0))
        return out

    def values(self, x: np.ndarray) -> dict:
        """Design-variable values at x (fixed ones from the study)."""
        vals = {v.name: v.start for v in self.study.variables}
        # IPOPT relaxes bounds by ~1e-8: report the design inside its box
        vals.update(self.scaling.to_values(np.clip(x[: self.nz], -1.0, 1.0)))
        return vals

    def sigma(self, x: np.ndarray) -> float:
        return math.exp(x[self.nz])


# ---------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class StartRecord:
    """One start of the multi-start run."""

    index: int
    start: dict
    status: str
    success: bool
    feasible: bool
    iterations: int
    wall_s: float
    objective: float
    max_violation: float
    final: dict

    def row(self) -> dict:
        """Flat dict for a table."""
        r = {"start": self.index, "status": self.status, "success": self.success,
             "feasible": self.feasible, "iterations": self.iterations, "wall_s": self.wall_s,
             "objective": self.objective, "max_violation": self.max_violation}
        r.update({f"start_{k}": v for k, v in self.start.items()})
        r.update({f"final_{k}": v for k, v in self.final.items()})
        return r


@dataclass(frozen=True)
class ConstraintReport:
    """A constraint at the optimum (its worst row for vector constraints).

    ``value``, ``lower`` and ``upper`` are in natural units (``unit``);
    ``margin`` is the NLP's margin in its internal units (the log of the ratio
    to the bound, or dB), which is what ``active`` (margin < 1e-4) is judged on;
    :attr:`margin_natural` is the distance to the nearest bound in ``unit``.
    """

    name: str
    value: float
    lower: float | None
    upper: float | None
    unit: str
    margin: float
    active: bool
    description: str

    @property
    def margin_natural(self) -> float:
        """Distance to the nearest bound in the constraint's own unit (>= 0: satisfied)."""
        m = [self.value - self.lower] if self.lower is not None else []
        m += [self.upper - self.value] if self.upper is not None else []
        return min(m) if m else math.inf


@dataclass(frozen=True, eq=False)
class OptimizationResult:
    """Outcome of :func:`optimize`.

    ``feasible`` is False when no start found a design that satisfies every
    constraint; ``design`` is then the best point found (least violation),
    reported with ``violations`` and not to be used as a design. ``peak`` records
    the exchange method on the peak grid: rounds, added frequencies, and the
    continuous peak of |T| at the optimum (dB, Hz).
    """

    study: Study
    objective: str
    feasible: bool
    status: str
    design: Any
    values: dict
    objective_value: float
    start_values: dict
    start_objective: float | None
    constraints: tuple[ConstraintReport, ...]
    starts: tuple[StartRecord, ...]
    n_reached_best: int
    violations: tuple[tuple[str, float], ...]
    flat_direction: dict | None
    recheck_max_rel_diff: float | None
    analysis: Any = None
    start_analysis: Any = None
    wall_s: float = 0.0
    settings: dict = field(default_factory=dict)
    peak: dict | None = None

    @property
    def success(self) -> bool:
        """True for a feasible, re-checked optimum."""
        return self.feasible and self.recheck_max_rel_diff is not None

    def raise_for_status(self) -> None:
        """Raise :class:`SolverError` unless the run found a feasible optimum."""
        if not self.feasible:
            worst = ", ".join(f"{n} ({v:.3g})" for n, v in self.violations[:3])
            raise SolverError(f"no feasible design ({self.status}); most violated: {worst}")

    def to_frame(self):
        """Design variables and figures, start vs optimum (one row per quantity)."""
        import pandas as pd

        rows = []
        for n in DESIGN_VARIABLES:
            fixed = self.study.variable(n).fixed
            rows.append({"quantity": n, "start": self.start_values[n], "optimum": self.values[n],
                         "unit": _UNITS[n], "note": "fixed" if fixed else ""})
        unit = OBJECTIVE_UNITS[self.objective]
        rows.append({"quantity": f"objective: {self.objective}", "start": self.start_objective,
                     "optimum": self.objective_value, "unit": unit, "note": ""})
        for c in self.constraints:
            rows.append({"quantity": f"constraint: {c.name}", "start": None, "optimum": c.value,
                         "unit": c.unit, "note": ("BINDING " if c.active else "")
                         + f"margin {c.margin:.3g}"})
        return pd.DataFrame(rows)

    def starts_frame(self):
        """One row per start (status, iterations, time, objective)."""
        import pandas as pd

        return pd.DataFrame([s.row() for s in self.starts])


_UNITS = {"volume_ratio": "-", "top_volume_m3": "m^3", "capillary_length_m": "m",
          "capillary_diameter_m": "m"}


# ---------------------------------------------------------------------------
# the driver
# ---------------------------------------------------------------------------
def start_points(study: Study, scaling: _Scaling) -> list[dict]:
    """The study's start plus Latin-hypercube starts in the scaled log space.

    A Latin hypercube: each free variable's range is cut into ``n`` equal strata
    and every stratum holds exactly one start, at a random place, the strata
    paired at random between variables (seeded by ``solver.seed``). Written with
    NumPy: importing ``scipy.stats`` for it cost a second of start-up.
    """
    base = {v.name: v.start for v in study.variables}
    pts = [base]
    n = study.solver["starts"] - 1
    if n > 0 and scaling.names:
        rng = np.random.default_rng(study.solver["seed"])
        d = len(scaling.names)
        strata = np.column_stack([rng.permutation(n) for _ in range(d)])
        z = 2.0 * (strata + rng.random((n, d))) / n - 1.0
        for zi in z:
            vals = dict(base)
            vals.update(scaling.to_values(0.98 * zi))
            pts.append(vals)
    return pts


_POOL_PROBLEM: Problem | None = None  # the problem the forked start workers inherit


def _solve_start(vals: dict):
    """Initial guess and IPOPT solve of one start (in a worker or in-process)."""
    prob = _POOL_PROBLEM
    try:
        x0 = prob.initial_guess(vals)
    except SolverError as exc:
        return str(exc)
    return prob.solve(x0, _POOL_PARAMS)


_POOL_PARAMS = None  # the NLP parameters of the starts (None: minimize the first objective)


def run_starts(prob: Problem, starts: list[dict], *, workers=None, progress=None,
               params=None) -> list:
    """Solve every start; in forked worker processes when more than one core is free.

    The workers inherit the built solver through ``fork`` (nothing is pickled but
    the start values and the results), so the NLP is built once. Results come
    back in start order: a solution dict, or the error message of a start whose
    initial guess failed.
    """
    global _POOL_PROBLEM, _POOL_PARAMS
    import os

    n = len(starts)
    if workers is None:
        workers = min(DEFAULT_WORKERS, os.cpu_count() or 1)
    _POOL_PROBLEM = prob
    _POOL_PARAMS = params
    results: list = [None] * n
    try:
        ctx = None
        if workers > 1 and n > 1:
            import multiprocessing as mp

            try:
                ctx = mp.get_context("fork")
            except ValueError:
                ctx = None
        if ctx is None:
            for i, vals in enumerate(starts):
                results[i] = _solve_start(vals)
                if progress:
                    progress(i + 1, n, results[i])
        else:
            with ctx.Pool(processes=min(workers, n)) as pool:
                done = 0
                for i, out in pool.imap_unordered(_indexed_start, list(enumerate(starts))):
                    results[i] = out
                    done += 1
                    if progress:
                        progress(done, n, out)
    finally:
        _POOL_PROBLEM = None
        _POOL_PARAMS = None
    return results


def _indexed_start(item):
    i, vals = item
    return i, _solve_start(vals)


#: Worker processes for the starts (capped by the machine's cores).
DEFAULT_WORKERS = 2


def optimize(study: Study, *, progress=None, problem: Problem | None = None,
             analyze: bool = True) -> OptimizationResult:
    """Optimize a study: multi-start IPOPT, tie-break, re-check, analysis.

    Parameters
    ----------
    study : Study
    progress : callable or None
        ``progress(done, total, record)`` after each start (for a progress bar).
    problem : Problem, optional
        A prebuilt NLP of this study whose first objective is the study's (a Pareto
        study passes its two-objective NLP); built here by default.
    analyze : bool
        Run the fine-grid band responses of the optimum and of the start (default).

    Returns
    -------
    OptimizationResult
        Check ``.feasible`` (or call ``.raise_for_status()``). Raises
        :class:`SolverError` when the NLP's optimum and the NumPy analysis
        disagree (a bug, never a silently wrong design).
    """
    t_all = time.perf_counter()
    prob = problem if problem is not None else Problem(study)
    starts = start_points(study, prob.scaling)
    results = run_starts(prob, starts, workers=study.solver.get("workers"),
                         progress=progress)
    records: list[StartRecord] = []
    sols = []
    for i, (vals, out) in enumerate(zip(starts, results, strict=True)):
        if isinstance(out, str):
            records.append(StartRecord(i, vals, f"initial guess failed: {out}", False, False,
                                       0, 0.0, math.nan, math.inf, {}))
            sols.append(None)
            continue
        sol = out
        feasible = sol["max_violation"] <= 1e-6
        records.append(StartRecord(i, vals, sol["status"], sol["success"], feasible,
                                   sol["iterations"], sol["wall_s"],
                                   objective_value_to_natural(prob.objective, sol["J"]),
                                   sol["max_violation"], prob.values(sol["x"])))
        sols.append(sol)
    good = [i for i, r in enumerate(records) if r.feasible and sols[i] is not None]
    settings = _settings(study)
    start_vals = starts[0]
    if not good:
        # best point found: least violation
        cand = [i for i, s in enumerate(sols) if s is not None]
        if not cand:
            raise SolverError("no start could be initialized (see the start records)")
        # least violation, preferring starts whose implicit equations are solved (a start
        # stopped by the iteration limit may leave them unsolved: not a physical point)
        ib = min(cand, key=lambda i: (_equation_residual(sols[i]) > 1e-6,
                                      sols[i]["max_violation"]))
        sol = sols[ib]
        viol = sorted(sol["violations"], key=lambda t: -t[1])
        vals = prob.values(sol["x"])
        return OptimizationResult(
            study=study, objective=prob.objective, feasible=False, status=sol["status"],
            design=study.design_at(vals), values=vals,
            objective_value=objective_value_to_natural(prob.objective, sol["J"]),
            start_values=start_vals, start_objective=None,
            constraints=tuple(_constraint_reports(prob, sol["g"])), starts=tuple(records),
            n_reached_best=0, violations=tuple((n, v) for n, v in viol if v > 1e-6),
            flat_direction=None, recheck_max_rel_diff=None,
            wall_s=time.perf_counter() - t_all, settings=settings,
        )
    ib = min(good, key=lambda i: sols[i]["J"])
    best = sols[ib]
    tol_j = _flat_tolerance(prob.objective, best["J"])
    n_best = sum(1 for i in good if sols[i]["J"] <= best["J"] + tol_j)

    flat = None
    final = best
    if study.solver["tie_break"]:
        flat, final = _tie_break(study, prob, best, tol_j)
    prob, final, best, flat, peak_info = _refine_peak(study, prob, final, best, flat, tol_j)
    vals = prob.values(final["x"])
    d = study.design_at(vals)
    diff = recheck(prob, final, d)

    kw = {"flow": study.models["flow"], "amplitude_mode": study.models["amplitude_mode"],
          "diaphragm": prob.dia, "random_method": study.models["random_method"]}
    analysis = start_analysis = None
    if analyze:
        analysis = band_response(d, study.payload, study.floor, study.target,
                                 bands=study.bands, derive_pressure=False, warn=False, **kw)
        d0 = study.design_at(start_vals)
        start_analysis = band_response(d0, study.payload, study.floor, study.target,
                                       bands=study.bands, derive_pressure=False, warn=False,
                                       **kw)
    j0 = None
    try:
        x00 = prob.initial_guess(start_vals)
        j0 = objective_value_to_natural(prob.objective, float(prob.objective_values(x00)[0]))
    except SolverError:
        pass
    return OptimizationResult(
        study=study, objective=prob.objective, feasible=True, status=final["status"], design=d,
        values=vals, objective_value=objective_value_to_natural(prob.objective, final["J"]),
        start_values=start_vals, start_objective=j0,
        constraints=tuple(_constraint_reports(prob, final["g"])), starts=tuple(records),
        n_reached_best=n_best, violations=(), flat_direction=flat,
        recheck_max_rel_diff=diff, analysis=analysis, start_analysis=start_analysis,
        peak=peak_info,
        wall_s=time.perf_counter() - t_all, settings=settings,
    )


#: Tolerance of the continuous peak of |T| over its sampled value (exchange method).
PEAK_TOLERANCE_DB = 0.01
#: Refinement rounds of the peak grid (five movable frequencies each).
PEAK_ROUNDS = 2
#: Movable peak-grid frequencies reserved in every NLP (parameters, no rebuild).
PEAK_SLOTS = 5 * PEAK_ROUNDS


def continuous_peak_db(prob: Problem, values: dict, sigma: float) -> tuple[float, float]:
    """Peak of |T| at the operating amplitude between the grid's frequencies (NumPy).

    A dense log grid over the peak grid's span, then a parabola through the
    largest sample and its neighbours in ln f. Returns (peak in dB, frequency in Hz).
    """

    st = prob.study
    d = st.design_at(values)
    pk = prob.grid.omega[prob.grid.peak_slice] / (2.0 * math.pi)
    f = np.geomspace(pk.min(), pk.max(), 4001)
    a = EQUIVALENT_AMPLITUDE_FACTOR * sigma
    w = 2.0 * math.pi * f

    k = complex_stiffness(d, f, a, flow=st.models["flow"],
                          amplitude_mode=st.models["amplitude_mode"], diaphragm=prob.dia,
                          pairwise=True, warn=False).k
    t2 = np.abs(transmissibility(Cx.from_complex(k), st.payload.mass_per_isolator_kg,
                                 w).to_complex()) ** 2
    i = int(np.clip(np.argmax(t2), 1, f.size - 2))
    x = np.log(f[i - 1: i + 2])
    y = 10.0 * np.log10(t2[i - 1: i + 2])
    c2, c1, c0 = np.polyfit(x - x[1], y, 2)
    if c2 < 0:
        xm = -c1 / (2.0 * c2)
        return float(c0 - c1 * c1 / (4.0 * c2)), float(f[i] * math.exp(xm))
    return float(y[1]), float(f[i])


def _refine_peak(study: Study, prob: Problem, final: dict, best: dict, flat, tol_j):
    """Exchange method for the semi-infinite peak constraint (and objective).

    The NLP bounds |T| at the peak grid's frequencies only, so an optimum can hide
    a sharper peak between them. After each solve, the continuous peak at the
    operating amplitude is measured; if it exceeds the bound (or the sampled
    objective) by more than :data:`PEAK_TOLERANCE_DB`, five of the grid's movable
    frequencies (NLP parameters: no rebuild) are placed within +-1 % of it and the
    NLP is solved again from the current design (then the tie-break again).
    """
    bound = study.constraints.get("max_peak_transmissibility_db")
    kind = prob.objective
    info = {"rounds": 0, "added_frequencies_hz": [], "peak_db": None, "peak_frequency_hz": None}
    if bound is None and kind != "peak_transmissibility":
        return prob, final, best, flat, info
    for _ in range(PEAK_ROUNDS + 1):
        vals = prob.values(final["x"])
        peak_db, f_pk = continuous_peak_db(prob, vals, prob.sigma(final["x"]))
        info.update(peak_db=peak_db, peak_frequency_hz=f_pk)
        sampled = objective_value_to_natural(kind, final["J"]) \
            if kind == "peak_transmissibility" else None
        limit = min(v for v in (bound, sampled) if v is not None)
        if peak_db <= limit + PEAK_TOLERANCE_DB or info["rounds"] >= PEAK_ROUNDS:
            break
        new = [f_pk * r for r in (0.99, 0.995, 1.0, 1.005, 1.01)]
        k = info["rounds"] * len(new)
        slots = prob.slot_hz.copy()
        slots[k: k + len(new)] = new
        prob.set_slots(slots)
        info["added_frequencies_hz"] += new
        info["rounds"] += 1
        sol = prob.solve(prob.initial_guess(vals))
        if sol["max_violation"] > 1e-6:
            raise SolverError(
                f"peak refinement: the re-solve with frequencies added near {f_pk:.4g} Hz "
                f"failed ({sol['status']})"
            )
        best = sol
        final = sol
        if study.solver["tie_break"]:
            flat, final = _tie_break(study, prob, sol, _flat_tolerance(kind, sol["J"]))
    return prob, final, best, flat, info


def _equation_residual(sol: dict) -> float:
    return dict(sol["violations"]).get("implicit_equations", 0.0)


def _flat_tolerance(kind: str, j: float) -> float:
    if kind in ("worst_band_margin", "peak_transmissibility", "transmissibility_at"):
        return FLAT_TOLERANCE_DB
    return FLAT_TOLERANCE_REL  # J is a log: relative tolerance


def _tie_break(study: Study, prob: Problem, best: dict, tol_j: float):
    """Range of D_c with the objective within tol of the optimum; pick the largest D_c.

    In the laminar limit L_c and D_c act through L_c/D_c^4 only (physics notes,
    section 5): the optimum is a valley. Two more solves of the same NLP
    (parameters changed, warm-started at the optimum) minimize and maximize
    ln D_c subject to ``J <= J* + tol``; the documented tie-break returns the
    largest D_c (larger bores are easier to make to tolerance and clog less).
    """
    if "capillary_diameter_m" not in prob.scaling.names:
        return None, best
    eps = [best["J"] + tol_j] + [None] * (len(prob.objectives) - 1)
    sols = {}
    for name, wd in (("max", -1.0), ("min", 1.0)):
        sol = prob.solve(best["x"], prob.params(weights=[0.0] * len(prob.objectives),
                                                diameter_weight=wd, eps=eps))
        sols[name] = sol if sol["max_violation"] <= 1e-6 else None
    d_opt = prob.values(best["x"])["capillary_diameter_m"]
    rng = {k: (prob.values(v["x"]) if v is not None else None) for k, v in sols.items()}
    d_lo = rng["min"]["capillary_diameter_m"] if rng["min"] else d_opt
    d_hi = rng["max"]["capillary_diameter_m"] if rng["max"] else d_opt
    info = {
        "pair": "capillary_length_m / capillary_diameter_m^4",
        "objective_tolerance": tol_j,
        "capillary_diameter_range_m": (min(d_lo, d_opt), max(d_hi, d_opt)),
        "capillary_length_range_m": (
            (rng["min"] or prob.values(best["x"]))["capillary_length_m"],
            (rng["max"] or prob.values(best["x"]))["capillary_length_m"],
        ),
        "capillary_diameter_at_optimum_m": d_opt,
        "flat": bool(max(d_hi, d_opt) / min(d_lo, d_opt) > 1.01),
        "tie_break": "largest capillary diameter with the objective within the tolerance",
    }
    chosen = best
    if sols["max"] is not None:
        # with zero objective weight the epigraph variables are slack: make them tight
        # (the point stays feasible) and re-evaluate the objective and constraints
        cand = prob.retighten(sols["max"])
        if cand["max_violation"] <= 1e-6 and cand["J"] <= best["J"] + tol_j + TIE_BREAK_SLACK:
            chosen = cand
    info["chosen_capillary_diameter_m"] = prob.values(chosen["x"])["capillary_diameter_m"]
    return info, chosen


def _constraint_reports(prob: Problem, g: np.ndarray) -> list[ConstraintReport]:
    """Constraints in natural units with margins; epigraph rows are skipped."""
    out = []
    for c, row, n in prob.con_rows:
        if c.name.startswith(("epigraph_", "bound_")):
            continue
        gi = g[row: row + n]
        lo, hi = c.lo, c.hi
        conv, unit = _NATURAL.get(c.name, (math.exp, ""))
        # the worst row of a vector constraint
        if math.isfinite(hi) and not math.isfinite(lo):
            k = int(np.argmax(gi))
        elif math.isfinite(lo) and not math.isfinite(hi):
            k = int(np.argmin(gi))
        else:
            k = int(np.argmin(np.minimum(gi - lo, hi - gi)))
        v = float(gi[k])
        margin = min(v - lo if math.isfinite(lo) else math.inf,
                     hi - v if math.isfinite(hi) else math.inf)
        out.append(ConstraintReport(
            name=c.name, value=conv(v), lower=conv(lo) if math.isfinite(lo) else None,
            upper=conv(hi) if math.isfinite(hi) else None, unit=unit,
            margin=margin, active=margin < 1e-4, description=c.describe,
        ))
    return out


def _exp(v):
    return math.exp(v)


def _db_of_ln2(v):
    return 10.0 * v / LN10


_NATURAL = {
    "total_volume": (_exp, "m^3"),
    "tilt_margin": (_exp, "-"),
    "natural_frequency": (_exp, "Hz"),
    "peak_transmissibility": (_db_of_ln2, "dB"),
    "damping_ratio": (_exp, "-"),
    "mach": (_exp, "-"),
    "laminar": (_exp, "Re"),
    "quasi_steady_alpha": (_exp, "alpha"),
    "lumped_tube": (_exp, "w l/c"),
    "lumped_top_chamber": (_exp, "w l/c"),
    "lumped_bottom_chamber": (_exp, "w l/c"),
}


def recheck(prob: Problem, sol: dict, d) -> float:
    """Re-evaluate the optimum with the NumPy analysis path; return the max rel. diff.

    The NumPy path solves sigma and the velocity amplitudes with its own
    solvers (not the NLP's values) and evaluates :func:`metrics` on them. Every
    constraint quantity must agree with the NLP's solution, and the objective
    IPOPT reports (epigraph variables included) with the analysis's, to
    :data:`RECHECK_RTOL` relative (in natural units; dB values absolute below 1).
    """

    st = prob.study
    sigma, _ = solve_stroke_rms(d, st.payload, prob.grid.response, flow=st.models["flow"],
                                amplitude_mode=st.models["amplitude_mode"], diaphragm=prob.dia)
    u = prob._velocity(d, sigma)
    mt_np = metrics(st, prob.grid, d, u, sigma, diaphragm=prob.dia)
    # the same quantities from the NLP's solution
    x = sol["x"]
    vals = prob.values(x)
    d_sym_vals = st.design_at(vals)
    sig_nlp = prob.sigma(x)
    if prob.self_consistent:
        u_nlp = np.exp(x[prob.nz + 1: prob.nz + 1 + prob.ny])
    else:
        u_nlp = prob._velocity(d_sym_vals, sig_nlp)
    mt_nlp = metrics(st, prob.grid, d_sym_vals, u_nlp, sig_nlp, diaphragm=prob.dia)
    worst = abs(sigma / sig_nlp - 1.0)
    names = []
    for key in ("stroke_variance", "ln_ms_band", "ln_T2_peak", "ln_total_volume", "ln_tilt",
                "ln_lumped", "ln_fn", "ln_zeta", "ln_mach", "ln_re", "ln_T2_point"):
        if key not in mt_np:
            continue
        a = np.asarray(mt_np[key], float)
        b = np.asarray(mt_nlp[key], float)
        if key.startswith("ln_"):
            rel = np.abs(np.expm1(a - b))
        else:
            rel = np.abs(a / b - 1.0)
        m = float(np.max(rel)) if rel.size else 0.0
        names.append((key, m))
        worst = max(worst, m)
    # the objective IPOPT reports (epigraph variables included) against the analysis
    for k, kind in enumerate(prob.objectives):
        v_nlp = objective_value_to_natural(kind, float(sol["J_all"][k]))
        v_np = objective_natural(kind, mt_np, st, prob.grid)
        m = abs(v_nlp - v_np) / max(1.0, abs(v_np))
        names.append((f"objective {kind}", m))
        worst = max(worst, m)
    if not worst <= RECHECK_RTOL:
        bad = ", ".join(f"{k} {v:.2e}" for k, v in names if v > RECHECK_RTOL)
        raise SolverError(
            f"the NLP optimum disagrees with the NumPy analysis (max relative difference "
            f"{worst:.2e} > {RECHECK_RTOL:g}: {bad or 'sigma'}); the design is not returned"
        )
    return worst


def _settings(study: Study) -> dict:
    return {
        "solver": "ipopt (CasADi nlpsol, exact Hessian)",
        "options": {"max_iter": study.solver["max_iter"], "tol": study.solver["tol"],
                    "constr_viol_tol": 1e-9,
                    **{k.removeprefix("ipopt."): v for k, v in IPOPT_OPTIONS.items()}},
        "starts": study.solver["starts"],
        "seed": study.solver["seed"],
        "recheck_rtol": RECHECK_RTOL,
        "flat_tolerance_db": FLAT_TOLERANCE_DB,
        "flat_tolerance_rel": FLAT_TOLERANCE_REL,
    }


def objective_natural(kind: str, mt: dict, study: Study, grid: Grid) -> float:
    """An objective's value in natural units from NumPy :func:`metrics`."""
    db = 10.0 / LN10
    if kind == "worst_band_margin":
        return float(np.min(db * (mt["ln_limit2"] - mt["ln_ms_band"])))
    if kind == "peak_transmissibility":
        return float(np.max(db * mt["ln_T2_peak"]))
    if kind == "transmissibility_at":
        return float(db * mt["ln_T2_point"])
    if kind == "total_volume":
        return float(np.exp(mt["ln_total_volume"]))
    if kind == "rms_velocity":
        return math.sqrt(_sum_rows(mt["ms_all"], rms_rows(study, grid)))
    raise KeyError(kind)


def evaluate_design(study: Study, values: dict, *, grid: Grid | None = None,
                    objectives: tuple = ()) -> dict:
    """Objective and constraint values of a design on the NumPy analysis path.

    The same :func:`metrics` the NLP uses, with sigma and the tube velocities
    from the NumPy solvers. Used by the re-check, by the comparison with
    gradient-free optimizers (benchmarks) and by studies.

    Returns
    -------
    dict
        ``objectives`` (kind -> natural value), ``constraints`` (name -> worst
        value in the NLP's units, with ``lower``/``upper``), ``max_violation``
        and ``sigma``.
    """

    grid = grid or build_grid(study)
    d = study.design_at(values)
    dia = diaphragm_model(study.models["diaphragm"])
    sigma, _ = solve_stroke_rms(d, study.payload, grid.response, flow=study.models["flow"],
                                amplitude_mode=study.models["amplitude_mode"], diaphragm=dia)
    a = EQUIVALENT_AMPLITUDE_FACTOR * sigma
    if study.models["amplitude_mode"] == "self_consistent":
        u = solve_velocity_amplitude(study.models["flow"], d, grid.omega, a).velocity
    else:
        u = kinematic_velocity(d, grid.omega, a)
    mt = metrics(study, grid, d, u, sigma, diaphragm=dia)
    objs = {kind: objective_natural(kind, mt, study, grid)
            for kind in objectives or (study.objective["kind"],)}
    cons = {}
    worst = 0.0
    for c in _constraints(study, mt, grid.omega.size):
        v = np.atleast_1d(np.asarray(c.expr, float))
        viol = np.maximum(np.maximum(c.lo - v, v - c.hi), 0.0)
        cons[c.name] = {"value": v, "lower": c.lo, "upper": c.hi,
                        "violation": float(np.max(viol))}
        worst = max(worst, float(np.max(viol)))
    return {"objectives": objs, "constraints": cons, "max_violation": worst, "sigma": sigma,
            "metrics": mt}
