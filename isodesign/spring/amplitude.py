"""The self-consistent tube-velocity amplitude, solved on NumPy arrays.

Vectorized bracketing and Illinois iterations on the residual of
:func:`isodesign.spring.equations.amplitude_residual` (derivation in
``docs/spring-model.md``); the CasADi path uses a rootfinder on the same residual.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.numerics.cplx import Cx
from isodesign.spring.acoustics import acoustic_network
from isodesign.spring.equations import kinematic_velocity
from isodesign.spring.flow_models import resistance_function

__all__ = ["solve_velocity_amplitude"]


# ---------------------------------------------------------------------------
# NumPy solver
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _Solve:
    velocity: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    residual: np.ndarray
    resistance_re: np.ndarray
    resistance_im: np.ndarray

    @property
    def resistance(self) -> Cx:
        """The resistance C at the solution."""
        return Cx(self.resistance_re, self.resistance_im)


def solve_velocity_amplitude(
    flow: str, design, omega, amplitude_m, *, tol: float = 1e-12, max_iter: int = 60
) -> _Solve:
    """Solve the self-consistent tube velocity amplitude on NumPy arrays.

    Solves ``h(U) = U |D(U)| - N Q = 0`` (``D = 1 + N + j w s C(U)``, ``Q`` the
    kinematic velocity of Eq. 37), the same root as :func:`amplitude_residual`,
    without logarithms. ``h`` is increasing and every evaluation brackets the
    root: ``N Q / |D(U)|`` lies on the other side of it. Start: ``U_hi = N Q /
    |D(0)|``; then Newton steps on ``ln U`` (exact for power laws) with the
    analytic slope of the resistance, safeguarded by bisection inside the
    bracket, on the points not yet converged (``|h| <= tol N Q``, i.e. U to
    about ``tol`` relative).

    Parameters
    ----------
    flow : str
        A self-consistent flow model (NumPy).
    design : SpringDesign
        The spring (numbers).
    omega : ndarray
        Angular frequencies, rad/s (same shape as ``amplitude_m``).
    amplitude_m : ndarray
        Piston displacement amplitudes, m.
    tol : float
        Relative tolerance on U.
    max_iter : int
        Iteration limit.

    Returns
    -------
    _Solve
        ``velocity`` (m/s), ``iterations``, ``converged``, the final relative
        ``residual`` ``h / (N Q)`` and the ``resistance`` C at the solution.
    """
    omega, amp = np.broadcast_arrays(np.asarray(omega, float), np.asarray(amplitude_m, float))
    shape = omega.shape
    w_flat, x_flat = omega.ravel(), amp.ravel()
    # Blocks of cache-sized arrays: large temporaries are page-faulted afresh at
    # every allocation, which doubles the cost of each elementwise operation.
    parts = [
        _solve_block(flow, design, w_flat[i : i + _BLOCK], x_flat[i : i + _BLOCK], tol, max_iter)
        for i in range(0, w_flat.size, _BLOCK)
    ]
    if not parts:
        parts = [_solve_block(flow, design, w_flat, x_flat, tol, max_iter)]
    return _Solve(
        *(
            np.concatenate([getattr(p, k) for p in parts]).reshape(shape)
            for k in (
                "velocity",
                "iterations",
                "converged",
                "residual",
                "resistance_re",
                "resistance_im",
            )
        )
    )


_BLOCK = 16384


def _solve_block(flow, design, w_all, x_all, tol, max_iter) -> _Solve:
    """:func:`solve_velocity_amplitude` on one block of flat arrays."""
    nq_all = design.volume_ratio * kinematic_velocity(design, w_all, x_all)
    n1 = 1.0 + design.volume_ratio
    s = design.compliance_factor_kg_per_pa

    def evaluate(u, idx):
        """|D(U)| and d|D|/dU at the points idx."""
        w = w_all if idx is None else w_all[idx]
        c, dcr = resistance_function(flow, design, w, with_slope=True)(u)
        dr = n1 - w * s * c.im
        di = w * s * c.re
        mod = np.sqrt(dr * dr + di * di)
        return mod, di * w * s * dcr / mod

    if getattr(design, "acoustics", "lumped") == "distributed":
        net_all = acoustic_network(design, w_all, flow)
        x_over = nq_all / x_all  # N (A_p/A_c) w

        def evaluate(u, idx):  # the distributed model's effective |D|
            """``|D| = N Q / U_driven`` of the network and its slope in U (difference)."""
            w = w_all if idx is None else w_all[idx]
            net = net_all if idx is None else net_all.take(idx)
            xo = x_over if idx is None else x_over[idx]
            c, dcr = resistance_function(flow, design, w, with_slope=True)(u)
            mod = xo / np.sqrt(net.velocity_gain2(c))
            h = 1e-6 * np.abs(c.re) + 1e-300
            mod_h = xo / np.sqrt(net.velocity_gain2(Cx(c.re + h, c.im)))
            return mod, (mod_h - mod) / h * dcr

    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        mod0, _ = evaluate(np.zeros_like(w_all), None)
    hi = nq_all / mod0
    lo = np.zeros_like(hi)
    u = hi.copy()
    res = np.full(u.shape, np.inf)
    iters = np.ones(u.shape, dtype=int)
    done = np.zeros(u.shape, dtype=bool)
    active = np.arange(u.size)
    for _ in range(max_iter):
        if active.size == 0:
            break
        ua, nq = u[active], nq_all[active]
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            mod, dmod = evaluate(ua, active)
        h = ua * mod - nq
        r = h / nq
        iters[active] += 1
        res[active] = r
        conv = np.abs(r) <= tol
        # bracket update: the driven velocity N Q/|D(U)| lies across the root
        ud = nq / mod
        above = h > 0
        hi_a = np.where(
            above, np.minimum(ua, hi[active]), np.minimum(hi[active], np.maximum(ud, ua))
        )
        lo_a = np.where(
            above, np.maximum(lo[active], np.minimum(ud, ua)), np.maximum(ua, lo[active])
        )
        # Newton on h near the root (quadratic, no transcendental); far from it a
        # Newton step in ln U, exact for power laws h ~ U^p:
        # F = ln(U|D|/NQ), F' = 1 + U d|D|/dU / |D| >= 1
        step = ua - h / (mod + ua * dmod)
        far = np.flatnonzero(np.abs(r) > 0.02)
        if far.size:
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                step[far] = ua[far] * np.power(
                    nq[far] / (ua[far] * mod[far]),
                    1.0 / (1.0 + ua[far] * dmod[far] / mod[far]),
                )
        inside = (step > lo_a) & (step < hi_a)
        u_new = np.where(inside, step, 0.5 * (lo_a + hi_a))
        hi[active], lo[active] = hi_a, lo_a
        u[active] = np.where(conv, ua, u_new)
        done[active] = conv
        active = active[~conv]
    c = resistance_function(flow, design, w_all)(u)
    return _Solve(
        velocity=u,
        iterations=iters,
        converged=done,
        residual=res,
        resistance_re=np.broadcast_to(c.re, u.shape),
        resistance_im=np.broadcast_to(c.im, u.shape),
    )
