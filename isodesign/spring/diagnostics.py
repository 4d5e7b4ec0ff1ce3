"""Per-point diagnostics of the spring model and its validity checks.

Every evaluated point carries the quantities that decide whether the models
apply there (velocity amplitude, Reynolds numbers, Womersley number, Mach
number, regime, pressure ripple) and a set of named boolean checks (True =
inside the model's validity). A result outside validity is flagged, never
silently returned: :meth:`Diagnostics.summary` lists every failed check with
its count, and :attr:`Diagnostics.valid` is the per-point conjunction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from isodesign.numerics.cplx import Cx
from isodesign.spring.capillary import flow_regime, kinetic_reynolds, linear_resistance
from isodesign.spring.chamber import first_transverse_mode_hz
from isodesign.spring.compactness import LUMPED_TOLERANCE, lumped_error_estimate
from isodesign.spring.equations import air_stiffness, kinematic_velocity
from isodesign.spring.equations import tube_velocity_gain2 as velocity_gain2
from isodesign.spring.flow_models import FlowPoint, flow_check_descriptions, flow_model
from isodesign.spring.transmission_line import TRANSVERSE_MODE_FACTOR

__all__ = ["CHECK_DESCRIPTIONS", "MAX_STATIC_PRESSURE_PA", "Diagnostics", "evaluate_diagnostics"]

#: Mach number above which the incompressible tube flow of Eq. 17 is flagged.
MACH_LIMIT = 0.3
#: Pressure ripple |P_t|/p0 and stroke A_p X/V_t0 above which the linearized
#: chamber thermodynamics (Eqs. 12-15) are flagged.
SMALL_SIGNAL_LIMIT = 0.1
#: Relative mismatch between the assumed (Eq. 37) and the driven tube velocity
#: above which the kinematic amplitude mode is flagged.
KINEMATIC_MISMATCH_LIMIT = 0.1
#: Static chamber pressure p0 (absolute, Pa) above which the model is flagged: the ideal
#: gas (real-gas correction |Z - 1| ~ |B| p0/(R T0) < 0.5 % for air near room temperature,
#: |B| < 10 cm^3/mol) and the rolling diaphragm (constant effective area, Eq. 43; stiffness
#: parameters independent of p0; about twice the paper's 4.93 bar) are not covered above it.
#: See docs/spring-model.md, section 10.
MAX_STATIC_PRESSURE_PA = 1.0e6
#: Acoustic compactness w l / c of the NLP's design-space guard of the lumped model
#: (``lumped_tube``, ``lumped_top_chamber``, ``lumped_bottom_chamber``). The per-point
#: ``lumped`` check is the first-order error estimate of :mod:`isodesign.spring.compactness`
#: against :data:`LUMPED_TOLERANCE` instead.
LUMPED_LIMIT = 0.3
#: Largest |theta^2| of the tube's line for which the first-order estimate is used: beyond it
#: the series of the line's two-port does not converge fast enough and the point is flagged.
LUMPED_THETA2_LIMIT = 2.0
#: The estimate (first order, times ``1 + |theta^2|/6`` for the series' next term) must stay
#: below this fraction of :data:`LUMPED_TOLERANCE`: the margin for the second-order
#: sensitivity terms the first-order estimate leaves out (docs/acoustics.md, section 4).
LUMPED_ESTIMATE_FRACTION = 0.9
#: Shortest tube, in bore radii, for which the ends' correction is applied with confidence:
#: each end's near field (the evanescent higher modes, decaying as exp(-3.83 x / a)) has
#: decayed to 2 % within one radius, so the two ends act independently while L_c >= 4 a
#: (docs/acoustics.md, section 1).
TUBE_END_MIN_LENGTH_RADII = 4.0

#: Name -> meaning of every validity check (the flow models' own come from
#: :mod:`isodesign.spring.flow_models`).
CHECK_DESCRIPTIONS = {
    "mach": f"tube Mach number <= {MACH_LIMIT} (incompressible flow, Eq. 17)",
    "small_signal": (
        f"pressure ripple |P_t|/p0 and stroke A_p X/V_t0 <= {SMALL_SIGNAL_LIMIT} "
        "(linearized chambers, Eqs. 12-15)"
    ),
    "passive": "Im k >= 0 (the spring dissipates energy)",
    "static_pressure": (
        f"static chamber pressure p0 <= {MAX_STATIC_PRESSURE_PA:g} Pa absolute (ideal gas and "
        "rolling-diaphragm assumptions; docs/spring-model.md, section 10)"
    ),
    "lumped": (
        f"lumped model's air stiffness within {LUMPED_TOLERANCE:.0%} of the distributed model's "
        "(first-order estimate from the chambers' lengths and the tube's line; "
        "docs/acoustics.md section 4)"
    ),
    "tube_end_correction": (
        f"tube at least {TUBE_END_MIN_LENGTH_RADII:g} bore radii long: the two ends' "
        "correction (0.8216 a each) independent of each other (docs/acoustics.md section 1)"
    ),
    "chamber_plane_wave": (
        "below the first transverse mode 1.8412 c / (pi D) of both chambers (plane waves, "
        "distributed model; docs/acoustics.md)"
    ),
    "tube_plane_wave": (
        "below the first transverse mode 1.8412 c / (pi D_c) of the tube (plane waves, "
        "distributed model)"
    ),
    **flow_check_descriptions(),
    "kinematic_consistency": (
        f"Eq. 37's tube velocity within {KINEMATIC_MISMATCH_LIMIT:.0%} of the velocity the "
        "pressures drive (otherwise use amplitude_mode='self_consistent')"
    ),
    "converged": "self-consistent flow amplitude converged",
    "diaphragm_table_range": "inside the diaphragm table's frequency and amplitude range",
}


@dataclass(frozen=True, eq=False)
class Diagnostics:
    """Flow quantities and validity checks at every evaluated point.

    Attributes
    ----------
    velocity_amplitude_m_s : ndarray
        Tube velocity amplitude U used in the resistance.
    driven_velocity_m_s : ndarray
        Velocity the resulting chamber pressures drive through the tube (equal to
        ``velocity_amplitude_m_s`` in self-consistent mode).
    kinematic_velocity_m_s : ndarray
        Eq. 37's ``(A_p/A_c) X w``.
    reynolds : ndarray
        Steady Reynolds number at the peak velocity, ``rho U D_c / mu``.
    reynolds_mean : ndarray
        The paper's Eq. 27 with the cycle-averaged velocity ``2U/pi`` (Eq. 28).
    kinetic_reynolds : ndarray
        ``Re_w = rho w D_c^2 / mu``.
    womersley_number : ndarray
        ``alpha = sqrt(Re_w)/2``.
    dimensionless_amplitude : ndarray
        ``A0 = x_max / D_c`` with ``x_max = U/w``.
    mach : ndarray
        ``U / c``.
    regime : ndarray of str
        'laminar', 'transitional' or 'turbulent' (by ``reynolds``).
    pressure_amplitude_pa : ndarray
        Top-chamber pressure amplitude ``|k_d*| X / A_p``.
    checks : dict of str to bool ndarray
        Named checks (True = inside validity); see :data:`CHECK_DESCRIPTIONS`.
    lumped_error : ndarray or None
        The lumped model's estimated relative error in ``k`` against the distributed model
        (``acoustics="lumped"`` only; :func:`isodesign.spring.compactness.lumped_error_estimate`
        with the series remainder), what the ``lumped`` check compares with its tolerance.
    """

    velocity_amplitude_m_s: np.ndarray
    driven_velocity_m_s: np.ndarray
    kinematic_velocity_m_s: np.ndarray
    reynolds: np.ndarray
    reynolds_mean: np.ndarray
    kinetic_reynolds: np.ndarray
    womersley_number: np.ndarray
    dimensionless_amplitude: np.ndarray
    mach: np.ndarray
    pressure_amplitude_pa: np.ndarray
    iterations: np.ndarray | None = None
    checks: dict = field(default_factory=dict)
    lumped_error: np.ndarray | None = None

    @property
    def regime(self) -> np.ndarray:
        """'laminar', 'transitional' or 'turbulent' at every point (by ``reynolds``)."""
        return flow_regime(self.reynolds)

    @property
    def valid(self) -> np.ndarray:
        """True where every check passes."""
        ok = np.ones(self.velocity_amplitude_m_s.shape, dtype=bool)
        for v in self.checks.values():
            ok &= v
        return ok

    def summary(self) -> tuple[str, ...]:
        """One line per failed check: name, count of points, meaning."""
        n = self.velocity_amplitude_m_s.size
        out = []
        for name, ok in self.checks.items():
            bad = int(np.size(ok) - np.count_nonzero(ok))
            if bad:
                line = f"{name}: {bad} of {n} points outside ({CHECK_DESCRIPTIONS.get(name, name)})"
                if name == "lumped" and self.lumped_error is not None:
                    worst = float(np.max(self.lumped_error))
                    line += ("; estimated error up to " + (
                        f"{worst:.2%}" if np.isfinite(worst) else
                        "an unknown amount (the tube's line is beyond the first-order "
                        f"estimate, |theta^2| > {LUMPED_THETA2_LIMIT:g})"))
                out.append(line)
        return tuple(out)

    def columns(self) -> dict[str, np.ndarray]:
        """Flat columns for a table (diagnostics, then ``ok_<check>``, ``valid``)."""
        cols = {
            "velocity_amplitude_m_s": self.velocity_amplitude_m_s.ravel(),
            "driven_velocity_m_s": self.driven_velocity_m_s.ravel(),
            "kinematic_velocity_m_s": self.kinematic_velocity_m_s.ravel(),
            "reynolds": self.reynolds.ravel(),
            "reynolds_mean": self.reynolds_mean.ravel(),
            "kinetic_reynolds": self.kinetic_reynolds.ravel(),
            "womersley_number": self.womersley_number.ravel(),
            "dimensionless_amplitude": self.dimensionless_amplitude.ravel(),
            "mach": self.mach.ravel(),
            "regime": self.regime.ravel(),
            "pressure_amplitude_pa": self.pressure_amplitude_pa.ravel(),
        }
        for name, ok in self.checks.items():
            cols[f"ok_{name}"] = np.broadcast_to(ok, self.mach.shape).ravel()
        if self.lumped_error is not None:
            cols["lumped_error_estimate"] = np.broadcast_to(self.lumped_error,
                                                            self.mach.shape).ravel()
        cols["valid"] = self.valid.ravel()
        return cols


def evaluate_diagnostics(
    flow: str,
    design,
    omega: np.ndarray,
    amplitude_m: np.ndarray,
    velocity: np.ndarray,
    c: Cx,
    k_air: np.ndarray,
    k_total: np.ndarray,
    diaphragm,
    amplitude_mode: str,
    *,
    converged: np.ndarray | None = None,
    iterations: np.ndarray | None = None,
) -> Diagnostics:
    """Compute :class:`Diagnostics` for evaluated points (NumPy only).

    Parameters
    ----------
    flow : str
        The flow model (its own checks come from its registry entry).
    design : SpringDesign
        The spring.
    omega, amplitude_m : ndarray
        Angular frequency (rad/s) and piston amplitude (m), broadcastable.
    velocity : ndarray
        Tube velocity amplitude used in the resistance, m/s.
    c : Cx
        The flow resistance at the points.
    k_air, k_total : ndarray of complex
        Air stiffness (Eq. 38) and total stiffness (Eq. 42), N/m.
    diaphragm : diaphragm model
        Supplies its own range checks (``in_range``).
    amplitude_mode : str
        ``self_consistent`` or ``kinematic``.
    converged, iterations : ndarray, optional
        From the self-consistent solver.

    Returns
    -------
    Diagnostics
    """
    model = flow_model(flow)
    d = design
    distributed = d.acoustics == "distributed"
    shape = np.broadcast_shapes(np.shape(omega), np.shape(amplitude_m), np.shape(velocity))
    u = np.broadcast_to(velocity, shape)
    rho, mu, dc = d.density_kg_m3, d.viscosity_pa_s, d.capillary_diameter_m
    re = u * (rho * dc / mu)
    # frequency-only quantities on the frequency axis, then broadcast
    re_w0 = kinetic_reynolds(d, omega)
    alpha0 = 0.5 * np.sqrt(re_w0)
    re_w = np.broadcast_to(re_w0, shape)
    alpha = np.broadcast_to(alpha0, shape)
    a0 = u * (1.0 / (omega * dc))
    mach = u * (1.0 / d.speed_of_sound_m_s)
    p_amp = np.abs(k_air) * (amplitude_m / d.piston_area_m2)
    u_kin = (u if amplitude_mode == "kinematic"  # u is Eq. 37's velocity already
             else np.broadcast_to(kinematic_velocity(d, omega, amplitude_m), shape))
    if distributed:
        g2 = velocity_gain2(d, omega, c, flow)
        ratio = np.sqrt(g2) * (amplitude_m / np.where(u_kin > 0, u_kin, 1.0))
    else:
        # driven velocity N Q/|D| from Eq. 38 itself: k_air = k_s (1 - N/D), so
        # N/|D| = |1 - k_air/k_s| (exact, and cheaper than recomputing D)
        ratio = np.abs(1.0 - k_air * (1.0 / d.single_chamber_stiffness_n_per_m))
    u_driven = u_kin * ratio

    checks: dict[str, np.ndarray] = {}
    checks["mach"] = mach <= MACH_LIMIT
    checks["small_signal"] = (p_amp / d.pressure_pa <= SMALL_SIGNAL_LIMIT) & np.broadcast_to(
        d.piston_area_m2 * amplitude_m / d.top_volume_m3 <= SMALL_SIGNAL_LIMIT, shape
    )
    checks["passive"] = k_total.imag >= -1e-9 * np.abs(k_total)
    checks["static_pressure"] = np.asarray(d.pressure_pa <= MAX_STATIC_PRESSURE_PA)
    if d.tube_end_correction and flow in ("quasi_steady", "womersley"):
        checks["tube_end_correction"] = np.asarray(
            d.capillary_length_m >= TUBE_END_MIN_LENGTH_RADII * 0.5 * d.capillary_diameter_m)
    if distributed:
        c0 = d.speed_of_sound_m_s
        f0 = omega / (2.0 * math.pi)
        checks["chamber_plane_wave"] = (
            f0 < np.minimum(first_transverse_mode_hz(d, d.top_volume_m3),
                            first_transverse_mode_hz(d, d.bottom_volume_m3)))
        checks["tube_plane_wave"] = (
            f0 < TRANSVERSE_MODE_FACTOR * c0 / (math.pi * d.capillary_diameter_m))
        lumped_error = None
    else:
        lumped_error = lumped_error_bound(d, omega, c, flow, shape)
        checks["lumped"] = lumped_error <= LUMPED_ESTIMATE_FRACTION * LUMPED_TOLERANCE
    checks.update(model.validity(FlowPoint(
        reynolds=re, kinetic_reynolds=re_w0, womersley_number=alpha0, dimensionless_amplitude=a0,
        laminar_k_error=(laminar_k_error(d, omega, c, k_air, flow)
                         if flow == "quasi_steady" else None),
    )))
    if amplitude_mode == "kinematic" and model.amplitude_dependent:
        # u is the kinematic velocity here, so u_driven / u is the ratio itself
        checks["kinematic_consistency"] = np.abs(ratio - 1.0) <= KINEMATIC_MISMATCH_LIMIT
    if converged is not None:
        checks["converged"] = np.broadcast_to(converged, shape)
    for name, ok in diaphragm.in_range(omega, amplitude_m).items():
        checks[name] = ok
    for name in list(checks):
        checks[name] = np.broadcast_to(np.asarray(checks[name], dtype=bool), shape)

    return Diagnostics(
        velocity_amplitude_m_s=u,
        driven_velocity_m_s=u_driven,
        kinematic_velocity_m_s=u_kin,
        reynolds=re,
        reynolds_mean=re * 2.0 / math.pi,
        kinetic_reynolds=re_w,
        womersley_number=alpha,
        dimensionless_amplitude=a0,
        mach=mach,
        pressure_amplitude_pa=p_amp,
        iterations=iterations,
        checks=checks,
        lumped_error=lumped_error,
    )


def laminar_k_error(design, omega, c, k_air, flow) -> np.ndarray:
    """``|k / k_exact - 1|``: the flow model's linear law against the exact laminar impedance.

    ``k_exact`` is the air stiffness (same acoustics) for ``C - C_lin + C_u zeta(alpha)``:
    the flow model's linear part replaced by the exact laminar oscillating impedance, its
    nonlinear part (minor loss, turbulent friction excess) kept. Evaluated both ways, so
    the error is the one in ``k`` itself (the impedance error propagated through the
    spring's network, resonances included).

    Parameters
    ----------
    design : SpringDesign
    omega : ndarray
        Angular frequency, rad/s.
    c : Cx
        The flow model's resistance at the points, Pa s/kg.
    k_air : ndarray of complex
        The air stiffness for ``c``, N/m.
    flow : str
        The flow model (``quasi_steady``).

    Returns
    -------
    ndarray
    """
    exact = c - linear_resistance(flow, design, omega) + linear_resistance(
        "womersley", design, omega)
    k_exact = air_stiffness(design, omega, exact, "womersley")
    k_exact = k_exact.to_complex() if isinstance(k_exact, Cx) else np.asarray(k_exact)
    return np.abs(np.asarray(k_air) / k_exact - 1.0)


def lumped_error_bound(design, omega, c, flow, shape) -> np.ndarray:
    """The lumped model's estimated relative error in ``k`` (``inf`` beyond the estimate).

    The first-order estimate of :func:`isodesign.spring.compactness.lumped_error_estimate`
    times ``1 + |theta^2|/6`` (the tube series' next term relative to the first); ``inf``
    where ``|theta^2| > LUMPED_THETA2_LIMIT`` (the expansion does not hold there).

    Parameters
    ----------
    design : SpringDesign
    omega : ndarray
        Angular frequency, rad/s.
    c : Cx
        The flow resistance at the points, Pa s/kg.
    flow : str
        The flow model.
    shape : tuple
        The points' shape.

    Returns
    -------
    ndarray
    """
    est = lumped_error_estimate(design, omega, c, flow)
    th2 = np.broadcast_to(est["tube_theta2"], shape)
    bound = np.broadcast_to(est["total"], shape) * (1.0 + th2 / 6.0)
    return np.where(th2 <= LUMPED_THETA2_LIMIT, bound, np.inf)
