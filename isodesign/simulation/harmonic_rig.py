"""Time-domain check of the frequency-domain spring model.

Integrates the NONLINEAR lumped equations of the dual-chamber spring (paper
Section 3.1, before any linearization) under a sinusoidal piston motion
``x(t) = X sin(w t)``, waits for the periodic steady state, and returns the
first harmonic of the piston force as a complex stiffness. Nothing here is
linearized: not the gas law, not the energy balance, not ``|u| u``.

Equations (``x > 0`` compresses the top chamber; ``m_dot`` is the mass flow
from the top to the bottom chamber):

* Top chamber volume ``V_t = V_t0 - A_p x``; bottom ``V_b0 = N V_t0`` fixed.
* Chamber masses ``dm_t/dt = -m_dot``, ``dm_b/dt = +m_dot`` (Eqs. 29-30); the
  total mass is an exact invariant and is eliminated (``m_b = M - m_t``).
* Adiabatic chambers (``design.polytropic_index is None``): the energy balance
  of an open control volume (Eqs. 7-11 without their small-signal steps) with
  the upwind enthalpy ``c_p T_flow`` of the gas that crosses the boundary::

      dp_i/dt = (kappa R T_flow m_dot_in,i - kappa p_i dV_i/dt) / V_i,   T_i = p_i V_i / (m_i R)

  ``T_flow`` is the temperature of the chamber the gas comes from. Linearized
  about ``(p0, T0)`` this is Eq. 14 (top) and Eq. 15 (bottom).
* Polytropic chambers (index n): ``p_i ~ (m_i/V_i)^n``, i.e.
  ``dp_i/dt = n p_i (m_dot_in,i/m_i - (dV_i/dt)/V_i)``, which linearizes to
  Eqs. 14-15 with ``kappa -> n``.
* Tube, ``flow="quasi_steady"``: ``m_dot = rho_up A_c u`` (``rho_up``: density
  of the upstream chamber) and the plug-flow momentum balance (Eq. 17 with the
  inertance coefficient of :data:`~isodesign.spring.capillary.QUASI_STEADY_INERTANCE_COEFFICIENT`,
  Eq. 20 with the minor loss)::

      rho_tube L_c c_I du/dt = (p_t - p_b) - L_c mu Phi(Re) u / (2 D_c^2) - K rho_up |u| u / 2

  with ``Phi = f Re`` the Churchill all-regime friction
  (:func:`~isodesign.spring.capillary.churchill_friction_re_product`) at the
  instantaneous ``Re = rho_up |u| D_c / mu`` (``Phi -> 64`` at ``u -> 0``: the
  laminar law is linear), and ``rho_tube = (rho_t + rho_b)/2`` (smooth across
  ``u = 0``).
* Tube, ``flow="poiseuille"``: no inertia, no minor loss (Eq. 41's model):
  ``m_dot = (p_t - p_b) / C_u`` with ``C_u`` from
  :func:`~isodesign.spring.capillary.poiseuille_resistance`.
* Force on the piston ``F = A_p (p_t - p0)`` (Eq. 3); with ``F_1 = a cos wt +
  b sin wt`` its first harmonic, ``k_air = (b + j a) / X``; the diaphragm's
  describing-function model is added in the frequency domain (Eq. 42).

Numerics: the states are the deviations from the static state, scaled by the
amplitudes of the harmonic-balance solution, integrated in the normalized time
``theta = w t`` (period 2 pi) with :func:`scipy.integrate.solve_ivp` (LSODA by
default: it switches to BDF where the tube's fast relaxation makes the system
stiff), starting from the harmonic-balance (frequency-domain) solution. All
cases of a grid are stacked into one vectorized right-hand side, so the
package's own friction function is called on arrays, not scalars. See
``docs/simulation.md`` for the verified error and the measured agreement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError, check_positive, check_range
from isodesign.results import ResultDisplay
from isodesign.simulation.lumped import lumped_twin
from isodesign.spring.amplitude import solve_velocity_amplitude
from isodesign.spring.capillary import (
    QUASI_STEADY_INERTANCE_COEFFICIENT,
    churchill_friction_re_product,
    poiseuille_resistance,
    tube_end_length_m,
)
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness
from isodesign.spring.flow_models import SIMULATION_FLOW_MODELS, flow_model
from isodesign.spring.stiffness import complex_stiffness

__all__ = [
    "MAX_STROKE_FRACTION",
    "SimulationGridResult",
    "SimulationResult",
    "agreement_table",
    "simulate_grid",
    "simulate_stiffness",
]

#: Largest allowed swept volume A_p X as a fraction of V_t0 (V_t must stay > 0).
MAX_STROKE_FRACTION = 0.5
#: Integration methods of solve_ivp that are accepted.
_METHODS = ("DOP853", "RK45", "Radau", "BDF", "LSODA")
#: Successive cycles whose change must be below the tolerance to stop.
_CONSECUTIVE = 2
#: Allowance for the secular heating of the closed adiabatic gas, as a multiple
#: of the relative energy gain per cycle (|d ln k / d ln T| <= 1 + N/(N+2) < 2).
_HEATING_ALLOWANCE = 2.0


# ---------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class SimulationResult(ResultDisplay):
    """Complex stiffness from the time-domain simulation at one (X, w).

    Attributes
    ----------
    frequency_hz, amplitude_m : float
        Excitation frequency (Hz) and piston amplitude X (m), ``x = X sin wt``.
    k : complex
        Total stiffness ``k_air + k_D*`` (Eq. 42), N/m.
    k_air : complex
        First harmonic of the air force over X (time-domain counterpart of
        Eq. 38), N/m.
    velocity_amplitude_m_s : float
        Amplitude of the first harmonic of the tube velocity u.
    peak_velocity_m_s : float
        ``max |u|`` over the last cycle.
    force_distortion : float
        Harmonic distortion of the air force: ``sqrt(sum_{n>=2} |F_n|^2) / |F_1|``
        (RMS of the harmonics 2, 3, ... over the RMS of the first harmonic).
    cycles : int
        Cycles integrated.
    periodic_change : float
        ``|k_n - k_(n-1)| / |k_n|`` of the air stiffness over the last cycle.
    converged : bool
        The periodic change stayed below the tolerance (plus the heating
        allowance, see ``heating_per_cycle``) for two successive cycles.
    heating_per_cycle : float
        Relative gain of the gas's internal energy over the last cycle. The
        closed adiabatic gas keeps the energy the tube dissipates, so it warms
        by ``(kappa - 1) pi X^2 Im(k_air) / (p0 V_tot)`` per cycle and the
        stiffness drifts by about as much: there is no exact periodic state.
    flow, diaphragm : str
        The models used.
    """

    frequency_hz: float
    amplitude_m: float
    k: complex
    k_air: complex
    velocity_amplitude_m_s: float
    peak_velocity_m_s: float
    force_distortion: float
    cycles: int
    periodic_change: float
    converged: bool
    heating_per_cycle: float = 0.0
    flow: str = "quasi_steady"
    diaphragm: str = "viscoelastic"

    @property
    def loss_factor(self) -> float:
        """Loss factor ``Im k / Re k`` of the total stiffness."""
        return self.k.imag / self.k.real

    def _summary_items(self) -> list[tuple[str, str]]:
        """Point, stiffness, loss factor and convergence (for repr and notebooks)."""
        return [("f", f"{self.frequency_hz:.4g} Hz"), ("X", f"{self.amplitude_m * 1e3:.4g} mm"),
                ("Re k", f"{self.k.real / 1e3:.5g} kN/m"),
                ("loss factor", f"{self.loss_factor:.4g}"),
                ("cycles", str(self.cycles)), ("converged", str(self.converged))]

    def _row(self) -> dict:
        return {
            "frequency_hz": self.frequency_hz,
            "amplitude_m": self.amplitude_m,
            "k_real_n_per_m": self.k.real,
            "k_imag_n_per_m": self.k.imag,
            "loss_factor": self.loss_factor,
            "k_air_real_n_per_m": self.k_air.real,
            "k_air_imag_n_per_m": self.k_air.imag,
            "velocity_amplitude_m_s": self.velocity_amplitude_m_s,
            "peak_velocity_m_s": self.peak_velocity_m_s,
            "force_distortion": self.force_distortion,
            "cycles": self.cycles,
            "periodic_change": self.periodic_change,
            "heating_per_cycle": self.heating_per_cycle,
            "converged": self.converged,
        }

    def to_frame(self):
        """One-row :class:`pandas.DataFrame` (same column names as
        :meth:`isodesign.spring.stiffness.StiffnessResult.to_frame` where they overlap)."""
        import pandas as pd

        df = pd.DataFrame([self._row()])
        df.attrs.update(flow=self.flow, diaphragm=self.diaphragm)
        return df


@dataclass(frozen=True, eq=False, repr=False)
class SimulationGridResult(ResultDisplay):
    """Time-domain stiffness on a frequency x amplitude grid.

    Attributes
    ----------
    frequency_hz : ndarray, shape (nf,)
    amplitude_m : ndarray, shape (na,)
    results : ndarray of SimulationResult, shape (nf, na)
        ``results[i, j]`` is the case ``(frequency_hz[i], amplitude_m[j])``.
    flow, diaphragm : str
        The models used.
    """

    frequency_hz: np.ndarray
    amplitude_m: np.ndarray
    results: np.ndarray
    flow: str = "quasi_steady"
    diaphragm: str = "viscoelastic"

    def _field(self, name: str, dtype) -> np.ndarray:
        out = np.empty(self.results.shape, dtype=dtype)
        for idx, r in np.ndenumerate(self.results):
            out[idx] = getattr(r, name)
        return out

    @property
    def shape(self) -> tuple[int, int]:
        """``(nf, na)``."""
        return self.results.shape

    @property
    def k(self) -> np.ndarray:
        """Total complex stiffness, shape (nf, na), N/m."""
        return self._field("k", complex)

    @property
    def k_air(self) -> np.ndarray:
        """Air stiffness, shape (nf, na), N/m."""
        return self._field("k_air", complex)

    @property
    def loss_factor(self) -> np.ndarray:
        """Loss factor of the total stiffness, shape (nf, na)."""
        k = self.k
        return k.imag / k.real

    @property
    def converged(self) -> np.ndarray:
        """Periodic state reached, shape (nf, na)."""
        return self._field("converged", bool)

    @property
    def cycles(self) -> np.ndarray:
        """Cycles integrated, shape (nf, na)."""
        return self._field("cycles", int)

    @property
    def periodic_change(self) -> np.ndarray:
        """Relative change of the first harmonic over the last cycle, shape (nf, na)."""
        return self._field("periodic_change", float)

    def _summary_items(self) -> list[tuple[str, str]]:
        """Grid size, range and convergence (for repr and notebooks)."""
        conv = np.array([[r.converged for r in row] for row in self.results], bool)
        return [("grid", f"{self.shape[0]} frequencies x {self.shape[1]} amplitudes"),
                ("range", f"{np.min(self.frequency_hz):.3g}-{np.max(self.frequency_hz):.3g} Hz, "
                          f"{np.min(self.amplitude_m) * 1e3:.3g}-"
                          f"{np.max(self.amplitude_m) * 1e3:.3g} mm"),
                ("converged", f"{int(conv.sum())} of {conv.size}"),
                ("models", f"{self.flow} flow, {self.diaphragm} diaphragm")]

    def to_frame(self):
        """One row per case (frequency outer, amplitude inner)."""
        import pandas as pd

        df = pd.DataFrame([r._row() for r in self.results.ravel()])
        df.attrs.update(flow=self.flow, diaphragm=self.diaphragm)
        return df


# ---------------------------------------------------------------------------
# input validation
# ---------------------------------------------------------------------------
def _check_design(design) -> SpringDesign:
    if not isinstance(design, SpringDesign):
        raise InputError(f"design: expected an isodesign.SpringDesign, got {type(design).__name__}")
    for name in ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m"):
        v = getattr(design, name)
        if not isinstance(v, int | float | np.floating):
            raise InputError(
                f"design.{name}: the time-domain simulation needs numbers, got {type(v).__name__}"
            )
    return design


def _check_flow(flow) -> str:
    if flow not in SIMULATION_FLOW_MODELS:
        raise InputError(
            f"flow: {flow!r} is not available in the time-domain simulation; valid: "
            f"{', '.join(SIMULATION_FLOW_MODELS)} (the other models are frequency-domain "
            "models with no time-domain counterpart here)"
        )
    return flow


def _max_amplitude(design) -> float:
    return MAX_STROKE_FRACTION * design.top_volume_m3 / design.piston_area_m2


def _check_amplitudes(design, amplitude_m) -> np.ndarray:
    x = check_positive("amplitude_m", amplitude_m, unit="m", allow_array=True)
    xmax = _max_amplitude(design)
    if np.any(x >= xmax):
        raise InputError(
            f"amplitude_m: must be in (0, {xmax:.6g}) m so that the top chamber keeps more than "
            f"half its volume (A_p X < {MAX_STROKE_FRACTION} V_t0); got {float(np.max(x)):g} m"
        )
    return x


def _check_options(rtol, max_cycles, periodic_tol, samples_per_cycle, method):
    rtol = check_range("rtol", rtol, 1e-14, 1e-3)
    if (
        isinstance(max_cycles, bool)
        or not isinstance(max_cycles, int | np.integer)
        or max_cycles < _CONSECUTIVE + 1
    ):
        raise InputError(
            f"max_cycles: must be an integer >= {_CONSECUTIVE + 1}, got {max_cycles!r}"
        )
    periodic_tol = check_range("periodic_tol", periodic_tol, 0.0, 1e-1, lo_open=True)
    if (
        isinstance(samples_per_cycle, bool)
        or not isinstance(samples_per_cycle, int | np.integer)
        or samples_per_cycle < 16
    ):
        raise InputError(f"samples_per_cycle: must be an integer >= 16, got {samples_per_cycle!r}")
    if method not in _METHODS:
        raise InputError(f"method: unknown value {method!r}; valid: {', '.join(_METHODS)}")
    return rtol, int(max_cycles), periodic_tol, int(samples_per_cycle), method


# ---------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class _Cases:
    """Constants of a batch of cases, one entry per case (arrays of shape (n,))."""

    omega: np.ndarray
    amplitude: np.ndarray
    scale_pt: np.ndarray  # Pa
    scale_pb: np.ndarray  # Pa
    scale_m: np.ndarray  # kg
    scale_u: np.ndarray  # m/s
    y0: np.ndarray  # initial scaled states, shape (n_states, n)

    def column(self) -> _Cases:
        """The same cases as column vectors (to broadcast against samples)."""
        return _Cases(
            self.omega[:, None],
            self.amplitude[:, None],
            self.scale_pt[:, None],
            self.scale_pb[:, None],
            self.scale_m[:, None],
            self.scale_u[:, None],
            self.y0,
        )

    def take(self, idx) -> _Cases:
        return _Cases(
            self.omega[idx],
            self.amplitude[idx],
            self.scale_pt[idx],
            self.scale_pb[idx],
            self.scale_m[idx],
            self.scale_u[idx],
            self.y0[:, idx],
        )


class _Model:
    """Right-hand side of the nonlinear lumped equations for a batch of cases.

    States (scaled, one row each, one column per case): ``dp_t/S_pt``,
    ``dp_b/S_pb``, ``dm_t/S_m`` (``dm_b = -dm_t``) and, for the quasi-steady
    tube, ``u/S_u``. Deviations from the static state keep full precision in
    ``p_t - p0`` (the force) even at tiny amplitudes.
    """

    def __init__(self, design: SpringDesign, flow: str):
        # the rig integrates the lumped chambers and tube slug (uniform pressures); its
        # harmonic-balance start is that model's, whatever acoustics the design names
        d = lumped_twin(design) or design
        self.design = d
        self.flow = flow
        #: the tube's momentum equation is a state ("inertial" law), or m_dot = dp / C_u
        self.inertial = flow_model(flow).time_domain == "inertial"
        self.n_states = 4 if self.inertial else 3
        self.p0 = d.pressure_pa
        self.vt0 = d.top_volume_m3
        self.vb0 = d.bottom_volume_m3
        self.ap = d.piston_area_m2
        self.ac = d.capillary_area_m2
        self.rho0 = d.density_kg_m3
        self.mt0 = self.rho0 * self.vt0
        self.mb0 = self.rho0 * self.vb0
        self.r_gas = d.gas.gas_constant_j_per_kg_k
        self.adiabatic = d.polytropic_index is None
        self.index = d.process_index  # kappa or n
        self.mu = d.viscosity_pa_s
        self.dc = d.capillary_diameter_m
        self.lc = d.capillary_length_m
        self.k_minor = d.minor_loss
        self.rel_rough = d.roughness_m / d.capillary_diameter_m
        # friction drop = friction_scale * Phi(Re) * u (Darcy with f = Phi / Re)
        self.friction_scale = self.lc * self.mu / (2.0 * self.dc * self.dc)
        # the slug's inertance length, the ends' entrained mass included (as in the
        # frequency domain, capillary.tube_end_length_m)
        self.inertia = QUASI_STEADY_INERTANCE_COEFFICIENT * self.lc + tube_end_length_m(d)
        self.c_u = poiseuille_resistance(d)

    # -- physical quantities from the scaled states -------------------------
    def unpack(self, y, theta, cases: _Cases):
        """Physical deviations and derived quantities at normalized time theta."""
        dpt = y[0] * cases.scale_pt
        dpb = y[1] * cases.scale_pb
        dmt = y[2] * cases.scale_m
        sx = np.sin(theta)
        vt = self.vt0 - self.ap * cases.amplitude * sx
        mt = self.mt0 + dmt
        mb = self.mb0 - dmt
        rho_t = mt / vt
        rho_b = mb / self.vb0
        dp = dpt - dpb
        if self.inertial:
            u = y[3] * cases.scale_u
            up = u >= 0.0
            rho_up = np.where(up, rho_t, rho_b)
            mdot = rho_up * self.ac * u
        else:  # Eq. 41: m_dot = (p_t - p_b)/C_u, algebraic
            mdot = dp / self.c_u
            up = mdot >= 0.0
            rho_up = np.where(up, rho_t, rho_b)
            u = mdot / (rho_up * self.ac)
        return dpt, dpb, vt, mt, mb, rho_t, rho_b, rho_up, up, u, mdot, dp

    def rhs(self, theta, y, cases: _Cases):
        """``dy/dtheta`` for the stacked states ``y``.

        ``y`` is flat and case-major (the states of case 0, then of case 1, ...),
        so the Jacobian is block diagonal with bandwidth ``n_states - 1``.
        """
        n = cases.omega.size
        y = y.reshape(n, self.n_states).T
        dpt, dpb, vt, mt, mb, rho_t, rho_b, rho_up, up, u, mdot, dp = self.unpack(y, theta, cases)
        w = cases.omega
        pt = self.p0 + dpt
        pb = self.p0 + dpb
        dvt = -self.ap * cases.amplitude * np.cos(theta) * w  # dV_t/dt
        if self.adiabatic:
            # open control volume, upwind enthalpy c_p T_flow (Eqs. 7-13, not linearized)
            kappa = self.index
            t_flow = np.where(up, pt * vt / (mt * self.r_gas), pb * self.vb0 / (mb * self.r_gas))
            flux = kappa * self.r_gas * t_flow * mdot
            dpt_dt = (-flux - kappa * pt * dvt) / vt
            dpb_dt = flux / self.vb0
        else:  # polytropic p ~ (m/V)^n
            n_idx = self.index
            dpt_dt = n_idx * pt * (-mdot / mt - dvt / vt)
            dpb_dt = n_idx * pb * (mdot / mb)
        out = np.empty_like(y)
        out[0] = dpt_dt / (w * cases.scale_pt)
        out[1] = dpb_dt / (w * cases.scale_pb)
        out[2] = -mdot / (w * cases.scale_m)
        if self.inertial:
            re = rho_up * np.abs(u) * self.dc / self.mu
            phi = churchill_friction_re_product(re, self.rel_rough)
            drop = self.friction_scale * phi * u + 0.5 * self.k_minor * rho_up * np.abs(u) * u
            rho_tube = 0.5 * (rho_t + rho_b)
            du_dt = (dp - drop) / (rho_tube * self.inertia)
            out[3] = du_dt / (w * cases.scale_u)
        return out.T.ravel()

    # -- harmonic-balance start -------------------------------------------
    def cases(self, omega, amplitude) -> _Cases:
        """Scales and initial states from the harmonic-balance solution.

        Phasors with ``x = Re(X^ e^{j w t})``, ``X^ = -j X``: ``P_t = k_air X^/A_p``
        (Eq. 31), ``P_b = P_t / (1 + j w s C)`` (Eqs. 33, 35), ``M_dot = (P_t -
        P_b)/C`` (Eq. 35), ``dm_b = M_dot/(j w)``, ``U = M_dot/(rho0 A_c)``.
        """
        d = self.design
        sol = solve_velocity_amplitude(self.flow, d, omega, amplitude)
        c = sol.resistance_re + 1j * sol.resistance_im
        k_air = air_stiffness(d, omega, sol.resistance)
        k_air = k_air.re + 1j * k_air.im
        xh = -1j * amplitude
        pt = k_air * xh / self.ap
        pb = pt / (1.0 + 1j * omega * d.compliance_factor_kg_per_pa * c)
        mdot = (pt - pb) / c
        dmt = -mdot / (1j * omega)
        uh = mdot / (self.rho0 * self.ac)
        s_pt = np.abs(pt)
        s_pb = np.maximum(np.abs(pb), 1e-3 * s_pt)
        s_m = np.maximum(np.abs(dmt), 1e-3 * s_pt * self.vt0 / (self.r_gas * d.temperature_k))
        s_u = np.maximum(np.abs(uh), 1e-3 * d.area_ratio * amplitude * omega)
        states = [pt.real / s_pt, pb.real / s_pb, dmt.real / s_m]
        if self.inertial:
            states.append(uh.real / s_u)
        return _Cases(omega, amplitude, s_pt, s_pb, s_m, s_u, np.array(states))


def _band_options(method: str, n_states: int, n_cases: int) -> dict:
    """Tell the implicit methods that the cases are independent.

    The Jacobian of the stacked system is block diagonal (one dense block per
    case), so LSODA gets it as a band matrix and Radau/BDF as a sparsity
    pattern: a finite-difference Jacobian then costs ``n_states`` right-hand
    sides, not ``n_states * n_cases``.
    """
    if method == "LSODA":
        return {"lband": n_states - 1, "uband": n_states - 1}
    if method in ("Radau", "BDF"):
        from scipy.sparse import block_diag

        blocks = [np.ones((n_states, n_states))] * n_cases
        return {"jac_sparsity": block_diag(blocks, format="csc")}
    return {}


def _first_harmonics(samples: np.ndarray, drift: np.ndarray) -> np.ndarray:
    """rfft coefficients ``c_n`` (``signal = sum Re(c_n e^{j n theta})``) of one cycle.

    ``samples`` has shape (n_cases, M + 1) on ``theta = 2 pi i/M``, ``i = 0..M``;
    the linear drift ``drift * i/M`` is removed first (the secular heating of
    the adiabatic gas would otherwise leak into the first harmonic).
    """
    m = samples.shape[1] - 1
    ramp = np.arange(m + 1) / m
    s = samples[:, :m] - drift[:, None] * ramp[None, :m]
    c = np.fft.rfft(s, axis=1) * (2.0 / m)
    c[:, 0] *= 0.5
    if m % 2 == 0:
        c[:, -1] *= 0.5  # Nyquist term
    return c


# ---------------------------------------------------------------------------
# the driver
# ---------------------------------------------------------------------------
def _simulate_cases(
    design, omega, amplitude, flow, rtol, max_cycles, periodic_tol, samples_per_cycle, method
):
    """Integrate a batch of cases to their periodic states.

    Returns a dict of arrays of shape (n,): ``k_air``, ``u1``, ``u_peak``,
    ``distortion``, ``cycles``, ``change``, ``converged``, ``heating``.
    """
    from scipy.integrate import solve_ivp

    model = _Model(design, flow)
    all_cases = model.cases(omega, amplitude)
    n = omega.size
    ns = model.n_states
    y = all_cases.y0.copy()
    theta = np.linspace(0.0, 2.0 * math.pi, samples_per_cycle + 1)
    energy_scale = design.pressure_pa * design.total_volume_m3

    out = {
        "k_air": np.full(n, np.nan + 0j),
        "u1": np.full(n, np.nan),
        "u_peak": np.full(n, np.nan),
        "distortion": np.full(n, np.nan),
        "cycles": np.zeros(n, dtype=int),
        "change": np.full(n, np.inf),
        "converged": np.zeros(n, dtype=bool),
        "heating": np.zeros(n),
    }
    below = np.zeros(n, dtype=int)
    active = np.arange(n)
    for cycle in range(1, max_cycles + 1):
        cases = all_cases.take(active)
        na = active.size
        # solve_ivp's error norm is the RMS over all stacked states: tighten it by
        # sqrt(n) so that each case is integrated to ``rtol`` as if it were alone.
        tol = rtol / math.sqrt(na)
        # explicit methods may try wild states in rejected steps (overflow in the
        # friction law): a real failure still shows as sol.success = False
        with np.errstate(over="ignore", invalid="ignore"):
            sol = solve_ivp(
                model.rhs,
                (0.0, 2.0 * math.pi),
                y[:, active].T.ravel(),
                method=method,
                t_eval=theta,
                rtol=tol,
                atol=tol,
                args=(cases,),
                **_band_options(method, ns, na),
            )
        if not sol.success:
            raise SolverError(
                f"time-domain simulation: solve_ivp({method}) failed in cycle {cycle}: "
                f"{sol.message}"
            )
        ys = sol.y.reshape(na, ns, -1).transpose(1, 0, 2)  # (state, case, sample)
        y_end = ys[:, :, -1]
        dpt = ys[0] * cases.scale_pt[:, None]
        dpb = ys[1] * cases.scale_pb[:, None]
        force = model.ap * dpt
        cf = _first_harmonics(force, force[:, -1] - force[:, 0])
        k_new = 1j * cf[:, 1] / cases.amplitude
        u = model.unpack(ys, theta, cases.column())[9]  # (case, sample)
        cu = _first_harmonics(u, u[:, -1] - u[:, 0])
        # internal energy (p_t V_t + p_b V_b)/(kappa - 1) at theta = 0 and 2 pi (V_t = V_t0)
        de = (dpt[:, -1] - dpt[:, 0]) * model.vt0 + (dpb[:, -1] - dpb[:, 0]) * model.vb0
        heating = de / energy_scale
        k_old = out["k_air"][active]
        change = np.abs(k_new - k_old) / np.abs(k_new)
        change = np.where(np.isfinite(change), change, np.inf)
        a1 = np.abs(cf[:, 1])
        out["k_air"][active] = k_new
        out["u1"][active] = np.abs(cu[:, 1])
        out["u_peak"][active] = np.max(np.abs(u), axis=1)
        out["distortion"][active] = np.sqrt(np.sum(np.abs(cf[:, 2:]) ** 2, axis=1)) / a1
        out["cycles"][active] = cycle
        out["change"][active] = change
        out["heating"][active] = heating
        y[:, active] = y_end
        ok = change <= periodic_tol + _HEATING_ALLOWANCE * np.abs(heating)
        below[active] = np.where(ok, below[active] + 1, 0)
        done = below[active] >= _CONSECUTIVE
        out["converged"][active[done]] = True
        active = active[~done]
        if active.size == 0:
            break
    return out


def _results(design, f, x, flow, dia, raw) -> list[SimulationResult]:
    w = 2.0 * math.pi * f
    kd = dia.stiffness(w, x)
    kd = np.broadcast_to(np.asarray(kd.re) + 1j * np.asarray(kd.im), f.shape)
    res = []
    for i in range(f.size):
        k_air = complex(raw["k_air"][i])
        res.append(
            SimulationResult(
                frequency_hz=float(f[i]),
                amplitude_m=float(x[i]),
                k=spring_stiffness(k_air, complex(kd[i])),
                k_air=k_air,
                velocity_amplitude_m_s=float(raw["u1"][i]),
                peak_velocity_m_s=float(raw["u_peak"][i]),
                force_distortion=float(raw["distortion"][i]),
                cycles=int(raw["cycles"][i]),
                periodic_change=float(raw["change"][i]),
                converged=bool(raw["converged"][i]),
                heating_per_cycle=float(raw["heating"][i]),
                flow=flow,
                diaphragm=dia.name,
            )
        )
    return res


def simulate_stiffness(
    design,
    frequency_hz: float,
    amplitude_m: float,
    *,
    flow: str = "quasi_steady",
    diaphragm="viscoelastic",
    rtol: float = 1e-9,
    max_cycles: int = 400,
    periodic_tol: float = 1e-6,
    samples_per_cycle: int = 512,
    method: str = "LSODA",
) -> SimulationResult:
    """Complex stiffness at (X, w) from the nonlinear equations in the time domain.

    Integrates the lumped model of paper Section 3.1 without linearization
    (adiabatic open control volumes with upwind enthalpy, Eqs. 7-13; tube
    momentum Eq. 17 with friction Eq. 20 evaluated on the instantaneous
    velocity; see the module docstring) under ``x = X sin(w t)`` until the
    first harmonic of the piston force (Eq. 3) is periodic, and returns
    ``k_air = F_1 / X`` plus the diaphragm's ``k_D*`` (Eq. 42).

    Parameters
    ----------
    design : SpringDesign
        The spring (numeric fields).
    frequency_hz : float
        Excitation frequency, Hz (finite, > 0).
    amplitude_m : float
        Piston amplitude X, m; ``0 < X < 0.5 V_t0 / A_p``.
    flow : {"quasi_steady", "poiseuille"}
        Tube law: the quasi-steady all-regime friction with minor loss and
        inertance, or Eq. 41's linear laminar resistance (no inertia, no minor
        loss). Other frequency-domain models raise :class:`InputError`.
    diaphragm : str or model
        Diaphragm model added in the frequency domain
        (:func:`isodesign.spring.diaphragm.diaphragm_model`), e.g. ``"none"``.
    rtol : float
        Relative (and, on the scaled states, absolute) tolerance of the
        integrator, per case.
    max_cycles : int
        Cycles integrated at most (>= 3). Each cycle starts at ``x = 0``; the
        first starts from the harmonic-balance solution (Eqs. 31-38 with the
        self-consistent flow amplitude).
    periodic_tol : float
        Periodic state: the relative change of the first harmonic between
        successive cycles stays below ``periodic_tol + 2 * heating_per_cycle``
        for two successive cycles.
    samples_per_cycle : int
        Samples per cycle for the Fourier analysis (dense output).
    method : str
        :func:`scipy.integrate.solve_ivp` method. ``LSODA`` (default) switches
        between Adams and BDF as the stiffness requires (the tube relaxes in
        milliseconds; at 0.2 Hz and large amplitudes that is stiff); the
        block-diagonal Jacobian of a batch is passed as a band (LSODA) or a
        sparsity pattern (Radau, BDF).

    Returns
    -------
    SimulationResult
        ``converged`` is False when ``max_cycles`` was reached first.

    Raises
    ------
    InputError
        Invalid input (the message names the parameter and its valid range).
    SolverError
        The integrator failed.
    """
    d = _check_design(design)
    _check_flow(flow)
    for name, v in (("frequency_hz", frequency_hz), ("amplitude_m", amplitude_m)):
        if np.ndim(v) != 0:
            raise InputError(f"{name}: expected one number (use simulate_grid for arrays)")
    f = check_positive("frequency_hz", frequency_hz, unit="Hz")
    x = check_positive("amplitude_m", amplitude_m, unit="m")
    _check_amplitudes(d, x)
    opts = _check_options(rtol, max_cycles, periodic_tol, samples_per_cycle, method)
    dia = diaphragm_model(diaphragm)
    fa, xa = np.array([f]), np.array([x])
    raw = _simulate_cases(d, 2.0 * math.pi * fa, xa, flow, *opts)
    return _results(d, fa, xa, flow, dia, raw)[0]


def simulate_grid(
    design,
    frequency_hz,
    amplitude_m,
    *,
    allow_unconverged: bool = False,
    **kwargs: Any,
) -> SimulationGridResult:
    """Time-domain stiffness for every frequency with every amplitude.

    All ``nf * na`` cases are integrated together (one vectorized right-hand
    side in the normalized time ``w t``); a case leaves the batch as soon as it
    is periodic. Keyword arguments are those of :func:`simulate_stiffness`.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    frequency_hz : array_like, shape (nf,)
        Frequencies, Hz.
    amplitude_m : array_like, shape (na,)
        Amplitudes X, m.
    allow_unconverged : bool
        Return cases that did not reach the periodic state (``converged=False``)
        instead of raising :class:`SolverError`.
    **kwargs
        The keyword arguments of :func:`simulate_stiffness` (flow, diaphragm,
        tolerances, method, ...).

    Returns
    -------
    SimulationGridResult
        ``.k`` has shape (nf, na).
    """
    allowed = {"flow", "diaphragm", "rtol", "max_cycles", "periodic_tol", "samples_per_cycle",
               "method"}  # fmt: skip
    unknown = sorted(set(kwargs) - allowed)
    if unknown:
        raise InputError(
            f"simulate_grid: unknown keyword(s) {', '.join(unknown)}; "
            f"valid: {', '.join(sorted(allowed))}"
        )
    d = _check_design(design)
    flow = _check_flow(kwargs.get("flow", "quasi_steady"))
    f = check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    x = _check_amplitudes(d, amplitude_m)
    if f.ndim > 1 or x.ndim > 1:
        raise InputError("frequency_hz, amplitude_m: expected 1-D arrays (or scalars)")
    f, x = f.reshape(-1), x.reshape(-1)
    opts = _check_options(
        kwargs.get("rtol", 1e-9),
        kwargs.get("max_cycles", 400),
        kwargs.get("periodic_tol", 1e-6),
        kwargs.get("samples_per_cycle", 512),
        kwargs.get("method", "LSODA"),
    )
    dia = diaphragm_model(kwargs.get("diaphragm", "viscoelastic"))
    ff, xx = np.meshgrid(f, x, indexing="ij")
    ff, xx = ff.ravel(), xx.ravel()
    raw = _simulate_cases(d, 2.0 * math.pi * ff, xx, flow, *opts)
    res = _results(d, ff, xx, flow, dia, raw)
    arr = np.empty(len(res), dtype=object)
    arr[:] = res
    arr = arr.reshape(f.size, x.size)
    arr.flags.writeable = False
    if not allow_unconverged:
        bad = [r for r in res if not r.converged]
        if bad:
            pts = ", ".join(
                f"({r.frequency_hz:g} Hz, {r.amplitude_m:g} m: change {r.periodic_change:.2g})"
                for r in bad[:5]
            )
            raise SolverError(
                f"time-domain simulation: {len(bad)} of {len(res)} cases did not reach the "
                f"periodic state in {opts[1]} cycles: {pts}; raise max_cycles or pass "
                "allow_unconverged=True"
            )
    return SimulationGridResult(
        frequency_hz=f, amplitude_m=x, results=arr, flow=flow, diaphragm=dia.name
    )


# ---------------------------------------------------------------------------
# comparison with the frequency-domain model
# ---------------------------------------------------------------------------
def agreement_table(grid: SimulationGridResult, design, *, modes=("self_consistent", "kinematic")):
    """Compare the simulated air stiffness with the frequency-domain model.

    For each amplitude mode of :func:`isodesign.spring.stiffness.complex_stiffness` (same
    flow law, ``diaphragm="none"``: the diaphragm is added identically on both
    sides and would only dilute the errors), the columns ``{mode}_abs_err``
    (``||k_fd|/|k_sim| - 1|``), ``{mode}_re_err``, ``{mode}_im_err`` (relative
    errors of the real and imaginary parts), ``{mode}_complex_err``
    (``|k_fd - k_sim|/|k_sim|``) and ``{mode}_loss_factor_diff`` (``eta_fd -
    eta_sim``) are added to the simulated values.

    Parameters
    ----------
    grid : SimulationGridResult
        Output of :func:`simulate_grid` for ``design``.
    design : SpringDesign
        The simulated spring.
    modes : sequence of str
        Amplitude modes to compare.

    Returns
    -------
    pandas.DataFrame
        One row per case (frequency outer, amplitude inner).
    """
    import pandas as pd


    k_sim = grid.k_air.ravel()
    eta_sim = k_sim.imag / k_sim.real
    cols = {
        "frequency_hz": np.repeat(grid.frequency_hz, grid.amplitude_m.size),
        "amplitude_m": np.tile(grid.amplitude_m, grid.frequency_hz.size),
        "k_sim_real_n_per_m": k_sim.real,
        "k_sim_imag_n_per_m": k_sim.imag,
        "loss_factor_sim": eta_sim,
    }
    for mode in modes:
        k = complex_stiffness(
            design,
            grid.frequency_hz,
            grid.amplitude_m,
            flow=grid.flow,
            amplitude_mode=mode,
            diaphragm="none",
            warn=False,
        ).k_air.ravel()
        cols[f"{mode}_abs_err"] = np.abs(np.abs(k) / np.abs(k_sim) - 1.0)
        cols[f"{mode}_re_err"] = np.abs(k.real / k_sim.real - 1.0)
        cols[f"{mode}_im_err"] = np.abs(k.imag / k_sim.imag - 1.0)
        cols[f"{mode}_complex_err"] = np.abs(k - k_sim) / np.abs(k_sim)
        cols[f"{mode}_loss_factor_diff"] = k.imag / k.real - eta_sim
    return pd.DataFrame(cols)


#: The grid of ``docs/simulation.md`` (reference spring, Table 1).
REFERENCE_FREQUENCIES_HZ = (0.2, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 24.0)
REFERENCE_AMPLITUDES_M = (0.05e-3, 0.15e-3, 0.5e-3)
