"""The air-spring equations of the dual-chamber spring (paper Eqs. 37, 38, 42).

* Eq. 38: ``k_d* = k_s (1 + j w tau) / (N + 1 + j w tau)``, ``tau = V_b0 C / (n R T0)``
  (:func:`air_stiffness`), for a complex flow resistance ``C`` (inertance included) and a
  polytropic index ``n`` (kappa if adiabatic).
* Eq. 37: the kinematic flow amplitude ``u_max = (A_p/A_c) X_p w`` (:func:`kinematic_velocity`).
* The driven flow amplitude ``U = (A_p/A_c) X w N / |1 + N + j w tau|`` and its
  harmonic-balance residual (:func:`driven_velocity`, :func:`amplitude_residual`); the
  derivation is in ``docs/spring-model.md``.
* Eq. 42: ``k*_{d+D} = k_d* + k_D*``, air and diaphragm in parallel (:func:`spring_stiffness`).

With ``design.acoustics == "distributed"`` (the default) the air stiffness, the tube
velocity and the harmonic-balance residual come from the distributed network of
:mod:`isodesign.spring.acoustics` (tube as a lossy transmission line, chambers with
their longitudinal modes) for the same resistance ``C``; ``"lumped"`` is Eq. 38 as
printed. The closures (harmonic balance, Gaussian equivalent) are unchanged: they only
see ``C(U)`` and the gain ``|U/X|``.

Every function evaluates on NumPy arrays and on CasADi symbols.
"""
from __future__ import annotations

from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.spring.acoustics import acoustic_network
from isodesign.spring.flow_models import resistance_function

__all__ = [
    "air_stiffness",
    "amplitude_residual",
    "driven_velocity",
    "kinematic_velocity",
    "spring_stiffness",
    "tube_velocity_gain2",
]


# ---------------------------------------------------------------------------
# backend-agnostic physics
# ---------------------------------------------------------------------------
def _distributed(design) -> bool:
    """True for the distributed acoustic model (a Python-level choice, never a symbol)."""
    return getattr(design, "acoustics", "lumped") == "distributed"


def _jw_tau(design, omega, c: Cx) -> Cx:
    """``j w tau = j w s C`` with ``s = V_b0/(n R T0)``."""
    s = design.compliance_factor_kg_per_pa
    return Cx(-omega * s * c.im, omega * s * c.re)


def air_stiffness(design, omega, c: Cx, flow: str | None = None) -> Cx:
    """Air stiffness without diaphragm, Eq. 38, for a (complex) resistance C.

    ``k_d* = k_s (1 + j w tau) / (N + 1 + j w tau)`` with ``k_s = n p0 A_p^2/V_t0``
    (Eq. 40) and ``tau = V_b0 C / (n R T0)``. Limits: ``k_s/(N+1)`` as w -> 0 and
    ``k_s`` as w -> inf (the tube blocks).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    c : Cx
        Flow resistance C (Pa s/kg), complex (inertance in the imaginary part).
    flow : str, optional
        The flow model that gave ``c`` (distributed acoustics: its linear part is
        replaced by the transmission line, the rest enters at the tube's ends; see
        :func:`isodesign.spring.acoustics.acoustic_network`).

    Notes
    -----
    With ``design.acoustics == "distributed"`` the distributed network's stiffness for
    the same ``C`` (:meth:`isodesign.spring.acoustics.AcousticNetwork.stiffness`).
    """
    if _distributed(design):
        return acoustic_network(design, omega, flow).stiffness(c)
    jwt = _jw_tau(design, omega, c)
    return design.single_chamber_stiffness_n_per_m * (1.0 + jwt) / (1.0 + design.volume_ratio + jwt)


def kinematic_velocity(design, omega, amplitude_m):
    """Eq. 37: ``u_max = (A_p / A_c) X_p w`` (compressibility neglected).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    amplitude_m : float, ndarray or CasADi symbol
        Piston displacement amplitude X_p, m.
    """
    return design.area_ratio * amplitude_m * omega


def driven_velocity(design, omega, amplitude_m, c: Cx, flow: str | None = None):
    """Tube velocity amplitude that the chamber pressures drive for a given C.

    ``U = (A_p/A_c) X w N / |1 + N + j w tau|`` (exact for the linearized
    chambers, Eqs. 29-35).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    amplitude_m : float, ndarray or CasADi symbol
        Piston displacement amplitude X_p, m.
    c : Cx
        Flow resistance C (Pa s/kg), complex (inertance in the imaginary part).
    flow : str, optional
        The flow model that gave ``c`` (distributed acoustics: its linear part is
        replaced by the transmission line, the rest enters at the tube's ends; see
        :func:`isodesign.spring.acoustics.acoustic_network`).
    """
    if _distributed(design):
        g2 = acoustic_network(design, omega, flow).velocity_gain2(c)
        return bk.sqrt(g2) * amplitude_m
    d = 1.0 + design.volume_ratio + _jw_tau(design, omega, c)
    return design.volume_ratio * kinematic_velocity(design, omega, amplitude_m) / d.abs()


def tube_velocity_gain2(design, omega, c: Cx, flow: str | None = None):
    """``|U / X|^2``: tube velocity per stroke, squared, for the linearized chambers.

    ``U/X = (A_p/A_c) j w N / (1 + N + j w s C)`` (the linear relation behind
    :func:`driven_velocity`), so ``|U/X|^2 = (N (A_p/A_c) w)^2 / |1 + N + j w s C|^2``.
    With the stroke's spectrum it gives the tube velocity's variance (random input).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : array or CasADi symbol
        Angular frequency, rad/s.
    c : Cx
        Flow resistance ``C`` at ``omega``, Pa s/kg.
    flow : str, optional
        The flow model that gave ``c`` (as in :func:`air_stiffness`).

    Returns
    -------
    array or CasADi symbol
        ``|U/X|^2`` in 1/s^2.
    """
    if _distributed(design):
        return acoustic_network(design, omega, flow).velocity_gain2(c)
    d = 1.0 + design.volume_ratio + _jw_tau(design, omega, c)
    g = design.volume_ratio * design.area_ratio * omega
    return g * g / d.abs2()


def amplitude_residual(flow: str, design, omega, amplitude_m, log_velocity):
    """Harmonic-balance residual ``F(x)`` of the self-consistent flow amplitude.

    ``F(x) = x + ln|1 + N + j w s C(e^x)| - ln(N (A_p/A_c) X w)``, zero at the
    self-consistent ``x = ln U``; smooth in every argument (an equality
    constraint of the NLP, or the function of a rootfinder).

    Parameters
    ----------
    flow : str
        A smooth flow model (:data:`isodesign.spring.flow_models.SMOOTH_FLOW_MODELS`).
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    amplitude_m : float, ndarray or CasADi symbol
        Piston displacement amplitude X_p, m.
    log_velocity : float, ndarray or CasADi symbol
        ``x = ln U`` with U in m/s.
    """
    c = resistance_function(flow, design, omega)(bk.exp(log_velocity))
    if _distributed(design):
        # x - ln(U_driven) with U_driven = |U/X| X
        g2 = acoustic_network(design, omega, flow).velocity_gain2(c)
        return log_velocity - 0.5 * bk.log(g2) - bk.log(amplitude_m)
    d = 1.0 + design.volume_ratio + _jw_tau(design, omega, c)
    q = design.volume_ratio * kinematic_velocity(design, omega, amplitude_m)
    return log_velocity + 0.5 * bk.log(d.abs2()) - bk.log(q)


def spring_stiffness(air, diaphragm):
    """Eq. 42: the spring's complex stiffness, air and diaphragm in parallel (N/m).

    ``k*_{d+D} = k_d* + k_D*``: the piston force is the air force plus the diaphragm's,
    both at the same piston motion. The one place the two are combined (the NumPy
    result, the CasADi function, the optimizer, the time-domain rig, the static
    stiffness).

    Parameters
    ----------
    air : Cx or complex ndarray
        The air spring ``k_d*`` (Eq. 38), N/m.
    diaphragm : Cx or complex ndarray
        The diaphragm ``k_D*``, N/m.

    Returns
    -------
    Cx or complex ndarray
        ``k*_{d+D}``, of the type of the inputs (a :class:`Cx` if either is one).
    """
    return air + diaphragm
