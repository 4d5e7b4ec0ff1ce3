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
from isodesign.spring.capillary import flow_regime, kinetic_reynolds
from isodesign.spring.chamber import first_transverse_mode_hz
from isodesign.spring.equations import kinematic_velocity
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
#: Acoustic compactness w l / c (l the largest of the tube length and the chamber
#: sizes V^(1/3)) above which the lumped model (uniform chamber pressures, an
#: incompressible slug in the tube) is flagged.
LUMPED_LIMIT = 0.3

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
        f"acoustically compact: w l / c <= {LUMPED_LIMIT} for the tube length and chamber sizes "
        "(lumped model)"
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
                out.append(
                    f"{name}: {bad} of {n} points outside ({CHECK_DESCRIPTIONS.get(name, name)})"
                )
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
    size0 = max(d.capillary_length_m, d.top_volume_m3 ** (1 / 3), d.bottom_volume_m3 ** (1 / 3))
    lumped0 = omega * size0 / d.speed_of_sound_m_s <= LUMPED_LIMIT
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
    if distributed:
        c0 = d.speed_of_sound_m_s
        f0 = omega / (2.0 * math.pi)
        checks["chamber_plane_wave"] = (
            f0 < np.minimum(first_transverse_mode_hz(d, d.top_volume_m3),
                            first_transverse_mode_hz(d, d.bottom_volume_m3)))
        checks["tube_plane_wave"] = (
            f0 < TRANSVERSE_MODE_FACTOR * c0 / (math.pi * d.capillary_diameter_m))
    else:
        checks["lumped"] = lumped0
    checks.update(model.validity(FlowPoint(
        reynolds=re, kinetic_reynolds=re_w0, womersley_number=alpha0, dimensionless_amplitude=a0
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
    )
