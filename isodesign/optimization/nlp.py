"""What every NLP of a study shares, written once.

The vertical NLP (:class:`~.problem.Problem`, the exact z reduction of a symmetric
payload, docs/table.md section 14), the table's six-degree-of-freedom NLP
(:class:`~.table_problem.TableProblem`) and their scenario stacks (:mod:`.robust`,
:mod:`.robust_table`) build different bodies on the same machinery:

* the IPOPT options (:data:`IPOPT_OPTIONS`, :func:`ipopt_options`) and the boxes on the
  implicit unknowns (:data:`SIGMA_BOUNDS_M`, :data:`VELOCITY_BOUNDS_M_S`,
  :data:`EPIGRAPH_BOUND`), :func:`variable_boxes`;
* the design values from the scaled variables ``z`` (:func:`design_values`: the spring's
  four, log-scaled, fixed ones from the study);
* the head of the parameter vector, ``[weights, w_D, epsilon bounds]``
  (:func:`objective_params`), shared by the nominal solve, the tie-break and the Pareto
  sweep;
* the constraint rows with their names and bounds (:func:`constraint_rows`), from which
  the violations (:meth:`NLP.violations`) and the binding flags
  (:func:`~.constraints.constraint_reports`) are read;
* one solve (:meth:`NLP.solve`) returning a :class:`~.solution.Solution`, and the design
  values at a point (:meth:`NLP.values`).
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from isodesign.optimization.solution import Solution
from isodesign.optimization.variables import DESIGN_VARIABLES

__all__ = [
    "CONSTRAINT_VIOLATION_TOL",
    "EPIGRAPH_BOUND",
    "IPOPT_OPTIONS",
    "NLP",
    "NO_BOUND",
    "SIGMA_BOUNDS_M",
    "VELOCITY_BOUNDS_M_S",
    "constraint_rows",
    "derivative_functions",
    "design_values",
    "ipopt_options",
    "objective_params",
    "row_name",
    "stacked_bounds",
    "variable_boxes",
]

#: IPOPT options beyond max_iter and tol. Every start is consistent (the implicit
#: unknowns solved by the NumPy path), so IPOPT must not push it off its bounds nor
#: start with a large barrier parameter: a monotone barrier from mu = 1e-3 and
#: tiny bound pushes converged from every start where the adaptive default often
#: wandered off (measured on the default study, benchmarks/bench_optimize.py). MUMPS
#: orders the KKT matrix by approximate minimum degree (``mumps_pivot_order = 0``) instead
#: of its automatic choice: the same iterates (a fill-reducing permutation), about a fifth
#: less CPU time per solve of the vertical study's starts and a tenth of the table's
#: (docs/optimization.md, section 3).
IPOPT_OPTIONS = {
    "ipopt.mu_strategy": "monotone",
    "ipopt.mu_init": 1e-3,
    "ipopt.bound_push": 1e-9,
    "ipopt.bound_frac": 1e-9,
    "ipopt.slack_bound_push": 1e-9,
    "ipopt.slack_bound_frac": 1e-9,
    "ipopt.mumps_pivot_order": 0,
}
#: A warm re-solve of the same point (:meth:`NLP.solve` ``warm=``: the peak refinement's
#: re-solves and the tie-break's): IPOPT starts from the previous solution's primal and
#: dual values with a small barrier parameter and tiny pushes off the bounds, so the
#: active set it had carries over (docs/sweep.md, section 6).
WARM_OPTIONS = {
    "ipopt.warm_start_init_point": "yes",
    "ipopt.mu_init": 1e-6,
    "ipopt.warm_start_bound_push": 1e-9,
    "ipopt.warm_start_bound_frac": 1e-9,
    "ipopt.warm_start_slack_bound_push": 1e-9,
    "ipopt.warm_start_slack_bound_frac": 1e-9,
    "ipopt.warm_start_mult_bound_push": 1e-9,
}
#: IPOPT's constraint violation tolerance (``ipopt.constr_viol_tol``).
CONSTRAINT_VIOLATION_TOL = 1e-9
#: IPOPT's "acceptable" termination of a limited-memory solve: three iterates in a row
#: whose optimality error is at most 1e-6 (IPOPT's default ``acceptable_tol``), their
#: constraints met to :data:`CONSTRAINT_VIOLATION_TOL` as at a full convergence. The
#: quasi-Newton Hessian converges only linearly near the optimum: the co-designed table's
#: full solve reached its objective to 8 digits in 57 iterations, then spent 35 more
#: (mu = 1e-10, line searches cut back 10-15 times) before its dual infeasibility met the
#: study's ``tol``; stopped here it ends at iteration 73 with the same optimum (+9.043 dB,
#: docs/optimization.md, section 3). The exact Hessian's solves converge quadratically and
#: keep IPOPT's defaults (15 such iterates, which their tail never reaches).
LIMITED_MEMORY_ACCEPTABLE = {
    "ipopt.acceptable_iter": 3,
    "ipopt.acceptable_tol": 1e-6,
    "ipopt.acceptable_constr_viol_tol": CONSTRAINT_VIOLATION_TOL,
}
#: Boxes on the implicit unknowns of the NLP (far outside any physical solution).
SIGMA_BOUNDS_M = (1e-13, 1e-1)
VELOCITY_BOUNDS_M_S = (1e-12, 1e3)
#: Box on an epigraph variable: dB, or ln(m/s) for rms_velocity.
EPIGRAPH_BOUND = 300.0
#: An epsilon bound that never binds.
NO_BOUND = 1e20


def ipopt_options(study, hessian: str) -> dict:
    """The options given to CasADi's ``nlpsol`` for a study's NLP.

    Parameters
    ----------
    study : Study
        Its ``solver`` table (``max_iter``, ``tol``).
    hessian : {'exact', 'limited-memory'}
        IPOPT's Hessian of the Lagrangian
        (:func:`~isodesign.optimization.hessian.hessian_choice`).

    Returns
    -------
    dict
    """
    return {
        "ipopt.print_level": 0,
        "print_time": False,
        # a trial point of IPOPT's line search where the model is not defined (a NaN or Inf
        # row) is cut back by IPOPT itself; CasADi would print one warning per evaluation
        # (9,634 on stderr in one co-designed table solve). A solve that fails says so with
        # its status, as every other failure does.
        "show_eval_warnings": False,
        "ipopt.sb": "yes",
        "ipopt.max_iter": study.solver["max_iter"],
        "ipopt.tol": study.solver["tol"],
        "ipopt.constr_viol_tol": CONSTRAINT_VIOLATION_TOL,
        **IPOPT_OPTIONS,
        **(LIMITED_MEMORY_ACCEPTABLE if hessian == "limited-memory" else {}),
        "ipopt.hessian_approximation": hessian,
        "error_on_fail": False,
    }


#: The options of an SX function evaluated at every frequency of an NLP's map: common
#: subexpressions merged in it and in its derivatives. The physics is written once for NumPy
#: and CasADi, so its SX graph repeats what NumPy computes once (each isolator's spring terms,
#: the assembly's products); merged, the table's point function has 2,594 instructions
#: instead of 4,330 (docs/table.md, section 13). The same operations on the same operands,
#: each evaluated once.
SX_CSE = {"cse": True, "der_options": {"cse": True}}


def point_function(ca, name: str, inputs: list, outputs, constant: tuple = (),
                   ahead: list | None = None):
    """One frequency's physics as an NLP maps it over a grid, differentiated by its Jacobian.

    IPOPT's constraint Jacobian asks the map for its forward derivative in as many
    directions as the NLP has variables (27 in the co-designed table, and its closure's
    ``s`` and ``y``). An SX function's own forward derivative is symbolic in every
    direction: each isolator's spring is differentiated along every variable, those of the
    other leveling groups' springs included. Here the SX function (:data:`SX_CSE`) has
    ``jac_penalty`` 0 and is called from an MX function, where CasADi evaluates its Jacobian
    instead (generated once with unit seeds, so a variable's derivative is formed only where
    the variable enters, its common subexpressions merged) and multiplies it by the
    directions. The co-designed default study's constraint Jacobian costs 19 ms an
    evaluation instead of 65 ms (the tied stage's NLP) and 32 ms instead of 110 ms (the
    full NLP with its 36 movable peak frequencies); the values are the same to rounding
    (``tests/optimization/test_table_problem.py`` compares them with the plain forward
    derivative). The price: about 0.6 s more to generate the NLP (the Jacobian's
    subexpressions merged).

    Parameters
    ----------
    ca : module
        CasADi.
    name : str
        The function's name.
    inputs : list of SX
        Its inputs.
    outputs : SX or list of SX
        Its output, or its outputs.
    constant : tuple of int
        Inputs given numbers at every call (a grid's frequencies): no derivative is formed
        with respect to them, which keeps the Jacobian smaller. A symbolic value given to
        one of them would be differentiated as a constant: pass its index only where the
        caller gives a ``DM``.
    ahead : list, optional
        Generate the Jacobian now, in a thread, while the caller assembles the rest of the
        NLP (CasADi releases the GIL while it differentiates), and append its
        :class:`JacobianAhead` here; :func:`derivative_functions` waits for it. None: on
        first use, in the caller's thread.

    Returns
    -------
    casadi.Function
        An MX function of the same inputs and outputs.
    """
    outs = list(outputs) if isinstance(outputs, list | tuple) else [outputs]
    diff = [i not in constant for i in range(len(inputs))]
    sx = ca.Function(name + "_sx", inputs, outs, {**SX_CSE, "jac_penalty": 0, "is_diff_in": diff})
    if ahead is not None:
        ahead.append(JacobianAhead(sx))
    mx_in = sx.mx_in()
    return ca.Function(name, mx_in, sx.call(mx_in))


class JacobianAhead:
    """A function's Jacobian generated in a thread (:func:`point_function`'s ``ahead``).

    CasADi keeps a function's Jacobian in a weak cache: this object holds it until the NLP's
    derivatives, which call it, are generated (:func:`derivative_functions`).

    Parameters
    ----------
    fn : casadi.Function
    """

    def __init__(self, fn):
        self.jacobian = None
        self._thread = threading.Thread(target=self._run, args=(fn,), daemon=True,
                                        name="isodesign-jacobian")
        self._thread.start()

    def _run(self, fn) -> None:
        try:
            self.jacobian = fn.jacobian()
        except Exception:  # generated again, and its error raised, on first use
            self.jacobian = None

    def wait(self):
        """The Jacobian (None if generating it failed: it is generated again on use)."""
        self._thread.join()
        return self.jacobian


def derivative_functions(nlp, threads: bool = True, hessian: bool = True,
                         ahead: list | tuple = ()) -> dict:
    """IPOPT's Jacobian and Hessian functions, generated side by side in two threads.

    What ``nlpsol`` would generate itself, one after the other: the constraint Jacobian
    ``jac_g(x, p) -> (g, dg/dx)`` and the upper triangle of the Hessian of the Lagrangian
    ``hess_lag(x, p, lam_f, lam_g)``, both exact (CasADi's symbolic differentiation of the
    SX graph). CasADi releases the GIL while it differentiates, so on two cores the two
    graphs are built at the same time.

    Parameters
    ----------
    nlp : namespace
        ``ca``, ``x``, ``p``, ``j_total`` (objective) and ``g`` (constraints), SX or MX.
    threads : bool
        Build the two in two threads (default); ``False``: one after the other, in this
        thread (a sweep point or a one-worker run, where no second core is the run's to
        take: :func:`isodesign.optimization.executor.parallel_allowed`).
    hessian : bool
        Build the Hessian (default); ``False``: the Jacobian only (IPOPT's limited-memory
        approximation, :func:`isodesign.optimization.hessian.hessian_choice`).
    ahead : sequence of JacobianAhead
        Jacobians of functions the graph calls, generated ahead (:func:`point_function`):
        waited for, and held while the NLP's derivatives are generated.

    Returns
    -------
    dict
        The ``nlpsol`` options ``jac_g`` and ``hess_lag``.
    """
    ca = nlp.ca
    x, p, f, g = nlp.x, nlp.p, nlp.j_total, nlp.g
    held = [a.wait() for a in ahead]  # noqa: F841 - CasADi's cache of them is weak

    def jac_g():
        return ca.Function("nlp_jac_g", [x, p], [g, ca.jacobian(g, x)], ["x", "p"],
                           ["g", "jac_g_x"])

    def hess_lag():
        sym = type(x).sym  # SX or MX, as the NLP's graph (a table NLP may be MX)
        lam_f, lam_g = sym("lam_f"), sym("lam_g", g.numel())
        hess = ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])
        return ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [hess],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])

    if not hessian:
        return {"jac_g": jac_g()}
    if not threads:
        return {"jac_g": jac_g(), "hess_lag": hess_lag()}
    with ThreadPoolExecutor(max_workers=2) as pool:
        hess = pool.submit(hess_lag)
        jac = jac_g()
        return {"jac_g": jac, "hess_lag": hess.result()}


def objective_params(n_objectives: int, weights=None, diameter_weight: float = 0.0,
                     eps=None) -> np.ndarray:
    """The head of every NLP's parameter vector: ``[w_1..w_K, w_D, eps_1..eps_K]``.

    Parameters
    ----------
    n_objectives : int
        K, the objectives in the NLP.
    weights : sequence of float, optional
        Objective weights (default: minimize the first objective).
    diameter_weight : float
        Weight of ``ln D_c`` (the tie-break).
    eps : sequence of float or None, optional
        Epsilon bounds on the objectives (None: :data:`NO_BOUND`).

    Returns
    -------
    ndarray
        ``2 K + 1`` values.
    """
    w = np.zeros(n_objectives)
    if weights is None:
        w[0] = 1.0
    else:
        w[:] = weights
    e = np.full(n_objectives, NO_BOUND) if eps is None else np.asarray(
        [NO_BOUND if v is None else v for v in eps], float)
    return np.concatenate([w, [diameter_weight], e])


def row_name(key) -> str:
    """The name of a constraint row's key.

    Parameters
    ----------
    key : str or Constraint
        A name (the table's rows), or a
        :class:`~isodesign.optimization.constraints.Constraint` (the vertical rows).

    Returns
    -------
    str
    """
    return key if isinstance(key, str) else key.name


def constraint_rows(n_eq: int, constraints) -> tuple[np.ndarray, np.ndarray, list]:
    """Bounds of the constraint rows and where each constraint sits.

    Parameters
    ----------
    n_eq : int
        The implicit equations (``= 0``), first in ``g``.
    constraints : iterable of (key, int, float, float)
        Each constraint's key (its name or its
        :class:`~isodesign.optimization.constraints.Constraint`), rows, lower and upper
        bound, in the order of ``g``.

    Returns
    -------
    lbg, ubg : ndarray
    rows : list of (key, int, int)
        Each constraint's key, first row in ``g`` and number of rows.
    """
    lbg = [0.0] * n_eq
    ubg = [0.0] * n_eq
    rows = []
    row = n_eq
    for key, n, lo, hi in constraints:
        lbg += [lo] * n
        ubg += [hi] * n
        rows.append((key, row, n))
        row += n
    return np.array(lbg), np.array(ubg), rows


def variable_boxes(*blocks) -> tuple[np.ndarray, np.ndarray]:
    """``lbx``, ``ubx`` from blocks of variables in the order of ``x``.

    Parameters
    ----------
    *blocks : (int, float, float)
        Size, lower and upper bound of each block.

    Returns
    -------
    lbx, ubx : ndarray
    """
    lbx = np.concatenate([np.full(int(n), float(lo)) for n, lo, _ in blocks])
    ubx = np.concatenate([np.full(int(n), float(hi)) for n, _, hi in blocks])
    return lbx, ubx


def stacked_bounds(blocks, nz: int, extra_rows: int = 0) -> dict:
    """Bounds of scenario blocks stacked in one NLP sharing the design (the robust NLP).

    The stacked NLP's variables are ``x = [z, w_1 .. w_K, t]`` (the shared scaled design,
    each block's own variables, the worst-case epigraph ``t``) and its rows
    ``g = [g_1 .. g_K, J_k - t (K rows), extra rows]``, the epigraph and extra rows
    ``<= 0``: one layout for the vertical body's block mapped over K scenarios
    (:mod:`.robust`) and the table's scenario NLPs (:mod:`.robust_table`).

    Parameters
    ----------
    blocks : sequence
        The K blocks' NLPs (``lbg``, ``ubg``, ``lbx``, ``ubx``; their first ``nz``
        variables are the shared design).
    nz : int
        The shared design's size.
    extra_rows : int
        Rows after the epigraph rows, ``<= 0`` (an epsilon bound on ``t``).

    Returns
    -------
    dict
        ``lbg``, ``ubg``, ``lbx``, ``ubx``.
    """
    k = len(blocks) + extra_rows
    return {"lbg": np.concatenate([*[b.lbg for b in blocks], np.full(k, -np.inf)]),
            "ubg": np.concatenate([*[b.ubg for b in blocks], np.zeros(k)]),
            "lbx": np.concatenate([blocks[0].lbx[:nz], *[b.lbx[nz:] for b in blocks],
                                   [-EPIGRAPH_BOUND]]),
            "ubx": np.concatenate([blocks[0].ubx[:nz], *[b.ubx[nz:] for b in blocks],
                                   [EPIGRAPH_BOUND]])}


def design_values(ca, X, z, scaling, study) -> list:
    """The spring's four design values on the NLP's variables.

    Parameters
    ----------
    ca : module
        casadi.
    X : type
        ``casadi.SX`` or ``casadi.MX``.
    z : casadi symbol
        The scaled variables (the spring's first, in ``scaling.names`` order).
    scaling : LogScaling
        The spring's log scaling (:func:`~isodesign.optimization.variables.log_scaling`).
    study : Study
        The fixed variables' values.

    Returns
    -------
    list
        In :data:`~isodesign.optimization.variables.DESIGN_VARIABLES` order.
    """
    vals = []
    for name in DESIGN_VARIABLES:
        if name in scaling.names:
            k = scaling.names.index(name)
            vals.append(ca.exp(scaling.center[k] + scaling.half[k] * z[k]))
        else:
            vals.append(X(study.variable(name).start))
    return vals


class NLP:
    """The part of a built NLP that does not depend on its body.

    A subclass sets ``study``, ``objectives``, ``scaling`` (and ``lever_scaling`` with
    ``n_levers`` free levers after the spring in ``z``), ``solver``, ``lbx``, ``ubx``,
    ``lbg``, ``ubg``, ``n_eq``, ``nz``, ``nx``, ``con_rows`` (:func:`constraint_rows`; its
    rows from the constraint registry, :mod:`.constraint_registry`), and defines
    :meth:`objective_values`, :attr:`hessian_info`, :meth:`closure`, :meth:`_fill_guess` and
    :meth:`_param_tail`.
    """

    n_levers = 0

    @property
    def hessian_info(self) -> dict:
        """IPOPT's Hessian of this NLP and why (``hessian``, ``reason``)."""
        raise NotImplementedError

    def hessian_approximation(self) -> str:
        """IPOPT's Hessian of this NLP (``exact`` or ``limited-memory``; :attr:`hessian_info`)."""
        return self.hessian_info["hessian"]

    def closure(self, d, values: dict | None = None):
        """``(sigma, sigma_u)`` of a design from the body's NumPy closure.

        Parameters
        ----------
        d : SpringDesign
        values : dict, optional
            Design-variable values (a table's levers); default their starts.
        """
        raise NotImplementedError

    def _reference_sigma(self):
        """The closure of the study's start design: the scale of the implicit unknowns'
        rows."""
        return self.closure(self.study.start_design())

    def _fill_guess(self, x0: np.ndarray, d, sigma, sigma_u) -> None:
        """Set the implicit unknowns and the dependent variables of ``x0`` (in place)."""
        raise NotImplementedError

    def scaled_design(self, values: dict) -> np.ndarray:
        """The scaled design ``z`` at design values (the spring's, then the free levers'),
        clipped to its box [-1, 1].

        Parameters
        ----------
        values : dict
            Design-variable values (SI); a missing lever at its start.
        """
        nzs = len(self.scaling.names)
        z = np.zeros(nzs + self.n_levers)
        z[:nzs] = np.clip(self.scaling.to_z(values), -1.0, 1.0)
        if self.n_levers:
            lev = {v.name: values.get(v.name, v.start) for v in self.study.levers}
            z[nzs:] = np.clip(self.lever_scaling.to_z(lev), -1.0, 1.0)
        return z

    def initial_guess(self, values: dict) -> np.ndarray:
        """A consistent ``x0`` at a design: the scaled design, the implicit unknowns from the
        body's NumPy closure, the dependent variables (partial sums, epigraphs) tight.

        Parameters
        ----------
        values : dict
            Design-variable values (SI).
        """
        d = self.study.design_at(values)
        sigma, sigma_u = self.closure(d, values)
        x0 = np.zeros(self.nx)
        x0[: self.nz] = self.scaled_design(values)
        self._fill_guess(x0, d, sigma, sigma_u)
        return x0

    def _param_tail(self) -> np.ndarray:
        """The parameters after the objectives' (:func:`objective_params`)."""
        raise NotImplementedError

    def objective_values(self, x: np.ndarray) -> np.ndarray:
        """Internal values J of every objective at ``x``."""
        raise NotImplementedError

    def ipopt_options(self) -> dict:
        """The options given to CasADi's nlpsol (:func:`ipopt_options`)."""
        return ipopt_options(self.study, self.hessian_approximation())

    def params(self, weights=None, diameter_weight: float = 0.0, eps=None) -> np.ndarray:
        """Parameter vector: objective weights (default: minimize the first objective),
        the weight of ``ln D_c``, the epsilon bounds (default: none), then the body's own
        parameters (movable peak frequencies, frozen modes and loop poles).

        Parameters
        ----------
        weights : sequence of float, optional
        diameter_weight : float
        eps : sequence of float or None, optional
        """
        return np.concatenate([objective_params(len(self.objectives), weights,
                                                diameter_weight, eps), self._param_tail()])

    @staticmethod
    def warm_solver_factory(ca, funcs: dict, opts: dict):
        """A function building, on first call, the IPOPT solver of warm re-solves
        (:data:`WARM_OPTIONS`) from the same NLP and derivative functions (no new
        derivatives: CasADi reuses the given ``jac_g`` and ``hess_lag``); shared by the
        shallow copies of a parametric NLP.

        Parameters
        ----------
        ca : module
            CasADi.
        funcs, opts : dict
            The ``nlpsol`` expressions and options of the cold solver.
        """
        built = []

        def get():
            if not built:
                built.append(ca.nlpsol("isodesign_warm", "ipopt", funcs,
                                       {**opts, **WARM_OPTIONS}))
            return built[0]

        return get

    def solve(self, x0: np.ndarray, p=None, warm: Solution | None = None) -> Solution:
        """Run IPOPT from ``x0``.

        Parameters
        ----------
        x0 : ndarray
            Initial point (``initial_guess``).
        p : ndarray, optional
            Parameters (:meth:`params`; default: minimize the first objective).
        warm : Solution, optional
            A solution of the same point (its multipliers): IPOPT is warm-started from
            ``x0`` and its multipliers (:data:`WARM_OPTIONS`). Without multipliers, or an
            NLP without a warm solver, a cold solve.

        Returns
        -------
        Solution
        """
        t0 = time.perf_counter()
        p = self.params() if p is None else np.asarray(p, float)
        solver, extra = self.solver, {}
        get_warm = getattr(self, "_warm_solver", None)
        if (warm is not None and warm.lam_g is not None and get_warm is not None
                and len(warm.lam_g) == len(self.lbg) and len(warm.lam_x) == len(x0)):
            solver, extra = get_warm(), {"lam_x0": warm.lam_x, "lam_g0": warm.lam_g}
        res = solver(x0=x0, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg, p=p,
                     **extra)
        wall = time.perf_counter() - t0
        stats = solver.stats()
        x = np.asarray(res["x"]).ravel()
        g = np.asarray(res["g"]).ravel()
        j_all = self.objective_values(x)
        return Solution(
            x=x, values=self.values(x), objective=float(j_all[0]), objectives=j_all, g=g,
            violations=tuple(self.violations(g)),
            status=stats.get("return_status", "unknown"),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)), wall_s=wall,
            finished_at=t0 + wall,  # perf_counter: system-wide, compares across forked workers
            lam_x=np.asarray(res["lam_x"]).ravel(), lam_g=np.asarray(res["lam_g"]).ravel(),
        )

    def violations(self, g: np.ndarray) -> list[tuple[str, float]]:
        """Worst violation of each constraint group (equalities as ``implicit_equations``).

        Parameters
        ----------
        g : ndarray
            Constraint values.
        """
        out = []
        eq = np.abs(g[: self.n_eq])
        if eq.size:
            out.append(("implicit_equations", float(np.max(eq))))
        for key, row, n in self.con_rows:
            gi = g[row: row + n]
            v = np.maximum(np.maximum(self.lbg[row: row + n] - gi, gi - self.ubg[row: row + n]),
                           0.0)
            out.append((row_name(key), float(np.max(v)) if v.size else 0.0))
        return out

    def values(self, x: np.ndarray) -> dict:
        """Design-variable values at ``x`` (fixed ones from the study).

        Parameters
        ----------
        x : ndarray
        """
        vals = {v.name: v.start for v in self.study.variables}
        nzs = len(self.scaling.names)
        # IPOPT relaxes bounds by ~1e-8: report the design inside its box
        vals.update(self.scaling.to_values(np.clip(x[:nzs], -1.0, 1.0)))
        if self.n_levers:  # the free levers' values (fixed ones: the study's table)
            vals.update(self.lever_scaling.to_values(
                np.clip(x[nzs: nzs + self.n_levers], -1.0, 1.0)))
        return vals

