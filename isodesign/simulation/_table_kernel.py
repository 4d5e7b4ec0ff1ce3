"""Compiled inner loop of the rigid-table Monte Carlo verifier (numba, imported lazily).

:func:`integrate_table` integrates a rigid body in six degrees of freedom on ``n``
isolators with the classical fourth-order Runge-Kutta method at a fixed step. Each
isolator's vertical spring is the nonlinear lumped model of the 1-DOF verifier, evaluated by
the same compiled function (:func:`isodesign.simulation._mc_kernel.spring_rhs`); its
horizontal element is a linear generalized Maxwell (Prony) series per horizontal axis.
Equations and conventions: ``isodesign.simulation.table_monte_carlo`` and
``docs/table-monte-carlo.md``.

State vector: ``q`` (6: x, y, z of the CG relative to the floor, rotations rx, ry, rz), ``q'``
(6), then per isolator ``i`` its spring's states at ``off[i]`` (``dp_t, dp_b, dm_t, [u |
u_1..u_M], q_1..q_B``) and its horizontal branch forces at ``hoff[i]`` (``B_h`` for x, then
``B_h`` for y).
"""

from __future__ import annotations

import numba
import numpy as np

from isodesign.simulation._mc_kernel import spring_rhs

__all__ = ["integrate_table"]


@numba.njit(cache=True, fastmath=False)
def _table_rhs(y, out, ax, ay, az, minv, kg, P, flow, n_modes, mode_gain, mode_rate, n_branch,
               br_k, br_rate, rv, rh, kh0, n_hb, hk, hrate, off, hoff, u_out, gen):
    """``dy/dt`` of the table; the tube velocities go to ``u_out`` (``gen``: scratch, 6)."""
    q = y[0:6]
    qd = y[6:12]
    for r in range(6):
        gen[r] = 0.0
    for i in range(P.shape[0]):
        # vertical force at the vertical-force point r_v (relative to the CG)
        xv = rv[i, 0]
        yv = rv[i, 1]
        z = q[2] + q[3] * yv - q[4] * xv
        zd = qd[2] + qd[3] * yv - qd[4] * xv
        fz, u = spring_rhs(y, off[i], out, z, zd, P[i], flow, n_modes[i], mode_gain[i],
                           mode_rate[i], n_branch[i], br_k[i], br_rate[i])  # fmt: skip
        u_out[i] = u
        gen[2] += fz
        gen[3] += yv * fz
        gen[4] -= xv * fz
        # horizontal force at the elastic centre r_h
        xh = rh[i, 0]
        yh = rh[i, 1]
        zh = rh[i, 2]
        sx = q[0] + q[4] * zh - q[5] * yh
        sy = q[1] + q[5] * xh - q[3] * zh
        sxd = qd[0] + qd[4] * zh - qd[5] * yh
        syd = qd[1] + qd[5] * xh - qd[3] * zh
        fx = -kh0[i] * sx
        fy = -kh0[i] * sy
        nb = n_hb[i]
        h0 = hoff[i]
        for j in range(nb):
            bx = y[h0 + j]
            by = y[h0 + nb + j]
            fx -= bx
            fy -= by
            out[h0 + j] = hk[i, j] * sxd - hrate[i, j] * bx
            out[h0 + nb + j] = hk[i, j] * syd - hrate[i, j] * by
        gen[0] += fx
        gen[1] += fy
        gen[3] -= zh * fy
        gen[4] += zh * fx
        gen[5] += xh * fy - yh * fx
    for r in range(6):
        acc = 0.0
        for c in range(6):
            acc -= kg[r, c] * q[c]
        gen[r] += acc
    for r in range(6):
        acc = 0.0
        for c in range(6):
            acc += minv[r, c] * gen[c]
        out[r] = qd[r]
        out[6 + r] = acc
    out[6] -= ax
    out[7] -= ay
    out[8] -= az


@numba.njit(cache=True, fastmath=False)
def integrate_table(y0, a_half, dt, n_skip, minv, kg, P, flow, n_modes, mode_gain, mode_rate,
                    n_branch, br_k, br_rate, rv, rh, kh0, n_hb, hk, hrate, off, hoff, rec_q,
                    rec_qd, rec_u):
    """RK4 over ``(a_half.shape[1] - 1) // 2`` steps; records after ``n_skip`` steps.

    ``a_half[axis, 2 i]`` is the floor acceleration (x, y, z) at step ``i``,
    ``a_half[axis, 2 i + 1]`` at its midpoint. Records ``q``, ``q'`` (relative to the floor)
    and each isolator's tube velocity. Returns the final state.
    """
    n = y0.size
    n_iso = P.shape[0]
    y = y0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    yt = np.empty(n)
    u_out = np.empty(n_iso)
    gen = np.empty(6)
    n_steps = (a_half.shape[1] - 1) // 2
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for i in range(n_steps):
        i0 = 2 * i
        _table_rhs(y, k1, a_half[0, i0], a_half[1, i0], a_half[2, i0], minv, kg, P, flow,
                   n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate, rv, rh, kh0, n_hb,
                   hk, hrate, off, hoff, u_out, gen)  # fmt: skip
        for j in range(n):
            yt[j] = y[j] + h2 * k1[j]
        _table_rhs(yt, k2, a_half[0, i0 + 1], a_half[1, i0 + 1], a_half[2, i0 + 1], minv, kg,
                   P, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate, rv, rh, kh0,
                   n_hb, hk, hrate, off, hoff, u_out, gen)  # fmt: skip
        for j in range(n):
            yt[j] = y[j] + h2 * k2[j]
        _table_rhs(yt, k3, a_half[0, i0 + 1], a_half[1, i0 + 1], a_half[2, i0 + 1], minv, kg,
                   P, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate, rv, rh, kh0,
                   n_hb, hk, hrate, off, hoff, u_out, gen)  # fmt: skip
        for j in range(n):
            yt[j] = y[j] + dt * k3[j]
        _table_rhs(yt, k4, a_half[0, i0 + 2], a_half[1, i0 + 2], a_half[2, i0 + 2], minv, kg,
                   P, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate, rv, rh, kh0,
                   n_hb, hk, hrate, off, hoff, u_out, gen)  # fmt: skip
        for j in range(n):
            y[j] += h6 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
        r = i + 1 - n_skip
        if r >= 0 and r < rec_q.shape[0]:
            for j in range(6):
                rec_q[r, j] = y[j]
                rec_qd[r, j] = y[6 + j]
            if flow == 0:
                for m in range(n_iso):
                    rec_u[r, m] = y[off[m] + 3]
            else:
                _table_rhs(y, k1, a_half[0, i0 + 2], a_half[1, i0 + 2], a_half[2, i0 + 2], minv,
                           kg, P, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate,
                           rv, rh, kh0, n_hb, hk, hrate, off, hoff, u_out, gen)  # fmt: skip
                for m in range(n_iso):
                    rec_u[r, m] = u_out[m]
    return y
