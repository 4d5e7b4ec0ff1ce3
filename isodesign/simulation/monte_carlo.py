"""Monte Carlo verifier of the payload's response to a random floor (time domain).

A payload on its springs stands on a floor whose velocity is a stationary Gaussian
process with the one-sided PSD of a :class:`~isodesign.floor.FloorSpectrum` (flat within
each one-third-octave band for band-defined floors). The NONLINEAR lumped equations of one
spring carrying ``m/n`` are integrated in the time domain, and the payload's velocity is
analysed in IEC one-third-octave bands; independent realizations (seeds) give standard
errors. Nothing is linearized: this is the independent check of
:func:`isodesign.response.band_response` (``docs/simulation.md``, "Monte Carlo").

Physics (per spring; the stroke ``z = x_payload - x_floor``, ``z > 0`` expands the top
chamber): the same lumped equations as :mod:`isodesign.simulation.harmonic_rig`

* top chamber ``V_t = V_t0 + A_p z``, bottom ``V_b0`` fixed; chamber masses with
  ``dm_t/dt = -m_dot``; adiabatic open control volumes with the upwind enthalpy (or
  polytropic chambers);
* tube, ``quasi_steady``: ``rho L c_I du/dt = (p_t - p_b) - L mu Phi(Re) u / (2 D^2) -
  K rho_up |u| u / 2`` (Churchill's all-regime friction at the instantaneous Reynolds
  number, the minor loss); ``poiseuille``: ``m_dot = (p_t - p_b) / C_u``;
  ``womersley``: the exact laminar oscillating tube flow as a sum of its Bessel modes
  (``u = sum u_n``, ``du_n/dt = (4/lambda_n^2) G/rho - nu lambda_n^2/R^2 u_n``,
  ``lambda_n`` the zeros of ``J0``, ``G`` the pressure gradient net of the minor loss;
  the modes faster than the step are held quasi-static);
* payload: ``(m/n) z'' = A_p (p_t - p0) - F_D - (m/n) a_floor``;
* diaphragm: a :class:`~isodesign.spring.diaphragm.PronyDiaphragm` is integrated as it is
  (branch forces ``dq_i/dt = k_i z' - r_i q_i``); the describing-function models have no
  time-domain law, so they are frozen at one amplitude (default ``A* = 1.880 sigma`` with
  the verifier's own stroke RMS from a pilot run) and realized as a linear viscoelastic
  element, a Prony series ``k_inf + sum k_i j w tau_i / (1 + j w tau_i)`` fitted to
  ``k_D*(w, A)`` over the floor's range (:func:`prony_diaphragm`; the fit error is
  reported).

Floor synthesis: a periodic signal of period ``duration_s`` (frequency resolution
``1/duration_s``) with bins up to the floor's range: ``v(t) = sum A_k cos(w_k t + phi_k)``
with uniform random phases. ``amplitudes='random_phase'`` (default): ``A_k^2/2 = S_v(f_k)
df``, rescaled so that every band of a band-defined floor carries exactly its band mean
square (a random-phase multisine: Gaussian in the limit of many bins, and the linear
response has no estimation variance); ``'gaussian'``: ``A_k`` Rayleigh-distributed
(a circular complex Gaussian spectrum: an exactly Gaussian periodic process). The
response is periodic too: after ``warmup_s`` of the same periodic input, exactly one
period is recorded and analysed by FFT, leakage-free.

Integration: classical RK4 at a fixed step (default ``1/2048`` s, ``1/8192`` s for
``womersley``), compiled with numba (``isodesign.simulation._mc_kernel``): a 320 s
realization of the reference case takes about a second on one core (``docs/benchmarks.md``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError, check_choice, check_positive
from isodesign.floor.bands import Bands
from isodesign.response.isolator import Payload
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR, default_bands
from isodesign.response.model import (
    LINEAR_REFERENCE_AMPLITUDE_M,
    resolve_floor,
    resolve_target,
    spring_model,
)
from isodesign.spring.capillary import (
    QUASI_STEADY_INERTANCE_COEFFICIENT,
    poiseuille_resistance,
    tube_end_length_m,
)
from isodesign.spring.diaphragm import NoDiaphragm, PronyDiaphragm, diaphragm_model

__all__ = [
    "MONTE_CARLO_FLOW_MODELS",
    "MonteCarloResult",
    "fit_prony",
    "prony_diaphragm",
    "simulate_random_response",
]

#: Flow laws available in the time domain.
MONTE_CARLO_FLOW_MODELS = ("quasi_steady", "poiseuille", "womersley")
_FLOW_CODE = {"quasi_steady": 0, "poiseuille": 1, "womersley": 2}
_AMPLITUDES = ("random_phase", "gaussian")
#: Default sample rates (Hz) of the integration.
_DEFAULT_RATE_HZ = 2048.0
_DEFAULT_RATE_WOMERSLEY_HZ = 8192.0


# ---------------------------------------------------------------------------
# result
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class MonteCarloResult:
    """Band RMS velocities of the payload from time-domain simulations, across seeds.

    Attributes
    ----------
    bands : Bands
        The one-third-octave bands analysed.
    payload_velocity_rms_m_s, payload_velocity_rms_se_m_s : ndarray (n_bands,)
        Band RMS velocity (the root of the mean over seeds of the band mean squares) and its
        standard error across seeds (NaN with one seed).
    floor_velocity_rms_m_s : ndarray (n_bands,)
        The synthesized floor's band RMS (mean over seeds).
    stroke_rms_m, stroke_rms_se_m : float
        RMS stroke and its standard error across seeds.
    tube_velocity_rms_m_s, tube_velocity_rms_se_m_s : float
        RMS of the capillary's mean velocity and its standard error.
    stroke_kurtosis, tube_velocity_kurtosis : float
        Kurtosis (3 for a Gaussian) over all samples of all seeds.
    seeds : tuple of int
    duration_s, warmup_s, time_step_s : float
    flow, diaphragm, amplitudes, floor_name : str
    diaphragm_amplitude_m : float or None
        Amplitude at which the diaphragm was frozen (``None`` without diaphragm).
    diaphragm_fit_error : float
        Largest relative error ``|k_fit - k_D*| / |k_D*|`` of the Prony fit of the diaphragm
        over the floor's range.
    seconds_per_realization : float
        Wall time of one realization (integration and analysis), s.
    per_seed_band_ms : ndarray (n_seeds, n_bands)
        Band mean squares of each seed ((m/s)^2).
    """

    bands: Bands
    payload_velocity_rms_m_s: np.ndarray
    payload_velocity_rms_se_m_s: np.ndarray
    floor_velocity_rms_m_s: np.ndarray
    stroke_rms_m: float
    stroke_rms_se_m: float
    tube_velocity_rms_m_s: float
    tube_velocity_rms_se_m_s: float
    stroke_kurtosis: float
    tube_velocity_kurtosis: float
    seeds: tuple
    duration_s: float
    warmup_s: float
    time_step_s: float
    flow: str
    diaphragm: str
    amplitudes: str
    floor_name: str
    diaphragm_amplitude_m: float | None
    diaphragm_fit_error: float
    seconds_per_realization: float
    per_seed_band_ms: np.ndarray = field(repr=False)
    design: Any = field(repr=False, default=None)
    payload: Payload | None = field(repr=False, default=None)

    def __repr__(self) -> str:
        return (
            f"MonteCarloResult({len(self.seeds)} seeds x {self.duration_s:g} s, dt = "
            f"{self.time_step_s * 1e3:.3g} ms, flow={self.flow}, diaphragm={self.diaphragm}; "
            f"{len(self.bands)} bands {self.bands.labels[0]}-{self.bands.labels[-1]} Hz; "
            f"stroke RMS {self.stroke_rms_m * 1e6:.4g} um, tube velocity RMS "
            f"{self.tube_velocity_rms_m_s:.4g} m/s)"
        )

    def error_db(self, response) -> np.ndarray:
        """``20 log10(response / Monte Carlo)`` per band, for a :class:`BandResponse`.

        Parameters
        ----------
        response : BandResponse
            Its bands must include this result's bands.

        Returns
        -------
        ndarray (n_bands,)
        """
        idx = _band_positions(response.bands, self.bands)
        return 20.0 * np.log10(
            np.asarray(response.payload_velocity_rms_m_s)[idx] / self.payload_velocity_rms_m_s
        )

    def standard_error_db(self) -> np.ndarray:
        """Standard error of the band RMS in dB (``20 log10(1 + se/rms)``)."""
        return 20.0 * np.log10(1.0 + self.payload_velocity_rms_se_m_s
                               / self.payload_velocity_rms_m_s)  # fmt: skip

    def to_frame(self):
        """One row per band: floor and payload band RMS velocity, standard error (SI)."""
        df = self.bands.to_frame()
        df["floor_velocity_rms_m_s"] = self.floor_velocity_rms_m_s
        df["payload_velocity_rms_m_s"] = self.payload_velocity_rms_m_s
        df["payload_velocity_rms_se_m_s"] = self.payload_velocity_rms_se_m_s
        df.attrs.update(
            seeds=list(self.seeds),
            duration_s=self.duration_s,
            time_step_s=self.time_step_s,
            stroke_rms_m=self.stroke_rms_m,
            stroke_rms_se_m=self.stroke_rms_se_m,
            tube_velocity_rms_m_s=self.tube_velocity_rms_m_s,
            tube_velocity_rms_se_m_s=self.tube_velocity_rms_se_m_s,
            stroke_kurtosis=self.stroke_kurtosis,
            tube_velocity_kurtosis=self.tube_velocity_kurtosis,
            flow=self.flow,
            diaphragm=self.diaphragm,
            amplitudes=self.amplitudes,
            floor=self.floor_name,
        )
        return df


def _band_positions(outer: Bands, inner: Bands) -> np.ndarray:
    pos = {int(b): i for i, b in enumerate(outer.index)}
    try:
        return np.array([pos[int(b)] for b in inner.index])
    except KeyError:
        raise InputError(
            "response: its bands do not include the Monte Carlo bands "
            f"({inner.labels[0]} to {inner.labels[-1]} Hz)"
        ) from None


# ---------------------------------------------------------------------------
# diaphragm: Prony series
# ---------------------------------------------------------------------------
def fit_prony(omega, k_target, *, per_decade: int = 3,
              weighting: str = "complex") -> tuple[float, np.ndarray, np.ndarray, float]:
    """Fit ``k_inf + sum k_i j w tau_i / (1 + j w tau_i)`` (all ``>= 0``) to ``k_target(w)``.

    Relaxation times log-spaced ``per_decade`` per decade from a decade below to a decade
    above the range of ``omega``; non-negative least squares on the real and imaginary
    parts relative to ``|k_target|`` (a passive, causal generalized Maxwell model).

    Parameters
    ----------
    omega : array_like
        Angular frequencies of the fit, rad/s.
    k_target : array_like of complex
        The complex stiffness to fit at ``omega``, N/m.
    per_decade : int
        Relaxation times per decade.
    weighting : {'complex', 'parts'}
        ``complex``: residuals relative to ``|k_target|`` (default; the storage part
        dominates when the loss factor is small). ``parts``: the real part relative to
        ``Re k_target`` and the imaginary part relative to ``Im k_target``, so that the loss
        stiffness is fitted as closely as the storage (for an element whose damping
        matters, such as the table's lateral stiffness).

    Returns
    -------
    k_inf : float
    k_i, rate_i : ndarray
        Branch stiffnesses (N/m) and relaxation rates ``1/tau_i`` (1/s).
    max_rel_error : float
        ``max |k_fit - k_target| / |k_target|`` on ``omega``. A causal model cannot follow
        a loss factor of 0.1-0.2 over a nearly frequency-independent storage stiffness
        exactly (Kramers-Kronig); for the default viscoelastic diaphragm this is about 4 %
        (storage within 1.5 %, the loss stiffness within 25 %).
    """
    from scipy.optimize import nnls

    w = np.asarray(omega, dtype=float)
    kt = np.asarray(k_target, dtype=complex)
    lo, hi = math.log10(w.min()) - 1.0, math.log10(w.max()) + 1.0
    rates = 10.0 ** np.arange(lo, hi + 1e-9, 1.0 / per_decade)
    jw = 1j * w[:, None]
    basis = np.concatenate([np.ones((w.size, 1)), jw / (jw + rates)], axis=1)
    check_choice("weighting", weighting, ("complex", "parts"))
    if weighting == "parts":
        if not (np.all(kt.real > 0) and np.all(kt.imag > 0)):
            raise InputError("k_target: weighting='parts' needs positive real and imaginary "
                             "parts")
        a = np.concatenate([basis.real / kt.real[:, None], basis.imag / kt.imag[:, None]])
        b = np.ones(2 * w.size)
    else:
        scale = np.abs(kt)[:, None]
        a = np.concatenate([(basis / scale).real, (basis / scale).imag])
        b = np.concatenate([(kt / scale[:, 0]).real, (kt / scale[:, 0]).imag])
    coef, _ = nnls(a, b, maxiter=50 * a.shape[1])
    fit = basis @ coef
    err = float(np.max(np.abs(fit - kt) / np.abs(kt)))
    keep = coef[1:] > 0
    return float(coef[0]), coef[1:][keep], rates[keep], err


def prony_diaphragm(diaphragm, frequency_hz, amplitude_m) -> tuple[PronyDiaphragm, float]:
    """A diaphragm model frozen at one amplitude, as a fitted :class:`PronyDiaphragm`.

    Parameters
    ----------
    diaphragm : str or model
        Any diaphragm model (:func:`~isodesign.spring.diaphragm.diaphragm_model`).
    frequency_hz : array_like
        Frequencies of the fit (Hz).
    amplitude_m : float
        The amplitude at which the model is frozen.

    Returns
    -------
    PronyDiaphragm, float
        The fit (:func:`fit_prony`) and its largest relative error.
    """
    dia = diaphragm_model(diaphragm)
    w = 2.0 * math.pi * check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    kd = dia.stiffness(w, check_positive("amplitude_m", amplitude_m, unit="m"))
    k_inf, k, rate, err = fit_prony(w, kd.re + 1j * np.asarray(kd.im))
    return PronyDiaphragm(k_inf, tuple(k.tolist()), tuple(rate.tolist())), err


# ---------------------------------------------------------------------------
# the simulation
# ---------------------------------------------------------------------------
def _parameters(design, flow: str, mass: float, k_inf: float, rate_hz: float):
    """The kernel's parameter vector and the Womersley modes."""
    from isodesign.simulation import _mc_kernel as kern

    d = design
    p = np.zeros(kern.N_PARAMS)
    rho0 = d.density_kg_m3
    p[kern._P0] = d.pressure_pa
    p[kern._VT0] = d.top_volume_m3
    p[kern._VB0] = d.bottom_volume_m3
    p[kern._AP] = d.piston_area_m2
    p[kern._AC] = d.capillary_area_m2
    p[kern._MT0] = rho0 * d.top_volume_m3
    p[kern._MB0] = rho0 * d.bottom_volume_m3
    p[kern._RGAS] = d.gas.gas_constant_j_per_kg_k
    p[kern._IDX] = d.process_index
    p[kern._ADIAB] = 1.0 if d.polytropic_index is None else 0.0
    p[kern._MU] = d.viscosity_pa_s
    p[kern._DC] = d.capillary_diameter_m
    p[kern._RELR] = d.roughness_m / d.capillary_diameter_m
    p[kern._FSCALE] = d.capillary_length_m * d.viscosity_pa_s / (2.0 * d.capillary_diameter_m**2)
    p[kern._KMIN] = d.minor_loss
    p[kern._CU] = poiseuille_resistance(d)
    p[kern._MASS] = mass
    p[kern._KINF] = k_inf
    p[kern._RHO0] = rho0
    gain = rate = np.zeros(0)
    if flow == "quasi_steady":
        p[kern._INERT] = (QUASI_STEADY_INERTANCE_COEFFICIENT * d.capillary_length_m
                          + tube_end_length_m(d))
    elif flow == "womersley":
        from scipy.special import jn_zeros

        p[kern._INERT] = rho0 * d.capillary_length_m
        # the ends' mass moves with the mean velocity (the kernel solves for its share)
        p[kern._LEND] = rho0 * tube_end_length_m(d)
        lam = jn_zeros(0, 400)
        radius = 0.5 * d.capillary_diameter_m
        nu = d.viscosity_pa_s / rho0
        rates = nu * lam**2 / radius**2
        m = int(np.sum(rates <= rate_hz))  # modes integrated: rate * dt <= 1
        gain, rate = 4.0 / lam[:m] ** 2, rates[:m]
        p[kern._GSUM] = float(np.sum(gain))
        # quasi-static remainder: sum_{n > m} 4 R^2/(mu L lambda_n^4); sum over all = 1/8
        p[kern._WREM] = radius**2 / (d.viscosity_pa_s * d.capillary_length_m) * (
            0.125 - float(np.sum(4.0 / lam[:m] ** 4))
        )
    return p, np.ascontiguousarray(gain), np.ascontiguousarray(rate)


def _floor_spectrum(fl, duration_s: float, rng, amplitudes: str, band_bins: Bands | None,
                    stride: int = 1, offset: int = 0):
    """Bin frequencies and complex amplitudes ``A_k e^{j phi_k}`` of the floor velocity.

    Only the bins ``k = offset (mod stride)`` carry power (``stride = 3``: three interleaved
    floors, one per axis, orthogonal over the period).
    """
    df = 1.0 / duration_s
    k_lo = max(1, math.ceil(fl.f_min_hz / df))
    k_hi = math.floor(fl.f_max_hz / df)
    k = np.arange(k_lo, k_hi + 1)
    f = k * df
    if stride > 1:
        keep = k % stride == offset
        k, f = k[keep], f[keep]
        df = stride / duration_s  # each bin kept stands for `stride` bins of the period
    s = np.asarray(fl.psd_velocity(f), dtype=float)
    a2 = 2.0 * s * df  # A_k^2 = 2 S df
    if band_bins is not None:  # every band exactly its mean square
        edges = np.append(band_bins.lower_hz, band_bins.upper_hz[-1])
        pos = np.searchsorted(edges, f, side="right") - 1
        ok = (pos >= 0) & (pos < len(band_bins))
        target = np.asarray(fl.band_rms(band_bins)) ** 2
        for b in range(len(band_bins)):
            m = ok & (pos == b)
            tot = 0.5 * float(np.sum(a2[m]))
            if tot > 0:
                a2[m] *= target[b] / tot
    phase = rng.uniform(0.0, 2.0 * math.pi, k.size)
    amp = np.sqrt(a2)
    if amplitudes == "gaussian":
        amp = amp * np.sqrt(rng.exponential(1.0, k.size))  # Rayleigh, E[A^2] = a2
    return k, amp * np.exp(1j * phase)


def _time_series(k, coef, n: int, derivative: bool) -> np.ndarray:
    """``sum Re(coef_k e^{j w_k t})`` (times ``j w_k`` if ``derivative``) on n samples/period."""
    spec = np.zeros(n // 2 + 1, dtype=complex)
    c = coef * (1j * k) if derivative else coef
    spec[k] = 0.5 * n * c
    return np.fft.irfft(spec, n)


def _check_seeds(seeds) -> tuple[int, ...]:
    if isinstance(seeds, bool):
        raise InputError(f"seeds: expected a count >= 1 or a sequence of integers, got {seeds!r}")
    if isinstance(seeds, int | np.integer):
        if seeds < 1:
            raise InputError(f"seeds: the number of seeds must be >= 1, got {seeds}")
        return tuple(range(int(seeds)))
    try:
        out = tuple(int(s) for s in seeds)
    except (TypeError, ValueError):
        raise InputError(
            f"seeds: expected a count >= 1 or a sequence of integers, got {seeds!r}"
        ) from None
    if not out or any(s < 0 for s in out):
        raise InputError("seeds: a non-empty sequence of non-negative integers")
    return out


def _diaphragm_branches(dia, dia_amp: float | None, f_fit):
    """``(k_inf, k_i, rate_i, fit_error)`` of the diaphragm as integrated in the time domain.

    A :class:`PronyDiaphragm` as it is; no diaphragm (``dia_amp is None``) as zero; any other
    model frozen at ``dia_amp`` and fitted on ``f_fit`` (:func:`prony_diaphragm`).
    """
    if isinstance(dia, PronyDiaphragm):  # linear and causal: integrated as it is
        return (dia.k_inf_n_per_m, np.array(dia.branch_stiffness_n_per_m, dtype=float),
                np.array(dia.branch_rate_1_per_s, dtype=float), 0.0)  # fmt: skip
    if dia_amp is None:
        return 0.0, np.zeros(0), np.zeros(0), 0.0
    pd, fit_err = prony_diaphragm(dia, f_fit, dia_amp)
    return (pd.k_inf_n_per_m, np.array(pd.branch_stiffness_n_per_m, dtype=float),
            np.array(pd.branch_rate_1_per_s, dtype=float), fit_err)  # fmt: skip


def _floor_half_steps(fl, ctx, rng, stride: int = 1, offset: int = 0):
    """Floor acceleration at the half steps (warm-up, then one period) and the velocity record.

    The warm-up repeats the same periodic input, so the record is one period of the
    periodic response (``docs/simulation.md``, section 7). ``stride``, ``offset``: the bins
    used (:func:`_floor_spectrum`).
    """
    n, n_skip = ctx["n"], ctx["n_skip"]
    kb, coef = _floor_spectrum(fl, ctx["duration"], rng, ctx["amplitudes"],
                               ctx["norm_bands"], stride, offset)  # fmt: skip
    w0 = 2.0 * math.pi / ctx["duration"]
    acc = _time_series(kb, coef * w0, 2 * n, True)  # dv/dt, 2n samples (half steps)
    vel = _time_series(kb, coef, n, False)
    n_steps = n_skip + n - 1
    idx = (np.arange(2 * n_steps + 1) - 2 * n_skip) % (2 * n)
    return np.ascontiguousarray(acc[idx]), vel


def _run(ctx, seed: int, dia_amp: float | None):
    """One realization: (band mean squares, floor band ms, z record, u record, seconds)."""
    from isodesign.simulation import _mc_kernel as kern

    t0 = time.perf_counter()
    model, n, n_skip = ctx["model"], ctx["n"], ctx["n_skip"]
    k_inf, br_k, br_rate, fit_err = _diaphragm_branches(ctx["dia"], dia_amp, ctx["f_fit"])
    p, gain, rate = _parameters(model.design, ctx["flow"], model.mass, k_inf, 1.0 / ctx["dt"])
    rng = np.random.default_rng(seed)
    a_half, vel = _floor_half_steps(ctx["floor"], ctx, rng)
    n_tube = {"quasi_steady": 1, "poiseuille": 0, "womersley": gain.size}[ctx["flow"]]
    y0 = np.zeros(5 + n_tube + br_k.size)
    rec_zd, rec_z, rec_u = np.empty(n), np.empty(n), np.empty(n)
    kern.integrate(y0, a_half, ctx["dt"], n_skip, p, _FLOW_CODE[ctx["flow"]], gain.size, gain,
                   rate, br_k.size, np.ascontiguousarray(br_k), np.ascontiguousarray(br_rate),
                   rec_zd, rec_z, rec_u)  # fmt: skip
    if not (np.all(np.isfinite(rec_z)) and np.all(np.isfinite(rec_u))):
        raise SolverError(
            f"Monte Carlo: the integration diverged (seed {seed}, dt = {ctx['dt']:.3g} s); "
            "reduce time_step_s"
        )
    v = rec_zd + vel
    bands = ctx["bands"]
    ms = _band_mean_square(v, ctx["duration"], bands)
    ms_floor = _band_mean_square(vel, ctx["duration"], bands)
    return ms, ms_floor, rec_z, rec_u, time.perf_counter() - t0, fit_err


def _band_mean_square(x: np.ndarray, duration: float, bands: Bands) -> np.ndarray:
    """One-sided power of a periodic record summed over the bins of each band."""
    n = x.size
    spec = np.fft.rfft(x)
    power = 2.0 * np.abs(spec) ** 2 / n**2
    power[0] = 0.0
    f = np.arange(power.size) / duration
    edges = np.append(bands.lower_hz, bands.upper_hz[-1])
    pos = np.searchsorted(edges, f, side="right") - 1
    out = np.zeros(len(bands))
    ok = (pos >= 0) & (pos < len(bands))
    np.add.at(out, pos[ok], power[ok])
    return out


def _kurtosis(x: np.ndarray) -> float:
    xc = x - x.mean()
    m2 = float(np.mean(xc * xc))
    return float(np.mean(xc**4) / m2**2) if m2 > 0 else float("nan")


def _timing(duration_s, warmup_s, time_step_s, b, f_max_hz: float, flow: str):
    """Validated ``(duration, warm-up, samples per period n, step dt)`` of a simulation."""
    duration = check_positive("duration_s", duration_s, unit="s")
    warm = float(warmup_s)
    if not (math.isfinite(warm) and warm >= 0):
        raise InputError(f"warmup_s: must be finite and >= 0 s, got {warmup_s!r}")
    if not isinstance(b, Bands):
        raise InputError(f"bands: expected Bands, got {type(b).__name__}")
    if duration * float(np.min(b.upper_hz - b.lower_hz)) < 4.0:
        raise InputError(
            f"duration_s: {duration:g} s leaves fewer than 4 frequency bins in the narrowest "
            f"band ({b.labels[0]} Hz); use a longer record"
        )
    rate = _DEFAULT_RATE_WOMERSLEY_HZ if flow == "womersley" else _DEFAULT_RATE_HZ
    dt0 = 1.0 / rate if time_step_s is None else check_positive("time_step_s", time_step_s,
                                                                 unit="s")  # fmt: skip
    if dt0 > 0.1 / f_max_hz:
        raise InputError(
            f"time_step_s: {dt0:g} s is too coarse for the floor's highest frequency "
            f"{f_max_hz:g} Hz; use at most {0.1 / f_max_hz:.3g} s"
        )
    n = round(duration / dt0)
    n += n % 2
    return duration, warm, n, duration / n


def _norm_bands(fl, amplitudes: str):
    """The bands whose mean squares a random-phase floor reproduces exactly (or None)."""
    return fl.bands if (fl.bands is not None and amplitudes == "random_phase") else None


def _rms_se(vals):
    """Root of the mean over seeds (axis 0) of mean squares, and its standard error.

    The standard error of the RMS is ``se(mean square) / (2 RMS)``; NaN with one seed.
    """
    vals = np.asarray(vals, dtype=float)
    ns = vals.shape[0]
    m = vals.mean(axis=0)
    rms = np.sqrt(m)
    if ns < 2:
        return rms, np.full(np.shape(rms), np.nan)
    se_ms = vals.std(axis=0, ddof=1) / math.sqrt(ns)
    return rms, se_ms / (2.0 * rms)


def simulate_random_response(
    design,
    payload,
    floor,
    *,
    target=None,
    bands=None,
    seeds=4,
    duration_s: float = 320.0,
    warmup_s: float = 20.0,
    time_step_s: float | None = None,
    flow: str = "quasi_steady",
    diaphragm="viscoelastic",
    diaphragm_amplitude_m: float | None = None,
    amplitudes: str = "random_phase",
    derive_pressure: bool = True,
) -> MonteCarloResult:
    """Monte Carlo simulation of the payload's band response to a random floor.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    floor : FloorSpectrum, str or path
        The floor (:func:`~isodesign.response.resolve_floor`).
    target : str or CriterionCurve, optional
        Only to choose the default bands (as :func:`~isodesign.response.band_response`).
    bands : Bands, optional
        Bands to analyse; default: the target's bands inside the floor's range, or the
        floor's own bands.
    seeds : int or sequence of int
        Number of realizations (seeds 0, 1, ...) or the seeds themselves.
    duration_s : float
        Length of each analysed record (its period), s; the frequency resolution is
        ``1/duration_s``.
    warmup_s : float
        Simulated time before the record (the transient decays), s.
    time_step_s : float, optional
        RK4 step; default ``1/2048`` s (``1/8192`` s for ``womersley``), rounded so that a
        whole number of steps fills ``duration_s``.
    flow : {'quasi_steady', 'poiseuille', 'womersley'}
    diaphragm : str or model
        ``none`` or a diaphragm model (frozen at ``diaphragm_amplitude_m``).
    diaphragm_amplitude_m : float, optional
        Amplitude of the frozen diaphragm; default ``1.880 sigma`` with the stroke RMS
        ``sigma`` of a pilot run of the first seed (itself at the linear-regime amplitude).
    amplitudes : {'random_phase', 'gaussian'}
        Fixed amplitudes with random phases (default) or Rayleigh amplitudes.
    derive_pressure : bool
        Derive p0 from the payload (default) or use the design's.

    Returns
    -------
    MonteCarloResult
    """
    check_choice("flow", flow, MONTE_CARLO_FLOW_MODELS)
    check_choice("amplitudes", amplitudes, _AMPLITUDES)
    model = spring_model(design, payload, flow, "self_consistent", diaphragm, derive_pressure)
    seed_list = _check_seeds(seeds)
    fl = resolve_floor(floor)
    tg = None if target is None else resolve_target(target)
    b = default_bands(fl, tg) if bands is None else bands
    duration, warm, n, dt = _timing(duration_s, warmup_s, time_step_s, b, fl.f_max_hz, flow)
    dia = diaphragm_model(diaphragm)
    ctx = {
        "model": model,
        "flow": flow,
        "floor": fl,
        "duration": duration,
        "amplitudes": amplitudes,
        "norm_bands": _norm_bands(fl, amplitudes),
        "bands": b,
        "n": n,
        "n_skip": round(warm / dt),
        "dt": dt,
        "dia": dia,
        "f_fit": np.geomspace(fl.f_min_hz, fl.f_max_hz, 60),
    }
    dia_amp = None
    if not isinstance(dia, NoDiaphragm | PronyDiaphragm):
        if diaphragm_amplitude_m is not None:
            dia_amp = check_positive("diaphragm_amplitude_m", diaphragm_amplitude_m, unit="m")
        else:  # pilot run of the first seed at the linear-regime amplitude
            pilot = _run(ctx, seed_list[0], LINEAR_REFERENCE_AMPLITUDE_M)
            dia_amp = EQUIVALENT_AMPLITUDE_FACTOR * float(np.sqrt(np.mean(pilot[2] ** 2)))
    runs = [_run(ctx, s, dia_amp) for s in seed_list]
    ms = np.array([r[0] for r in runs])
    ms_floor = np.array([r[1] for r in runs])
    z = [r[2] for r in runs]
    u = [r[3] for r in runs]
    v_rms, v_se = _rms_se(ms)
    z_rms, z_se = _rms_se([np.mean(zz**2) for zz in z])
    u_rms, u_se = _rms_se([np.mean(uu**2) for uu in u])
    return MonteCarloResult(
        bands=b,
        payload_velocity_rms_m_s=v_rms,
        payload_velocity_rms_se_m_s=v_se,
        floor_velocity_rms_m_s=np.sqrt(ms_floor.mean(axis=0)),
        stroke_rms_m=float(z_rms),
        stroke_rms_se_m=float(z_se),
        tube_velocity_rms_m_s=float(u_rms),
        tube_velocity_rms_se_m_s=float(u_se),
        stroke_kurtosis=_kurtosis(np.concatenate(z)),
        tube_velocity_kurtosis=_kurtosis(np.concatenate(u)),
        seeds=seed_list,
        duration_s=duration,
        warmup_s=warm,
        time_step_s=dt,
        flow=flow,
        diaphragm=dia.name,
        amplitudes=amplitudes,
        floor_name=fl.name,
        diaphragm_amplitude_m=dia_amp,
        diaphragm_fit_error=float(max(r[5] for r in runs)),
        seconds_per_realization=float(np.mean([r[4] for r in runs])),
        per_seed_band_ms=ms,
        design=model.design,
        payload=payload,
    )
