"""Response to random floor vibration: the band response and its closures.

Random floor motion is given by a velocity PSD (:func:`band_response`). By default the
tube's nonlinear pressure drop is replaced by its Gaussian-equivalent resistance at the
tube velocity's RMS ``sigma_u`` and the diaphragm is evaluated at ``A* = 1.880 sigma`` of
the stroke, both RMS values solved self-consistently (``docs/random-response.md``); the
older harmonic closures on the stroke RMS ``sigma`` alone are kept by name. The quadratures are the
backend-agnostic functions of :mod:`isodesign.response.linearization`, the same ones the
optimizer evaluates on CasADi symbols. See ``docs/response.md``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from isodesign.errors import (
    InputError,
    ModelValidityWarning,
    SolverError,
    check_choice,
    check_positive,
)
from isodesign.numerics.cplx import Cx
from isodesign.response.band import BandResponse
from isodesign.response.distortion import DISTORTION_FIRST_RTOL
from isodesign.response.isolator import (
    relative_transmissibility,
)
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    RAYLEIGH_NODES,
    ResponseGrid,
    band_mean_square,
    equivalent_amplitude,
    rayleigh_rule,
    response_grid,
    stroke_variance,
    tube_velocity_variance,
)
from isodesign.response.model import (
    LINEAR_REFERENCE_AMPLITUDE_M,
    TWO_PI,
    SpringModel,
    emit_flags,
    resolve_floor,
    resolve_target,
    spring_model,
)
from isodesign.response.stability import stability_of_model
from isodesign.spring.capillary import STATISTICAL_FLOW_MODELS, statistical_resistance_function
from isodesign.spring.diagnostics import evaluate_diagnostics
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness, tube_velocity_gain2
from isodesign.spring.stiffness import StiffnessResult

__all__ = [
    "RANDOM_METHODS",
    "BandResponse",
    "band_response",
    "band_response_at",
    "solve_stroke_rms",
]

#: Closures of the random response: ``statistical`` (the default: Gaussian statistical
#: linearization of the tube's nonlinear pressure drop at the tube velocity's RMS, the
#: diaphragm at ``A* = 1.880 sigma``), and the harmonic closures on the stroke kept for
#: comparison: the spring's describing function at ``A* = 1.880 sigma``
#: (``equivalent_amplitude``) or its Rayleigh average (``rayleigh``).
RANDOM_METHODS = ("statistical", "equivalent_amplitude", "rayleigh")

# ---------------------------------------------------------------------------
# random floor input: band response
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Eval:
    log_sigma_in: float
    log_sigma_out: float
    k: np.ndarray
    result: Any


def _random_evaluator(model: SpringModel, grid: ResponseGrid, method: str, nodes: int):
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


class _Statistical:
    """The statistical linearization on a response grid (NumPy; the NLP uses the same parts).

    ``C(w; sigma_u)`` = linear part (frequency dependent) + Gaussian-equivalent resistance
    of the nonlinear drop at ``sigma_u``; the diaphragm at ``A* = 1.880 sigma`` of the
    stroke. :meth:`evaluate` maps ``(ln sigma, ln sigma_u)`` to the variances they produce.
    """

    def __init__(self, model: SpringModel, grid: ResponseGrid):
        self.model = model
        self.grid = grid
        self.dia = diaphragm_model(model.diaphragm)
        self.c_of = statistical_resistance_function(model.flow, model.design, grid.omega)
        #: variances added to the linearization's (the distortion power, if carried)
        self.offset = (0.0, 0.0)
        #: the distortion bins' ``sigma_u -> C`` (computed once, :func:`_distortion_at`)
        self.bin_c_of = None
        #: the inner (tube) closure's last slope, for a first Newton step (None: the
        #: fixed-point step; set for the closure solved again with the distortion)
        self.tube_slope = None
        #: the minor loss's equivalent gain over the Gaussian ``sqrt(8/pi)`` (1: Gaussian;
        #: the non-Gaussian correction of the distortion, docs/random-response.md 3c)
        self.gain_ratio = 1.0

    def resistance(self, c_of, sigma_u):
        """``C(sigma_u)`` from ``c_of``, the minor loss's gain scaled by :attr:`gain_ratio`."""
        c = c_of(sigma_u)
        if self.gain_ratio == 1.0 or self.model.flow == "poiseuille":
            return c
        from isodesign.response.distortion import minor_loss_gain_shift

        return Cx(c.re + minor_loss_gain_shift(self.model.design, sigma_u, self.gain_ratio),
                  c.im)

    def stiffness(self, omega, sigma, sigma_u, c_of=None):
        """``(k, k_air, k_dia, C)`` as Cx at ``omega`` for the two RMS values."""
        d = self.model.design
        c = self.resistance(c_of or statistical_resistance_function(self.model.flow, d, omega),
                            sigma_u)
        k_air = air_stiffness(d, omega, c, self.model.flow)
        k_d = self.dia.stiffness(omega, equivalent_amplitude(sigma))
        return spring_stiffness(k_air, k_d), k_air, k_d, c

    def variances(self, sigma, sigma_u, k_dia=None):
        """``(sigma^2, sigma_u^2, k)`` produced by the linearization at ``(sigma, sigma_u)``."""
        d, w = self.model.design, self.grid.omega
        c = self.resistance(self.c_of, sigma_u)
        if k_dia is None:
            k_dia = self.dia.stiffness(w, equivalent_amplitude(sigma))
        k = spring_stiffness(air_stiffness(d, w, c, self.model.flow), k_dia)
        rel = relative_transmissibility(k, self.model.mass, w)
        s2 = float(stroke_variance(rel, self.grid)) + self.offset[0]
        su2 = float(tube_velocity_variance(rel, c, d, self.grid, self.model.flow)) + self.offset[1]
        return s2, su2, k

    def tube_closure(self, sigma, y0: float, rtol: float, max_iter: int):
        """Solve ``sigma_u`` at a fixed stroke RMS: ``(ln sigma_u, s2, k, n)``."""
        k_dia = self.dia.stiffness(self.grid.omega, equivalent_amplitude(sigma))
        cache = {}

        def ev(y):
            s2, su2, k = self.variances(sigma, math.exp(y), k_dia)
            cache[y] = (s2, k)
            return _Eval(y, 0.5 * math.log(su2), k, None)

        e, n, slope = _random_closure(ev, y0, rtol, max_iter, self.tube_slope)
        if self.tube_slope is not None and slope is not None:
            self.tube_slope = slope  # the next inner solve starts with Newton's step
        s2, k = cache[e.log_sigma_in]
        return e.log_sigma_in, s2, k, n


def _statistical_closure(st: _Statistical, x0: float, y0: float, rtol: float, max_iter: int,
                         slope0: float | None = None):
    """Nested closure: the stroke RMS outside (secant), the tube velocity RMS inside.

    Returns ``(ln sigma, ln sigma_u, k, evaluations, slope)``.
    """
    state = {"y": y0, "n": 0}
    memo: dict[float, tuple] = {}

    def evaluate(x):
        y, s2, k, n = st.tube_closure(math.exp(x), state["y"], 0.1 * rtol, max_iter)
        state["y"] = y
        state["n"] += n
        memo[x] = (y, k)
        return _Eval(x, 0.5 * math.log(s2), k, None)

    ev, _, slope = _random_closure(evaluate, x0, rtol, max_iter, slope0)
    y, k = memo[ev.log_sigma_in]
    return ev.log_sigma_in, y, k, state["n"], slope


def _distortion_at(st: _Statistical, sigma: float, sigma_u: float):
    """The distortion power at the closure's state ``(sigma, sigma_u)``."""
    from isodesign.response.distortion import distortion_power

    m, g = st.model, st.grid
    k, _, _, c = st.stiffness(g.omega, sigma, sigma_u, st.c_of)
    rel = relative_transmissibility(k, m.mass, g.omega)
    lines = g.stroke_weight * rel.abs2() * tube_velocity_gain2(m.design, g.omega, c, m.flow)

    def state_at(w):
        # the bins' linear resistance does not move with the state: once per response
        key = (w.size, float(w[0]), float(w[-1]))
        if st.bin_c_of is None or st.bin_c_of[0] != key:
            st.bin_c_of = (key, statistical_resistance_function(m.flow, m.design, w))
        kk, _, _, cc = st.stiffness(w, sigma, sigma_u, st.bin_c_of[1])
        return kk.to_complex(), cc.to_complex()

    edges = np.concatenate([g.bands.lower_hz, g.bands.upper_hz])
    return distortion_power(m.design, m.flow, g.frequency_hz, lines, state_at, m.mass,
                            edges_hz=edges)


def _with_distortion(st: _Statistical, x: float, y: float, rtol: float, max_iter: int,
                     slope: float | None = None, first=None):
    """The closure with the distortion power added to its variances: one pass of the
    distortion at the plain closure's state, the closure solved again with it (from there),
    and the distortion at the new state. Returns ``(x, y, DistortionPower, evaluations)``."""
    dist = (first or _distortion_at)(st, math.exp(x), math.exp(y))
    st.offset = (dist.stroke_variance, dist.tube_velocity_variance)
    st.gain_ratio = dist.gain_ratio
    # start one fixed-point step on: the plain closure's variances plus the distortion's
    x = 0.5 * math.log(math.exp(2.0 * x) + dist.stroke_variance)
    y = 0.5 * math.log(math.exp(2.0 * y) + dist.tube_velocity_variance)
    st.tube_slope = 0.0  # inner solves from a Newton step once a slope is known
    x, y, _, n, _ = _statistical_closure(st, x, y, rtol, max_iter, slope)
    dist = _distortion_at(st, math.exp(x), math.exp(y))
    st.offset = (dist.stroke_variance, dist.tube_velocity_variance)
    return x, y, dist, n


def _random_closure(evaluate, x0: float, rtol: float, max_iter: int,
                    slope0: float | None = None):
    """Secant (then Brent) on ``g(x) = ln sigma_new(e^x) - x``; returns (eval, n, slope)."""
    hist: list[_Eval] = []

    def g(x):
        e = evaluate(x)
        hist.append(e)
        return e.log_sigma_out - x

    x_prev, g_prev = x0, g(x0)
    if abs(g_prev) <= rtol:
        return hist[-1], len(hist), None
    # first step: the fixed-point iteration, or Newton's with a known slope of the map
    # (a closure solved again from a nearby one's solution, its slope)
    step0 = g_prev
    if slope0 is not None and math.isfinite(slope0) and slope0 < 0.9:
        step0 = max(-2.0, min(2.0, g_prev / (1.0 - slope0)))
    x, gx = x_prev + step0, None
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
        from scipy.optimize import brentq  # the fallback only: the import costs 0.1 s

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
    random_method: str = "equivalent_amplitude",
    distortion: bool = False,
) -> tuple[float, dict]:
    """RMS stroke sigma of the random-input closure on a given response grid (NumPy).

    The same closures as :func:`band_response`, on a prebuilt
    :class:`~isodesign.response.linearization.ResponseGrid`; the optimizer uses it to
    initialize and to re-check its NLP. ``random_method``: ``equivalent_amplitude`` (the
    spring at ``A* = 1.880 sigma``, secant in ``ln sigma`` from the linear-regime value) or
    ``statistical`` (the tube's Gaussian-equivalent resistance at ``sigma_u``, both RMS
    values solved together; ``docs/random-response.md``).

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    grid : ResponseGrid
        The frequencies and quadrature weights (:func:`response_grid`).
    flow, amplitude_mode, diaphragm : str
        Spring models, as in :func:`band_response`.
    derive_pressure : bool
        Derive p0 from the payload (default ``False``: the design's own).
    rtol : float
        Tolerance on ``|ln(sigma_new / sigma)|``.
    max_iter : int
        Secant iterations before the Brent fallback.
    random_method : {'equivalent_amplitude', 'statistical'}
        The closure.
    distortion : bool
        With the statistical closure: the closure with the minor loss's distortion power
        (:func:`band_response`'s ``distortion=True``, docs/random-response.md 3a-3c), both
        of its closures solved to ``rtol`` (the optimizer differentiates it).

    Returns
    -------
    sigma : float
        RMS stroke, m (with ``distortion``: the closure's state, its variances including the
        distortion's at the plain closure's state).
    info : dict
        ``iterations`` and ``closure_slope``; for ``statistical`` also
        ``tube_velocity_rms_m_s`` (``sigma_u``) and ``linearization`` (the closure's state
        on ``grid``, which :func:`band_response_at` reuses); with ``distortion`` also
        ``distortion`` (the :class:`~isodesign.response.distortion.DistortionPower` at the
        final state, whose band powers :func:`band_response` adds), ``distortion_offset``
        (the added stroke and tube-velocity variances the closure was solved with) and
        ``distortion_gain_ratio`` (the minor loss's gain ratio it was solved with).
    """
    check_choice("random_method", random_method, ("equivalent_amplitude", "statistical"))
    model = spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    f, w = grid.frequency_hz, grid.omega
    if distortion and random_method != "statistical":
        raise InputError("distortion: the distortion power is the statistical closure's "
                         "residual; valid with random_method='statistical' only")
    if random_method == "statistical":
        if flow not in STATISTICAL_FLOW_MODELS:
            raise InputError(f"flow: {flow!r} has no time-domain law to linearize "
                             f"statistically; valid: {', '.join(STATISTICAL_FLOW_MODELS)}")
        st = _Statistical(model, grid)
        s2_lin, su2_lin, _ = st.variances(
            LINEAR_REFERENCE_AMPLITUDE_M / EQUIVALENT_AMPLITUDE_FACTOR, 1e-9)
        if not s2_lin > 0:
            raise InputError("floor: the spectrum carries no motion (PSD zero)")
        x, y, _, n_it, slope = _statistical_closure(
            st, 0.5 * math.log(s2_lin), 0.5 * math.log(max(su2_lin, 1e-300)), rtol,
            int(max_iter))  # fmt: skip
        info = {}
        if distortion:
            st.tube_slope = 0.0
            offset0 = None

            def first(stt, sig, sig_u):
                nonlocal offset0
                dist0 = _distortion_at(stt, sig, sig_u)
                offset0 = (dist0.stroke_variance, dist0.tube_velocity_variance,
                           dist0.gain_ratio)
                return dist0

            x, y, dist, n_more = _with_distortion(st, x, y, rtol, int(max_iter), slope,
                                                  first=first)
            n_it += n_more
            info = {"distortion": dist, "distortion_offset": offset0[:2],
                    "distortion_gain_ratio": offset0[2]}
        return math.exp(x), {"iterations": n_it, "closure_slope": slope,
                             "tube_velocity_rms_m_s": math.exp(y),
                             "linearization": st, **info}  # fmt: skip
    k_lin = model.k(f, LINEAR_REFERENCE_AMPLITUDE_M)
    s2_lin = float(
        stroke_variance(relative_transmissibility(Cx.from_complex(k_lin), model.mass, w), grid)
    )
    if not s2_lin > 0:
        raise InputError("floor: the spectrum carries no motion (PSD zero)")
    evaluate = _random_evaluator(model, grid, "equivalent_amplitude", RAYLEIGH_NODES)
    ev, n_it, slope = _random_closure(evaluate, 0.5 * math.log(s2_lin), rtol, int(max_iter))
    return math.exp(ev.log_sigma_in), {"iterations": n_it, "closure_slope": slope}


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
    random_method: str = "statistical",
    rayleigh_nodes: int = RAYLEIGH_NODES,
    stroke_amplitude_m: float | None = None,
    rtol: float = 1e-10,
    max_iter: int = 50,
    derive_pressure: bool = True,
    strict: bool = True,
    warn: bool = True,
    distortion: bool = False,
) -> BandResponse:
    """One-third-octave band response of the payload to a random floor, and compliance.

    The floor is a one-sided velocity PSD ``S_v``. With the spring linearized at the
    stroke's RMS ``sigma``, the payload's band mean-square velocity is
    ``integral_band |T|^2 S_v df`` and the stroke variance
    ``sigma^2 = integral |T - 1|^2 S_v / w^2 df`` over the floor's whole range
    (:func:`~isodesign.response.linearization.band_mean_square`,
    :func:`~isodesign.response.linearization.stroke_variance` on a
    :class:`~isodesign.response.linearization.ResponseGrid`). ``sigma`` is closed self-consistently:
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
        Spring models (:func:`~isodesign.spring.stiffness.complex_stiffness`;
        ``amplitude_mode`` is the tube-flow amplitude of the spring model).
    random_method : {'statistical', 'equivalent_amplitude', 'rayleigh'}
        ``statistical`` (default): Gaussian statistical linearization where the
        nonlinearity lives. The tube's nonlinear pressure drop (minor loss, turbulent part
        of the friction) becomes one frequency-independent equivalent resistance at the
        tube velocity's RMS ``sigma_u``
        (:func:`~isodesign.spring.capillary.gaussian_equivalent_resistance`), the linear
        parts (Poiseuille or Womersley resistance, inertance) stay frequency dependent, and
        ``sigma_u`` is solved self-consistently with the stroke RMS ``sigma`` (nested
        secant iterations); the diaphragm is evaluated at ``A* = 1.880 sigma``.
        ``amplitude_mode`` does not enter (the tube velocity is the linearized system's
        own). Needs ``flow`` in ``quasi_steady``, ``womersley``, ``poiseuille``. See
        ``docs/random-response.md``. The harmonic closures on the stroke, kept for
        comparison: ``equivalent_amplitude``, the spring's describing function at
        ``A* = 1.880 sigma`` (:data:`EQUIVALENT_AMPLITUDE_FACTOR`) at every frequency;
        ``rayleigh``, its Rayleigh average over the amplitude distribution of a
        narrow-band Gaussian stroke (:func:`rayleigh_rule`).
    rayleigh_nodes : int
        Nodes of the Rayleigh rule.
    stroke_amplitude_m : float, optional
        Skip the closure: evaluate the spring's describing function at this fixed
        amplitude (the result reports ``random_method='equivalent_amplitude'``).
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
    distortion : bool
        Add the minor loss's distortion power, the residual of the statistical linearization
        carried through the system as an uncorrelated pressure-drop source in the tube
        (:mod:`isodesign.response.distortion`, ``docs/random-response.md`` section 3a), to the
        bands, the stroke and the tube velocity, self-consistently with the closure; the
        residual's power and the minor loss's equivalent gain at the tube velocity's
        predicted kurtosis (section 3c; ``distortion_kurtosis`` and ``flags`` of the
        result). ``random_method="statistical"`` only. Off by default here, where every
        model is an explicit argument; a study's default is on (``models.distortion``,
        which :func:`isodesign.analyze`, the optimizer's NLP, section 3d, and every command
        apply; ``isodesign response`` without a study too), so pass ``distortion=True`` for
        the study's answer.

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
    model = spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    rtol = check_positive("rtol", rtol)
    if stroke_amplitude_m is not None and random_method == "statistical":
        random_method = "equivalent_amplitude"  # a fixed harmonic amplitude: no closure
    if random_method == "statistical" and flow not in STATISTICAL_FLOW_MODELS:
        raise InputError(
            f"flow: {flow!r} has no time-domain law to linearize statistically; valid with "
            f"random_method='statistical': {', '.join(STATISTICAL_FLOW_MODELS)} (or use "
            "random_method='equivalent_amplitude')"
        )
    fl = resolve_floor(floor)
    tg = resolve_target(target)
    grid = response_grid(fl, bands, target=tg, points_per_band=points_per_band)
    f, w = grid.frequency_hz, grid.omega
    k_lin = model.k(f, LINEAR_REFERENCE_AMPLITUDE_M)
    t_lin = model.transmissibility(k_lin, f)
    converged, slope, dist = True, None, None
    if distortion and random_method != "statistical":
        raise InputError("distortion: the distortion power is the statistical closure's "
                         "residual; valid with random_method='statistical' only")
    if random_method == "statistical":
        st = _Statistical(model, grid)
        # start: the linear regime (laminar tube, diaphragm at the reference amplitude)
        sigma_lin = LINEAR_REFERENCE_AMPLITUDE_M / EQUIVALENT_AMPLITUDE_FACTOR
        s2_lin, su2_lin, _ = st.variances(sigma_lin, 1e-9)
        if not s2_lin > 0:
            raise InputError(f"floor: the spectrum {fl.name!r} carries no motion (PSD zero)")
        x0, y0 = 0.5 * math.log(s2_lin), 0.5 * math.log(max(su2_lin, 1e-300))
        # with the distortion, the plain closure only as close as the distortion evaluated
        # there needs: the closure with it, the one reported, is solved to rtol
        rtol0 = max(rtol, DISTORTION_FIRST_RTOL) if distortion else rtol
        if distortion:  # the inner solves start with Newton's step once a slope is known
            st.tube_slope = 0.0
        try:
            x, y, _, n_it, slope = _statistical_closure(st, x0, y0, rtol0, int(max_iter))
        except SolverError as exc:
            if strict:
                raise
            warnings.warn(f"band_response: {exc}", ModelValidityWarning, stacklevel=2)
            converged, x, y, n_it = False, x0, y0, int(max_iter)
        if distortion:
            x, y, dist, n_more = _with_distortion(st, x, y, rtol, int(max_iter), slope)
            n_it += n_more
        res, lines = _result_at(model, payload, grid, fl.name, tg.name, random_method,
                                (math.exp(x), math.exp(y)), n_it, converged, slope, warn,
                                t_lin, st=st, dist=dist)
        if dist is not None:
            from isodesign.response.distortion import kurtosis_flag

            flag = kurtosis_flag(dist.kurtosis_first_order, dist.kurtosis)
            res = replace(res, distortion_kurtosis=dist.kurtosis, flags=tuple(flag))
            lines += flag
        emit_flags(lines, "band_response", warn)
        return res
    else:
        evaluate = _random_evaluator(model, grid, random_method, rayleigh_nodes)
        if stroke_amplitude_m is not None:
            amp = check_positive("stroke_amplitude_m", stroke_amplitude_m, unit="m")
            ev = evaluate(math.log(amp / EQUIVALENT_AMPLITUDE_FACTOR))
            n_it = 1
        else:
            s2_lin = float(
                stroke_variance(relative_transmissibility(Cx.from_complex(k_lin), model.mass, w),
                                grid)
            )  # fmt: skip
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
        res, lines = _result_at(model, payload, grid, fl.name, tg.name, random_method,
                                (math.exp(ev.log_sigma_in), None), n_it, converged, slope,
                                warn, t_lin, evaluated=(ev.k, ev.result),
                                rayleigh_nodes=rayleigh_nodes)
        emit_flags(lines, "band_response", warn)
        return res


def band_response_at(design, payload, floor, target, sigma_m: float,
                     tube_velocity_rms_m_s: float | None = None, *, bands=None,
                     points_per_band: int = 50, flow: str = "quasi_steady",
                     amplitude_mode: str = "self_consistent", diaphragm="viscoelastic",
                     random_method: str = "statistical", rayleigh_nodes: int = RAYLEIGH_NODES,
                     derive_pressure: bool = True, iterations: int = 0,
                     converged: bool = True, closure_slope: float | None = None,
                     warn: bool = True, grid: ResponseGrid | None = None,
                     linearization=None) -> BandResponse:
    """The band response at a given closure state (the closure solved elsewhere).

    :func:`band_response` solves the closure and calls the same assembly; a caller that
    solved it otherwise (the table model's z DOF, :func:`isodesign.analyze`) passes the
    state: the stroke RMS ``sigma`` (and, for ``statistical``, the tube velocity RMS
    ``sigma_u``) that the spring is linearized at.

    Parameters
    ----------
    design, payload, floor, target, bands, points_per_band, flow, amplitude_mode, diaphragm,
    random_method, rayleigh_nodes, derive_pressure, warn :
        As in :func:`band_response`.
    sigma_m : float
        The closure's stroke RMS, m.
    tube_velocity_rms_m_s : float, optional
        The statistical closure's tube velocity RMS ``sigma_u`` (required for it).
    iterations : int
        Evaluations the closure took (reported).
    converged : bool
    closure_slope : float, optional
        ``d ln sigma_new / d ln sigma`` at the solution, when known.
    grid : ResponseGrid, optional
        The response grid of ``floor``, ``target``, ``bands`` and ``points_per_band``,
        when the caller built it already.
    linearization : optional
        ``solve_stroke_rms(...)[1]["linearization"]`` of the same design, payload, models
        and ``grid`` (reused instead of rebuilt; ignored on another grid).

    Returns
    -------
    BandResponse
    """
    check_choice("random_method", random_method, RANDOM_METHODS)
    model = spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    fl, tg = resolve_floor(floor), resolve_target(target)
    if grid is None:
        grid = response_grid(fl, bands, target=tg, points_per_band=points_per_band)
    sigma = check_positive("sigma_m", sigma_m, unit="m")
    st = None
    if random_method == "statistical":
        if tube_velocity_rms_m_s is None:
            raise InputError("tube_velocity_rms_m_s: the statistical closure's state needs "
                             "the tube velocity RMS")
        st = linearization if _reusable(linearization, model, grid) \
            else _Statistical(model, grid)
    t_lin = model.transmissibility(model.k(grid.frequency_hz, LINEAR_REFERENCE_AMPLITUDE_M),
                                   grid.frequency_hz)
    res, lines = _result_at(model, payload, grid, fl.name, tg.name, random_method,
                            (sigma, tube_velocity_rms_m_s), int(iterations), bool(converged),
                            closure_slope, warn, t_lin, st=st, rayleigh_nodes=rayleigh_nodes)
    emit_flags(lines, "band_response", warn)
    return res


def _reusable(lin, model: SpringModel, grid) -> bool:
    """A closure's linearization is that of ``model`` on ``grid`` (its p0 within 1e-12:
    a leveled table's rounding)."""
    if not isinstance(lin, _Statistical) or lin.grid is not grid:
        return False
    m = lin.model
    p, q = float(m.design.pressure_pa), float(model.design.pressure_pa)
    return (abs(p - q) <= 1e-12 * q and m.mass == model.mass and m.flow == model.flow
            and m.diaphragm == model.diaphragm
            and m.design.replace(pressure_pa=q) == model.design)


def _result_at(model, payload, grid, floor_name, target_name, random_method, state, n_it,
               converged, slope, warn, t_lin, *, st=None, dist=None, evaluated=None,
               rayleigh_nodes: int = RAYLEIGH_NODES) -> tuple[BandResponse, list]:
    """The :class:`BandResponse` at the closure state ``(sigma, sigma_u)``: the spring
    linearized there, T, the bands, the stroke, the stability figures; and its flags (the
    caller emits them, so that the warning names the user's call)."""
    f, w = grid.frequency_hz, grid.omega
    sigma_in, sigma_u_in = state
    sigma_u = None
    if random_method == "statistical":
        kc, k_air_c, k_d_c, c = st.stiffness(w, sigma_in, sigma_u_in, st.c_of)
        k = kc.to_complex()
        rel = relative_transmissibility(kc, model.mass, w)
        sigma_u = math.sqrt(float(tube_velocity_variance(rel, c, model.design, grid,
                                                         model.flow)) + st.offset[1])
        amp = equivalent_amplitude(sigma_in)
        diag = evaluate_diagnostics(
            model.flow, model.design, w, np.full(f.shape, amp),
            np.full(f.shape, math.sqrt(2.0) * sigma_u), c, k_air_c.to_complex(), k,
            st.dia, "self_consistent",
        )  # fmt: skip
        spring_res = StiffnessResult(
            frequency_hz=f, amplitude_m=np.full(f.shape, amp), k=k,
            k_air=k_air_c.to_complex(), k_diaphragm=np.broadcast_to(k_d_c.to_complex(), f.shape),
            diagnostics=diag, flow=model.flow, amplitude_mode="statistical",
            diaphragm=st.dia.name, design=model.design,
        )  # fmt: skip

        def t_exc(ff):
            kk = st.stiffness(TWO_PI * np.asarray(ff), sigma_in, sigma_u_in)[0]
            return model.transmissibility(kk.to_complex(), ff)

    else:
        if evaluated is None:
            evaluated = _random_evaluator(model, grid, random_method, rayleigh_nodes)(
                math.log(sigma_in))
            evaluated = (evaluated.k, evaluated.result)
        k, spring_res = evaluated
        if random_method == "equivalent_amplitude":

            def t_exc(ff):
                return model.transmissibility(model.k(ff, equivalent_amplitude(sigma_in)), ff)

        else:
            a, wq = rayleigh_rule(rayleigh_nodes)

            def t_exc(ff):
                return model.transmissibility(model.k(ff, sigma_in * a, pairwise=False) @ wq, ff)

    t = model.transmissibility(k, f)
    tc = Cx.from_complex(t)
    rel = relative_transmissibility(Cx.from_complex(k), model.mass, w)
    sigma = math.sqrt(float(stroke_variance(rel, grid)) + (dist.stroke_variance if dist else 0))
    ms_v = np.asarray(band_mean_square(tc, grid, "velocity"))
    ms_x = np.asarray(band_mean_square(tc, grid, "displacement"))
    ms_a = np.asarray(band_mean_square(tc, grid, "acceleration"))
    if dist is not None:
        lo, hi = grid.bands.lower_hz, grid.bands.upper_hz
        ms_v = ms_v + dist.band_mean_square(lo, hi, 0)
        ms_x = ms_x + dist.band_mean_square(lo, hi, -2)
        ms_a = ms_a + dist.band_mean_square(lo, hi, 2)
    stab = stability_of_model(
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
        spring_diagnostics=spring_res,
        iterations=n_it,
        converged=converged,
        closure_slope=slope,
        random_method=random_method,
        flow=model.flow,
        amplitude_mode=model.amplitude_mode,
        diaphragm=stab.diaphragm,
        floor_name=floor_name,
        target_name=target_name,
        design=model.design,
        payload=payload,
        tube_velocity_rms_m_s=sigma_u,
    )
    lines = list(res.warnings)
    if slope is not None and slope >= 1.0:
        lines.append(
            f"closure: d ln sigma_new/d ln sigma = {slope:.3g} >= 1 at the solution; the "
            "stroke RMS may not be unique"
        )
    return res, lines
