"""The NLP of a study (CasADi SX, IPOPT), built once and solved from many starts.

Decision variables, scaled to [-1, 1] in log space (:mod:`.variables`): volume
ratio N, top-chamber volume V_t0, capillary length L_c and diameter D_c (fixed ones
are constants). Implicit unknowns, solved inside the NLP as equality constraints:

* ``s = ln sigma``: the RMS stroke of the spring under the random floor input,
  ``sigma^2 = integral |T - 1|^2 S_x df``, written as a chain of partial sums; the
  diaphragm at ``A* = 1.880 sigma``;
* with the statistical closure (``random_method = "statistical"``, the default;
  ``docs/random-response.md``): ``y = ln sigma_u``, the RMS of the tube velocity,
  ``sigma_u^2 = integral |T - 1|^2 |U/X|^2 S_x df`` (a second chain of partial sums), at
  which the capillary's nonlinear drop is replaced by its Gaussian-equivalent resistance
  (one expression per design, passed to every grid point);
* with the harmonic closure (``equivalent_amplitude``): ``y_j = ln U_j``, the
  self-consistent tube velocity amplitude at every grid frequency for the stroke amplitude
  ``A* = 1.880 sigma`` (:func:`isodesign.spring.equations.amplitude_residual` = 0).

Every objective and constraint is computed by :mod:`.metrics`, the same
backend-agnostic functions that evaluate them on NumPy arrays for the re-check.
Max-over-bands and max-over-frequency quantities are written in epigraph form
(:mod:`.objectives`), so the NLP has no max or abs.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.numerics.cplx import Cx
from isodesign.optimization.constraints import Constraint, build_constraints
from isodesign.optimization.distortion_rows import DistortionMixin
from isodesign.optimization.executor import parallel_allowed
from isodesign.optimization.grid import build_grid, take
from isodesign.optimization.metrics import (
    combine,
    design_quantities,
    point_quantities,
    statistical,
)
from isodesign.optimization.nlp import (
    EPIGRAPH_BOUND,
    NLP,
    SIGMA_BOUNDS_M,
    VELOCITY_BOUNDS_M_S,
    constraint_rows,
    derivative_functions,
    design_values,
    variable_boxes,
)
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.solution import Solution
from isodesign.optimization.variables import DESIGN_VARIABLES, log_scaling
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR
from isodesign.response.random_input import solve_stroke_rms
from isodesign.spring.amplitude import solve_velocity_amplitude
from isodesign.spring.capillary import gaussian_equivalent_resistance
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import amplitude_residual, kinematic_velocity

__all__ = [
    "PEAK_ROUNDS",
    "PEAK_SLOTS",
    "Problem",
    "VerticalDistortionProblem",
    "derivative_functions",
    "hoisted_map",
]

#: Options of the per-point SX function: common subexpressions (the flow model and the
#: distributed network share the Womersley function and the line elements) computed once.
_POINT_OPTIONS = {"cse": True}

#: Refinement rounds of the peak grid (five movable frequencies each).
PEAK_ROUNDS = 4
#: Movable peak-grid frequencies reserved in every NLP (parameters, no rebuild).
PEAK_SLOTS = 5 * PEAK_ROUNDS


def hoisted_map(point, n: int, shared: tuple):
    """``point`` mapped over ``n`` grid points, its grid-independent parts computed once.

    Every subexpression of the per-point physics that depends only on the inputs listed in
    ``shared`` (those that are the same at every grid point: the design, ``ln sigma``,
    the Gaussian-equivalent resistance...) is extracted (``casadi.extract_parametric``)
    into one function evaluated once; the mapped function receives its values as a further
    input. The outputs are the same expressions (``substitute`` restores them exactly), so
    values and exact derivatives are unchanged; the NLP's graph loses the ``n - 1`` copies
    of the design-level parts (chamber dimensions, wave speeds, areas). The NLP's size per
    acoustic model is a row of ``docs/benchmarks.md`` (``benchmarks/bench_acoustics.py``).

    Parameters
    ----------
    point : casadi.Function
        SX function of scalar or column inputs and scalar outputs.
    n : int
        Number of grid points.
    shared : tuple of int
        Indices of the inputs that are broadcast (the same value at every point).

    Returns
    -------
    callable
        ``call(*args)`` with ``point``'s inputs (shared ones once, the others as rows of
        ``n`` columns), returning the mapped outputs (rows of ``n`` columns).
    """
    import casadi as ca

    ins = point.sx_in()
    outs = point.call(ins)
    ex, syms, par = ca.extract_parametric(ca.vertcat(*outs), ca.vertcat(*[ins[i] for i in shared]),
                                          {})
    if not syms:
        mapped = point.map(n, "unroll")
        return lambda *args: mapped(*args)
    feats = ca.vertcat(*syms)
    part = ca.Function("shared_part", [ins[i] for i in shared], [ca.vertcat(*par)])
    rest = ca.Function("point_rest", [feats, *ins], [ex[i] for i in range(ex.numel())],
                       _POINT_OPTIONS)
    mapped = rest.map(n, "unroll")

    def call(*args):
        return mapped(part(*[args[i] for i in shared]), *args)

    return call


class Problem(NLP):
    """The NLP of a study, built once and solved from many starts.

    ``Problem(study)`` builds every study's NLP on the one machinery of :mod:`.nlp`; the
    study picks the body. A study without ``[table]`` (the symmetric table of its
    ``[payload]``) gets this class's body, the exact z reduction of the table model
    (docs/table.md, section 14): one spring, its payload share, the vertical response;
    a study with ``[table]`` gets the six-degree-of-freedom assembly,
    :class:`~isodesign.optimization.table_problem.TableProblem` (``Problem(study,
    objectives, hessian=..., peak_slots=...)`` passes its options on), so no study is
    answered by the other body.

    The objective is parametric, so that one built solver serves the main
    solve, the flat-direction tie-break and a Pareto sweep::

        minimize   sum_k w_k J_k + w_D ln D_c
        subject to J_k <= eps_k  (k in objectives), physics, constraints

    with parameters ``p = [w_1..w_K, w_D, eps_1..eps_K, slot frequencies]`` (see
    :meth:`params`). The per-frequency physics (:func:`.metrics.point_quantities`
    and the amplitude residual) is one small SX Function mapped over the grid, so
    the exact Hessian is cheap to build and to evaluate.

    Built in named steps: :meth:`_point_function` (per-frequency physics),
    :meth:`_decision_variables`, :meth:`_physics` (metrics over the grid),
    :meth:`_stroke_chain`, :meth:`_objectives_and_constraints`, :meth:`_assemble`
    (rows, bounds) and :meth:`_build_solver`.

    Parameters
    ----------
    study : Study
    objectives : tuple of str
        Objective kinds present in the NLP (default: the study's objective).
    extra_peak_hz : tuple of float
        Fixed frequencies added to the peak grid.
    """

    def __new__(cls, study=None, *args, **kwargs):
        # study=None: a copy (copy.copy calls __new__ without arguments)
        if cls is Problem and getattr(study, "table", None) is not None:
            from isodesign.optimization.table_problem import TableProblem

            return TableProblem(study, *args, **kwargs)
        if _distortion(study) and not issubclass(cls, DistortionMixin):
            return super().__new__(_with_distortion(cls))  # the closure with its distortion
        return super().__new__(cls)

    def __init__(self, study, objectives: tuple | None = None, extra_peak_hz: tuple = ()):
        import casadi as ca

        if _distortion(study) and not getattr(self, "distortion", False):
            raise InputError("models.distortion = true: this NLP does not carry the "
                             "distortion power yet; set models.distortion = false")
        self.study = study
        self.objectives = tuple(objectives or (study.objective["kind"],))
        self.objective = self.objectives[0]
        self.extra_peak_hz = tuple(extra_peak_hz)
        self.grid = build_grid(study, objectives=self.objectives, extra_peak_hz=extra_peak_hz,
                               slots=PEAK_SLOTS)
        self.slot_hz = self.grid.omega[self.grid.slot_slice] / (2.0 * math.pi)
        self.dia = diaphragm_model(study.models["diaphragm"])
        self.scaling = log_scaling(study)
        self.statistical = statistical(study)
        self.self_consistent = (study.models["amplitude_mode"] == "self_consistent"
                                and not self.statistical)
        # SX throughout: with MX the Jacobian's colouring needed one sweep per grid point,
        # tens of times the cost of a Jacobian of the expanded SX graph
        nlp = SimpleNamespace(ca=ca, X=ca.SX)
        self._decision_variables(nlp)
        self._physics(nlp, self._point_function(ca))
        self._stroke_chain(nlp)
        self._objectives_and_constraints(nlp)
        self._assemble(nlp)
        self._build_solver(nlp)

    # -- construction steps ------------------------------------------------------
    def _point_function(self, ca):
        """The per-frequency physics as one SX Function ``(design, s, y, c_nl, w)``.

        ``y`` is ``ln U`` at that frequency (harmonic closure) or ``ln sigma_u`` (statistical,
        the same at every point, like ``s``); ``c_nl`` the Gaussian-equivalent resistance
        (statistical closure; unused otherwise). Outputs: amplitude residual, T, R,
        ln Mach, ln Re and ``|U/X|^2``.
        """
        extra = self._point_inputs(ca)
        study = self._point_study(extra)
        dv = ca.SX.sym("design", len(DESIGN_VARIABLES))
        d_sx = study.design_at({n: dv[i] for i, n in enumerate(DESIGN_VARIABLES)})
        s_sx, y_sx, w_sx = ca.SX.sym("s"), ca.SX.sym("y"), ca.SX.sym("w")
        cnl_sx = ca.SX.sym("c_nl")
        ins = [dv, s_sx, y_sx, cnl_sx, w_sx, *extra]
        sig_sx = ca.exp(s_sx)
        a_sx = EQUIVALENT_AMPLITUDE_FACTOR * sig_sx
        if self.statistical:
            pq = point_quantities(study, d_sx, w_sx, math.sqrt(2.0) * ca.exp(y_sx), sig_sx,
                                  self.dia, cnl_sx)
            return ca.Function("point", ins,
                               [ca.SX(0), pq["T"].re, pq["T"].im, pq["R"].re, pq["R"].im,
                                pq["ln_mach"], pq["ln_re"], pq["G2"]], _POINT_OPTIONS)
        if self.self_consistent:
            u_sx = ca.exp(y_sx)
            res_sx = amplitude_residual(study.models["flow"], d_sx, w_sx, a_sx, y_sx)
        else:
            u_sx = kinematic_velocity(d_sx, w_sx, a_sx)
            res_sx = ca.SX(0)
        pq = point_quantities(study, d_sx, w_sx, u_sx, sig_sx, self.dia)
        return ca.Function("point", ins,
                           [res_sx, pq["T"].re, pq["T"].im, pq["R"].re, pq["R"].im,
                            pq["ln_mach"], pq["ln_re"], ca.SX(0)], _POINT_OPTIONS)

    # hooks of a subclass whose NLP has further parameters (:mod:`.parametric`)
    def _point_inputs(self, ca) -> list:
        """Further SX inputs of the point function (none here)."""
        return []

    def _point_study(self, extra):
        """The study the per-point physics is written on (``extra``: its further inputs)."""
        return self.study

    def _point_args(self, nlp) -> list:
        """The NLP's values of the point function's further inputs (none here)."""
        return []

    def _nlp_study(self, nlp):
        """The study the NLP's design-level expressions and constraints are written on."""
        return self.study

    def _omega_column(self, nlp):
        """The grid's angular frequencies, the movable peak slots as parameters."""
        ca = nlp.ca
        w, sl = self.grid.omega, self.grid.slot_slice
        return ca.vertcat(ca.DM(w[: sl.start]), nlp.p_slot, ca.DM(w[sl.stop:]))

    def _adjust_metrics(self, nlp) -> None:
        """Change the NLP's metrics after :func:`.metrics.combine` (nothing here)."""

    def _closure_resistance(self, nlp, c_nl):
        """The nonlinear drop's equivalent resistance the grid sees (``c_nl`` here; the
        distortion's gain, :mod:`.distortion_rows`)."""
        return c_nl

    def _chain_factors(self, nlp) -> tuple:
        """Factors of the stroke (and tube) chains: the floor weights' scale and
        ``1 / sigma_ref^2`` (``1 / sigma_u,ref^2``)."""
        self.sigma_ref, self.tube_rms_ref = self._reference_sigma()
        k_u = 1.0 / self.tube_rms_ref**2 if self.statistical else None
        return 1.0, 1.0 / self.sigma_ref**2, k_u

    def _fn_param_sym(self, nlp):
        """The parameters of the evaluation functions beside x (the slots here)."""
        return nlp.p_slot

    def _fn_params(self) -> np.ndarray:
        """Their values (:meth:`_fn_param_sym`)."""
        return self._slot_omega()

    def _decision_variables(self, nlp) -> None:
        """Scaled design z, ln sigma s, ln U y, the design values and the slot parameters."""
        ca, X = nlp.ca, nlp.X
        nlp.n_all = self.grid.omega.size
        nlp.z = X.sym("z", len(self.scaling.names))
        nlp.s = X.sym("s")
        nlp.y = X.sym("y", nlp.n_all if self.self_consistent else int(self.statistical))
        nlp.vals = design_values(ca, X, nlp.z, self.scaling, self.study)
        # the movable peak frequencies are parameters: refining the peak grid needs no
        # rebuild of the NLP
        nlp.p_slot = X.sym("slot_omega", self.grid.n_slots)

    def _physics(self, nlp, point) -> None:
        """The point function mapped over the grid; the metrics of the design."""
        ca, X = nlp.ca, nlp.X
        st = nlp.st = self._nlp_study(nlp)
        args = self._point_args(nlp)
        more = tuple(range(5, 5 + len(args)))
        # design, ln sigma and c_nl (and ln sigma_u, statistical closure) are broadcast
        mapped = hoisted_map(point, nlp.n_all,
                             (0, 1, 3, 2, *more) if self.statistical else (0, 1, 3, *more))
        v = ca.vertcat(*nlp.vals)
        nlp.d = st.design_at({n: nlp.vals[i] for i, n in enumerate(DESIGN_VARIABLES)})
        if self.self_consistent:
            y_row = nlp.y.T
        elif self.statistical:
            y_row = nlp.y  # ln sigma_u: broadcast like s
        else:
            y_row = X.zeros(1, nlp.n_all)
        c_nl = (gaussian_equivalent_resistance(st.models["flow"], nlp.d, ca.exp(nlp.y[0]))
                if self.statistical else X(0))  # fmt: skip
        c_nl = self._closure_resistance(nlp, c_nl)
        w_sym = self._omega_column(nlp)
        # v, s and c_nl keep their shape: map broadcasts them (and sums their derivatives)
        outs = mapped(v, nlp.s, y_row, c_nl, w_sym.T, *args)
        res_u, t_re, t_im, r_re, r_im, ln_mach, ln_re, g2 = (o.T for o in outs)
        nlp.pq = {"T": Cx(t_re, t_im), "R": Cx(r_re, r_im), "ln_mach": ln_mach, "ln_re": ln_re}
        if self.statistical:
            nlp.pq["G2"] = g2
        nlp.mt = combine(st, self.grid, nlp.pq, design_quantities(st, self.grid, nlp.d, self.dia))
        self._adjust_metrics(nlp)
        nlp.res_u = res_u if self.self_consistent else X(0, 1)

    def _stroke_chain(self, nlp) -> None:
        """sigma^2 = sum_j stroke_weight_j |R_j|^2 as a chain of partial sums.

        (:func:`isodesign.response.linearization.stroke_variance`) The partial sums
        c_j are in units of sigma_ref^2, so that no constraint row couples all grid
        points: a dense row would make the Jacobian's colouring need one sweep per point.
        """
        ca, X = nlp.ca, nlp.X
        scale, k_s, k_u = self._chain_factors(nlp)
        sw = np.asarray(self.grid.response.stroke_weight, float)
        fl = self.grid.floor_slice
        r2 = take(nlp.pq["R"], fl).abs2()
        nlp.inc = sw * (scale * k_s) * r2
        nf = self.grid.n_floor
        nlp.c = X.sym("stroke_partial_sums", nf)
        res_chain = nlp.c - ca.vertcat(X(0), nlp.c[: nf - 1]) - nlp.inc
        nlp.res_s = ca.vertcat(res_chain, ca.exp(2.0 * nlp.s) * k_s - nlp.c[nf - 1])
        self.nc = nf
        if self.statistical:  # sigma_u^2 = sum_j stroke_weight_j |R_j|^2 |U/X|_j^2, likewise
            inc_u = sw * (scale * k_u) * r2 * nlp.pq["G2"][fl]
            cu = X.sym("tube_partial_sums", nf)
            res_u = cu - ca.vertcat(X(0), cu[: nf - 1]) - inc_u
            nlp.res_u = ca.vertcat(res_u, ca.exp(2.0 * nlp.y[0]) * k_u - cu[nf - 1])
            nlp.c = ca.vertcat(nlp.c, cu)
            nlp.inc = ca.vertcat(nlp.inc, inc_u)
            self.nc = 2 * nf

    def _objectives_and_constraints(self, nlp) -> None:
        """The study's constraints, each objective's form, epsilon bounds and weights."""
        ca, X = nlp.ca, nlp.X
        aux: list = []

        def sym(name, n):
            a = X.sym(name, n)
            aux.append(a)
            return a

        st = getattr(nlp, "st", self.study)  # a subclass's _physics may not set it
        cons = build_constraints(st, nlp.mt, nlp.n_all)
        nk = len(self.objectives)
        nlp.p_w = X.sym("weights", nk)
        nlp.p_wd = X.sym("w_diameter")
        nlp.p_eps = X.sym("eps", nk)
        j_total = nlp.p_wd * ca.log(nlp.d.capillary_diameter_m)
        js = []
        for k, kind in enumerate(self.objectives):
            jk, _, ocons = OBJECTIVES[kind].nlp(nlp.mt, st, self.grid, sym)
            cons += ocons
            cons.append(Constraint(f"bound_{kind}", jk - nlp.p_eps[k], -math.inf, 0.0, 1,
                                   f"{kind} <= epsilon"))
            j_total = j_total + nlp.p_w[k] * jk
            js.append(jk)
        self.constraints = cons
        nlp.aux, nlp.js, nlp.j_total = aux, js, j_total

    def _assemble(self, nlp) -> None:
        """x, p and g; constraint rows with their bounds; boxes on the variables."""
        ca = nlp.ca
        nlp.x = ca.vertcat(nlp.z, nlp.s, nlp.y, nlp.c, *nlp.aux)
        nlp.p = ca.vertcat(nlp.p_w, nlp.p_wd, nlp.p_eps, nlp.p_slot)
        nlp.g = ca.vertcat(nlp.res_u, nlp.res_s, *[c.expr for c in self.constraints])
        self.n_eq = int(nlp.res_u.numel()) + int(nlp.res_s.numel())
        self.lbg, self.ubg, self.con_rows = self._constraint_rows(self.constraints)
        self.nz, self.ny = int(nlp.z.numel()), int(nlp.y.numel())
        self.naux = int(sum(int(a.numel()) for a in nlp.aux))
        self.nx = int(nlp.x.numel())
        self.np = int(nlp.p.numel())
        self.lbx, self.ubx = self._variable_bounds()

    def _constraint_rows(self, constraints) -> tuple[np.ndarray, np.ndarray, list]:
        """lbg, ubg (the implicit equations first) and ``(constraint, row, size)`` of each
        (:func:`.nlp.constraint_rows`)."""
        return constraint_rows(self.n_eq, [(c, int(c.expr.numel()), c.lo, c.hi)
                                           for c in constraints])

    def _variable_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The scaled design in [-1, 1]; generous physical boxes on the implicit unknowns
        keep IPOPT's trial steps away from overflow; the partial sums free (a bound would
        be pushed off its zeros); the epigraph variables in +-:data:`.nlp.EPIGRAPH_BOUND`."""
        return variable_boxes(
            (self.nz, -1.0, 1.0),
            (1, math.log(SIGMA_BOUNDS_M[0]), math.log(SIGMA_BOUNDS_M[1])),
            (self.ny, math.log(VELOCITY_BOUNDS_M_S[0]), math.log(VELOCITY_BOUNDS_M_S[1])),
            (self.nc, -np.inf, np.inf),
            (self.naux, -EPIGRAPH_BOUND, EPIGRAPH_BOUND))

    def _build_solver(self, nlp) -> None:
        """Evaluation functions and the IPOPT solver."""
        ca = nlp.ca
        mt = nlp.mt
        self.eval_fn = ca.Function("eval", [nlp.x, nlp.p], [nlp.j_total, nlp.g])
        q = self._fn_param_sym(nlp)
        self._j_fn_p = ca.Function("objectives", [nlp.x, q], [ca.vertcat(*nlp.js)])
        x_core = ca.vertcat(nlp.z, nlp.s, nlp.y)
        nf = self.grid.n_floor
        chain = (ca.vertcat(ca.cumsum(nlp.inc[:nf]), ca.cumsum(nlp.inc[nf:]))
                 if self.statistical else ca.cumsum(nlp.inc))  # fmt: skip
        self._chain_fn_p = ca.Function("chain", [x_core, q], [chain])
        self._aux_fn_p = ca.Function("aux_quantities", [x_core, q],
                                     [mt["ln_ms_band"] - mt["ln_limit2"], mt["ln_T2_peak"],
                                      mt["ms_all"]])
        exact = self.hessian_info["hessian"] == "exact"
        funcs = {"x": nlp.x, "f": nlp.j_total, "g": nlp.g, "p": nlp.p}
        opts = {**self.ipopt_options(), **derivative_functions(
            nlp, parallel_allowed(self.study.solver["workers"]), hessian=exact)}
        self.solver = ca.nlpsol("isodesign", "ipopt", funcs, opts)
        self._warm_solver = self.warm_solver_factory(ca, funcs, opts)

    @property
    def hessian_info(self) -> dict:
        """IPOPT's Hessian of this NLP and why
        (:func:`isodesign.optimization.hessian.hessian_choice` of its size)."""
        from isodesign.optimization.hessian import hessian_choice

        return hessian_choice(self.study, getattr(self, "nx", None))

    # -- parameters and grid -------------------------------------------------------
    def _param_tail(self) -> np.ndarray:
        """The movable peak-grid frequencies (rad/s) after the objectives' parameters."""
        return 2.0 * math.pi * self.slot_hz

    def set_slots(self, frequencies_hz) -> None:
        """Move the movable peak-grid frequencies (Hz); the grid follows."""
        f = np.asarray(frequencies_hz, float)
        if f.size != self.grid.n_slots:
            raise ValueError(f"set_slots: need {self.grid.n_slots} frequencies, got {f.size}")
        self.slot_hz = f.copy()
        self.grid = self.grid.with_slots(f)

    def _slot_omega(self) -> np.ndarray:
        return 2.0 * math.pi * self.slot_hz

    def objective_values(self, x: np.ndarray) -> np.ndarray:
        """Internal values J_k of every objective at x."""
        return np.asarray(self._j_fn_p(x, self._fn_params())).ravel()

    def _aux_fn(self, x_core):
        return self._aux_fn_p(x_core, self._fn_params())

    def _chain_fn(self, x_core):
        return self._chain_fn_p(x_core, self._fn_params())

    def closure(self, d, values: dict | None = None) -> tuple[float, float | None]:
        """``(sigma, sigma_u)`` of a design from the NumPy closure (``sigma_u``: ``None``
        for the harmonic closure; ``values`` unused: no levers)."""
        st = self.study
        sigma, info = solve_stroke_rms(
            d, st.payload, self.grid.response, flow=st.models["flow"],
            amplitude_mode=st.models["amplitude_mode"], diaphragm=self.dia,
            random_method="statistical" if self.statistical else "equivalent_amplitude")
        return sigma, info.get("tube_velocity_rms_m_s")

    # -- starting points (NLP.initial_guess) -------------------------------------------
    def _fill_guess(self, x0: np.ndarray, d, sigma, sigma_u) -> None:
        """ln sigma, ln sigma_u or ln U from the NumPy solvers; partial sums, epigraphs."""
        x0[self.nz] = math.log(sigma)
        if self.statistical:
            x0[self.nz + 1] = math.log(sigma_u)
        elif self.self_consistent:
            u = self.velocity(d, sigma)
            x0[self.nz + 1: self.nz + 1 + self.ny] = np.log(u)
        self.fill_dependent(x0)

    def retighten(self, sol: Solution) -> Solution:
        """A solution with its epigraph variables made tight and J, g re-evaluated."""
        x = sol.x.copy()
        x[self.nx - self.naux:] = self.aux_guess(x)
        _, g = self.eval_fn(x, self.params())
        g = np.asarray(g).ravel()
        j_all = self.objective_values(x)
        return sol.replace(x=x, g=g, objective=float(j_all[0]), objectives=j_all,
                           violations=tuple(self.violations(g)))

    def fill_dependent(self, x: np.ndarray) -> np.ndarray:
        """Set the partial sums and the epigraph variables consistent with x (in place)."""
        n_core = self.nz + 1 + self.ny
        x[n_core: n_core + self.nc] = np.asarray(self._chain_fn(x[:n_core])).ravel()
        x[self.nx - self.naux:] = self.aux_guess(x)
        return x

    def aux_guess(self, x: np.ndarray) -> np.ndarray:
        """Epigraph variables on their boundary at x (worst margin, peak |T|, in dB)."""
        if not self.naux:
            return np.zeros(0)
        n_core = self.nz + 1 + self.ny
        margins, t2, ms = (np.asarray(v).ravel() for v in self._aux_fn(x[:n_core]))
        # the objectives' NumPy values on the quantities the epigraphs bound
        mt = {"ln_ms_band": margins, "ln_limit2": 0.0, "ln_T2_peak": t2, "ms_all": ms}
        vals = []
        for kind in self.objectives:
            obj = OBJECTIVES[kind]
            if obj.epigraph is not None:
                vals.append(obj.epigraph(obj.value(mt, self.study, self.grid)))
        return np.asarray(vals[: self.naux], float)

    def velocity(self, d, sigma) -> np.ndarray:
        """Tube velocity amplitude at every grid frequency (NumPy solver or kinematic)."""
        a = EQUIVALENT_AMPLITUDE_FACTOR * sigma
        w = self.grid.omega
        if self.self_consistent:
            sol = solve_velocity_amplitude(self.study.models["flow"], d, w, a)
            if not np.all(sol.converged):
                raise SolverError("velocity amplitude did not converge at the initial guess")
            return sol.velocity
        return kinematic_velocity(d, w, a)

    def sigma(self, x: np.ndarray) -> float:
        """RMS stroke sigma at x (m)."""
        return math.exp(x[self.nz])

    def tube_rms(self, x: np.ndarray) -> float | None:
        """RMS tube velocity sigma_u at x (m/s; statistical closure), else ``None``."""
        return math.exp(x[self.nz + 1]) if self.statistical else None


def _distortion(study) -> bool:
    """The study asks for the closure with its distortion power (``models.distortion``)."""
    return bool(getattr(study, "models", {}).get("distortion", False))


class VerticalDistortionProblem(DistortionMixin, Problem):
    """The vertical body with the distortion power's rows (:mod:`.distortion_rows`):
    ``Problem(study)`` of a study with ``models.distortion = true``."""


_COMPOSED: dict = {Problem: VerticalDistortionProblem}


def _with_distortion(cls):
    """``cls`` with the distortion's rows, for a subclass whose NLP is its study's own (one
    that overrides none of the hooks of further parameters, e.g. the command line's
    prefetching build); any other (a parametric NLP, whose point is not its study's) keeps
    ``cls`` and refuses the key in ``__init__``."""
    if cls in _COMPOSED:  # a registered composition (the parametric NLP's)
        return _COMPOSED[cls]
    own = all(getattr(cls, h) is getattr(Problem, h)
              for h in ("_point_inputs", "_point_study", "_point_args", "_nlp_study"))
    if not own:
        return cls
    if cls not in _COMPOSED:
        _COMPOSED[cls] = type(f"{cls.__name__}WithDistortion", (DistortionMixin, cls),
                              {"__module__": cls.__module__, "__doc__": cls.__doc__})
    return _COMPOSED[cls]
