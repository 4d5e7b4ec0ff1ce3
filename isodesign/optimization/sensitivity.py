"""Parametric sensitivities of a design to the uncertain parameters, from the NLP.

At a drawn design ``z`` and a scenario ``theta`` the NLP block
(:class:`.robust.ScenarioBlock`) defines the implicit unknowns ``u`` (RMS stroke,
tube-velocity RMS, partial sums) by its equality rows ``R(z, u, theta) = 0``. With the
design held (a built table does not re-optimize itself), the implicit function theorem
gives ``du/dtheta = -(dR/du)^-1 dR/dtheta``, and every constraint row and the objective
follow exactly:

    dg/dtheta = dg/dtheta|_u + dg/du du/dtheta

(CasADi's exact Jacobians of the block, no finite differences). An objective written as
an epigraph (``worst_band_margin``: ``ms_b / lim_b^2 <= 10^(-t/10)``) moves with its
active row ``b``: ``dt/dtheta = -(de_b/dtheta) / (de_b/dt)``.

The *re-optimized* sensitivity of the robust optimum's worst case to a scenario's
parameters is the NLP's own ``lam_p`` (the derivative of the optimal value with respect
to the parameters, the envelope theorem: ``dL/dp`` at the solution); see
:func:`reoptimized_sensitivities`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.optimization.constraint_registry import natural_value
from isodesign.optimization.constraints import ACTIVE_MARGIN
from isodesign.optimization.objectives import OBJECTIVES

__all__ = ["Sensitivity", "design_sensitivities", "reoptimized_sensitivities"]

_DB = 10.0 / math.log(10.0)
#: Constraints whose NLP value is ln |T|^2 (reported in dB); the others are logs.
_DB_ROWS = ("peak_transmissibility",)


@dataclass(frozen=True)
class Sensitivity:
    """d(quantity)/d(parameter) at one design and scenario.

    ``quantity`` is ``"objective"`` or a constraint's name, ``unit`` its unit (dB for
    the objective in dB and the peak of |T|, else the quantity's own unit), ``per_unit``
    the derivative per unit of the parameter (``parameter_unit``: kg, Pa, K, m, or ``%``
    for a relative deviation), ``effect`` the change over
    the parameter's half-width (``per_unit * half_width``), ``binding`` whether the
    constraint is binding at the design in that scenario.
    """

    quantity: str
    parameter: str
    per_unit: float
    unit: str
    parameter_unit: str
    effect: float
    binding: bool

    def row(self) -> dict:
        """Flat dict for a table."""
        return dict(self.__dict__)


def _functions(block):
    """CasADi Jacobians of a block's rows and objectives (built once per block)."""
    if getattr(block, "_sens_fn", None) is None:
        import casadi as ca

        s = block._sym
        x, p = s["x"], s["p"]
        block._sens_fn = ca.Function(
            "sensitivities", [x, p],
            [s["g"], s["js"], ca.jacobian(s["g"], x), ca.jacobian(s["g"], p),
             ca.jacobian(s["js"], x), ca.jacobian(s["js"], p)])
    return block._sens_fn


def design_sensitivities(block, x: np.ndarray, theta, slot_hz=None) -> list[Sensitivity]:
    """Sensitivities of the objective and of every constraint at a design, design held.

    Parameters
    ----------
    block : ScenarioBlock
        The study's NLP block.
    x : ndarray
        The block's variables at the point (``[z, s, y, partial sums, epigraphs]``,
        consistent: e.g. :meth:`~.problem.Problem.initial_guess` or a robust solution's
        ``block_x``).
    theta : array
        The scenario.
    slot_hz : array, optional
        The block's movable peak frequencies at the point.

    Returns
    -------
    list of Sensitivity
        The objective and each constraint (its worst row) against each parameter.
    """
    space = block.space
    theta = np.asarray(theta, float)
    p = block.block_params(theta, slot_hz)
    g, js, gx, gp, jx, jp = (np.asarray(v) for v in _functions(block)(x, p))
    g = g.ravel()
    nz, ny, nc, naux = block.nz, block.ny, block.nc, block.naux
    n_eq = block.n_eq
    u = slice(nz, nz + 1 + ny + nc)
    aux = slice(block.nx - naux, block.nx)
    th = slice(block.np - space.size, block.np)
    gp_th, jp_th = gp[:, th], jp[0, th]
    if getattr(block, "distortion", False):  # the distortion's terms move with theta too
        cols, dq = block.terms_theta_jacobian(x[:nz], theta)
        gp_th, jp_th = gp_th + gp[:, cols] @ dq, jp_th + jp[0, cols] @ dq
    a = gx[:n_eq, u]
    b = gp_th[:n_eq]
    du = -np.linalg.solve(a, b)  # d u / d theta
    total_g = gp_th + gx[:, u] @ du  # every row, aux held
    out: list[Sensitivity] = []
    # a relative deviation is reported per percent
    pct = np.array([0.01 if pr.mode == "relative" else 1.0 for pr in space.parameters])
    half = np.array([pr.half_width for pr in space.parameters]) / pct
    units = ["%" if pr.mode == "relative" else pr.unit for pr in space.parameters]
    # the objective
    kind = block.objective
    obj = OBJECTIVES[kind]
    dj = jp_th + jx[0, u] @ du
    if naux:
        ep = [(c, row, n) for c, row, n in block.con_rows if c.name.startswith("epigraph_")]
        c, row, n = ep[0]
        i = row + int(np.argmax(g[row: row + n]))
        dt = -(total_g[i]) / gx[i, aux][0]
        dj = dj + jx[0, aux][0] * dt
    sign = obj.to_natural(1.0) - obj.to_natural(0.0) if obj.db else None
    jval = float(np.asarray(js).ravel()[0])
    dnat = (dj * sign if obj.db else dj * obj.to_natural(jval)) * pct
    for k, name in enumerate(space.names):
        out.append(Sensitivity("objective", name, float(dnat[k]), obj.unit, units[k],
                               float(dnat[k] * half[k]), True))
    # the constraints: worst row of each
    for c, row, n in block.con_rows:
        if c.name.startswith(("epigraph_", "bound_")):
            continue
        gi = g[row: row + n]
        marg = np.minimum(gi - c.lo, c.hi - gi)
        i = row + int(np.argmin(marg))
        val = g[i]
        nat, unit = natural_value(c.name, float(val))
        d = total_g[i]
        d_nat = (_DB * d if c.name in _DB_ROWS else nat * d) * pct
        binding = float(np.min(marg)) < ACTIVE_MARGIN
        for k, name in enumerate(space.names):
            out.append(Sensitivity(c.name, name, float(d_nat[k]), unit, units[k],
                                   float(d_nat[k] * half[k]), binding))
    return out


def reoptimized_sensitivities(prob, sol) -> dict:
    """d(worst-case objective)/d(theta_k) of the robust optimum, per scenario (``lam_p``).

    Parameters
    ----------
    prob : RobustProblem
    sol : RobustSolution

    Returns
    -------
    dict
        Scenario index -> {parameter: derivative of the worst-case objective (natural
        units, e.g. dB) per unit of the parameter's coordinate}, for every scenario
        whose derivative is not zero (the active ones).
    """
    obj = OBJECTIVES[prob.block.objective]
    out = {}
    for k in range(prob.K):
        lam = -sol.lam_p[prob.theta_slice(k)]  # d f* / d theta (CasADi's sign convention)
        if getattr(prob.block, "distortion", False):  # through the scenario's terms too
            b = prob.block
            b.select(prob.thetas[k], prob.slots[k])
            cols, dq = b.terms_theta_jacobian(sol.x[:b.nz], prob.thetas[k])
            lam = lam - sol.lam_p[k * b.np + cols] @ dq
        d = lam * (obj.to_natural(1.0) - obj.to_natural(0.0)) if obj.db else \
            lam * obj.to_natural(sol.objective)
        if np.any(np.abs(d) > 1e-9):
            out[k] = dict(zip(prob.block.space.names, map(float, d), strict=True))
    return out
