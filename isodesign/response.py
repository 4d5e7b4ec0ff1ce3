"""Payload response on a vibrating floor: transmissibility, band compliance, stability.

A rigid payload of mass ``m`` on ``n`` identical dual-chamber springs, excited by the
floor (base excitation). Per spring (mass ``m/n``, complex stiffness ``k*(X, w)`` of
:func:`isodesign.spring.complex_stiffness`)::

    T = k* / (k* - (m/n) w^2)          floor -> payload (absolute motion)
    T - 1 = (m/n) w^2 / (k* - (m/n) w^2)   floor -> spring stroke (relative motion)

The spring's amplitude is its stroke, which depends on ``T`` itself; this module closes
that loop:

* harmonic floor motion of amplitude ``X_f`` (:func:`harmonic_response`): per frequency the
  stroke amplitude solves ``X_s = |T(X_s) - 1| X_f`` (bracketed scan in ``ln X_s``, then
  Illinois regula falsi; every root is counted, one branch is returned);
* random floor motion given by a velocity PSD (:func:`band_response`): equivalent
  linearization iterated to convergence on the stroke RMS ``sigma`` (one scalar; secant in
  ``ln sigma``), with the spring evaluated at ``A* = 1.880 sigma`` (default) or
  Rayleigh-averaged over the amplitude distribution.

The quadratures are the backend-agnostic functions of :mod:`isodesign.linearization`
(:class:`ResponseGrid`, :func:`stroke_variance`, :func:`band_mean_square`), the same ones
the optimizer evaluates on CasADi symbols. python-control interop lives in
:mod:`isodesign.control_interop` (re-exported here). See ``docs/response.md``.

p0 and the payload
------------------
Every function takes the spring ``design`` and the :class:`~isodesign.isolator.Payload`.
By default (``derive_pressure=True``) the chamber pressure is derived from the payload
weight, ``p0 = p_atm + m g/(n A_p)`` (Eq. 1, :func:`~isodesign.isolator.loaded_design`);
``derive_pressure=False`` uses the design's own ``pressure_pa`` as given (for a design
whose pressure is set otherwise, e.g. a leveling valve holding a fixed p0).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .control_interop import (
    RATIONAL_FLOW_MODELS,
    StepMetrics,
    dominant_pole_pair,
    step_metrics,
    to_frd,
    to_transfer_function,
)
from .cplx import Cx
from .diaphragm import diaphragm_model
from .errors import InputError, ModelValidityWarning, SolverError, check_choice, check_positive
from .isolator import (
    Payload,
    loaded_design,
    relative_transmissibility,
    tilt_margin,
    transmissibility,
    zener_damping_ratio,
    zener_optimum,
)
from .linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    RAYLEIGH_NODES,
    ResponseGrid,
    band_margin_db,
    band_mean_square,
    equivalent_amplitude,
    rayleigh_average,
    rayleigh_rule,
    response_grid,
    stroke_variance,
)

__all__ = [
    "BRANCHES",
    "EQUIVALENT_AMPLITUDE_FACTOR",
    "LINEAR_REFERENCE_AMPLITUDE_M",
    "RANDOM_METHODS",
    "RATIONAL_FLOW_MODELS",
    "SCAN_AMPLITUDE_RANGE_M",
    "BandResponse",
    "HarmonicResponse",
    "ResponseGrid",
    "StabilityFigures",
    "StepMetrics",
    "band_margin_db",
    "band_mean_square",
    "band_response",
    "dominant_pole_pair",
    "equivalent_amplitude",
    "harmonic_response",
    "linear_transmissibility",
    "loaded_design",
    "rayleigh_average",
    "rayleigh_rule",
    "resolve_floor",
    "resolve_target",
    "response_grid",
    "stability_figures",
    "step_metrics",
    "stroke_variance",
    "to_frd",
    "to_transfer_function",
]

#: Stroke amplitude of the "linear, small-amplitude regime" (m): the natural frequency, the
#: linear peak of |T|, :func:`linear_transmissibility` and :func:`to_frd` use it.
LINEAR_REFERENCE_AMPLITUDE_M = 1e-6
#: Spring amplitude for the random closure: ``A* = 1.880 sigma`` or the Rayleigh average.
RANDOM_METHODS = ("equivalent_amplitude", "rayleigh")
#: Which self-consistent harmonic stroke to return where several exist.
BRANCHES = ("upper", "lower")
#: Amplitude window (m) of the harmonic root scan; outside it the spring is taken as
#: amplitude-independent for counting roots (see :func:`harmonic_response`).
SCAN_AMPLITUDE_RANGE_M = (1e-9, 1e-1)
#: Scan points per decade of amplitude.
SCAN_POINTS_PER_DECADE = 8

_TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------
# inputs
# ---------------------------------------------------------------------------
def _prepare(design, payload, derive_pressure: bool):
    """Validate (design, payload); return the design to use and the payload."""
    from .design import SpringDesign

    if not isinstance(design, SpringDesign):
        raise InputError(f"design: expected a SpringDesign, got {type(design).__name__}")
    if not isinstance(payload, Payload):
        raise InputError(
            f"payload: expected an isodesign.isolator.Payload, got {type(payload).__name__}"
        )
    return (loaded_design(design, payload) if derive_pressure else design), payload


def _looks_like_file(x) -> bool:
    if isinstance(x, os.PathLike):
        return True
    return isinstance(x, str) and (x.lower().endswith(".csv") or Path(x).is_file())


def resolve_floor(floor):
    """A :class:`~isodesign.criteria.FloorSpectrum` from a spectrum, a criterion or a CSV file.

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
    from .criteria import CriterionCurve, FloorSpectrum, criterion, criterion_names

    if isinstance(floor, FloorSpectrum):
        return floor
    try:
        if _looks_like_file(floor):
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
    """A :class:`~isodesign.criteria.CriterionCurve` from a name, a curve or a CSV file.

    Raises
    ------
    InputError
        The message starts with ``target:``.
    """
    from .criteria import CriterionCurve, criterion, criterion_from_csv

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
class _Model:
    """A loaded design, the mass per spring and the spring models."""

    design: Any
    mass: float
    flow: str
    amplitude_mode: str
    diaphragm: Any

    def stiffness(self, frequency_hz, amplitude_m, pairwise=True):
        """:func:`complex_stiffness` without warnings (they are collected by the caller)."""
        from .spring import complex_stiffness

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
        t = transmissibility(Cx.from_complex(k), self.mass, _TWO_PI * np.asarray(frequency_hz))
        return t.to_complex()


def _model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure) -> _Model:
    from .spring import check_models

    d, payload = _prepare(design, payload, derive_pressure)
    check_models(flow, amplitude_mode)
    diaphragm_model(diaphragm)  # validate early
    return _Model(d, payload.mass_per_isolator_kg, flow, amplitude_mode, diaphragm)


def _emit(lines, what: str, warn: bool) -> None:
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
        Spring models (:func:`isodesign.spring.complex_stiffness`).
    amplitude_m : float
        Stroke amplitude, m (default 1 um, :data:`LINEAR_REFERENCE_AMPLITUDE_M`).
    derive_pressure : bool
        Derive p0 from the payload (default) or use the design's.

    Returns
    -------
    ndarray of complex
        ``T``, shape of ``frequency_hz``.
    """
    m = _model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    f = check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    x = check_positive("amplitude_m", amplitude_m, unit="m")
    return m.transmissibility(m.k(f, x), f)


def _natural_frequency(model: _Model, amplitude_m: float) -> tuple[float, float]:
    """``f_n = sqrt(K0/(m/n)) / (2 pi)`` with K0 from :func:`isolator.static_stiffness`."""
    from .isolator import static_stiffness

    dia = diaphragm_model(model.diaphragm)
    k0 = float(np.asarray(static_stiffness(model.design, dia, model.mass, amplitude_m)))
    if not k0 > 0:
        raise SolverError(f"static stiffness K0 = {k0:.4g} N/m is not positive")
    return math.sqrt(k0 / model.mass) / _TWO_PI, k0


def _peak(t_of_f, f_center: float, coarse=None) -> tuple[float, float]:
    """Maximum of ``|T(f)|`` near ``f_center``: a coarse and a fine log grid, a parabola.

    ``t_of_f`` maps a frequency array to complex T. Coarse pass: ``coarse = (f, T)`` already
    computed (used if its maximum is not at an end), else 241 points from ``f_center / 20``
    to ``20 f_center``. Fine pass: 81 points between the neighbours of the coarse maximum.
    Then the vertex of the parabola in ``ln f`` through the best three points; if the fine
    step exceeds 2e-4 in ``ln f``, ``|T|`` is evaluated there. Accuracy: frequency about
    1e-6 relative, peak value about 1e-12.
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


# ---------------------------------------------------------------------------
# stability figures
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class StabilityFigures:
    """Natural frequency, damping, resonance peak and tilt margin of a loaded isolator.

    Attributes
    ----------
    natural_frequency_hz : float
        ``f_n = sqrt(K0 / (m/n)) / (2 pi)`` with ``K0 = k_s/(N+1) + Re k_D(X_ref, f_air)``
        (:func:`isodesign.isolator.static_stiffness`): the air spring's low-frequency limit
        plus the diaphragm's storage stiffness at the reference amplitude and at the air
        spring's own natural frequency; the optimizer's constraints use the same K0.
    static_stiffness_n_per_m : float
        ``K0`` per isolator, N/m.
    air_static_stiffness_n_per_m : float
        ``k_s/(N+1)``, N/m.
    reference_amplitude_m : float
        ``X_ref`` (:data:`LINEAR_REFERENCE_AMPLITUDE_M`).
    mass_per_isolator_kg, pressure_pa : float
        ``m/n`` and the chamber pressure p0 used.
    tilt_margin : float or None
        ``n K0 (s/2)^2 / (m g h)`` (> 1: statically stable in rocking); ``None`` without the
        payload's spacing and CG height.
    zener_damping_ratio, zener_optimal_damping_ratio : float
        ``c/(2 sqrt(k m))`` of the air spring's Zener form with ``C_u`` (diaphragm
        ignored), and the optimum ``N sqrt(2(N+2))/(4(N+1))`` for the same N.
    peak_transmissibility, peak_frequency_hz : float
        Maximum of ``|T(f)|`` at the reference amplitude, and where.
    pole_damping_ratio, pole_frequency_hz : float or None
        Damping ratio and natural frequency of the dominant (slowest-decaying) complex pole
        pair of the rational transfer function (python-control); ``None`` for models
        without one (womersley, zhao, any diaphragm but ``none``).
    excited_peak_transmissibility, excited_peak_frequency_hz : float or None
        Maximum of ``|T(f)|`` for the spring linearized at the self-consistent amplitude of
        a given excitation (:func:`band_response`); ``None`` otherwise.
    excitation_amplitude_m : float or None
        That amplitude (``A*`` of the random closure).
    flow, amplitude_mode, diaphragm : str
    """

    natural_frequency_hz: float
    static_stiffness_n_per_m: float
    air_static_stiffness_n_per_m: float
    reference_amplitude_m: float
    mass_per_isolator_kg: float
    pressure_pa: float
    tilt_margin: float | None
    zener_damping_ratio: float
    zener_optimal_damping_ratio: float
    peak_transmissibility: float
    peak_frequency_hz: float
    pole_damping_ratio: float | None
    pole_frequency_hz: float | None
    excited_peak_transmissibility: float | None = None
    excited_peak_frequency_hz: float | None = None
    excitation_amplitude_m: float | None = None
    flow: str = ""
    amplitude_mode: str = ""
    diaphragm: str = ""

    @property
    def tilt_stable(self) -> bool | None:
        """``tilt_margin > 1`` (None when not computed)."""
        return None if self.tilt_margin is None else bool(self.tilt_margin > 1.0)

    def to_frame(self):
        """One row per figure: ``figure``, ``value``, ``unit``, ``definition``."""
        import pandas as pd

        rows = [
            ("natural_frequency_hz", self.natural_frequency_hz, "Hz",
             "sqrt(K0/(m/n))/(2 pi), K0 = k_s/(N+1) + Re k_D(X_ref, f_air)"),
            ("static_stiffness_n_per_m", self.static_stiffness_n_per_m, "N/m",
             "K0 per isolator"),
            ("air_static_stiffness_n_per_m", self.air_static_stiffness_n_per_m, "N/m",
             "k_s/(N+1)"),
            ("reference_amplitude_m", self.reference_amplitude_m, "m", "X_ref"),
            ("mass_per_isolator_kg", self.mass_per_isolator_kg, "kg", "m/n"),
            ("pressure_pa", self.pressure_pa, "Pa", "absolute chamber pressure p0"),
            ("tilt_margin", self.tilt_margin, "-",
             "n K0 (s/2)^2/(m g h); > 1 statically stable in rocking"),
            ("zener_damping_ratio", self.zener_damping_ratio, "-",
             "c/(2 sqrt(k m)), Zener form with C_u (air only)"),
            ("zener_optimal_damping_ratio", self.zener_optimal_damping_ratio, "-",
             "N sqrt(2(N+2))/(4(N+1))"),
            ("peak_transmissibility", self.peak_transmissibility, "-", "max |T| at X_ref"),
            ("peak_frequency_hz", self.peak_frequency_hz, "Hz", "frequency of max |T| at X_ref"),
            ("pole_damping_ratio", self.pole_damping_ratio, "-",
             "dominant complex pole pair of T(s) (rational models)"),
            ("pole_frequency_hz", self.pole_frequency_hz, "Hz",
             "|p|/(2 pi) of that pole pair"),
            ("excited_peak_transmissibility", self.excited_peak_transmissibility, "-",
             "max |T| at the self-consistent amplitude"),
            ("excited_peak_frequency_hz", self.excited_peak_frequency_hz, "Hz",
             "frequency of that maximum"),
            ("excitation_amplitude_m", self.excitation_amplitude_m, "m",
             "self-consistent spring amplitude A*"),
        ]  # fmt: skip
        df = pd.DataFrame(rows, columns=["figure", "value", "unit", "definition"])
        df.attrs.update(flow=self.flow, amplitude_mode=self.amplitude_mode,
                        diaphragm=self.diaphragm)  # fmt: skip
        return df


def _stability(
    model: _Model, payload: Payload, *, excited=None, linear_coarse=None
) -> StabilityFigures:
    """Stability figures of a prepared model.

    ``excited = (t_of_f, amplitude, coarse)`` adds the excited peak; ``linear_coarse`` and
    ``coarse`` are ``(f, T)`` arrays already computed, to start the peak searches.
    """
    d = model.design
    x_ref = LINEAR_REFERENCE_AMPLITUDE_M
    fn, k0 = _natural_frequency(model, x_ref)
    tilt = None
    if payload.spacing_m is not None and payload.cg_height_m is not None:
        tilt = float(tilt_margin(k0, payload))

    def t_lin(f):
        return model.transmissibility(model.k(f, x_ref), f)

    f_pk, t_pk = _peak(t_lin, fn, linear_coarse)
    pole_z = pole_f = None
    dia = diaphragm_model(model.diaphragm)
    if model.flow in RATIONAL_FLOW_MODELS and dia.name == "none":
        import control

        from .control_interop import transfer_function_polynomials

        num, den = transfer_function_polynomials(d, model.mass, model.flow)
        dom = dominant_pole_pair(control.TransferFunction(num, den))
        if dom is not None:
            pole_f, pole_z = dom[0] / _TWO_PI, dom[1]
    ex_t = ex_f = ex_a = None
    if excited is not None:
        t_of_f, ex_a, coarse = excited
        ex_f, ex_t = _peak(t_of_f, f_pk, coarse)
    return StabilityFigures(
        natural_frequency_hz=fn,
        static_stiffness_n_per_m=k0,
        air_static_stiffness_n_per_m=float(d.static_stiffness_n_per_m),
        reference_amplitude_m=x_ref,
        mass_per_isolator_kg=model.mass,
        pressure_pa=float(d.pressure_pa),
        tilt_margin=tilt,
        zener_damping_ratio=float(zener_damping_ratio(d, model.mass)),
        zener_optimal_damping_ratio=zener_optimum(float(d.volume_ratio))[2],
        peak_transmissibility=t_pk,
        peak_frequency_hz=f_pk,
        pole_damping_ratio=pole_z,
        pole_frequency_hz=pole_f,
        excited_peak_transmissibility=ex_t,
        excited_peak_frequency_hz=ex_f,
        excitation_amplitude_m=None if ex_a is None else float(ex_a),
        flow=model.flow,
        amplitude_mode=model.amplitude_mode,
        diaphragm=dia.name,
    )


def stability_figures(
    design,
    payload,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    derive_pressure: bool = True,
) -> StabilityFigures:
    """Natural frequency, damping ratios, linear resonance peak and tilt margin.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
        ``spacing_m`` and ``cg_height_m`` enable the tilt margin.
    flow, amplitude_mode, diaphragm : str
        Spring models.
    derive_pressure : bool

    Returns
    -------
    StabilityFigures
        Without the excitation-dependent figures (see :func:`band_response`).
    """
    model = _model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    return _stability(model, payload)


# ---------------------------------------------------------------------------
# harmonic floor input
# ---------------------------------------------------------------------------
def _log_ratio(model: _Model, f, xf, x):
    """``h(x) = ln(|T(e^x) - 1| X_f) - x``, pairwise over (f, X_f, x)."""
    k = model.k(f, np.exp(x))
    rel = relative_transmissibility(Cx.from_complex(k), model.mass, _TWO_PI * f)
    return np.log(rel.abs()) + np.log(xf) - x


def _harmonic_closure(model: _Model, f: np.ndarray, xf: np.ndarray, branch: str, rtol: float,
                      max_iter: int):  # fmt: skip
    """Solve ``X_s = |T(X_s) - 1| X_f`` on the grid f (n_f,) x X_f (n_a,)."""
    lo, hi = SCAN_AMPLITUDE_RANGE_M
    n_s = round(SCAN_POINTS_PER_DECADE * math.log10(hi / lo)) + 1
    lx = np.linspace(math.log(lo), math.log(hi), n_s)
    k_scan = model.k(f[:, None], np.exp(lx)[None, :])  # (n_f, n_s)
    rel = relative_transmissibility(Cx.from_complex(k_scan), model.mass, _TWO_PI * f[:, None])
    lr = np.log(rel.abs())  # ln |T - 1|, independent of X_f
    h = lr[:, None, :] + np.log(xf)[None, :, None] - lx  # (n_f, n_a, n_s)
    pos = h > 0
    cross = pos[..., :-1] & ~pos[..., 1:]
    below, above = ~pos[..., 0], pos[..., -1]
    n_roots = cross.sum(axis=-1) + below + above
    shape = h.shape[:2]
    ff = np.broadcast_to(f[:, None], shape).ravel()
    xff = np.broadcast_to(xf[None, :], shape).ravel()
    cross2 = cross.reshape(-1, n_s - 1)
    hf = h.reshape(-1, n_s)
    below, above = below.ravel(), above.ravel()
    any_cross = cross2.any(axis=1)
    first = np.argmax(cross2, axis=1)
    last = n_s - 2 - np.argmax(cross2[:, ::-1], axis=1)
    kk = last if branch == "upper" else first
    use_above = above if branch == "upper" else above & ~below & ~any_cross
    use_below = below & ~any_cross & ~above if branch == "upper" else below
    rows = np.arange(hf.shape[0])
    a, b = lx[kk].copy(), lx[kk + 1].copy()
    ha, hb = hf[rows, kk].copy(), hf[rows, kk + 1].copy()
    # roots outside the scan window: the spring is linear there; extend geometrically
    for mask, edge in ((use_below, 0), (use_above, n_s - 1)):
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            continue
        guess = np.repeat(lr[:, edge], len(xf))[idx]
        guess = guess + np.log(xff[idx])  # ln(|T - 1| X_f) at the window edge
        step = -1.0 if edge == 0 else 1.0
        x_new = guess + step
        for _ in range(40):
            hx = _log_ratio(model, ff[idx], xff[idx], x_new)
            ok = hx > 0 if edge == 0 else hx <= 0
            if edge == 0:
                a[idx], ha[idx] = x_new, hx
                b[idx], hb[idx] = lx[0], hf[idx, 0]
            else:
                a[idx], ha[idx] = lx[-1], hf[idx, -1]
                b[idx], hb[idx] = x_new, hx
            if np.all(ok):
                break
            x_new = np.where(ok, x_new, x_new + 2.0 * step)
        else:
            raise SolverError(
                "harmonic stroke: no bracket found outside the amplitude scan window "
                f"{lo:g}..{hi:g} m"
            )
    # Illinois regula falsi on all points: ha > 0 >= hb
    n = a.size
    x = b.copy()
    hx = hb.copy()
    iters = np.zeros(n, dtype=int)
    done = np.abs(hb) <= rtol
    side = np.zeros(n, dtype=int)
    for _ in range(max_iter):
        act = np.flatnonzero(~done)
        if act.size == 0:
            break
        aa, bb, fa, fb = a[act], b[act], ha[act], hb[act]
        c = (aa * fb - bb * fa) / (fb - fa)
        c = np.where(np.isfinite(c) & (c > np.minimum(aa, bb)) & (c < np.maximum(aa, bb)),
                     c, 0.5 * (aa + bb))  # fmt: skip
        hc = _log_ratio(model, ff[act], xff[act], c)
        iters[act] += 1
        x[act], hx[act] = c, hc
        conv = np.abs(hc) <= rtol
        posc = hc > 0
        s = side[act]
        # replace the endpoint on the same side; halve the other one if it stayed twice
        fb_new = np.where(posc & (s == 1), fb * 0.5, fb)
        fa_new = np.where(~posc & (s == -1), fa * 0.5, fa)
        a[act] = np.where(posc, c, aa)
        ha[act] = np.where(posc, hc, fa_new)
        b[act] = np.where(posc, bb, c)
        hb[act] = np.where(posc, fb_new, hc)
        side[act] = np.where(posc, 1, -1)
        done[act] = conv
    if not np.all(done):
        bad = int(np.sum(~done))
        raise SolverError(
            f"harmonic stroke X_s = |T(X_s) - 1| X_f did not converge at {bad} of {n} points "
            f"(max |ln residual| {np.max(np.abs(hx[~done])):.3g} after {max_iter} iterations)"
        )
    return (
        np.exp(x).reshape(shape),
        iters.reshape(shape),
        hx.reshape(shape),
        n_roots.reshape(shape).astype(int),
    )


@dataclass(frozen=True, eq=False)
class HarmonicResponse:
    """Payload response to harmonic floor motion, with the stroke closed self-consistently.

    Arrays have shape ``(n_frequencies, n_floor_amplitudes)``.

    Attributes
    ----------
    frequency_hz : ndarray (n_f,)
    floor_amplitude_m : ndarray (n_a,)
    transmissibility : ndarray of complex
        ``T`` at the self-consistent stroke.
    stroke_m : ndarray
        Spring stroke amplitude ``X_s = |T - 1| X_f``.
    n_roots : ndarray of int
        Number of stable self-consistent strokes found (1 almost everywhere; 2 or more
        where the response is multivalued, the jump phenomenon).
    iterations : ndarray of int
        Regula falsi iterations.
    residual : ndarray
        ``ln(|T - 1| X_f / X_s)`` at the solution.
    branch : str
        ``upper`` (largest stable stroke) or ``lower`` (smallest).
    spring : StiffnessResult
        The spring at the solution (diagnostics, validity warnings).
    transmissibility_linear : ndarray of complex (n_f,)
        At :data:`LINEAR_REFERENCE_AMPLITUDE_M`.
    stability : StabilityFigures
    design : SpringDesign
        The design used (p0 derived from the payload unless told otherwise).
    payload : Payload
    """

    frequency_hz: np.ndarray
    floor_amplitude_m: np.ndarray
    transmissibility: np.ndarray
    stroke_m: np.ndarray
    n_roots: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    branch: str
    spring: Any
    transmissibility_linear: np.ndarray
    stability: StabilityFigures
    design: Any = field(repr=False, default=None)
    payload: Payload | None = None

    @property
    def converged(self) -> bool:
        """Always True: a point that does not converge raises SolverError."""
        return True

    @property
    def magnitude(self) -> np.ndarray:
        """``|T|``."""
        return np.abs(self.transmissibility)

    @property
    def phase_deg(self) -> np.ndarray:
        """Phase of ``T`` in degrees."""
        return np.degrees(np.angle(self.transmissibility))

    @property
    def multiple_roots(self) -> np.ndarray:
        """True where more than one stable self-consistent stroke exists."""
        return self.n_roots > 1

    @property
    def peak_transmissibility(self) -> np.ndarray:
        """Largest ``|T|`` over the frequencies, per floor amplitude (n_a,)."""
        return self.magnitude.max(axis=0)

    @property
    def peak_frequency_hz(self) -> np.ndarray:
        """Frequency of the largest ``|T|``, per floor amplitude (on the given grid)."""
        return self.frequency_hz[np.argmax(self.magnitude, axis=0)]

    @property
    def warnings(self) -> tuple[str, ...]:
        """Validity warnings of the spring model at the solution, and multiple roots."""
        out = list(self.spring.warnings)
        nm = int(np.sum(self.multiple_roots))
        if nm:
            out.append(
                f"multiple_roots: {nm} of {self.n_roots.size} points have several "
                f"self-consistent strokes (jump phenomenon); the {self.branch} branch is returned"
            )
        return tuple(out)

    def to_frame(self):
        """One row per (frequency, floor amplitude)."""
        import pandas as pd

        f = np.broadcast_to(self.frequency_hz[:, None], self.stroke_m.shape)
        xf = np.broadcast_to(self.floor_amplitude_m[None, :], self.stroke_m.shape)
        t = self.transmissibility
        tl = np.broadcast_to(self.transmissibility_linear[:, None], t.shape)
        df = pd.DataFrame(
            {
                "frequency_hz": f.ravel(),
                "floor_amplitude_m": xf.ravel(),
                "transmissibility_abs": np.abs(t).ravel(),
                "transmissibility_phase_deg": np.degrees(np.angle(t)).ravel(),
                "transmissibility_real": t.real.ravel(),
                "transmissibility_imag": t.imag.ravel(),
                "payload_amplitude_m": (np.abs(t) * xf).ravel(),
                "stroke_m": self.stroke_m.ravel(),
                "stroke_ratio": (self.stroke_m / xf).ravel(),
                "linear_transmissibility_abs": np.abs(tl).ravel(),
                "k_real_n_per_m": self.spring.k.real.ravel(),
                "k_imag_n_per_m": self.spring.k.imag.ravel(),
                "n_roots": self.n_roots.ravel(),
                "iterations": self.iterations.ravel(),
                "residual": self.residual.ravel(),
                "valid": np.asarray(self.spring.valid).ravel(),
            }
        )
        df.attrs.update(
            branch=self.branch,
            flow=self.stability.flow,
            amplitude_mode=self.stability.amplitude_mode,
            diaphragm=self.stability.diaphragm,
        )
        return df

    def plot(self, path) -> Path:
        """|T| and the stroke ratio vs frequency for each floor amplitude (PNG etc.)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
        f = self.frequency_hz
        ax1.loglog(f, np.abs(self.transmissibility_linear), "k--", lw=1,
                   label=f"linear ({LINEAR_REFERENCE_AMPLITUDE_M * 1e6:g} um)")  # fmt: skip
        for j, xf in enumerate(self.floor_amplitude_m):
            ax1.loglog(f, self.magnitude[:, j], label=f"X_f = {xf * 1e6:.3g} um")
            ax2.loglog(f, self.stroke_m[:, j] / xf, label=f"X_f = {xf * 1e6:.3g} um")
            multi = self.multiple_roots[:, j]
            if multi.any():
                ax1.plot(f[multi], self.magnitude[multi, j], "rx", ms=4)
        ax1.set_xlabel("frequency (Hz)")
        ax1.set_ylabel("|T| (payload / floor)")
        ax1.grid(True, which="both", alpha=0.3)
        ax1.legend(fontsize=8)
        ax2.set_xlabel("frequency (Hz)")
        ax2.set_ylabel("stroke / floor amplitude, |T - 1|")
        ax2.grid(True, which="both", alpha=0.3)
        fig.suptitle(f"harmonic floor input, {self.branch} branch "
                     f"({self.stability.flow}, {self.stability.diaphragm})")  # fmt: skip
        fig.tight_layout()
        p = Path(path)
        fig.savefig(p, dpi=120)
        plt.close(fig)
        return p


def harmonic_response(
    design,
    payload,
    frequency_hz,
    floor_amplitude_m,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    derive_pressure: bool = True,
    branch: str = "upper",
    rtol: float = 1e-10,
    max_iter: int = 100,
    warn: bool = True,
) -> HarmonicResponse:
    """Payload response to harmonic floor motion, stroke amplitude closed self-consistently.

    For each frequency ``f`` and floor amplitude ``X_f`` the spring's stroke amplitude
    solves ``X_s = |T(X_s, f) - 1| X_f``, i.e. ``h(x) = ln(|T(e^x) - 1| X_f) - x = 0`` in
    ``x = ln X_s``.

    Method: ``|T - 1|`` is scanned at :data:`SCAN_POINTS_PER_DECADE` amplitudes per decade
    over :data:`SCAN_AMPLITUDE_RANGE_M` (one vectorized spring call for all frequencies; it
    does not depend on ``X_f``); every sign change of ``h`` from + to - is a stable root,
    and a root beyond the window (where the spring is taken as linear) is bracketed by
    geometric extension. The chosen bracket is refined by the Illinois regula falsi,
    vectorized over all points, to ``|h| <= rtol``. A point that does not converge raises
    :class:`~isodesign.errors.SolverError`.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    frequency_hz : float or array_like
        Frequencies, Hz (> 0).
    floor_amplitude_m : float or array_like
        Floor displacement amplitudes ``X_f``, m (> 0).
    flow, amplitude_mode, diaphragm : str
        Spring models (:func:`isodesign.spring.complex_stiffness`).
    derive_pressure : bool
        Derive p0 from the payload (default) or use the design's.
    branch : {'upper', 'lower'}
        Where several stable strokes exist (softening and amplitude-dependent damping near
        resonance): ``upper`` (default) returns the largest one (the resonant branch:
        conservative for stroke and transmissibility), ``lower`` the smallest (the branch
        continued from small amplitudes). The unstable middle roots are never returned;
        ``n_roots`` counts the stable ones.
    rtol : float
        Tolerance on ``|h|`` (relative error of the stroke).
    max_iter : int
        Regula falsi iterations.
    warn : bool
        Emit one ModelValidityWarning for validity flags and multiple roots.

    Returns
    -------
    HarmonicResponse

    Notes
    -----
    The scan resolves root pairs closer than one scan step (a factor 10^(1/8) = 1.33 in
    stroke) only if ``h`` changes sign at the scan points; narrower multivalued regions can
    go undetected.
    """
    check_choice("branch", branch, BRANCHES)
    model = _model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    f = np.atleast_1d(check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True))
    xf = np.atleast_1d(
        check_positive("floor_amplitude_m", floor_amplitude_m, unit="m", allow_array=True)
    )
    if f.ndim != 1 or xf.ndim != 1:
        raise InputError("frequency_hz, floor_amplitude_m: expected scalars or 1-D arrays")
    rtol = check_positive("rtol", rtol)
    xs, iters, _, n_roots = _harmonic_closure(model, f, xf, branch, rtol, int(max_iter))
    fg = np.broadcast_to(f[:, None], xs.shape)
    spring = model.stiffness(fg, xs, pairwise=True)
    t = model.transmissibility(spring.k, fg)
    resid = np.log(np.abs(t - 1.0) * xf[None, :] / xs)
    t_lin = model.transmissibility(model.k(f, LINEAR_REFERENCE_AMPLITUDE_M), f)
    res = HarmonicResponse(
        frequency_hz=f,
        floor_amplitude_m=xf,
        transmissibility=t,
        stroke_m=xs,
        n_roots=n_roots,
        iterations=iters,
        residual=resid,
        branch=branch,
        spring=spring,
        transmissibility_linear=t_lin,
        stability=_stability(model, payload, linear_coarse=(f, t_lin) if f.size > 20 else None),
        design=model.design,
        payload=payload,
    )
    _emit(res.warnings, "harmonic_response", warn)
    return res


# ---------------------------------------------------------------------------
# random floor input: band response
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Eval:
    log_sigma_in: float
    log_sigma_out: float
    k: np.ndarray
    result: Any


def _random_evaluator(model: _Model, grid: ResponseGrid, method: str, nodes: int):
    """``x = ln sigma -> (ln sigma_new, k, StiffnessResult)`` for the random closure."""
    f, w = grid.frequency_hz, grid.omega
    if method == "rayleigh":
        a, wq = rayleigh_rule(nodes)

    def evaluate(x: float) -> _Eval:
        sigma = math.exp(x)
        if method == "equivalent_amplitude":
            res = model.stiffness(f, equivalent_amplitude(sigma), pairwise=True)
            k = res.k
        else:
            res = model.stiffness(f, sigma * a, pairwise=False)  # (n, nodes)
            k = res.k @ wq
        rel = relative_transmissibility(Cx.from_complex(k), model.mass, w)
        s2 = float(stroke_variance(rel, grid))
        return _Eval(x, 0.5 * math.log(s2), k, res)

    return evaluate


def _random_closure(evaluate, x0: float, rtol: float, max_iter: int):
    """Secant (then Brent) on ``g(x) = ln sigma_new(e^x) - x``; returns (eval, n, slope)."""
    from scipy.optimize import brentq

    hist: list[_Eval] = []

    def g(x):
        e = evaluate(x)
        hist.append(e)
        return e.log_sigma_out - x

    x_prev, g_prev = x0, g(x0)
    if abs(g_prev) <= rtol:
        return hist[-1], len(hist), None
    x, gx = x_prev + g_prev, None  # first step: the fixed-point iteration
    gx = g(x)
    for _ in range(max_iter):
        if abs(gx) <= rtol:
            break
        den = gx - g_prev
        step = -gx * (x - x_prev) / den if den != 0 else gx
        if not math.isfinite(step):
            step = gx
        step = max(-2.0, min(2.0, step))
        x_prev, g_prev = x, gx
        x = x + step
        gx = g(x)
    if abs(gx) > rtol:  # fallback: bracket and Brent
        gs = [(e.log_sigma_in, e.log_sigma_out - e.log_sigma_in) for e in hist]
        pos = [p for p in gs if p[1] > 0]
        neg = [p for p in gs if p[1] < 0]
        if not pos or not neg:
            best = min(gs, key=lambda p: abs(p[1]))[0]
            for d in range(1, 16):
                for xt in (best - d, best + d):
                    gt = g(xt)
                    (pos if gt > 0 else neg).append((xt, gt))
                if pos and neg:
                    break
        if not pos or not neg:
            raise SolverError("random closure: no bracket of the stroke RMS sigma found")
        a = max(pos, key=lambda p: p[0]) if pos[0][0] < neg[0][0] else min(pos, key=lambda p: p[0])
        b = min(neg, key=lambda p: abs(p[0] - a[0]))
        try:
            x = brentq(g, a[0], b[0], xtol=1e-15, rtol=4.5e-16, maxiter=200)
        except (ValueError, RuntimeError) as exc:
            raise SolverError(f"random closure: Brent's method failed ({exc})") from None
        gx = g(x)
        if abs(gx) > rtol:
            raise SolverError(
                f"random closure did not converge: |ln(sigma_new/sigma)| = {abs(gx):.3g} > "
                f"rtol = {rtol:g} after {len(hist)} evaluations"
            )
    last = hist[-1]
    slope = None
    if len(hist) >= 2:
        e1, e0 = hist[-1], hist[-2]
        dx = e1.log_sigma_in - e0.log_sigma_in
        if dx != 0:
            slope = (e1.log_sigma_out - e0.log_sigma_out) / dx
    return last, len(hist), slope


def solve_stroke_rms(
    design,
    payload,
    grid: ResponseGrid,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    derive_pressure: bool = False,
    rtol: float = 1e-12,
    max_iter: int = 50,
) -> tuple[float, dict]:
    """RMS stroke sigma of the random-input closure on a given response grid (NumPy).

    The same closure as :func:`band_response` (equivalent amplitude
    ``A* = 1.880 sigma``, secant in ``ln sigma`` from the linear-regime value), on a
    prebuilt :class:`~isodesign.linearization.ResponseGrid`; the optimizer uses it
    to initialize and to re-check its NLP.

    Returns
    -------
    sigma : float
        RMS stroke, m.
    info : dict
        ``iterations`` and ``closure_slope``.
    """
    model = _model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    f, w = grid.frequency_hz, grid.omega
    k_lin = model.k(f, LINEAR_REFERENCE_AMPLITUDE_M)
    s2_lin = float(
        stroke_variance(relative_transmissibility(Cx.from_complex(k_lin), model.mass, w), grid)
    )
    if not s2_lin > 0:
        raise InputError("floor: the spectrum carries no motion (PSD zero)")
    evaluate = _random_evaluator(model, grid, "equivalent_amplitude", RAYLEIGH_NODES)
    ev, n_it, slope = _random_closure(evaluate, 0.5 * math.log(s2_lin), rtol, int(max_iter))
    return math.exp(ev.log_sigma_in), {"iterations": n_it, "closure_slope": slope}


@dataclass(frozen=True, eq=False)
class BandResponse:
    """Payload band response to a random floor, with the compliance verdict.

    Attributes
    ----------
    grid : ResponseGrid
        Frequencies and quadrature weights (``grid.bands`` the bands).
    transmissibility : ndarray of complex (n_points,)
        ``T`` on ``grid.frequency_hz`` at the final linearization.
    transmissibility_linear : ndarray of complex (n_points,)
        ``T`` at :data:`LINEAR_REFERENCE_AMPLITUDE_M` (the starting point).
    floor_velocity_rms_m_s : ndarray (n_bands,)
    payload_velocity_rms_m_s, payload_displacement_rms_m, payload_acceleration_rms_m_s2 :
        ndarray (n_bands,)
    limit_velocity_rms_m_s : ndarray (n_bands,)
        The target curve.
    stroke_rms_m : float
        RMS stroke ``sigma`` computed from the final ``T``.
    equivalent_amplitude_m : float
        ``A* = 1.880 sigma`` (the amplitude the spring sees with the default method).
    stability : StabilityFigures
        With the excited peak at the final linearization.
    spring_diagnostics : StiffnessResult
        The spring at the final linearization (shape (n_points,), or (n_points, nodes) for
        ``random_method='rayleigh'``); ``.warnings`` lists validity flags.
    iterations : int
        Evaluations of the closure (one spring evaluation each, the linear start excluded).
    converged : bool
    closure_slope : float or None
        ``d ln sigma_new / d ln sigma`` at the solution (< 1: a stable, locally unique fixed
        point).
    random_method, flow, amplitude_mode, diaphragm, floor_name, target_name : str
    design : SpringDesign
    payload : Payload
    """

    grid: ResponseGrid
    transmissibility: np.ndarray
    transmissibility_linear: np.ndarray
    floor_velocity_rms_m_s: np.ndarray
    payload_velocity_rms_m_s: np.ndarray
    payload_displacement_rms_m: np.ndarray
    payload_acceleration_rms_m_s2: np.ndarray
    limit_velocity_rms_m_s: np.ndarray
    stroke_rms_m: float
    equivalent_amplitude_m: float
    stability: StabilityFigures
    spring_diagnostics: Any
    iterations: int
    converged: bool
    closure_slope: float | None
    random_method: str
    flow: str
    amplitude_mode: str
    diaphragm: str
    floor_name: str = ""
    target_name: str = ""
    design: Any = field(repr=False, default=None)
    payload: Payload | None = None

    @property
    def bands(self):
        """The one-third-octave bands."""
        return self.grid.bands

    @property
    def margin_db(self) -> np.ndarray:
        """``20 log10(limit / payload)`` per band (positive: below the limit)."""
        with np.errstate(divide="ignore"):
            return 20.0 * np.log10(self.limit_velocity_rms_m_s / self.payload_velocity_rms_m_s)

    @property
    def band_passes(self) -> np.ndarray:
        """Payload band RMS velocity <= limit, per band."""
        return self.payload_velocity_rms_m_s <= self.limit_velocity_rms_m_s

    @property
    def passes(self) -> bool:
        """True when every band meets the target."""
        return bool(np.all(self.band_passes))

    @property
    def worst_band_hz(self) -> float:
        """Nominal centre of the band with the smallest margin."""
        return float(self.bands.nominal_hz[int(np.argmin(self.margin_db))])

    @property
    def worst_band_label(self) -> str:
        """Label of that band."""
        return self.bands.labels[int(np.argmin(self.margin_db))]

    @property
    def worst_margin_db(self) -> float:
        """Smallest margin over the bands, dB."""
        return float(np.min(self.margin_db))

    @property
    def warnings(self) -> tuple[str, ...]:
        """Validity warnings of the spring model at the final linearization."""
        return tuple(self.spring_diagnostics.warnings)

    def verdict(self) -> str:
        """One line: PASS/FAIL, worst band and margin."""
        n = len(self.bands)
        nfail = int(np.sum(~self.band_passes))
        head = (
            f"PASS: {self.target_name} met in all {n} bands"
            if self.passes
            else f"FAIL: {self.target_name} exceeded in {nfail} of {n} bands"
        )
        return (
            f"{head}; worst band {self.worst_band_label} Hz, margin {self.worst_margin_db:+.2f} dB"
        )

    def to_frame(self):
        """One row per band: floor, payload (v, x, a), target, margin and pass."""
        df = self.bands.to_frame()
        df["floor_velocity_rms_m_s"] = self.floor_velocity_rms_m_s
        df["payload_velocity_rms_m_s"] = self.payload_velocity_rms_m_s
        df["payload_displacement_rms_m"] = self.payload_displacement_rms_m
        df["payload_acceleration_rms_m_s2"] = self.payload_acceleration_rms_m_s2
        df["limit_velocity_rms_m_s"] = self.limit_velocity_rms_m_s
        df["margin_db"] = self.margin_db
        df["passes"] = self.band_passes
        df.attrs.update(
            floor=self.floor_name,
            target=self.target_name,
            stroke_rms_m=self.stroke_rms_m,
            equivalent_amplitude_m=self.equivalent_amplitude_m,
            random_method=self.random_method,
            flow=self.flow,
            amplitude_mode=self.amplitude_mode,
            diaphragm=self.diaphragm,
            verdict=self.verdict(),
        )
        return df

    def transmissibility_frame(self):
        """``T`` on the grid: final linearization and linear regime."""
        import pandas as pd

        t, tl = self.transmissibility, self.transmissibility_linear
        return pd.DataFrame(
            {
                "frequency_hz": self.grid.frequency_hz,
                "transmissibility_abs": np.abs(t),
                "transmissibility_phase_deg": np.degrees(np.angle(t)),
                "linear_transmissibility_abs": np.abs(tl),
            }
        )

    def plot(self, path) -> Path:
        """Floor, payload and target band RMS velocity, and |T| vs frequency (PNG etc.)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
        c = self.bands.centre_hz
        um = 1e6
        ax1.loglog(c, self.floor_velocity_rms_m_s * um, "o-", ms=3,
                   label=f"floor ({self.floor_name})")  # fmt: skip
        ax1.loglog(c, self.payload_velocity_rms_m_s * um, "s-", ms=3, label="payload")
        ax1.loglog(c, self.limit_velocity_rms_m_s * um, "k--", label=f"target {self.target_name}")
        bad = ~self.band_passes
        if bad.any():
            ax1.plot(c[bad], self.payload_velocity_rms_m_s[bad] * um, "rx", ms=8,
                     label="exceeds")  # fmt: skip
        ax1.set_xlabel("one-third-octave band centre (Hz)")
        ax1.set_ylabel("band RMS velocity (um/s)")
        ax1.set_title(self.verdict(), fontsize=9)
        ax1.grid(True, which="both", alpha=0.3)
        ax1.legend(fontsize=8)
        f = self.grid.frequency_hz
        ax2.loglog(
            f,
            np.abs(self.transmissibility),
            label=f"A* = {self.equivalent_amplitude_m * 1e6:.3g} um ({self.random_method})",
        )
        ax2.loglog(f, np.abs(self.transmissibility_linear), "k--", lw=1,
                   label=f"linear ({LINEAR_REFERENCE_AMPLITUDE_M * 1e6:g} um)")  # fmt: skip
        ax2.axhline(1.0, color="0.6", lw=0.8)
        ax2.set_xlabel("frequency (Hz)")
        ax2.set_ylabel("|T| (payload / floor)")
        ax2.grid(True, which="both", alpha=0.3)
        ax2.legend(fontsize=8)
        fig.tight_layout()
        p = Path(path)
        fig.savefig(p, dpi=120)
        plt.close(fig)
        return p


def band_response(
    design,
    payload,
    floor,
    target,
    *,
    bands=None,
    points_per_band: int = 50,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    random_method: str = "equivalent_amplitude",
    rayleigh_nodes: int = RAYLEIGH_NODES,
    stroke_amplitude_m: float | None = None,
    rtol: float = 1e-10,
    max_iter: int = 50,
    derive_pressure: bool = True,
    strict: bool = True,
    warn: bool = True,
) -> BandResponse:
    """One-third-octave band response of the payload to a random floor, and compliance.

    The floor is a one-sided velocity PSD ``S_v``. With the spring linearized at the
    stroke's RMS ``sigma``, the payload's band mean-square velocity is
    ``integral_band |T|^2 S_v df`` and the stroke variance
    ``sigma^2 = integral |T - 1|^2 S_v / w^2 df`` over the floor's whole range
    (:func:`~isodesign.linearization.band_mean_square`,
    :func:`~isodesign.linearization.stroke_variance` on a
    :class:`~isodesign.linearization.ResponseGrid`). ``sigma`` is closed self-consistently:
    ``g(x) = ln sigma_new(e^x) - x = 0`` in ``x = ln sigma``, from the linear-regime sigma,
    by a secant iteration (Brent's method if it fails), to ``|g| <= rtol``.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    floor : FloorSpectrum, str or path
        The floor: a spectrum, a criterion name (``"VC-A"``: the floor exactly on the curve)
        or a CSV file (:func:`resolve_floor`).
    target : str, CriterionCurve or path
        The instrument's criterion (:func:`resolve_target`).
    bands : Bands or (f_min_hz, f_max_hz), optional
        Default: the target's bands within the floor's range.
    points_per_band : int
        Trapezoid points per band, edges included (>= 2; default 50).
    flow, amplitude_mode, diaphragm : str
        Spring models (:func:`isodesign.spring.complex_stiffness`; ``amplitude_mode`` is the
        tube-flow amplitude of the spring model).
    random_method : {'equivalent_amplitude', 'rayleigh'}
        ``equivalent_amplitude`` (default): the spring at ``A* = 1.880 sigma``
        (:data:`EQUIVALENT_AMPLITUDE_FACTOR`), exact for quadratic damping, one spring
        evaluation per iteration. ``rayleigh``: the Rayleigh average of ``k*`` over the
        amplitude distribution of a narrow-band Gaussian stroke (:func:`rayleigh_rule`,
        ``rayleigh_nodes`` evaluations per frequency and iteration).
    rayleigh_nodes : int
        Nodes of the Rayleigh rule.
    stroke_amplitude_m : float, optional
        Skip the closure: evaluate the spring at this fixed amplitude.
    rtol : float
        Tolerance on ``|ln(sigma_new / sigma)|``.
    max_iter : int
        Secant iterations before the Brent fallback.
    derive_pressure : bool
        Derive p0 from the payload (default) or use the design's.
    strict : bool
        Raise SolverError if the closure does not converge (default); otherwise return the
        last iterate with ``converged=False`` and a warning.
    warn : bool
        Emit one ModelValidityWarning with the spring's validity flags.

    Returns
    -------
    BandResponse

    Raises
    ------
    InputError
        Bad design, payload, floor (``floor: ...``), target (``target: ...``), bands outside
        the floor data or the curve (``bands: ...``), unknown model names.
    SolverError
        The closure did not converge (``strict=True``).
    """
    check_choice("random_method", random_method, RANDOM_METHODS)
    model = _model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    rtol = check_positive("rtol", rtol)
    fl = resolve_floor(floor)
    tg = resolve_target(target)
    grid = response_grid(fl, bands, target=tg, points_per_band=points_per_band)
    f, w = grid.frequency_hz, grid.omega
    k_lin = model.k(f, LINEAR_REFERENCE_AMPLITUDE_M)
    t_lin = model.transmissibility(k_lin, f)
    evaluate = _random_evaluator(model, grid, random_method, rayleigh_nodes)
    converged, slope = True, None
    if stroke_amplitude_m is not None:
        amp = check_positive("stroke_amplitude_m", stroke_amplitude_m, unit="m")
        ev = evaluate(math.log(amp / EQUIVALENT_AMPLITUDE_FACTOR))
        n_it = 1
    else:
        s2_lin = float(
            stroke_variance(relative_transmissibility(Cx.from_complex(k_lin), model.mass, w), grid)
        )
        if not s2_lin > 0:
            raise InputError(f"floor: the spectrum {fl.name!r} carries no motion (PSD zero)")
        try:
            ev, n_it, slope = _random_closure(evaluate, 0.5 * math.log(s2_lin), rtol,
                                              int(max_iter))  # fmt: skip
        except SolverError as exc:
            if strict:
                raise
            warnings.warn(f"band_response: {exc}", ModelValidityWarning, stacklevel=2)
            converged = False
            ev = evaluate(0.5 * math.log(s2_lin))
            n_it = int(max_iter)
    k = ev.k
    t = model.transmissibility(k, f)
    tc = Cx.from_complex(t)
    rel = relative_transmissibility(Cx.from_complex(k), model.mass, w)
    sigma = math.sqrt(float(stroke_variance(rel, grid)))
    sigma_in = math.exp(ev.log_sigma_in)
    ms_v = np.asarray(band_mean_square(tc, grid, "velocity"))
    ms_x = np.asarray(band_mean_square(tc, grid, "displacement"))
    ms_a = np.asarray(band_mean_square(tc, grid, "acceleration"))
    if random_method == "equivalent_amplitude":

        def t_exc(ff):
            return model.transmissibility(model.k(ff, equivalent_amplitude(sigma_in)), ff)

    else:
        a, wq = rayleigh_rule(rayleigh_nodes)

        def t_exc(ff):
            return model.transmissibility(model.k(ff, sigma_in * a, pairwise=False) @ wq, ff)

    stab = _stability(
        model,
        payload,
        excited=(t_exc, equivalent_amplitude(sigma_in), (f, t)),
        linear_coarse=(f, t_lin),
    )
    res = BandResponse(
        grid=grid,
        transmissibility=t,
        transmissibility_linear=t_lin,
        floor_velocity_rms_m_s=grid.floor_velocity_rms_m_s,
        payload_velocity_rms_m_s=np.sqrt(ms_v),
        payload_displacement_rms_m=np.sqrt(ms_x),
        payload_acceleration_rms_m_s2=np.sqrt(ms_a),
        limit_velocity_rms_m_s=grid.limit_velocity_m_s,
        stroke_rms_m=sigma,
        equivalent_amplitude_m=equivalent_amplitude(sigma_in),
        stability=stab,
        spring_diagnostics=ev.result,
        iterations=n_it,
        converged=converged,
        closure_slope=slope,
        random_method=random_method,
        flow=flow,
        amplitude_mode=amplitude_mode,
        diaphragm=stab.diaphragm,
        floor_name=fl.name,
        target_name=tg.name,
        design=model.design,
        payload=payload,
    )
    lines = list(res.warnings)
    if slope is not None and slope >= 1.0:
        lines.append(
            f"closure: d ln sigma_new/d ln sigma = {slope:.3g} >= 1 at the solution; the "
            "stroke RMS may not be unique"
        )
    _emit(lines, "band_response", warn)
    return res
