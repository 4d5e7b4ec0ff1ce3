"""The linear-regime isolator as python-control systems.

* :func:`to_frd`: any model, as a ``control.FrequencyResponseData`` of the absolute
  transmissibility ``T(jw)`` at a small stroke amplitude (the linear regime).
* :func:`to_transfer_function`: the rational models as a ``control.TransferFunction``.
  The spring (diaphragm ``none``) is ``k(s) = k_s (1 + s s_f C(s)) / (N + 1 + s s_f C(s))``
  with ``s_f = V_b0/(n R T0)`` (Eq. 38 with ``jw -> s``) and a resistance affine in ``s``:

  - ``poiseuille``: ``C(s) = C_u`` (Eq. 41);
  - ``quasi_steady``, small-amplitude laminar limit: ``C(s) = C_u + s (4/3) L_c/A_c``
    (Poiseuille friction plus the developed-laminar inertance; the minor loss and the
    turbulent friction vanish as the amplitude goes to zero).

  The payload (mass ``m/n`` per spring, floor as base excitation) then has
  ``T(s) = k(s) / ((m/n) s^2 + k(s))``.
* :func:`step_metrics`: the floor-step response of ``T(s)`` with ``control.step_response``
  and ``control.step_info`` (rise and settling time, overshoot).
* :func:`dominant_pole_pair`: natural frequency and damping ratio of the slowest-decaying
  complex pole pair (``TransferFunction.damp``).

``control`` is imported inside the functions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_choice, check_range
from isodesign.response.model import linear_transmissibility, prepare_inputs
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import RATIONAL_FLOW_MODELS, flow_model, resistance_function

__all__ = [
    "StepMetrics",
    "dominant_pole_pair",
    "resistance_coefficients",
    "step_metrics",
    "to_frd",
    "to_transfer_function",
    "transfer_function_polynomials",
]

#: Outputs of :func:`to_transfer_function`.
TRANSFER_OUTPUTS = ("transmissibility", "relative", "stiffness")


def check_rational(flow: str, diaphragm) -> None:
    """Raise InputError unless (flow, diaphragm) has a rational transfer function."""
    if not flow_model(flow).rational:
        raise InputError(
            f"flow: {flow!r} has no rational transfer function (its resistance is not affine "
            f"in s); valid: {', '.join(RATIONAL_FLOW_MODELS)} (with diaphragm='none'), or use "
            "to_frd for any model"
        )
    dia = diaphragm_model(diaphragm)
    if dia.name != "none":
        raise InputError(
            f"diaphragm: {dia.name!r} is not rational (hysteretic or tabulated k_D*); valid: "
            "none (or use to_frd for any model)"
        )


def resistance_coefficients(design, flow: str) -> tuple[float, float]:
    """``(c0, c1)`` of the small-amplitude resistance ``C(s) = c0 + c1 s`` (Pa s/kg, Pa s^2/kg).

    ``poiseuille``: ``(C_u, 0)``; ``quasi_steady``: ``(C_u, (4/3) L_c / A_c)``.

    Parameters
    ----------
    design : SpringDesign
        The spring (numbers).
    flow : str
        A rational flow model (:data:`isodesign.spring.flow_models.RATIONAL_FLOW_MODELS`).
    """
    check_choice("flow", flow, RATIONAL_FLOW_MODELS)
    # the flow model itself at zero velocity: Re C is c0, Im C = w c1 (both models'
    # small-amplitude resistance is frequency-independent, their inertance constant)
    c = resistance_function(flow, design, 1.0)(0.0)
    return float(np.asarray(c.re)), float(np.asarray(c.im))


def transfer_function_polynomials(
    design, mass_per_isolator_kg: float, flow: str, output: str = "transmissibility"
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator coefficients (highest power first) of a rational model.

    With ``a(s) = s s_f C(s) = s_f c1 s^2 + s_f c0 s``::

        k(s)     = k_s (1 + a) / (N + 1 + a)
        T(s)     = k_s (1 + a) / (m s^2 (N + 1 + a) + k_s (1 + a))
        T(s) - 1 = -m s^2 (N + 1 + a) / (same denominator)

    Parameters
    ----------
    design : SpringDesign
        With p0 set (see :func:`isodesign.response.isolator.loaded_design`).
    mass_per_isolator_kg : float
    flow : {'poiseuille', 'quasi_steady'}
    output : {'transmissibility', 'relative', 'stiffness'}

    Returns
    -------
    num, den : ndarray
    """
    check_choice("output", output, TRANSFER_OUTPUTS)
    c0, c1 = resistance_coefficients(design, flow)
    sf = float(design.compliance_factor_kg_per_pa)
    ks = float(design.single_chamber_stiffness_n_per_m)
    n1 = 1.0 + float(design.volume_ratio)
    m = float(mass_per_isolator_kg)
    one_a = np.array([sf * c1, sf * c0, 1.0])  # 1 + a(s)
    n1_a = np.array([sf * c1, sf * c0, n1])  # N + 1 + a(s)
    if output == "stiffness":
        num, den = ks * one_a, n1_a
    else:
        ms2 = np.array([m, 0.0, 0.0])
        den = np.polyadd(np.polymul(ms2, n1_a), ks * one_a)
        num = ks * one_a if output == "transmissibility" else -np.polymul(ms2, n1_a)
    return _trim(num), _trim(den)


def _trim(p: np.ndarray) -> np.ndarray:
    p = np.asarray(p, dtype=float)
    nz = np.flatnonzero(p != 0.0)
    return p[nz[0] :] if nz.size else np.zeros(1)


def to_transfer_function(
    design,
    payload,
    *,
    flow: str = "quasi_steady",
    diaphragm="none",
    output: str = "transmissibility",
    derive_pressure: bool = True,
):
    """The linear isolator as a ``control.TransferFunction`` (rational models only).

    The spring is the lumped model (Eq. 38, ``acoustics="lumped"`` whatever the design
    names): the distributed acoustics (a transmission line, chamber modes) is not
    rational; its frequency response is :func:`to_frd`.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    flow : {'quasi_steady', 'poiseuille'}
        ``quasi_steady`` is taken in its small-amplitude laminar limit
        ``C(s) = C_u + s (4/3) L_c/A_c``; ``poiseuille`` is ``C = C_u``.
    diaphragm : 'none'
        The diaphragm models are not rational; anything else raises InputError.
    output : {'transmissibility', 'relative', 'stiffness'}
        ``T(s)`` (floor to payload), ``T(s) - 1`` (floor to stroke) or the spring's ``k(s)``.
    derive_pressure : bool
        Derive p0 from the payload (default) or use the design's own.

    Returns
    -------
    control.TransferFunction

    Raises
    ------
    InputError
        A non-rational flow model or diaphragm (the message names the valid choices).
    """
    import control


    check_rational(flow, diaphragm)
    d, payload = prepare_inputs(design, payload, derive_pressure)
    num, den = transfer_function_polynomials(d, payload.mass_per_isolator_kg, flow, output)
    return control.TransferFunction(num, den)


def to_frd(
    design,
    payload,
    frequency_hz=None,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    amplitude_m: float = 1e-6,
    derive_pressure: bool = True,
):
    """The linear-regime transmissibility as a ``control.FrequencyResponseData`` (any model).

    ``T(jw)`` of :func:`isodesign.response.model.linear_transmissibility` at a fixed small stroke
    amplitude, on ``omega = 2 pi frequency_hz``.

    Parameters
    ----------
    design, payload
    frequency_hz : array_like, optional
        Default: 400 points log-spaced from 0.1 to 100 Hz.
    flow, amplitude_mode, diaphragm : str
        Spring models (:func:`isodesign.spring.stiffness.complex_stiffness`).
    amplitude_m : float
        Stroke amplitude of the linearization (default 1 um).
    derive_pressure : bool

    Returns
    -------
    control.FrequencyResponseData
    """
    import control


    f = np.geomspace(0.1, 100.0, 400) if frequency_hz is None else frequency_hz
    f = np.atleast_1d(np.asarray(f, dtype=float))
    t = linear_transmissibility(
        design,
        payload,
        f,
        flow=flow,
        amplitude_mode=amplitude_mode,
        diaphragm=diaphragm,
        amplitude_m=amplitude_m,
        derive_pressure=derive_pressure,
    )
    return control.FrequencyResponseData(np.asarray(t), 2.0 * math.pi * f)


def dominant_pole_pair(sys) -> tuple[float, float, complex] | None:
    """The slowest-decaying complex pole pair of a system (python-control ``damp``).

    Parameters
    ----------
    sys : control.TransferFunction or control.StateSpace
        A linear system.

    Returns
    -------
    (natural_frequency_rad_s, damping_ratio, pole) or None
        ``None`` if the system has no complex pole pair. Among the pairs, the one with the
        smallest ``|Re p|`` (closest to the imaginary axis).
    """
    wn, zeta, poles = sys.damp()
    cplx = np.flatnonzero(np.imag(poles) > 1e-12 * np.abs(poles))
    if cplx.size == 0:
        return None
    i = cplx[int(np.argmin(np.abs(np.real(poles[cplx]))))]
    return float(wn[i]), float(zeta[i]), complex(poles[i])


@dataclass(frozen=True, eq=False)
class StepMetrics:
    """Floor-step response of the linear isolator (python-control ``step_info``).

    Attributes
    ----------
    rise_time_s, settling_time_s, peak_time_s : float
        ``RiseTime`` (10 to 90 %), ``SettlingTime`` (within ``settling_threshold`` of the
        final value), ``PeakTime``.
    overshoot_percent, peak, steady_state : float
        ``Overshoot`` (%), ``Peak``, ``SteadyStateValue`` (1 for T(s)).
    settling_threshold : float
    time_s, response : ndarray
        The step response (``control.step_response``).
    dominant_frequency_hz, dominant_damping_ratio : float or None
        Of the dominant pole pair.
    """

    rise_time_s: float
    settling_time_s: float
    peak_time_s: float
    overshoot_percent: float
    peak: float
    steady_state: float
    settling_threshold: float
    time_s: np.ndarray
    response: np.ndarray
    dominant_frequency_hz: float | None = None
    dominant_damping_ratio: float | None = None

    def as_dict(self) -> dict:
        """The scalar metrics."""
        return {
            "rise_time_s": self.rise_time_s,
            "settling_time_s": self.settling_time_s,
            "peak_time_s": self.peak_time_s,
            "overshoot_percent": self.overshoot_percent,
            "peak": self.peak,
            "steady_state": self.steady_state,
            "settling_threshold": self.settling_threshold,
            "dominant_frequency_hz": self.dominant_frequency_hz,
            "dominant_damping_ratio": self.dominant_damping_ratio,
        }

    def to_frame(self):
        """The step response: columns ``time_s`` and ``response`` (metrics in ``attrs``)."""
        import pandas as pd

        df = pd.DataFrame({"time_s": self.time_s, "response": self.response})
        df.attrs.update(self.as_dict())
        return df


def step_metrics(
    design,
    payload,
    *,
    flow: str = "quasi_steady",
    diaphragm="none",
    settling_threshold: float = 0.02,
    derive_pressure: bool = True,
) -> StepMetrics:
    """Step response and settling time of ``T(s)`` (rational models) with python-control.

    The payload's absolute displacement after a unit step of the floor:
    ``control.step_response(T)`` and ``control.step_info(T, SettlingTimeThreshold=...)``.

    Parameters
    ----------
    design, payload
    flow : {'quasi_steady', 'poiseuille'}
    diaphragm : 'none'
    settling_threshold : float
        Settling band as a fraction of the final value (default 2 %).
    derive_pressure : bool

    Returns
    -------
    StepMetrics
    """
    import control

    thr = check_range("settling_threshold", settling_threshold, 0.0, 1.0, lo_open=True,
                      hi_open=True)  # fmt: skip
    tf = to_transfer_function(
        design, payload, flow=flow, diaphragm=diaphragm, derive_pressure=derive_pressure
    )
    resp = control.step_response(tf)
    t = np.asarray(resp.time, dtype=float)
    y = np.asarray(resp.outputs, dtype=float).reshape(-1)
    info = control.step_info(tf, SettlingTimeThreshold=thr)
    dom = dominant_pole_pair(tf)
    return StepMetrics(
        rise_time_s=float(info["RiseTime"]),
        settling_time_s=float(info["SettlingTime"]),
        peak_time_s=float(info["PeakTime"]),
        overshoot_percent=float(info["Overshoot"]),
        peak=float(info["Peak"]),
        steady_state=float(info["SteadyStateValue"]),
        settling_threshold=thr,
        time_s=t,
        response=y,
        dominant_frequency_hz=None if dom is None else dom[0] / (2.0 * math.pi),
        dominant_damping_ratio=None if dom is None else dom[1],
    )
