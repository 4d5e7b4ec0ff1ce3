"""The NumPy re-check of the NLP's optimum, and designs evaluated on the NumPy path."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import SolverError
from isodesign.optimization.analyze import vertical_stroke_rms
from isodesign.optimization.constraint_registry import CONSTRAINTS
from isodesign.optimization.constraints import build_constraints
from isodesign.optimization.grid import build_grid
from isodesign.optimization.metrics import metrics, statistical
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR
from isodesign.spring.amplitude import solve_velocity_amplitude
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import kinematic_velocity
from isodesign.spring.gas import P_ATM

__all__ = ["RECHECK_RTOL", "RECHECK_VIOLATION_TOL", "RowRecheck", "evaluate_design", "recheck",
           "recheck_design", "recheck_rows"]

#: Agreement required between the NLP and the NumPy re-check: relative, and absolute
#: (dB) for the objectives in dB.
RECHECK_RTOL = 1e-6
_METRIC_KEYS = ("stroke_variance", "tube_velocity_variance", "ln_ms_band", "ln_T2_peak",
                "ln_total_volume", "ln_tilt", "ln_lumped", "ln_plane_wave", "ln_fn", "ln_zeta",
                "ln_mach", "ln_re", "ln_T2_point")
#: A re-checked row breaks its bound when its NumPy value lies outside it by more than this,
#: in the row's units (a log, ``ln |T|^2``: a relative excess of the quantity; a given row's
#: own, relative to the bound where it exceeds 1 in magnitude).
RECHECK_VIOLATION_TOL = 1e-6


@dataclass(frozen=True)
class RowRecheck:
    """The NumPy re-check of an optimum's constraint rows (:func:`recheck_rows`).

    Attributes
    ----------
    rows : tuple of (str, str, float, float)
        Each re-checked row (a vector constraint once): its key (the NLP's row name), its
        registry kind, the largest difference between its NumPy and NLP values (a log or
        ``ln |T|^2`` row: absolute, a relative difference of the quantity; a given row in its
        own unit: relative to the value where it exceeds 1 in magnitude), and its NumPy
        value's worst violation of its bounds (0 when inside; a given row's relative to the
        bound where it exceeds 1 in magnitude).
    max_difference : float
        The largest difference over the rows (and, from :func:`recheck_design` and the
        table driver, the closure and the objectives).
    violations : tuple of (str, float)
        The rows whose NumPy value breaks a bound by more than
        :data:`RECHECK_VIOLATION_TOL`: their kind's name (the key for a given row) and the
        violation, in the row's units.
    unchecked : tuple of str
        The NLP's rows without a NumPy quantity (the frozen-mode and loop rows, reported
        from the exact modes and loop; the objectives' epigraph rows).
    """

    rows: tuple
    max_difference: float
    violations: tuple
    unchecked: tuple = ()

    def merged(self, difference: float) -> RowRecheck:
        """This re-check with a further difference (the closure's, an objective's) folded
        into :attr:`max_difference`.

        Parameters
        ----------
        difference : float
        """
        return RowRecheck(self.rows, max(self.max_difference, float(difference)),
                          self.violations, self.unchecked)


def _label_key(label) -> str:
    """The row key of an entry of ``con_rows`` (a Constraint, or its key)."""
    return getattr(label, "key", None) or getattr(label, "name", None) or str(label)


def recheck_rows(numpy_rows, con_rows, g, *, tol: float = RECHECK_RTOL,
                 what: str = "optimization") -> RowRecheck:
    """Re-check an optimum's constraint rows: each row's NumPy value against its NLP value
    and its bounds. The one re-check of every body (docs/optimization.md, "The NumPy
    re-check").

    Parameters
    ----------
    numpy_rows : list of Constraint
        The registry's rows on the NumPy analysis's quantities
        (:func:`~.constraint_registry.constraint_rows_of`,
        :func:`~.constraint_registry.vertical_rows`), with their bounds.
    con_rows : sequence of (label, int, int)
        The NLP's rows: each constraint (a :class:`~.constraint_registry.Constraint` or its
        key), its first row in ``g`` and its number of rows.
    g : ndarray
        The NLP's constraint values at the optimum.
    tol : float
        The agreement required (:data:`RECHECK_RTOL`).
    what : str
        The optimizer's name in the error message.

    Returns
    -------
    RowRecheck

    Raises
    ------
    SolverError
        When a row's NumPy value and its NLP value disagree by more than ``tol`` (a bug,
        never a silently wrong design), or a row has a different size.
    """
    g = np.asarray(g, float).ravel()
    by_key = {}
    for c in numpy_rows:
        by_key.setdefault(c.key, c)
    rows, viols, unchecked, bad = [], [], [], []
    worst = 0.0
    for label, row, n in con_rows:
        key = _label_key(label)
        c = by_key.get(key)
        if c is None:
            unchecked.append(key)
            continue
        v = np.atleast_1d(np.asarray(c.expr, float)).ravel()
        if v.size != n:
            raise SolverError(f"{what}: the NumPy re-check of {key} has {v.size} rows, the "
                              f"NLP {n}")
        gi = g[row: row + n]
        # a log or ln |T|^2 row: absolute (a relative difference of the quantity); a given
        # row in its own unit (m, kN, bar): relative where it exceeds 1 in magnitude
        given = c.kind not in CONSTRAINTS or CONSTRAINTS[c.kind].form == "given"
        diff = float(np.max(np.abs(v - gi) / (np.maximum(1.0, np.abs(v)) if given else 1.0))) \
            if n else 0.0
        scale_lo = max(1.0, abs(c.lo)) if given and np.isfinite(c.lo) else 1.0
        scale_hi = max(1.0, abs(c.hi)) if given and np.isfinite(c.hi) else 1.0
        out = np.maximum(np.maximum((c.lo - v) / scale_lo, (v - c.hi) / scale_hi), 0.0)
        viol = float(np.max(out)) if n else 0.0
        name = c.kind if c.kind and c.kind not in ("layout", "loads") else key
        rows.append((key, c.kind, diff, viol))
        worst = max(worst, diff)
        if not diff <= tol:
            bad.append(f"{key} {diff:.2e}")
        if viol > RECHECK_VIOLATION_TOL:
            viols.append((name, viol))
    if bad:
        raise SolverError(f"{what}: the NLP optimum disagrees with the NumPy analysis's "
                          f"constraint rows (> {tol:g}: {', '.join(bad)}); the design is not "
                          "returned")
    return RowRecheck(tuple(rows), worst, tuple(viols), tuple(unchecked))


def recheck(prob, sol, d) -> float:
    """Re-evaluate the optimum with the NumPy analysis path; return the max rel. diff.

    :func:`recheck_design`'s :attr:`RowRecheck.max_difference` (the same checks; a design
    whose re-checked rows break a bound is the caller's to report, with
    :func:`recheck_design`).

    Parameters
    ----------
    prob : Problem
    sol : Solution
    d : SpringDesign

    Returns
    -------
    float

    Raises
    ------
    SolverError
        When they disagree.
    """
    return recheck_design(prob, sol, d).max_difference


def recheck_design(prob, sol, d) -> RowRecheck:
    """Re-evaluate the vertical optimum with the NumPy analysis path.

    The NumPy path solves sigma and the velocity amplitudes with its own
    solvers (not the NLP's values) and evaluates :func:`.metrics.metrics` on them.
    Every constraint quantity must agree with the NLP's solution, and the objective
    IPOPT reports (epigraph variables included) with the analysis's, to
    :data:`RECHECK_RTOL`: relative, except the objectives in dB, compared in dB
    with :data:`RECHECK_RTOL` as an absolute tolerance (the unit from the
    objective registry, :data:`~.objectives.OBJECTIVES`).

    Parameters
    ----------
    prob : Problem
        The NLP that produced ``sol``, with its movable peak frequencies where the
        refinement left them (the re-check evaluates on the same grid).
    sol : Solution
        The NLP's optimum: its ``x`` gives the NLP's design, ``ln sigma`` and
        ``ln sigma_u`` (statistical closure) or, self-consistent mode of the harmonic
        closure, ``ln U`` at every grid frequency; its ``objectives`` the internal values J.
    d : SpringDesign
        The design at the optimum (``study.design_at(sol.values)``), on which the
        NumPy path solves sigma and the velocities afresh.

    Every constraint row of the NLP is then re-checked by :func:`recheck_rows` (the one
    re-check of both bodies): the registry's rows on the NumPy metrics
    (:func:`~.constraints.build_constraints`, the NLP's own call) against the NLP's ``g``
    and the bounds.

    Returns
    -------
    RowRecheck
        ``max_difference``, the largest relative difference found:
        ``|sigma_np / sigma_nlp - 1|`` (and the same for ``sigma_u``); for
        each metric ``|exp(a - b) - 1|`` on the ``ln_*`` quantities (a relative
        difference of the quantity itself) and ``|a / b - 1|`` otherwise, worst over
        the vector's rows; for each objective in natural units, ``|v_nlp - v_np|``
        (dB) for an objective in dB and ``|v_nlp - v_np| / |v_np|`` for the others
        (``rms_velocity`` in m/s, ``total_volume`` in m^3).

    Raises
    ------
    SolverError
        When they disagree (a bug, never a silently wrong design).
    """

    st = prob.study
    sigma, sigma_u = prob.closure(d)
    u = None if prob.statistical else prob.velocity(d, sigma)
    # the distortion power (an NLP that carries it, :mod:`.distortion_rows`): the NumPy
    # terms at d against the terms the NLP used at its answer
    carried = getattr(prob, "distortion", False)
    dist_np = prob.distortion_terms(d) if carried else None
    mt_np = metrics(st, prob.grid, d, u, sigma, diaphragm=prob.dia, tube_rms=sigma_u,
                    distortion=dist_np)
    # the same quantities from the NLP's solution
    x = sol.x
    d_nlp = st.design_at(prob.values(x))
    sig_nlp = prob.sigma(x)
    if prob.statistical:
        u_nlp = None
    elif prob.self_consistent:
        u_nlp = np.exp(x[prob.nz + 1: prob.nz + 1 + prob.ny])
    else:
        u_nlp = prob.velocity(d_nlp, sig_nlp)
    mt_nlp = metrics(st, prob.grid, d_nlp, u_nlp, sig_nlp, diaphragm=prob.dia,
                     tube_rms=prob.tube_rms(x),
                     distortion=prob.nlp_terms(x, sol.outer_params) if carried else None)
    worst = abs(sigma / sig_nlp - 1.0)
    if prob.statistical:
        worst = max(worst, abs(sigma_u / prob.tube_rms(x) - 1.0))
    names = []
    for key in _METRIC_KEYS:
        if key not in mt_np:
            continue
        a = np.asarray(mt_np[key], float)
        b = np.asarray(mt_nlp[key], float)
        rel = np.abs(np.expm1(a - b)) if key.startswith("ln_") else np.abs(a / b - 1.0)
        m = float(np.max(rel)) if rel.size else 0.0
        names.append((key, m))
        worst = max(worst, m)
    # the objective IPOPT reports (epigraph variables included) against the analysis
    for k, kind in enumerate(prob.objectives):
        obj = OBJECTIVES[kind]
        v_nlp = obj.to_natural(float(sol.objectives[k]))
        v_np = obj.value(mt_np, st, prob.grid)
        # absolute in dB; relative in any other unit (m/s, m^3: values far below 1)
        m = abs(v_nlp - v_np) if obj.db else abs(v_nlp - v_np) / abs(v_np)
        names.append((f"objective {kind}", m))
        worst = max(worst, m)
    if not worst <= RECHECK_RTOL:
        bad = ", ".join(f"{k} {v:.2e}" for k, v in names if v > RECHECK_RTOL)
        raise SolverError(
            f"the NLP optimum disagrees with the NumPy analysis (max relative difference "
            f"{worst:.2e} > {RECHECK_RTOL:g}: {bad or 'sigma'}); the design is not returned"
        )
    rows = recheck_rows(build_constraints(st, mt_np, prob.grid.omega.size), prob.con_rows,
                        sol.g, what="vertical optimization")
    return rows.merged(worst)


def evaluate_design(study, values: dict, *, grid=None, objectives: tuple = ()) -> dict:
    """Objective and constraint values of a design on the NumPy analysis path.

    The same :func:`.metrics.metrics` the NLP uses, with sigma and the tube velocities
    from the NumPy solvers. Used by the re-check, by the comparison with
    gradient-free optimizers (benchmarks) and by studies.

    Parameters
    ----------
    study : Study
    values : dict
        Design-variable values (SI): ``volume_ratio`` (-), ``top_volume_m3``,
        ``capillary_length_m``, ``capillary_diameter_m``; missing or fixed ones
        take the study's start values.
    grid : Grid, optional
        The frequency grid; default :func:`.grid.build_grid` of the study and the
        objectives asked for (fixed peak grid, no movable frequencies; the one
        frequency of ``transmissibility_at`` appended when asked for, at the
        study's ``objective.frequency_hz``, else
        :data:`~.grid.DEFAULT_POINT_FREQUENCY_HZ`). A grid passed in must carry
        that frequency itself.
    objectives : tuple of str
        Objective kinds to evaluate; default the study's own.

    Returns
    -------
    dict
        ``objectives`` (kind -> natural value: dB, m/s or m^3); ``constraints``
        (name -> ``value``, the expression at every row as an array in the NLP's
        log or dB units, ``lower``, ``upper`` and ``violation``, the worst row's
        distance outside the bounds); ``max_violation`` (the largest violation, NLP
        units); ``sigma`` (RMS stroke, m), ``tube_rms`` (``sigma_u`` of the statistical
        closure, m/s, else ``None``) and ``metrics`` (the metrics dict).

    Notes
    -----
    sigma solves ``sigma^2 = sum_j w_j |T_j - 1|^2`` on the study's symmetric table
    (:func:`.analyze.vertical_stroke_rms`: its z DOF,
    :func:`isodesign.response.random_input.solve_stroke_rms`). With the statistical
    closure (``models.random_method``, the default) ``sigma_u`` is solved with it and the
    capillary's nonlinear drop is its Gaussian-equivalent resistance there; with
    ``equivalent_amplitude`` the stiffness is at ``A* = 1.880 sigma`` and the tube velocity
    amplitudes at ``A*`` are self-consistent
    (:func:`isodesign.spring.amplitude.solve_velocity_amplitude`) or kinematic, as
    ``models.amplitude_mode`` says. With ``models.distortion = true`` the closure carries
    the distortion power (:func:`.distortion_rows.vertical_distortion_terms`: the
    problem the optimizer's NLP solves).
    """

    kinds = tuple(objectives) or (study.objective["kind"],)
    # the grid carries the one extra frequency of a one-frequency objective asked for
    grid = grid or build_grid(study, objectives=kinds)
    d = study.design_at(values)
    dia = diaphragm_model(study.models["diaphragm"])
    stat = statistical(study)
    # the closure of the study's symmetric table (its z DOF; docs/table.md, section 14)
    theta = getattr(study, "theta", None) or {}
    terms = None
    if stat and study.models.get("distortion"):  # the closure with its distortion power
        from isodesign.optimization.distortion_rows import vertical_distortion_terms

        sigma, sigma_u, terms = vertical_distortion_terms(study, grid, dia, d)
        info = {"tube_velocity_rms_m_s": sigma_u}
    else:
        sigma, info = vertical_stroke_rms(
            d, study.payload, grid.response, flow=study.models["flow"],
            amplitude_mode=study.models["amplitude_mode"], diaphragm=dia,
            random_method="statistical" if stat else "equivalent_amplitude",
            p_atm_pa=float(theta.get("ambient_pressure_pa", P_ATM)))
    a = EQUIVALENT_AMPLITUDE_FACTOR * sigma
    if stat:
        u = None
    elif study.models["amplitude_mode"] == "self_consistent":
        u = solve_velocity_amplitude(study.models["flow"], d, grid.omega, a).velocity
    else:
        u = kinematic_velocity(d, grid.omega, a)
    mt = metrics(study, grid, d, u, sigma, diaphragm=dia,
                 tube_rms=info.get("tube_velocity_rms_m_s"), distortion=terms)
    objs = {kind: OBJECTIVES[kind].value(mt, study, grid)
            for kind in kinds}
    cons = {}
    worst = 0.0
    for c in build_constraints(study, mt, grid.omega.size):
        v = np.atleast_1d(np.asarray(c.expr, float))
        viol = np.maximum(np.maximum(c.lo - v, v - c.hi), 0.0)
        cons[c.name] = {"value": v, "lower": c.lo, "upper": c.hi,
                        "violation": float(np.max(viol))}
        worst = max(worst, float(np.max(viol)))
    return {"objectives": objs, "constraints": cons, "max_violation": worst, "sigma": sigma,
            "tube_rms": info.get("tube_velocity_rms_m_s"), "metrics": mt, "distortion": terms}
