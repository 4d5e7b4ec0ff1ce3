"""Response to harmonic floor motion, closed self-consistently on the stroke amplitude.

Per frequency the stroke amplitude solves ``X_s = |T(X_s) - 1| X_f`` (bracketed scan in
``ln X_s``, then Illinois regula falsi; every root is counted, one branch is returned).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.domain import AMPLITUDE_DOMAIN_M, FREQUENCY_DOMAIN_HZ
from isodesign.errors import (
    InputError,
    SolverError,
    check_choice,
    check_domain,
    check_positive,
)
from isodesign.numerics.cplx import Cx
from isodesign.plotting.response import (
    draw_transmissibility,
    finish_transmissibility,
    harmonic_figure,
)
from isodesign.plotting.style import candidate_style
from isodesign.response.isolator import (
    Payload,
    relative_transmissibility,
)
from isodesign.response.model import (
    LINEAR_REFERENCE_AMPLITUDE_M,
    TWO_PI,
    SpringModel,
    emit_flags,
    spring_model,
)
from isodesign.response.stability import StabilityFigures, stability_of_model
from isodesign.results import ResultDisplay

__all__ = [
    "BRANCHES",
    "SCAN_AMPLITUDE_RANGE_M",
    "SCAN_POINTS_PER_DECADE",
    "HarmonicResponse",
    "harmonic_response",
]

#: Which self-consistent harmonic stroke to return where several exist.
BRANCHES = ("upper", "lower")
#: Amplitude window (m) of the harmonic root scan; outside it the spring is taken as
#: amplitude-independent for counting roots (see :func:`harmonic_response`).
SCAN_AMPLITUDE_RANGE_M = (1e-9, 1e-1)
#: Scan points per decade of amplitude.
SCAN_POINTS_PER_DECADE = 8

# ---------------------------------------------------------------------------
# harmonic floor input
# ---------------------------------------------------------------------------
def _log_ratio(model: SpringModel, f, xf, x):
    """``h(x) = ln(|T(e^x) - 1| X_f) - x``, pairwise over (f, X_f, x)."""
    k = model.k(f, np.exp(x))
    rel = relative_transmissibility(Cx.from_complex(k), model.mass, TWO_PI * f)
    return np.log(rel.abs()) + np.log(xf) - x


def _harmonic_closure(model: SpringModel, f: np.ndarray, xf: np.ndarray, branch: str, rtol: float,
                      max_iter: int):  # fmt: skip
    """Solve ``X_s = |T(X_s) - 1| X_f`` on the grid f (n_f,) x X_f (n_a,)."""
    lo, hi = SCAN_AMPLITUDE_RANGE_M
    n_s = round(SCAN_POINTS_PER_DECADE * math.log10(hi / lo)) + 1
    lx = np.linspace(math.log(lo), math.log(hi), n_s)
    k_scan = model.k(f[:, None], np.exp(lx)[None, :])  # (n_f, n_s)
    rel = relative_transmissibility(Cx.from_complex(k_scan), model.mass, TWO_PI * f[:, None])
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


@dataclass(frozen=True, eq=False, repr=False)
class HarmonicResponse(ResultDisplay):
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

    def _summary_items(self) -> list[tuple[str, str]]:
        """Grid, peak |T| per floor amplitude and models (for repr and notebooks)."""
        f = self.frequency_hz
        peaks = ", ".join(
            f"{xf * 1e6:.3g} um: {20 * np.log10(p):+.1f} dB at {fp:.3g} Hz"
            for xf, p, fp in zip(self.floor_amplitude_m, self.peak_transmissibility,
                                 self.peak_frequency_hz, strict=True))
        s = self.stability
        return [
            ("frequencies", f"{f.size} ({f.min():.3g}-{f.max():.3g} Hz)"),
            ("floor amplitudes", str(self.floor_amplitude_m.size)),
            ("peak |T|", peaks),
            ("branch", self.branch),
            ("models", f"{s.flow} flow, {s.amplitude_mode}, {s.diaphragm} diaphragm"),
            ("validity flags", str(len(self.warnings))),
        ]

    def plot(self, ax=None, *, title=None, peak_limit_db=None):
        """|T| in dB and its phase, and the stroke, per floor amplitude.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw |T| (dB) only, into this axes. Default: a new figure with |T| (dB), the
            phase and the stroke; the linear regime on top, the 0 dB line, points with
            several strokes and points outside the model's validity marked.
        title : str, optional
        peak_limit_db : float, optional
            A peak-|T| limit line.

        Returns
        -------
        matplotlib.figure.Figure
            Made with an Agg canvas; the global Matplotlib backend is not touched.
        """
        if ax is None:
            return harmonic_figure(self, title=title, peak_limit_db=peak_limit_db)
        valid = np.asarray(self.spring.valid, bool).reshape(self.stroke_m.shape)
        curves = [(f"floor amplitude {xf * 1e6:.3g} um", self.frequency_hz,
                   self.transmissibility[:, j], candidate_style(j), valid[:, j])
                  for j, xf in enumerate(self.floor_amplitude_m)]
        for k, (label, f, t, style, v) in enumerate(curves):
            draw_transmissibility(ax, None, f, t, style=style, label=label, valid=v,
                                  flagged_label=k == 0)
        finish_transmissibility(ax, None, self.frequency_hz, peak_limit_db)
        if title:
            ax.set_title(title, fontsize=10)
        return ax.figure


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
        Spring models (:func:`isodesign.spring.stiffness.complex_stiffness`).
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
    model = spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    f = np.atleast_1d(check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True))
    xf = np.atleast_1d(
        check_positive("floor_amplitude_m", floor_amplitude_m, unit="m", allow_array=True)
    )
    check_domain("frequency_hz", f, FREQUENCY_DOMAIN_HZ, unit="Hz")
    check_domain("floor_amplitude_m", xf, AMPLITUDE_DOMAIN_M, unit="m")
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
        stability=stability_of_model(
            model, payload, linear_coarse=(f, t_lin) if f.size > 20 else None
        ),
        design=model.design,
        payload=payload,
    )
    emit_flags(res.warnings, "harmonic_response", warn)
    return res
