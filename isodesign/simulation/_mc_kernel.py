"""Compiled inner loop of the Monte Carlo verifier (numba, imported lazily).

One function, :func:`integrate`, integrates the nonlinear lumped equations of
:mod:`isodesign.simulation.monte_carlo` (payload on one spring, relative coordinates)
with the classical fourth-order Runge-Kutta method at a fixed step. It is the same
physics as :mod:`isodesign.simulation.harmonic_rig` (adiabatic open control volumes with
upwind enthalpy, tube momentum with Churchill friction and the minor loss), written with
scalars so that numba compiles it. Churchill's law is repeated here as a scalar function
(:func:`churchill_phi`); a test checks it against
:func:`isodesign.spring.capillary.churchill_friction_re_product` to rounding error.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["churchill_phi", "integrate", "spring_rhs"]

_LN7 = math.log(7.0)
_EIGHT12 = 8.0**12


@numba.njit(cache=True, fastmath=False)
def churchill_phi(re, rel_rough):
    """``f Re`` of Churchill (1977), the formula of ``capillary._churchill`` (scalar)."""
    if re <= 1000.0:
        return 64.0
    lr = math.log(re)
    if rel_rough == 0.0:
        a = 2.457 * 0.9 * (lr - _LN7)
    else:
        v = math.exp(0.9 * (_LN7 - lr))
        a = -2.457 * math.log(v + 0.27 * rel_rough)
    a2 = a * a
    a4 = a2 * a2
    a8 = a4 * a4
    big_a = a8 * a8
    b = 37530.0 / re
    b2 = b * b
    b4 = b2 * b2
    b8 = b4 * b4
    big_b = b8 * b8
    s = big_a + big_b
    r2 = re * re
    r4 = r2 * r2
    r12 = r4 * r4 * r4
    term = r12 / (s * math.sqrt(s))
    return 8.0 * (_EIGHT12 + term) ** (1.0 / 12.0)


# parameter vector layout (see monte_carlo._parameters)
_P0, _VT0, _VB0, _AP, _AC, _MT0, _MB0, _RGAS, _IDX, _ADIAB = range(10)
_MU, _DC, _RELR, _FSCALE, _INERT, _KMIN, _CU, _MASS, _KINF, _RHO0 = range(10, 20)
_WREM = 20
# the tube ends' entrained mass rho0 L_end (Womersley flow) and the integrated modes' gain sum
_LEND, _GSUM = 21, 22
N_PARAMS = 23


@numba.njit(cache=True, fastmath=False)
def spring_rhs(y, i0, out, z, zd, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k,
               br_rate):
    """One spring's internal derivatives; returns ``(force, u)``.

    ``y[i0:]`` holds ``dp_t, dp_b, dm_t, [u | u_1..u_M], q_1..q_B`` (their derivatives go to
    ``out[i0:]``); ``z``, ``zd`` are the stroke and its rate. ``force = A_p dp_t - F_D`` is the
    spring's force on the payload (deviation from the static load); ``u`` the tube velocity.
    Shared by the 1-DOF kernel (:func:`integrate`) and the rigid-table kernel
    (``isodesign.simulation._table_kernel``).
    """
    dpt = y[i0]
    dpb = y[i0 + 1]
    dmt = y[i0 + 2]
    p0 = p[_P0]
    vt = p[_VT0] + p[_AP] * z
    dvt = p[_AP] * zd
    mt = p[_MT0] + dmt
    mb = p[_MB0] - dmt
    vb = p[_VB0]
    pt = p0 + dpt
    pb = p0 + dpb
    rho_t = mt / vt
    rho_b = mb / vb
    dp = dpt - dpb
    i_dia = i0 + 3
    if flow == 0:  # quasi-steady plug flow with inertance
        u = y[i0 + 3]
        rho_up = rho_t if u >= 0.0 else rho_b
        re = rho_up * abs(u) * p[_DC] / p[_MU]
        phi = churchill_phi(re, p[_RELR])
        drop = p[_FSCALE] * phi * u + 0.5 * p[_KMIN] * rho_up * abs(u) * u
        rho_tube = 0.5 * (rho_t + rho_b)
        out[i0 + 3] = (dp - drop) / (rho_tube * p[_INERT])
        i_dia = i0 + 4
    elif flow == 1:  # Poiseuille, algebraic (Eq. 41)
        mdot0 = dp / p[_CU]
        rho_up = rho_t if mdot0 >= 0.0 else rho_b
        u = mdot0 / (rho_up * p[_AC])
    else:  # Womersley: laminar modes of the oscillating tube flow, plus the minor loss
        s_modes = 0.0
        for j in range(n_modes):
            s_modes += y[i0 + 3 + j]
        # u = s_modes + w_rem (dp - kappa |u| u): the fast modes held quasi-static
        kap = 0.5 * p[_KMIN] * p[_RHO0]
        wv = s_modes + p[_WREM] * dp
        bk = p[_WREM] * kap
        if bk > 0.0:
            u = 2.0 * wv / (1.0 + math.sqrt(1.0 + 4.0 * bk * abs(wv)))
        else:
            u = wv
        # pressure gradient / rho0 (m/s^2); the ends' mass rho0 L_end du/dt takes its share of
        # dp, with du/dt = G g - sum(rate_j y_j) (G the integrated modes' gain): solved for g
        relax = 0.0
        for j in range(n_modes):
            relax += mode_rate[j] * y[i0 + 3 + j]
        g = ((dp - kap * abs(u) * u + p[_LEND] * relax)
             / (p[_INERT] + p[_LEND] * p[_GSUM]))
        for j in range(n_modes):
            out[i0 + 3 + j] = mode_gain[j] * g - mode_rate[j] * y[i0 + 3 + j]
        i_dia = i0 + 3 + n_modes
        rho_up = rho_t if u >= 0.0 else rho_b
    mdot = rho_up * p[_AC] * u
    if p[_ADIAB] > 0.0:
        kappa = p[_IDX]
        if u >= 0.0:
            t_flow = pt * vt / (mt * p[_RGAS])
        else:
            t_flow = pb * vb / (mb * p[_RGAS])
        flux = kappa * p[_RGAS] * t_flow * mdot
        dpt_dt = (-flux - kappa * pt * dvt) / vt
        dpb_dt = flux / vb
    else:
        n_idx = p[_IDX]
        dpt_dt = n_idx * pt * (-mdot / mt - dvt / vt)
        dpb_dt = n_idx * pb * (mdot / mb)
    f_dia = p[_KINF] * z
    for j in range(n_branch):
        q = y[i_dia + j]
        f_dia += q
        out[i_dia + j] = br_k[j] * zd - br_rate[j] * q
    out[i0] = dpt_dt
    out[i0 + 1] = dpb_dt
    out[i0 + 2] = -mdot
    return p[_AP] * dpt - f_dia, u


@numba.njit(cache=True, fastmath=False)
def _rhs(y, out, a_floor, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate):
    """``dy/dt``; states: z, z', dp_t, dp_b, dm_t, [u | u_1..u_M], q_1..q_B."""
    force, u = spring_rhs(y, 2, out, y[0], y[1], p, flow, n_modes, mode_gain, mode_rate,
                          n_branch, br_k, br_rate)  # fmt: skip
    out[0] = y[1]
    out[1] = force / p[_MASS] - a_floor
    return u


@numba.njit(cache=True, fastmath=False)
def integrate(y0, a_half, dt, n_skip, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k,
              br_rate, rec_zd, rec_z, rec_u):
    """RK4 over ``len(a_half) // 2`` steps; records z', z and u after ``n_skip`` steps.

    ``a_half[2 i]`` is the floor acceleration at step ``i``, ``a_half[2 i + 1]`` at its
    midpoint. Returns the final state.
    """
    n = y0.size
    y = y0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    yt = np.empty(n)
    n_steps = (a_half.size - 1) // 2
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for i in range(n_steps):
        a0 = a_half[2 * i]
        am = a_half[2 * i + 1]
        a1 = a_half[2 * i + 2]
        _rhs(y, k1, a0, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate)
        for j in range(n):
            yt[j] = y[j] + h2 * k1[j]
        _rhs(yt, k2, am, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate)
        for j in range(n):
            yt[j] = y[j] + h2 * k2[j]
        _rhs(yt, k3, am, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate)
        for j in range(n):
            yt[j] = y[j] + dt * k3[j]
        _rhs(yt, k4, a1, p, flow, n_modes, mode_gain, mode_rate, n_branch, br_k, br_rate)
        for j in range(n):
            y[j] += h6 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
        r = i + 1 - n_skip
        if r >= 0 and r < rec_zd.size:
            rec_zd[r] = y[1]
            rec_z[r] = y[0]
            if flow == 0:
                rec_u[r] = y[5]
            else:
                rec_u[r] = _rhs(y, k1, a1, p, flow, n_modes, mode_gain, mode_rate, n_branch,
                                br_k, br_rate)
    return y
