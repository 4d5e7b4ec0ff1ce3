"""The payload-on-spring model shared by every response calculation.

A rigid payload of mass ``m`` on ``n`` identical dual-chamber springs, excited by the
floor (base excitation). Per spring (mass ``m/n``, complex stiffness ``k*(X, w)`` of
:func:`isodesign.spring.stiffness.complex_stiffness`)::

    T = k* / (k* - (m/n) w^2)              floor -> payload (absolute motion)
    T - 1 = (m/n) w^2 / (k* - (m/n) w^2)   floor -> spring stroke (relative motion)

This module validates the inputs (design, payload, floor, target), binds the spring model
(:class:`SpringModel`) and gives the linear, small-amplitude transmissibility.

p0 and the payload
------------------
Every function takes the spring ``design`` and the :class:`~isodesign.response.isolator.Payload`.
By default (``derive_pressure=True``) the chamber pressure is derived from the payload
weight, ``p0 = p_atm + m g/(n A_p)`` (Eq. 1, :func:`~isodesign.response.isolator.loaded_design`);
``derive_pressure=False`` uses the design's own ``pressure_pa`` as given (for a design
whose pressure is set otherwise, e.g. a leveling valve holding a fixed p0).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from isodesign.domain import FREQUENCY_DOMAIN_HZ, MODEL_AMPLITUDE_DOMAIN_M
from isodesign.errors import (
    InputError,
    ModelValidityWarning,
    SolverError,
    check_domain,
    check_positive,
)
from isodesign.floor import (
    CriterionCurve,
    FloorSpectrum,
    criterion,
    criterion_from_csv,
    criterion_names,
)
from isodesign.floor.survey import floor_from_record, is_record_csv
from isodesign.numerics.cplx import Cx
from isodesign.response.isolator import (
    Payload,
    loaded_design,
    static_stiffness,
    transmissibility,
)
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import model_design
from isodesign.spring.stiffness import check_models, complex_stiffness

__all__ = [
    "LINEAR_REFERENCE_AMPLITUDE_M",
    "TWO_PI",
    "SpringModel",
    "emit_flags",
    "linear_natural_frequency",
    "linear_transmissibility",
    "peak_of",
    "prepare_inputs",
    "resolve_floor",
    "resolve_target",
    "spring_model",
]

#: Stroke amplitude of the "linear, small-amplitude regime" (m): the natural frequency, the
#: linear peak of |T|, :func:`linear_transmissibility` and :func:`to_frd` use it.
LINEAR_REFERENCE_AMPLITUDE_M = 1e-6

TWO_PI = 2.0 * math.pi

# ---------------------------------------------------------------------------
# inputs
# ---------------------------------------------------------------------------
def prepare_inputs(design, payload, derive_pressure: bool):
    """Validate (design, payload); return the design to use and the payload.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    payload : Payload
        The payload.
    derive_pressure : bool
        Replace p0 by the pressure that carries the payload (Eq. 1).
    """

    if not isinstance(design, SpringDesign):
        raise InputError(f"design: expected a SpringDesign, got {type(design).__name__}")
    if not isinstance(payload, Payload):
        raise InputError(
            f"payload: expected an isodesign.Payload, got {type(payload).__name__}"
        )
    return (loaded_design(design, payload) if derive_pressure else design), payload


def _looks_like_file(x) -> bool:
    if isinstance(x, os.PathLike):
        return True
    return isinstance(x, str) and (x.lower().endswith(".csv") or Path(x).is_file())


def resolve_floor(floor):
    """A :class:`~isodesign.floor.FloorSpectrum` from a spectrum, a criterion or a CSV file.

    Parameters
    ----------
    floor : FloorSpectrum, str, CriterionCurve or path
        A spectrum (returned as is); a criterion name such as ``"VC-A"`` or a curve (the
        floor that sits exactly on the curve in every band,
        :meth:`FloorSpectrum.from_criterion`); a path to a CSV file
        (:meth:`FloorSpectrum.from_csv`, its header gives quantity, kind and unit).

    Raises
    ------
    InputError
        The message starts with ``floor:``.
    """

    if isinstance(floor, FloorSpectrum):
        return floor
    try:
        if _looks_like_file(floor):
            if is_record_csv(floor):  # a survey time history: mean-square average, z axis
                return floor_from_record(floor)
            return FloorSpectrum.from_csv(floor)
        if isinstance(floor, CriterionCurve):
            return FloorSpectrum.from_criterion(floor)
        if isinstance(floor, str):
            try:
                curve = criterion(floor)
            except InputError:
                raise InputError(
                    f"{floor!r} is neither a criterion name nor a CSV file; valid criteria: "
                    f"{', '.join(criterion_names())}"
                ) from None
            return FloorSpectrum.from_criterion(curve)
    except InputError as exc:
        raise InputError(f"floor: {exc}") from None
    raise InputError(
        f"floor: expected a FloorSpectrum, a criterion name or a CSV path, got "
        f"{type(floor).__name__}"
    )


def resolve_target(target):
    """A :class:`~isodesign.floor.CriterionCurve` from a name, a curve or a CSV file.

    Parameters
    ----------
    target : str, CriterionCurve or path
        A criterion name (:func:`isodesign.floor.criterion_names`), a curve, or a CSV file.

    Raises
    ------
    InputError
        The message starts with ``target:``.
    """

    if isinstance(target, CriterionCurve):
        return target
    try:
        if _looks_like_file(target):
            return criterion_from_csv(target)
        if isinstance(target, str):
            return criterion(target)
    except InputError as exc:
        raise InputError(f"target: {exc}") from None
    raise InputError(
        f"target: expected a criterion name, a CriterionCurve or a CSV path, got "
        f"{type(target).__name__}"
    )


@dataclass(frozen=True)
class SpringModel:
    """A loaded design, the mass per spring and the spring models."""

    design: Any
    mass: float
    flow: str
    amplitude_mode: str
    diaphragm: Any

    def stiffness(self, frequency_hz, amplitude_m, pairwise=True):
        """:func:`complex_stiffness` without warnings (they are collected by the caller)."""

        return complex_stiffness(
            self.design,
            frequency_hz,
            amplitude_m,
            flow=self.flow,
            amplitude_mode=self.amplitude_mode,
            diaphragm=self.diaphragm,
            pairwise=pairwise,
            warn=False,
        )

    def k(self, frequency_hz, amplitude_m, pairwise=True) -> np.ndarray:
        """Complex stiffness as a NumPy complex array."""
        return self.stiffness(frequency_hz, amplitude_m, pairwise).k

    def transmissibility(self, k: np.ndarray, frequency_hz) -> np.ndarray:
        """``T`` from a complex stiffness array (the isolator formula, on Cx pairs)."""
        t = transmissibility(Cx.from_complex(k), self.mass, TWO_PI * np.asarray(frequency_hz))
        return t.to_complex()


def spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure) -> SpringModel:
    """Validate the inputs and bind the spring model to the payload.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    payload : Payload
        The payload and its isolators.
    flow, amplitude_mode : str
        The flow model and the amplitude mode (validated together).
    diaphragm : str or model
        The diaphragm (validated now).
    derive_pressure : bool
        Set p0 from the payload weight (Eq. 1) instead of the design's own.

    Returns
    -------
    SpringModel
    """

    d, payload = prepare_inputs(design, payload, derive_pressure)
    check_models(flow, amplitude_mode)
    diaphragm_model(diaphragm)  # validate early
    d = model_design(flow, d)  # the paper's flow models are lumped by definition
    return SpringModel(d, payload.mass_per_isolator_kg, flow, amplitude_mode, diaphragm)


def emit_flags(lines, what: str, warn: bool) -> None:
    """Emit one :class:`~isodesign.errors.ModelValidityWarning` listing the flagged lines.

    Parameters
    ----------
    lines : sequence of str
        Validity flags (nothing is emitted when empty).
    what : str
        The computation, to prefix the message.
    warn : bool
        False: stay silent (the flags stay in the result).
    """
    if warn and lines:
        warnings.warn(f"{what}: " + "; ".join(lines), ModelValidityWarning, stacklevel=3)


# ---------------------------------------------------------------------------
# linear regime
# ---------------------------------------------------------------------------
def linear_transmissibility(
    design,
    payload,
    frequency_hz,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M,
    derive_pressure: bool = True,
) -> np.ndarray:
    """Transmissibility at a fixed stroke amplitude (the linear, small-amplitude regime).

    ``T(f) = k*(X, f) / (k*(X, f) - (m/n) w^2)`` with the spring evaluated at the stroke
    amplitude ``X = amplitude_m`` at every frequency (no closure).

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    frequency_hz : float or array_like
        Frequencies, Hz (> 0).
    flow, amplitude_mode, diaphragm : str
        Spring models (:func:`isodesign.spring.stiffness.complex_stiffness`).
    amplitude_m : float
        Stroke amplitude, m (default 1 um, :data:`LINEAR_REFERENCE_AMPLITUDE_M`).
    derive_pressure : bool
        Derive p0 from the payload (default) or use the design's.

    Returns
    -------
    ndarray of complex
        ``T``, shape of ``frequency_hz``.
    """
    m = spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    f = check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    x = check_positive("amplitude_m", amplitude_m, unit="m")
    check_domain("frequency_hz", f, FREQUENCY_DOMAIN_HZ, unit="Hz")
    check_domain("amplitude_m", x, MODEL_AMPLITUDE_DOMAIN_M, unit="m")
    return m.transmissibility(m.k(f, x), f)


def linear_natural_frequency(model: SpringModel, amplitude_m: float) -> tuple[float, float]:
    """``f_n = sqrt(K0/(m/n)) / (2 pi)`` with K0 from :func:`isolator.static_stiffness`.

    Parameters
    ----------
    model : SpringModel
        The bound spring model.
    amplitude_m : float
        Reference amplitude of the static stiffness, m.
    """

    dia = diaphragm_model(model.diaphragm)
    k0 = float(np.asarray(static_stiffness(model.design, dia, model.mass, amplitude_m)))
    if not k0 > 0:
        raise SolverError(f"static stiffness K0 = {k0:.4g} N/m is not positive")
    return math.sqrt(k0 / model.mass) / TWO_PI, k0


def peak_of(t_of_f, f_center: float, coarse=None) -> tuple[float, float]:
    """Maximum of ``|T(f)|`` near ``f_center``: a coarse and a fine log grid, a parabola.

    ``t_of_f`` maps a frequency array to complex T. Coarse pass: ``coarse = (f, T)`` already
    computed (used if its maximum is not at an end), else 241 points from ``f_center / 20``
    to ``20 f_center``. Fine pass: 81 points between the neighbours of the coarse maximum.
    Then the vertex of the parabola in ``ln f`` through the best three points; if the fine
    step exceeds 2e-4 in ``ln f``, ``|T|`` is evaluated there. Accuracy: frequency about
    1e-6 relative, peak value about 1e-12.

    Parameters
    ----------
    t_of_f : callable
        ``f (Hz, ndarray) -> complex T``.
    f_center : float
        Where to look, Hz.
    coarse : tuple of ndarray, optional
        ``(f, T)`` already computed.
    """
    f1 = a1 = None
    if coarse is not None:
        f1, a1 = np.asarray(coarse[0]), np.abs(np.asarray(coarse[1]))
        if int(np.argmax(a1)) in (0, f1.size - 1):
            f1 = None
    if f1 is None:
        f1 = np.geomspace(f_center / 20.0, f_center * 20.0, 241)
        a1 = np.abs(t_of_f(f1))
    i = int(np.argmax(a1))
    if i in (0, f1.size - 1):
        return float(f1[i]), float(a1[i])
    f2 = np.geomspace(f1[i - 1], f1[i + 1], 81)
    a2 = np.abs(t_of_f(f2))
    j = int(np.argmax(a2))
    if j in (0, f2.size - 1):
        return float(f2[j]), float(a2[j])
    ym, y0, yp = a2[j - 1], a2[j], a2[j + 1]
    den = ym - 2.0 * y0 + yp
    if not den < 0:
        return float(f2[j]), float(y0)
    delta = 0.5 * (ym - yp) / den
    h = math.log(f2[1] / f2[0])
    fv = float(f2[j] * math.exp(delta * h))
    if h <= 2e-4:
        return fv, float(y0 - 0.25 * (ym - yp) * delta)
    av = float(np.abs(t_of_f(np.array([fv])))[0])
    return (fv, av) if av >= y0 else (float(f2[j]), float(y0))
