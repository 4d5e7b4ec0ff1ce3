"""The robust table's search of the scenario box without an NLP build per scenario.

The robust table's exchange (:mod:`.robust_table`) scores a scenario at a design by the
quantities its table NLP checks: the objective ``J`` (minus the worst margin over the
judged points, axes and bands, or the log of the total volume) and every constraint row
(volume, natural frequency, stroke, tilt, layout, loads, peak ``|T|`` on the grid and the
movable frequencies, model validity, the frozen modes' damping and rocking rows). Through
the scenario's compiled NLP (:meth:`.robust_table._Scenarios.check`) that costs a build
of ~0.7 s per scenario met; :func:`score_table_scenario` computes the same numbers from the
product's NumPy analysis of the scenario's study (:func:`.table_scenario.table_scenario`):

* the closure (with ``models.distortion`` its terms: the NLP's outer fixed point's NumPy
  terms, :func:`.distortion_rows.table_distortion_terms`) on the NLP's grid;
* the band mean squares ``sum_a W_a |T_p,ba|^2`` (plus the distortion's ``dB``) from the
  model's outputs at the closure's springs (:func:`isodesign.table.peaks.closure_springs`),
  the margins ``10 log10(limit^2 / ms)``;
* the rows of the registry on the NumPy quantities the table optimizer's re-check uses
  (:func:`.table_constraints.table_quantities`, ``constraint_rows_of(..., TABLE_ROWS)``);
* the frozen-mode rows at the exact modes of the design (the NLP check freezes its modes
  there too: :func:`.table_driver._modes_at`), ``phi^H K phi`` of the 6x6 dynamic stiffness
  (:func:`isodesign.table.assembly.dynamic_stiffness`) at each mode's frequency.

The scenario's TableProblem is constructed (its grid, leveling, geometry, peak cut and
movable frequencies: the NLP's numbers) but not built (:class:`_Measured`). It agrees with
the NLP check to 1e-9 dB in the margin and 1e-9 in every row
(``tests/optimization/test_robust_table_search.py``). The search (:func:`search_box`): the
corners and the centre through the NLP check (as before: their NLPs are the ones the
exchange stacks), ``search_samples`` uniform samples with :func:`score_table_scenario`,
then the best :data:`REFINE` candidates refined by a bounded local maximization (L-BFGS-B,
its gradient by finite differences of the scorer, at most :data:`REFINE_EVALUATIONS`
evaluations each) of the quantity that scored them (docs/robust.md, section 3). The corners
(one map with the samples) and the maximizations run in the forked workers the study allows
(:func:`~.multistart.map_in_workers`),
each task a function of its scenario (or start and quantity) alone: the same worst scenario
as in one process.
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.optimization.mode_rows import mode_row_quantities
from isodesign.optimization.table_problem import TableProblem

__all__ = ["REFINE", "REFINE_EVALUATIONS", "score_table_scenario", "search_box"]

#: Candidates of the search refined by the local maximization (the vertical's ``refine``).
REFINE = 3
#: Evaluations of the scorer per refinement (L-BFGS-B's ``maxfun``, its finite
#: differences included).
REFINE_EVALUATIONS = 40
#: The finite-difference step of the maximization's gradient, a fraction of the box's
#: width (the scorer's closure is solved to 1e-10: its differences carry ~1e-6 of noise).
REFINE_STEP = 1e-4
_LN10 = math.log(10.0)
#: The registry's kinds of the frozen-mode rows (an inactive mode's row is zero).
_MODE_KINDS = ("damping_rows", "min_rocking_frequency", "max_rocking_frequency")


class _Spent(Exception):
    """A refinement's evaluations are spent (:data:`REFINE_EVALUATIONS`)."""


class _Measured(TableProblem):
    """A scenario's TableProblem with its numbers (grid, leveling, geometry, peak cut,
    movable frequencies) and no NLP: ``_build`` does nothing."""

    def _build(self, ca) -> None:  # the NumPy scorer needs no NLP
        return None

    def closure(self, d, values: dict | None = None):
        """The NumPy closure on the NLP's grid, solved once per design (the scorer and
        :func:`.table_constraints.table_quantities` both take it)."""
        key = repr(d) + repr(sorted((values or {}).items()))
        memo = self.__dict__.setdefault("_closures", {})
        if key not in memo:
            memo[key] = super().closure(d, values)
        return memo[key]


def _measured(study, n_slots: int):
    """The unbuilt TableProblem of a scenario's study (with the distortion's NumPy terms
    when ``models.distortion``)."""
    if study.models.get("distortion"):
        from isodesign.optimization.distortion_rows import TableDistortionMixin

        cls = type("_MeasuredDistortion", (TableDistortionMixin, _Measured), {})
        return cls(study, peak_slots=n_slots)
    return _Measured(study, peak_slots=n_slots)


def _excess(value, lo, hi) -> float:
    """The worst signed excess of rows over their bounds (negative: inside)."""
    v = np.atleast_1d(np.asarray(value, float)).ravel()
    if not v.size:
        return -math.inf
    return float(np.max(np.maximum(lo - v, v - hi)))


def _mode_rows(prob, model, springs, modes) -> dict:
    """The frozen-mode rows (damping, rocking frequencies) at ``modes``: the NLP's
    :meth:`~.mode_rows.TableModeRows._damping` in NumPy, its shapes and frequencies the
    modes' (:meth:`~.mode_rows.TableModeRows.set_modes`)."""
    from isodesign.table.assembly import dynamic_stiffness

    c = prob.study.constraints
    zmin = c.get("min_damping_ratio")
    f_lo, f_hi = c.get("min_rocking_frequency_hz"), c.get("max_rocking_frequency_hz")
    if not (zmin or f_lo or f_hi):
        return {}
    prob.set_modes(modes)
    blocks = prob.mode_params.reshape(-1, 14)

    nm = prob.n_modes
    used = (list(range(nm)) if zmin else []) + (list(range(nm, 2 * nm)) if f_lo or f_hi else [])
    # the springs at every block's frequency in one vectorized evaluation
    w = blocks[used, 1]
    kv = springs(w)
    kh = model.horizontal_stiffness(w)
    d, _ = dynamic_stiffness(model.geometry, kv, kh, np.zeros(w.size))
    kr = np.asarray(d.re, float).reshape(-1, 6, 6)
    ki = np.asarray(d.im, float).reshape(-1, 6, 6)
    q = {}
    for j, b in enumerate(used):
        phi = blocks[b, 2:8] + 1j * blocks[b, 8:14]
        q[b] = (blocks[b, 0], float(np.real(np.vdot(phi, kr[j] @ phi))),
                float(np.real(np.vdot(phi, ki[j] @ phi))))
    damping = [q[b] for b in range(nm)] if zmin else []
    rocking = [q[b][:2] for b in range(nm, 2 * nm)] if (f_lo or f_hi) else []
    return mode_row_quantities(c, damping, rocking, fmax=max, stack=np.array)


def score_table_scenario(study, theta, values: dict, reference: float | None, *,
                         n_slots: int = 0, slot_hz=None) -> dict:
    """A table scenario's objective and constraint rows at a design, without its NLP.

    The numbers :meth:`.robust_table._Scenarios.check` takes from the scenario's compiled
    NLP at its NumPy initial guess, from the NumPy analysis alone (the module docstring).

    Parameters
    ----------
    study : Study
        A table study with ``[scenarios]``.
    theta : array
        The scenario (``study.scenarios.names`` order).
    values : dict
        The design (SI values by variable name).
    reference : float or None
        The stated worst-case ``J`` (``gap`` is measured from it).
    n_slots : int
        The scenario NLP's movable peak frequencies (its peak rows at them).
    slot_hz : array, optional
        Where they are (default: unused, the grid's first frequency, as a new NLP's).

    Returns
    -------
    dict
        ``j`` (the NLP's objective: minus the worst judged margin in dB, or the log of the
        total volume), ``margin_db`` (worst judged margin), ``violations`` (``(row name,
        violation >= 0)`` per constraint group, the NLP's rows without the objective's
        epigraph and bound rows and without the closure's equations, which the NumPy
        closure solves), ``excess`` (row name -> worst signed excess, negative inside),
        ``max_violation``, ``gap`` (``j - reference`` or None).
    """
    from isodesign.optimization.constraint_registry import TABLE_ROWS, constraint_rows_of
    from isodesign.optimization.nlp import row_name
    from isodesign.optimization.table_constraints import table_quantities
    from isodesign.optimization.table_driver import _modes_at, _with_gain
    from isodesign.optimization.table_scenario import table_scenario
    from isodesign.table.model import table_model
    from isodesign.table.peaks import closure_springs
    from isodesign.table.response import band_mean_square

    st = table_scenario(study, theta)
    prob = _measured(st, n_slots)
    if slot_hz is not None and prob.n_slots:
        prob.set_slots(slot_hz)
    d = st.design_at(values)
    sigma, sigma_u = prob.closure(d, values)
    sig_u = _with_gain(prob, d, sigma_u, values)  # the NLP's springs (distortion's gain)
    model = table_model(d, st.table_at(values), flow=prob.flow,
                        amplitude_mode=st.models["amplitude_mode"], diaphragm=prob.dia)
    springs = closure_springs(model, sigma, sig_u)
    g = prob.grid
    out = model.outputs(springs(g.omega), g.omega)
    ms = band_mean_square(g, out.points)  # (k, 3, nb), the analysis' own
    if getattr(prob, "distortion", False):
        n = prob.n
        ms = ms + np.asarray(prob.distortion_terms(d, values)[3 * n:], float).reshape(ms.shape)
    lim2 = np.asarray(g.limit_velocity_m_s, float) ** 2
    margins = (10.0 / _LN10) * (np.log(lim2)[None, None, :] - np.log(ms))
    judged = margins[np.ix_(list(prob.objective_points), list(prob.objective_axes))]
    margin = float(np.min(judged))
    kind = prob.objective
    if kind == "worst_band_margin":
        j = -margin
    elif kind == "total_volume":
        if prob.grouped:
            j = math.log(sum(di.total_volume_m3 for di in model.designs) / prob.n)
        else:
            j = math.log(d.total_volume_m3)
    else:  # the robust table takes no free levers: no footprint or added mass objective
        raise InputError(f"objective.kind: {kind!r} has no scenario scorer")
    q = table_quantities(prob, values)
    c = st.constraints
    if c.get("min_damping_ratio") or c.get("min_rocking_frequency_hz") or \
            c.get("max_rocking_frequency_hz"):  # the frozen modes' rows: the exact modes
        q.update(_mode_rows(prob, model, springs, _modes_at(prob, d, sigma, sigma_u,
                                                            values=values, side_by_side=True)))
    excess, viol = {}, []
    for row in constraint_rows_of(st, q, TABLE_ROWS):
        name = row_name(row.key)
        v = np.atleast_1d(np.asarray(row.expr, float)).ravel()
        if row.kind in _MODE_KINDS:  # an inactive mode's row is 0 (act = 0): no quantity
            v = v[v != 0.0]
        e = _excess(v, row.lo, row.hi)
        excess[name] = max(excess.get(name, -math.inf), e)
    for name, e in excess.items():
        viol.append((name, max(e, 0.0)))  # 0 for a group with no active row
    return {"j": j, "margin_db": margin, "violations": viol, "excess": excess,
            "max_violation": max((v for _, v in viol), default=0.0),
            "gap": None if reference is None else j - reference}


def _score(c: dict, tol: float, feas_tol: float) -> tuple:
    """(largest excess over its tolerance, which quantity) of a scenario's check."""
    items = [(c["gap"] / tol, "objective")]
    items += [(v / feas_tol, f"constraint:{n}") for n, v in c["violations"]]
    return max(items, key=lambda r: r[0])


def _refined_quantity(c: dict, tol: float, feas_tol: float) -> str:
    """The quantity a refinement raises from a scorer's check: the largest signed excess
    over its tolerance (a constraint inside its bounds too, so that the maximization has
    a slope; the closure's equations are no quantity of the scorer)."""
    items = [(c["gap"] / tol, "objective")]
    items += [(e / feas_tol, f"constraint:{n}") for n, e in c["excess"].items()]
    return max(items, key=lambda r: r[0])[1]


def _quantity(c: dict, which: str, tol: float, feas_tol: float) -> float:
    """The signed quantity the local maximization raises (scaled as the score)."""
    if which == "objective":
        return c["gap"] / tol
    name = which.split(":", 1)[1]
    exc = c.get("excess")
    if exc is not None and name in exc:
        return exc[name] / feas_tol
    return dict(c["violations"]).get(name, 0.0) / feas_tol


def search_box(study, values: dict, reference: float, check, corners, *, samples: int,
               seed: int, tol: float, feas_tol: float, n_slots: int,
               refine: int = REFINE, max_evaluations: int = REFINE_EVALUATIONS) -> dict:
    """The robust table's search of the box at a design (the module docstring).

    Parameters
    ----------
    study : Study
        A table study with ``[scenarios]``.
    values : dict
        The design.
    reference : float
        The stated worst-case ``J``.
    check : callable
        ``check(theta, values, reference) -> dict``: the NLP check of a corner
        (:meth:`.robust_table._Scenarios.check`).
    corners : array (m, p)
        The corners and the centre (scored by ``check``).
    samples : int
        Uniform samples scored by :func:`score_table_scenario`; 0: the corners and the
        centre alone, no local maximization.
    seed : int
        The samples' seed (``numpy.random.default_rng(seed)``).
    tol, feas_tol : float
        The objective's and the constraints' tolerances (the score is the largest excess
        over them).
    n_slots : int
        The scenario NLP's movable peak frequencies.
    refine : int
        How many of the best candidates are refined.
    max_evaluations : int
        Scorer evaluations per refinement.

    Returns
    -------
    dict
        ``score``, ``theta``, ``which`` (the quantity), ``check`` (of the worst),
        ``source`` (``"corner"``, ``"sample"`` or ``"refined"``) and ``evaluations``
        (``corners``, ``samples``, ``refinement`` and ``refinements``).
    """
    from functools import partial

    from isodesign.optimization.multistart import map_in_workers

    space = study.scenarios
    workers = int(study.solver.get("workers", 1) or 1)

    def sample(th):  # the scorer's check of scenario th at this design
        return score_table_scenario(study, th, values, reference, n_slots=n_slots)

    def scored_by(item):  # a corner by ``check``, a sample by the scorer
        kind, th = item
        return check(th, values, reference) if kind == "corner" else sample(th)

    # the corners, the centre and the samples in the workers, in one map (map_in_workers:
    # the same checks as in this process, in item order)
    items = [("corner", np.asarray(th, float)) for th in corners]
    if samples > 0:
        items += [("sample", th) for th in space.box_samples(samples,
                                                            np.random.default_rng(seed))]
    scored = []
    for (kind, th), c in zip(items, map_in_workers(scored_by, items, workers=workers),
                             strict=True):
        s, which = _score(c, tol, feas_tol)
        scored.append((s, which, th, c, kind))
    n_ref = 0
    n_runs = 0
    if samples > 0:
        lo, hi = space.lower(), space.upper()
        cont = np.array([not p.discrete for p in space.parameters])
        width = np.where(hi > lo, hi - lo, 1.0)
        order = sorted(range(len(scored)), key=lambda k: -scored[k][0])
        best = scored[order[0]]
        runs, seen = [], []  # the candidates refined: (theta, quantity), best first
        for k in order[: max(3 * refine, refine)]:
            if len(seen) >= refine or not cont.any():
                break
            _s0, _, th0, c0, _ = scored[k]
            if "excess" not in c0:  # a corner's NLP check: its signed excesses
                c0 = sample(th0)
                n_ref += 1
            which = _refined_quantity(c0, tol, feas_tol)
            key = (which, tuple(np.round((th0 - lo) / width, 2)))
            if key in seen:
                continue
            seen.append(key)
            runs.append((th0, which))
        n_runs = len(runs)
        refine_run = partial(_refine_run, sample, lo=lo, width=width, cont=cont, tol=tol,
                             feas_tol=feas_tol, max_evaluations=max_evaluations)
        for evals, top in map_in_workers(refine_run, runs, workers=workers):
            n_ref += evals
            if top is None:
                continue
            th, c = top
            s, w2 = _score(c, tol, feas_tol)
            if s > best[0]:
                best = (s, w2, th, c, "refined")
    else:
        best = max(scored, key=lambda r: r[0])
    return {"score": best[0], "which": best[1], "theta": best[2], "check": best[3],
            "source": best[4],
            "evaluations": {"corners": len(corners), "samples": int(max(samples, 0)),
                            "refinement": n_ref, "refinements": n_runs}}


def _refine_run(sample, run, *, lo, width, cont, tol, feas_tol, max_evaluations) -> tuple:
    """One refinement: L-BFGS-B from ``theta`` raising ``which`` (``run``), at most
    ``max_evaluations`` evaluations of ``sample`` (the scorer at the search's design), its
    finite differences included. Returns ``(evaluations, (theta, check) of the largest
    quantity met, or None)``."""
    from scipy.optimize import minimize

    th0, which = run
    tried: list = []  # (quantity, theta, check) of every evaluation

    def f(u):
        if len(tried) >= max_evaluations:  # the cap, finite differences included
            raise _Spent
        th = th0.copy()
        th[cont] = lo[cont] + np.clip(u, 0.0, 1.0) * width[cont]
        try:
            c = sample(th)
        except (InputError, SolverError, FloatingPointError, ValueError):
            tried.append((-math.inf, th, None))
            return 1e300  # a scenario the analysis cannot close: not a maximum
        q = _quantity(c, which, tol, feas_tol)
        tried.append((q, th, c))
        return -q

    u0 = (th0[cont] - lo[cont]) / width[cont]
    try:
        minimize(f, u0, method="L-BFGS-B", bounds=[(0.0, 1.0)] * int(cont.sum()),
                 options={"maxfun": max_evaluations, "eps": REFINE_STEP})
    except _Spent:
        pass
    # the largest quantity met (L-BFGS-B's answer, or the best before the cap)
    _, th, c = max(tried, key=lambda t: t[0], default=(None, None, None))
    return len(tried), (None if c is None else (th, c))
