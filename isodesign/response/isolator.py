"""A payload on identical dual-chamber springs: transmissibility and stability.

Vertical motion of a rigid payload of mass ``m`` on ``n`` identical springs,
excited by the floor (base excitation). Each spring carries ``m/n``; with the
spring's complex stiffness ``k*`` the absolute transmissibility is::

    T = x / x_f = k* / (k* - (m/n) w^2)

and the relative motion (the spring's stroke) is ``x - x_f = (T - 1) x_f`` with
``T - 1 = (m/n) w^2 / (k* - (m/n) w^2)``.

Every formula here is written once for NumPy and CasADi (complex values as
:class:`~isodesign.numerics.cplx.Cx` pairs); solvers that close the amplitude
dependence live in :mod:`isodesign.response`.

Derivations: docs/physics.md, section 5 (Zener form, classical optimum) and
section 8 (tilt stability).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from isodesign.domain import LAYOUT_DOMAIN
from isodesign.errors import InputError, check_positive, check_range
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx, as_cx
from isodesign.spring.capillary import poiseuille_resistance
from isodesign.spring.equations import spring_stiffness
from isodesign.spring.gas import G_STANDARD

__all__ = [
    "Payload",
    "loaded_design",
    "natural_frequency_hz",
    "relative_transmissibility",
    "static_stiffness",
    "tilt_margin",
    "transmissibility",
    "zener_damping_ratio",
    "zener_optimum",
    "zener_transmissibility",
]


#: Most isolators a payload may stand on.
MAX_ISOLATORS = 1000


@dataclass(frozen=True)
class Payload:
    """A rigid payload on identical isolators.

    Parameters
    ----------
    mass_kg : float
        Total supported mass (table plus instrument), kg.
    isolators : int
        Number of identical isolators sharing the load equally (>= 1).
    spacing_m : float or None
        Narrowest centre-to-centre spacing of the isolators, m, for the tilt
        (rocking) margin. ``None``: not checked.
    cg_height_m : float or None
        Height of the centre of gravity above the diaphragm plane, m.
    g_m_s2 : float
        Gravity.
    """

    mass_kg: float
    isolators: int = 4
    spacing_m: float | None = None
    cg_height_m: float | None = None
    g_m_s2: float = G_STANDARD

    def __post_init__(self):
        for name in ("mass_kg", "spacing_m", "cg_height_m", "g_m_s2"):
            v = getattr(self, name)
            if v is None and name in ("spacing_m", "cg_height_m"):
                continue
            if isinstance(v, bool | np.bool_) or not isinstance(v, numbers.Real):
                raise InputError(f"{name}: expected a number, got {type(v).__name__} {v!r:.40}")
        object.__setattr__(self, "mass_kg", check_positive("mass_kg", self.mass_kg, unit="kg"))
        n = self.isolators
        if (isinstance(n, bool | np.bool_) or not isinstance(n, numbers.Integral)
                or not 1 <= n <= MAX_ISOLATORS):
            shown = f"{n!r:.40}" if not isinstance(n, int) or n < 10**6 else "a larger integer"
            raise InputError(f"isolators: must be an integer in [1, {MAX_ISOLATORS}], got "
                             f"{shown}")
        object.__setattr__(self, "isolators", int(n))
        if self.spacing_m is not None:
            object.__setattr__(
                self, "spacing_m", check_positive("spacing_m", self.spacing_m, unit="m")
            )
        if self.cg_height_m is not None:
            object.__setattr__(
                self,
                "cg_height_m",
                check_range("cg_height_m", self.cg_height_m, 0.0, None, lo_open=True, unit="m"),
            )
        check_range("g_m_s2", self.g_m_s2, 0.0, 100.0, lo_open=True, unit="m/s^2")
        for name, (lo, hi, unit) in LAYOUT_DOMAIN.items():  # the models' numeric domain
            v = getattr(self, name)
            if v is not None:
                check_range(name, v, lo, hi, unit=unit)

    @property
    def mass_per_isolator_kg(self) -> float:
        """m / n."""
        return self.mass_kg / self.isolators

    @property
    def load_per_isolator_n(self) -> float:
        """Weight carried by one isolator, m g / n."""
        return self.mass_kg * self.g_m_s2 / self.isolators


def loaded_design(design, payload: Payload):
    """Copy of ``design`` with p0 derived from the payload's weight (Eq. 1).

    ``p0 = p_atm + m g / (n A_p)``: each of the payload's ``isolators`` identical springs
    carries an equal share of ``mass_kg`` under the payload's gravity ``g_m_s2``
    (:meth:`isodesign.spring.design.SpringDesign.with_load`).

    Parameters
    ----------
    design : SpringDesign
    payload : Payload

    Returns
    -------
    SpringDesign
    """
    if not isinstance(payload, Payload):
        raise InputError(f"payload: expected an isodesign Payload, got {type(payload).__name__}")
    return design.with_load(payload.mass_kg, payload.isolators, g_m_s2=payload.g_m_s2)


def transmissibility(k: Cx, mass_per_isolator_kg, omega) -> Cx:
    """Absolute transmissibility ``T = k* / (k* - (m/n) w^2)`` (floor to payload).

    Parameters
    ----------
    k : Cx
        Complex stiffness of one spring, N/m.
    mass_per_isolator_kg : float
        Payload mass per isolator m/n, kg.
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    k = as_cx(k)
    return k / (k - mass_per_isolator_kg * omega * omega)


def relative_transmissibility(k: Cx, mass_per_isolator_kg, omega) -> Cx:
    """Stroke per floor motion, ``T - 1 = (m/n) w^2 / (k* - (m/n) w^2)``.

    Parameters
    ----------
    k : Cx
        Complex stiffness of one spring, N/m.
    mass_per_isolator_kg : float
        Payload mass per isolator m/n, kg.
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    k = as_cx(k)
    mw2 = mass_per_isolator_kg * omega * omega
    # as_cx: a NumPy array on the left of "/" would make an object array of Cx
    return as_cx(mw2) / (k - mw2)


def natural_frequency_hz(stiffness_n_per_m, mass_per_isolator_kg):
    """Undamped natural frequency ``sqrt(k/m) / (2 pi)`` in Hz.

    Parameters
    ----------
    stiffness_n_per_m : float or ndarray
        Stiffness of one spring, N/m.
    mass_per_isolator_kg : float
        Payload mass per isolator m/n, kg.
    """
    return bk.sqrt(stiffness_n_per_m / mass_per_isolator_kg) / (2.0 * math.pi)


#: Reference amplitude of the static (linear-regime) stiffness: 1 um.
STATIC_REFERENCE_AMPLITUDE_M = 1e-6


def static_stiffness(design, diaphragm, mass_per_isolator_kg,
                     amplitude_m=STATIC_REFERENCE_AMPLITUDE_M):
    """Low-frequency (static) stiffness K0 of one spring, any backend.

    ``K0 = k_s/(N+1) + Re k_D(X_ref, f_air)``: the air spring's low-frequency
    limit plus the diaphragm's storage stiffness at the reference amplitude
    (1 um) and at the air spring's own natural frequency
    ``f_air = sqrt((k_s/(N+1)) / (m/n)) / (2 pi)``. Explicit and smooth, so the
    optimizer's constraints and the analysis's stability figures use the same
    number. Used for the natural frequency and the tilt margin.

    Parameters
    ----------
    design : SpringDesign
        The spring (any backend).
    diaphragm : diaphragm model
        Its storage stiffness is added (Eq. 42).
    mass_per_isolator_kg : float
        Payload mass per isolator m/n, kg.
    amplitude_m : float
        Reference amplitude, m (1 um).
    """
    k_air = design.static_stiffness_n_per_m
    w_air = bk.sqrt(k_air / mass_per_isolator_kg)
    return spring_stiffness(Cx(k_air, 0.0), diaphragm.stiffness(w_air, amplitude_m)).re


def tilt_margin(stiffness_n_per_m, payload: Payload):
    """Static rocking (tilt) margin ``n k (s/2)^2 / (m g h)`` (docs/physics.md, section 8).

    Rocking about the diaphragm plane is statically stable when the isolators'
    total vertical stiffness ``n k`` times ``(s/2)^2`` exceeds ``m g h`` (``s`` the
    narrowest isolator spacing, ``h`` the centre-of-gravity height above the
    diaphragms): margin > 1. Isolator makers' rule of thumb: spacing at least
    twice the CG height.

    Parameters
    ----------
    stiffness_n_per_m : float or CasADi symbol
        Static stiffness of one spring, N/m.
    payload : Payload
        With ``spacing_m`` and ``cg_height_m`` set.
    """
    if payload.spacing_m is None or payload.cg_height_m is None:
        raise InputError("payload: spacing_m and cg_height_m are needed for the tilt margin")
    s = payload.spacing_m
    return (
        payload.isolators
        * stiffness_n_per_m
        * (s / 2.0) ** 2
        / (payload.mass_kg * payload.g_m_s2 * payload.cg_height_m)
    )


def zener_damping_ratio(design, mass_per_isolator_kg, resistance=None):
    """Damping ratio of the linearized spring's Zener form (docs/physics.md, section 5).

    With Poiseuille flow (or any flow model's small-amplitude, low-frequency
    resistance ``C``) and no diaphragm, Eq. 38 is a spring ``k = k_s/(N+1)`` in
    parallel with ``k1 = N k`` in series with a damper ``c = k_s N tau/(N+1)^2``,
    ``tau = V_b0 C/(n R T0)``. The damping ratio is ``zeta = c / (2 sqrt(k m))``.

    Parameters
    ----------
    design : SpringDesign
    mass_per_isolator_kg : float
    resistance : float or None
        The resistance C; default Eq. 41's ``C_u``, the small-amplitude limit of
        every passive flow model.
    """
    c_flow = poiseuille_resistance(design) if resistance is None else resistance
    n = design.volume_ratio
    ks = design.single_chamber_stiffness_n_per_m
    tau = design.compliance_factor_kg_per_pa * c_flow
    c = ks * n * tau / ((n + 1.0) ** 2)
    k = ks / (n + 1.0)
    return c / (2.0 * bk.sqrt(k * mass_per_isolator_kg))


def zener_transmissibility(volume_ratio, damping_ratio, frequency_ratio):
    """Closed-form |T| of the Zener isolator (docs/physics.md, section 5).

    ``T^2 = [1 + 4 z^2 r^2 (N+1)^2/N^2] / [(1-r^2)^2 + (4 z^2 r^2/N^2)(N+1-r^2)^2]``
    with ``r = w/w_n``, ``w_n = sqrt(k/m)``, ``k = k_s/(N+1)``.

    Parameters
    ----------
    volume_ratio : float or ndarray
        N = V_b0 / V_t0.
    damping_ratio : float or ndarray
        ``zeta = k / (2 sqrt(k m) ...)`` of the Zener form (see :func:`zener_damping_ratio`).
    frequency_ratio : float or ndarray
        ``r = w / w_n``.
    """
    n, z, r = volume_ratio, damping_ratio, frequency_ratio
    num = 1.0 + 4.0 * z * z * r * r * (n + 1.0) ** 2 / (n * n)
    den = (1.0 - r * r) ** 2 + (4.0 * z * z * r * r / (n * n)) * (n + 1.0 - r * r) ** 2
    return bk.sqrt(num / den)


def zener_optimum(volume_ratio):
    """Optimal damping of the Zener isolator at fixed N (Ruzicka and Derby, 1971).

    Parameters
    ----------
    volume_ratio : float
        N = V_b0 / V_t0.

    Returns
    -------
    tuple of float
        ``(T_max, r_peak, zeta)``: the minimum peak transmissibility ``1 + 2/N``,
        the frequency ratio of the peak ``sqrt(2(N+1)/(N+2))`` and the damping
        ratio ``N sqrt(2(N+2)) / (4(N+1))`` that achieves it.
    """
    n = check_positive("volume_ratio", volume_ratio)
    return (
        1.0 + 2.0 / n,
        math.sqrt(2.0 * (n + 1.0) / (n + 2.0)),
        n * math.sqrt(2.0 * (n + 2.0)) / (4.0 * (n + 1.0)),
    )
