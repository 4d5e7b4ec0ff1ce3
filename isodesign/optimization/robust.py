"""Robust design: several scenarios stacked in one CasADi NLP that shares the design.

One scenario's NLP block (:class:`ScenarioBlock`) is the study's NLP
(:class:`~.problem.Problem`, same physics, same constraints) with the uncertain
parameters as CasADi *parameters* ``theta`` (:mod:`.uncertainty`): the payload mass,
the ambient pressure, the temperature, the manufacturing deviations of the built
spring. It is built once, as one SX Function; :class:`RobustProblem` stacks K copies
that share the scaled design ``z``, each with its own implicit unknowns (RMS stroke,
tube-velocity RMS, partial sums, epigraph variables), and minimizes the worst case::

    minimize    w t + w_D ln D_c
    subject to  J_k(z, x_k; theta_k) <= t           (every scenario k)
                physics_k = 0, constraints_k        (every scenario k)
                t <= eps

The scenario values and each block's movable peak frequencies are parameters, so one
compiled NLP serves changing scenario values; adding a scenario rebuilds it.
:func:`.exchange.robust_optimize` runs the exchange method on it.
"""

from __future__ import annotations

import math
import time

import numpy as np

from isodesign.numerics.cplx import Cx
from isodesign.optimization.distortion_rows import ScenarioDistortionMixin
from isodesign.optimization.hessian import hessian_choice
from isodesign.optimization.metrics import combine, design_quantities, point_quantities
from isodesign.optimization.nlp import (
    NO_BOUND,
    ipopt_options,
    objective_params,
    stacked_bounds,
)
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.problem import _COMPOSED, Problem, hoisted_map
from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
from isodesign.optimization.uncertainty import ScenarioStudy
from isodesign.optimization.variables import DESIGN_VARIABLES
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR
from isodesign.spring.capillary import gaussian_equivalent_resistance
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import amplitude_residual, kinematic_velocity

__all__ = ["RobustBuilds", "RobustProblem", "RobustSolution", "ScenarioBlock", "add_scenarios",
           "best_solve",
           "block_function", "global_params", "scenario_structure_key", "stack_scenarios"]


def stack_scenarios(groups, nz: int, scaling) -> tuple[dict, object]:
    """The robust NLP of scenario blocks sharing the scaled design: one construction for
    every body.

    Each block is a CasADi Function ``block(z, w, p) -> (g, J)`` (the shared scaled design,
    the block's own unknowns, its parameters; its constraint rows and its objectives). The
    vertical body's one :class:`ScenarioBlock` with the scenario as parameters is mapped over
    its K scenarios (one group); the table's scenario NLPs, each compiled for its scenario
    (:func:`block_function`), are one group each. The stacked NLP has the layout of
    :func:`.nlp.stacked_bounds`::

        x = [z, w_1 .. w_K, t]          p = [p_1 .. p_K, w_t, w_D, eps]
        g = [g_1 .. g_K, J_k - t (K rows), t - eps]
        minimize  w_t t + w_D ln D_c

    (``J_k`` the first objective of block ``k``; ``w_t``, ``w_D``, ``eps``:
    :func:`global_params`).

    Parameters
    ----------
    groups : sequence of (casadi.Function, int)
        Each block Function and how many consecutive scenarios it answers (mapped).
    nz : int
        The shared design's size.
    scaling : LogScaling
        The spring's scaling (``ln D_c`` of the tie-break, when ``D_c`` is free).

    Returns
    -------
    nlp : dict
        ``x``, ``f``, ``g``, ``p`` for ``casadi.nlpsol``.
    j_fn : casadi.Function
        ``(x, p) -> J_k`` of every scenario.
    """
    import casadi as ca

    z = ca.MX.sym("z", nz)
    t = ca.MX.sym("t")
    pg = ca.MX.sym("global", 3)  # weight of t, weight of ln D_c, epsilon bound on t
    ws, ps, gs, js = [], [], [], []
    for fn, count in groups:
        w = ca.MX.sym("w", fn.size1_in(1), count)
        p = ca.MX.sym("p", fn.size1_in(2), count)
        g_all, j_all = fn.map(count)(z, w, p)
        ws.append(ca.vec(w))
        ps.append(ca.vec(p))
        gs.append(ca.vec(g_all))
        js.append(j_all[0, :].T)
    j_vec = ca.vertcat(*js)
    ln_d = 0
    if "capillary_diameter_m" in scaling.names:
        i = scaling.names.index("capillary_diameter_m")
        ln_d = scaling.center[i] + scaling.half[i] * z[i]
    x = ca.vertcat(z, *ws, t)
    p = ca.vertcat(*ps, pg)
    nlp = {"x": x, "f": pg[0] * t + pg[1] * ln_d,
           "g": ca.vertcat(*gs, j_vec - t, t - pg[2]), "p": p}
    return nlp, ca.Function("scenario_objectives", [x, p], [j_vec])


def global_params(weight: float = 1.0, diameter_weight: float = 0.0,
                  eps: float | None = None) -> list:
    """The stacked NLP's last parameters: the weights of ``t`` and ``ln D_c``, the epsilon
    bound on ``t`` (None: :data:`.nlp.NO_BOUND`).

    Parameters
    ----------
    weight, diameter_weight : float
    eps : float, optional
    """
    return [weight, diameter_weight, NO_BOUND if eps is None else eps]


def block_function(nlp, nz: int):
    """A scenario NLP (its ``eval_fn(x, p) -> (J, g)``, ``nx`` variables) as the block
    Function ``block(z, w, p) -> (g, J)`` of :func:`stack_scenarios`.

    Parameters
    ----------
    nlp : NLP
        A built NLP of one scenario (the table's :class:`.table_problem.TableProblem`).
    nz : int
        Its first ``nz`` variables are the shared design.
    """
    import casadi as ca

    z = ca.MX.sym("z", nz)
    w = ca.MX.sym("w", nlp.nx - nz)
    p = ca.MX.sym("p", int(np.asarray(nlp.params()).size))
    j, g = nlp.eval_fn(ca.vertcat(z, w), p)
    return ca.Function("block", [z, w, p], [g, j])


def best_solve(prob, starts: list, study):
    """Solve a stacked NLP from each distinct start (in forked workers); the best.

    A new scenario can push IPOPT from the last design onto a worse branch (a restoration
    phase far from it): the exchange of either body tries the last design, the nominal
    optimum and the best robust design so far, and keeps the feasible solution with the best
    worst case (the first on a tie, the last design being first), else the least violating.

    Parameters
    ----------
    prob : RobustProblem or TableStack
        With ``initial_guess(values)`` and ``solve(x0) -> RobustSolution``.
    starts : list of dict
        Designs (SI values by name), the last design first.
    study : Study
        Its ``solver.workers``.

    Returns
    -------
    RobustSolution
    """
    from isodesign.errors import SolverError
    from isodesign.optimization.multistart import map_in_workers

    distinct = []
    for v in starts:
        if not any(all(abs(v[k] / w[k] - 1.0) < 1e-9 for k in v) for w in distinct):
            distinct.append(dict(v))

    def one(v):
        try:
            return prob.solve(prob.initial_guess(v))
        except Exception as exc:
            return str(exc)

    sols = [s for s in map_in_workers(one, distinct, workers=study.solver.get("workers"))
            if not isinstance(s, str)]
    if not sols:
        raise SolverError("robust NLP: no start could be initialized")
    feas = [s for s in sols if s.feasible]
    if feas:
        return min(feas, key=lambda s: s.objective)
    return min(sols, key=lambda s: s.max_violation)


def add_scenarios(thetas: list, seeds) -> int:
    """Append the scenarios of ``seeds`` not already in ``thetas`` (in place).

    Parameters
    ----------
    thetas : list of ndarray
        An exchange's scenario set, changed in place.
    seeds : iterable of array_like
        Scenarios to add (a sweep point's neighbours' active scenarios).

    Returns
    -------
    int
        How many were added (the last ones of ``thetas``).
    """
    n = 0
    for th in seeds:
        th = np.asarray(th, float)
        if not any(np.allclose(th, t, rtol=1e-9, atol=1e-12) for t in thetas):
            thetas.append(th)
            n += 1
    return n


class ScenarioBlock(Problem):
    """The study's NLP with the uncertain parameters ``theta`` as CasADi parameters.

    Built like :class:`~.problem.Problem` (same steps, same physics through
    :class:`~.uncertainty.ScenarioStudy`), but ends in one SX Function
    ``block(z, w, p) -> (g, J)`` (``w``: the block's own unknowns, ``p``: the
    problem's parameters followed by ``theta``) instead of an IPOPT solver. The
    NumPy-side helpers (initial guess, closure, epigraph guesses) work on the scenario
    selected with :meth:`select`.

    Parameters
    ----------
    study : Study
        The nominal study, with ``scenarios`` (its :class:`~.uncertainty.UncertaintySpace`).
    """

    def __init__(self, study):
        self.space = study.scenarios
        self.nominal_study = study
        self.theta = self.space.nominal()
        super().__init__(ScenarioStudy(study, self.space, self.theta))
        self.base_slot_hz = self.slot_hz.copy()  # the study's peak grid (no refinement)

    # -- selecting a scenario (NumPy side) -------------------------------------------
    def select(self, theta, slot_hz=None) -> None:
        """Make the NumPy helpers work on scenario ``theta`` (and its peak slots)."""
        self.theta = np.asarray(theta, float)
        self.study = ScenarioStudy(self.nominal_study, self.space, self.theta)
        self.dia = diaphragm_model(self.study.models["diaphragm"])
        if slot_hz is not None and not np.array_equal(slot_hz, self.slot_hz):
            self.set_slots(slot_hz)

    def _reference_sigma(self):
        return self.closure(self.study.start_design())

    # -- construction: theta enters the point function and the design ----------------
    def _sym_study(self, theta):
        return ScenarioStudy(self.nominal_study, self.space,
                             [theta[i] for i in range(self.space.size)])

    def _decision_variables(self, nlp) -> None:
        super()._decision_variables(nlp)
        nlp.p_theta = nlp.X.sym("theta", self.space.size)

    def _point_function(self, ca):
        """:meth:`Problem._point_function` with ``theta`` as a further input."""
        th = ca.SX.sym("theta", self.space.size)
        study = self._sym_study(th)
        dia = diaphragm_model(study.models["diaphragm"])
        dv = ca.SX.sym("design", len(DESIGN_VARIABLES))
        d_sx = study.design_at({n: dv[i] for i, n in enumerate(DESIGN_VARIABLES)})
        s_sx, y_sx, w_sx = ca.SX.sym("s"), ca.SX.sym("y"), ca.SX.sym("w")
        cnl_sx = ca.SX.sym("c_nl")
        sig_sx = ca.exp(s_sx)
        a_sx = EQUIVALENT_AMPLITUDE_FACTOR * sig_sx
        ins = [dv, s_sx, y_sx, cnl_sx, w_sx, th]
        if self.statistical:
            pq = point_quantities(study, d_sx, w_sx, math.sqrt(2.0) * ca.exp(y_sx), sig_sx, dia,
                                  cnl_sx)
            return ca.Function("point", ins, [ca.SX(0), pq["T"].re, pq["T"].im, pq["R"].re,
                                              pq["R"].im, pq["ln_mach"], pq["ln_re"], pq["G2"]])
        if self.self_consistent:
            u_sx = ca.exp(y_sx)
            res_sx = amplitude_residual(study.models["flow"], d_sx, w_sx, a_sx, y_sx)
        else:
            u_sx = kinematic_velocity(d_sx, w_sx, a_sx)
            res_sx = ca.SX(0)
        pq = point_quantities(study, d_sx, w_sx, u_sx, sig_sx, dia)
        return ca.Function("point", ins, [res_sx, pq["T"].re, pq["T"].im, pq["R"].re,
                                          pq["R"].im, pq["ln_mach"], pq["ln_re"], ca.SX(0)])

    def _physics(self, nlp, point) -> None:
        """:meth:`Problem._physics` with the scenario's study (theta symbolic)."""
        ca, X = nlp.ca, nlp.X
        study = self._sym_study(nlp.p_theta)
        dia = diaphragm_model(study.models["diaphragm"])
        w = self.grid.omega
        mapped = hoisted_map(point, nlp.n_all,
                             (0, 1, 3, 5, 2) if self.statistical else (0, 1, 3, 5))
        v = ca.vertcat(*nlp.vals)
        nlp.d = study.design_at({n: nlp.vals[i] for i, n in enumerate(DESIGN_VARIABLES)})
        if self.self_consistent:
            y_row = nlp.y.T
        elif self.statistical:
            y_row = nlp.y
        else:
            y_row = X.zeros(1, nlp.n_all)
        c_nl = (gaussian_equivalent_resistance(study.models["flow"], nlp.d, ca.exp(nlp.y[0]))
                if self.statistical else X(0))  # fmt: skip
        c_nl = self._closure_resistance(nlp, c_nl)  # models.distortion's gain
        sl = self.grid.slot_slice
        w_sym = ca.vertcat(ca.DM(w[: sl.start]), nlp.p_slot, ca.DM(w[sl.stop:]))
        outs = mapped(v, nlp.s, y_row, c_nl, w_sym.T, nlp.p_theta)
        res_u, t_re, t_im, r_re, r_im, ln_mach, ln_re, g2 = (o.T for o in outs)
        nlp.pq = {"T": Cx(t_re, t_im), "R": Cx(r_re, r_im), "ln_mach": ln_mach, "ln_re": ln_re}
        if self.statistical:
            nlp.pq["G2"] = g2
        nlp.mt = combine(study, self.grid, nlp.pq, design_quantities(study, self.grid, nlp.d, dia))
        self._adjust_metrics(nlp)  # models.distortion's band powers
        nlp.res_u = res_u if self.self_consistent else X(0, 1)

    def _assemble(self, nlp) -> None:
        super()._assemble(nlp)
        nlp.p = nlp.ca.vertcat(nlp.p, nlp.p_theta)
        self.np = int(nlp.p.numel())

    def _build_solver(self, nlp) -> None:
        """The block Function and the NumPy-side helpers (no IPOPT solver)."""
        ca = nlp.ca
        mt = nlp.mt
        th = nlp.p_theta
        # models.distortion: the scenario's terms (distortion_rows.ScenarioDistortionMixin)
        pd = getattr(nlp, "p_dist", None)
        pd = nlp.X.sym("no_distortion", 0) if pd is None else pd
        w_own = nlp.x[self.nz:]
        self.block = ca.Function("block", [nlp.z, w_own, nlp.p], [nlp.g, ca.vertcat(*nlp.js)])
        self._j_fn_t = ca.Function("objectives", [nlp.x, nlp.p_slot, th, pd],
                                   [ca.vertcat(*nlp.js)])
        x_core = ca.vertcat(nlp.z, nlp.s, nlp.y)
        nf = self.grid.n_floor
        chain = (ca.vertcat(ca.cumsum(nlp.inc[:nf]), ca.cumsum(nlp.inc[nf:]))
                 if self.statistical else ca.cumsum(nlp.inc))  # fmt: skip
        self._chain_fn_t = ca.Function("chain", [x_core, nlp.p_slot, th, pd], [chain])
        self._aux_fn_t = ca.Function("aux_quantities", [x_core, nlp.p_slot, th, pd],
                                     [mt["ln_ms_band"] - mt["ln_limit2"], mt["ln_T2_peak"],
                                      mt["ms_all"]])
        self.eval_fn = ca.Function("eval", [nlp.x, nlp.p], [nlp.j_total, nlp.g])
        self.solver = None
        self._sym = {"z": nlp.z, "w": w_own, "p": nlp.p, "theta": th, "g": nlp.g,
                     "js": ca.vertcat(*nlp.js), "x": nlp.x}

    def objective_values(self, x: np.ndarray) -> np.ndarray:
        """J of every objective at x, for the selected scenario."""
        return np.asarray(self._j_fn_t(x, self._slot_omega(), self.theta,
                                       self._block_dist(x))).ravel()

    def _aux_fn(self, x_core):
        return self._aux_fn_t(x_core, self._slot_omega(), self.theta, self._block_dist(x_core))

    def _chain_fn(self, x_core):
        return self._chain_fn_t(x_core, self._slot_omega(), self.theta,
                                self._block_dist(x_core))

    def _block_dist(self, x=None) -> np.ndarray:
        """The distortion's parameters at ``x`` (none here; models.distortion's block:
        :class:`~.distortion_rows.ScenarioDistortionMixin`)."""
        return np.zeros(0)

    def block_params(self, theta=None, slot_hz=None) -> np.ndarray:
        """The block's parameter vector: first objective, no epsilon bound, slots, theta."""
        slots = self.slot_hz if slot_hz is None else np.asarray(slot_hz, float)
        th = self.theta if theta is None else np.asarray(theta, float)
        return np.concatenate([objective_params(len(self.objectives)),
                               2.0 * math.pi * slots, th])


class ScenarioDistortionBlock(ScenarioDistortionMixin, ScenarioBlock):
    """:class:`ScenarioBlock` with the distortion power's rows (``models.distortion =
    true``): ``ScenarioBlock(study)`` of such a study; each scenario its own terms."""


_COMPOSED[ScenarioBlock] = ScenarioDistortionBlock


class RobustSolution:
    """One solve of the stacked NLP: the shared design and every scenario's state.

    Attributes: ``x``, ``values`` (the drawn design), ``objective`` (the worst-case J,
    the epigraph ``t``), ``scenario_objectives`` (J of each scenario), ``violations``
    (scenario index -> [(constraint, amount)]), ``status``, ``success``, ``iterations``,
    ``wall_s``, ``lam_p`` (the objective's sensitivity to the parameters).
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @property
    def max_violation(self) -> float:
        """Largest violation over the scenarios."""
        return max((v for vs in self.violations.values() for _, v in vs), default=0.0)

    @property
    def feasible(self) -> bool:
        """Every scenario's constraints within :data:`.solution.FEASIBILITY_TOLERANCE`."""
        return self.max_violation <= FEASIBILITY_TOLERANCE

    def worst_scenario(self) -> tuple[int, str, float]:
        """(scenario index, constraint, amount) of the largest violation."""
        best = (0, "", 0.0)
        for k, vs in self.violations.items():
            for name, v in vs:
                if v > best[2]:
                    best = (k, name, v)
        return best


class RobustProblem:
    """K scenario blocks sharing the design, worst-case objective by epigraph.

    Parameters
    ----------
    block : ScenarioBlock
        Built once for the study.
    thetas : sequence of arrays
        The scenarios (coordinates in ``block.space.names`` order).
    """

    def __init__(self, block: ScenarioBlock, thetas):
        import casadi as ca

        t0 = time.perf_counter()
        self.block = block
        self.thetas = [np.asarray(t, float) for t in thetas]
        self.slots = [block.slot_hz.copy() for _ in self.thetas]
        b = block
        nw = b.nx - b.nz
        self.nz, self.nw, self.K = b.nz, nw, len(self.thetas)
        # the block Function mapped K times (one group): its derivatives are generated once,
        # so adding a scenario costs a rebuild of about a second, not K inlined copies
        nlp, self.j_fn = stack_scenarios([(b.block, self.K)], b.nz, b.scaling)
        x = nlp["x"]
        self.ng_block = int(b.block.size1_out(0))
        bounds = stacked_bounds([b] * self.K, b.nz, extra_rows=1)  # t <= epsilon
        self.lbg, self.ubg, self.lbx, self.ubx = (bounds[k] for k in ("lbg", "ubg", "lbx",
                                                                       "ubx"))
        self.nx = int(x.numel())
        self.hessian_info = hessian_choice(b.study, b.nx, scenarios=self.K)
        self.solver = ca.nlpsol("isodesign_robust", "ipopt", nlp,
                                ipopt_options(b.study, self.hessian_info["hessian"]))
        self.build_s = time.perf_counter() - t0

    # -- parameters -------------------------------------------------------------------
    def params(self, weight: float = 1.0, diameter_weight: float = 0.0,
               eps: float | None = None) -> np.ndarray:
        """Every block's parameters (its scenario and slots), then the global ones."""
        parts = [self.block.block_params(th, sl) for th, sl in
                 zip(self.thetas, self.slots, strict=True)]
        parts.append(global_params(weight, diameter_weight, eps))
        return np.concatenate(parts)

    def theta_slice(self, k: int) -> slice:
        """Where scenario k's theta sits in the parameter vector."""
        b = self.block
        start = k * b.np + b.np - b.space.size
        return slice(start, start + b.space.size)

    # -- initial guess ------------------------------------------------------------------
    def initial_guess(self, values: dict, previous: RobustSolution | None = None) -> np.ndarray:
        """A consistent x0 at a drawn design: each block's unknowns from the NumPy closure."""
        b = self.block
        x0 = np.zeros(self.nx)
        js = []
        for k, th in enumerate(self.thetas):
            b.select(th, self.slots[k])
            xk = b.initial_guess(values)
            x0[: b.nz] = xk[: b.nz]
            x0[b.nz + k * self.nw: b.nz + (k + 1) * self.nw] = xk[b.nz:]
            js.append(b.objective_values(xk)[0])
        x0[-1] = max(js)
        return x0

    # -- solving --------------------------------------------------------------------------
    def solve(self, x0: np.ndarray, p=None) -> RobustSolution:
        """Run IPOPT on the stacked NLP from x0 (models.distortion: the outer fixed point
        over the stack, :func:`.distortion_rows.solve_stack`, each scenario's terms in
        :meth:`params`)."""
        if getattr(self.block, "distortion", False):
            from isodesign.optimization.distortion_rows import solve_stack

            b = self.block
            members = [(b, lambda th=th, sl=sl: b.select(th, sl))
                        for th, sl in zip(self.thetas, self.slots, strict=True)]
            return solve_stack(members, x0, self._solve_once, self.params, self.block_x)
        return self._solve_once(x0, p)

    def _solve_once(self, x0: np.ndarray, p=None) -> RobustSolution:
        """One IPOPT solve of the stacked NLP from x0."""
        t0 = time.perf_counter()
        p = self.params() if p is None else np.asarray(p, float)
        res = self.solver(x0=x0, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg, p=p)
        stats = self.solver.stats()
        x = np.asarray(res["x"]).ravel()
        g = np.asarray(res["g"]).ravel()
        b = self.block
        viol = {}
        for k in range(self.K):
            gk = g[k * self.ng_block: (k + 1) * self.ng_block]
            viol[k] = [(n, v) for n, v in b.violations(gk)
                       if not n.startswith(("epigraph_", "bound_"))]
        js = np.asarray(self.j_fn(x, p)).ravel()
        return RobustSolution(
            x=x, g=g, values=b.values(x[: b.nz]), objective=float(np.max(js)),
            epigraph=float(x[-1]), scenario_objectives=js, violations=viol,
            status=stats.get("return_status", "unknown"),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)), wall_s=time.perf_counter() - t0,
            lam_p=np.asarray(res["lam_p"]).ravel(), lam_g=np.asarray(res["lam_g"]).ravel(),
            params=p)

    def block_x(self, sol: RobustSolution, k: int) -> np.ndarray:
        """Scenario k's block variables ``[z, w_k]`` at a solution."""
        return np.concatenate([sol.x[: self.nz],
                               sol.x[self.nz + k * self.nw: self.nz + (k + 1) * self.nw]])

    def block_g(self, sol: RobustSolution, k: int) -> np.ndarray:
        """Scenario k's constraint rows at a solution."""
        return sol.g[k * self.ng_block: (k + 1) * self.ng_block]

    def objective_name(self) -> str:
        """The study's objective kind."""
        return self.block.objective

    def natural(self, j: float) -> float:
        """Internal J -> the objective's natural value."""
        return OBJECTIVES[self.block.objective].to_natural(j)


#: Solver settings that are not the scenario block's (starts, seed, workers, tie-break).
_SOLVER_FREE_KEYS = ("starts", "seed", "workers", "tie_break")


def scenario_structure_key(study) -> str:
    """The part of a robust vertical study that shapes its scenario block and stacked NLPs.

    A scenario's values (``theta``) are parameters of the block (:class:`ScenarioBlock`):
    what a ``[scenarios]`` range says (its ends, a list's values, the distribution) and the
    exchange settings never reach the NLP; which parameters are uncertain and how a
    tolerance applies (``relative``: ``x (1 + delta)``, ``absolute``: ``x + delta``, an
    operating value) do. So two studies that differ only in their ranges (a sweep of a
    tolerance) have the same key, and one built block serves both.

    Parameters
    ----------
    study : Study
        A study with ``[scenarios]`` and without ``[table]``.

    Returns
    -------
    str
        A hash of the resolved study without its name, description, ``[scenarios]`` table
        and the solver's starts, seed, workers and tie-break; and of the uncertain
        parameters' names and modes, in order.
    """
    import hashlib
    import json

    from isodesign.io.record import resolved_study_dict

    d = resolved_study_dict(study)
    for k in ("name", "description", "scenarios"):
        d.pop(k, None)
    d["solver"] = {k: v for k, v in (d.get("solver") or {}).items()
                   if k not in _SOLVER_FREE_KEYS}
    d["scenarios"] = [[p.name, p.mode] for p in study.scenarios.parameters]
    text = json.dumps(d, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class RobustBuilds:
    """Built scenario blocks and stacked NLPs, kept for the next study of the same structure.

    :func:`.exchange.robust_optimize` builds one :class:`ScenarioBlock` per study and one
    :class:`RobustProblem` per number of scenarios. A sweep worker that solves robust
    points differing only in their ``[scenarios]`` ranges (a tolerance swept,
    :func:`scenario_structure_key`) builds them once: the block is rebound to the point's
    study and ranges (:meth:`block`), a stack of K scenarios is reused with the point's
    scenario values and peak slots as its parameters (:meth:`stacked`). ``builds`` counts
    both (the sweep's "NLPs built").

    Parameters
    ----------
    on_build : callable, optional
        Called once per build (a :class:`~.parametric.ProblemCache` counts its own).
    """

    def __init__(self, on_build=None):
        self._blocks: dict[str, ScenarioBlock] = {}
        self._stacks: dict[tuple[str, int], RobustProblem] = {}
        self._on_build = on_build
        self.blocks_built = self.stacks_built = 0

    @property
    def builds(self) -> int:
        """Scenario blocks and stacked NLPs built."""
        return self.blocks_built + self.stacks_built

    def _built(self) -> None:
        if self._on_build is not None:
            self._on_build()

    def block(self, study) -> ScenarioBlock:
        """The scenario block of ``study`` (built on the first study of its structure),
        bound to its study, ranges and nominal scenario.

        Parameters
        ----------
        study : Study
            With ``[scenarios]``, without ``[table]``.

        Returns
        -------
        ScenarioBlock
        """
        key = scenario_structure_key(study)
        b = self._blocks.get(key)
        if b is None:
            b = self._blocks[key] = ScenarioBlock(study)
            b.structure_key = key
            self.blocks_built += 1
            self._built()
            return b
        # the same NLP; the point's ranges are the NumPy side's (box, descriptions)
        b.space = study.scenarios
        b.nominal_study = study
        b.select(b.space.nominal(), b.base_slot_hz)
        return b

    def stacked(self, block: ScenarioBlock, thetas) -> tuple[RobustProblem, bool]:
        """The stack of ``len(thetas)`` scenarios of ``block``, with these scenarios.

        Parameters
        ----------
        block : ScenarioBlock
            From :meth:`block`.
        thetas : sequence of arrays

        Returns
        -------
        (RobustProblem, bool)
            The stacked NLP (its scenarios ``thetas``, slots the block's study grid's) and
            whether it was built now.
        """
        key = (getattr(block, "structure_key", str(id(block))), len(thetas))
        prob = self._stacks.get(key)
        new = prob is None or prob.block is not block
        if new:
            prob = self._stacks[key] = RobustProblem(block, thetas)
            self.stacks_built += 1
            self._built()
        prob.thetas = [np.asarray(t, float) for t in thetas]
        prob.slots = [block.base_slot_hz.copy() for _ in prob.thetas]
        return prob, new
