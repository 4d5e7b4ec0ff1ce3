"""Optimize a table study in three axes: multi-start, mode refresh, re-check, analysis.

:func:`optimize_table` runs the :class:`~isodesign.table.problem.TableProblem` from the
study's start and Latin-hypercube starts (the vertical optimizer's
:func:`~isodesign.optimization.multistart.run_starts`), keeps the best feasible start, and
then:

1. **Mode refresh.** The damping constraint holds on the modes below 5 Hz with shapes and
   frequencies frozen at the last nonlinear-eigenproblem solution. The modes are solved
   again at the optimum (springs linearized at its closure); while one of them misses the
   damping bound and the frozen shapes or frequencies moved (shape correlation < 0.999 or
   frequency by > 0.1 %), the NLP is solved again from the optimum with the new modes (at
   most three rounds).
2. **Re-check.** The NumPy closure (:func:`~isodesign.table.response.solve_table_closure`)
   at the optimum on the NLP's grid must give the NLP's stroke RMS values to 1e-6 and its
   worst margin to 1e-6 dB, else :class:`~isodesign.errors.SolverError`.
3. **Analysis.** The band response on the fine grid (50 points per band), the modes and
   the rocking stability of the optimum and of the start.

Derivatives: the gradient and the constraint Jacobian are exact (CasADi AD); the Hessian of
the Lagrangian is IPOPT's limited-memory quasi-Newton approximation (:data:`HESSIAN`): the
exact Hessian through the mapped 6x6 solve gives the same optimum at several times the cost
(``benchmarks/bench_table.py`` times both).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.optimization.multistart import run_starts, start_points
from isodesign.response.linearization import equivalent_amplitude
from isodesign.results import ResultDisplay
from isodesign.spring.capillary import statistical_resistance_function
from isodesign.spring.equations import air_stiffness, spring_stiffness

__all__ = ["HESSIAN", "TableOptimizationResult", "closure_springs", "optimize_table"]

#: IPOPT's Hessian of the table NLP (``exact`` or ``limited-memory``).
HESSIAN = "limited-memory"
#: Agreement required of the NumPy re-check (relative on sigma, dB on the margin).
RECHECK_TOL = 1e-6
_MODE_ROUNDS = 3


def closure_springs(model, sigma, sigma_u):
    """``omega -> [Cx]``: each isolator's vertical spring linearized at a closure state.

    Parameters
    ----------
    model : TableModel
    sigma, sigma_u : ndarray (n,)
        Stroke and tube-velocity RMS per isolator.
    """
    from isodesign.spring.diaphragm import diaphragm_model

    dia = diaphragm_model(model.diaphragm)

    def springs(omega):
        w = np.asarray(omega, float)
        out = []
        for i, d in enumerate(model.designs):
            c = statistical_resistance_function(model.flow, d, w)(float(sigma_u[i]))
            out.append(spring_stiffness(air_stiffness(d, w, c, model.flow),
                                        dia.stiffness(w, equivalent_amplitude(float(sigma[i])))))
        return out

    return springs


@dataclass(frozen=True, eq=False, repr=False)
class TableOptimizationResult(ResultDisplay):
    """The optimum of a table study, its checks and its analysis.

    Attributes
    ----------
    study : Study
    feasible : bool
    status : str
        IPOPT's status of the final solve.
    values : dict
        Design-variable values (SI).
    design : SpringDesign
    objective : str
    objective_value : float
        Worst margin (dB) or total volume (m^3) at the optimum (the NLP's grid).
    start_objective : float or None
    starts : tuple
        ``(index, status, feasible, iterations, wall_s, objective)`` per start.
    n_reached_best : int
    constraints : tuple
        ``(name, worst violation)`` per constraint group at the optimum.
    mode_rounds : int
        NLP solves after the first (mode refreshes).
    recheck_sigma_rel, recheck_margin_db : float
        NumPy re-check differences.
    analysis, start_analysis : TableBandResponse or None
        Fine-grid band responses.
    modes, start_modes : TableModes or None
        At the closure state of each design.
    stability : RockingStability or None
    wall_s : float
    hessian : str
    """

    study: Any
    feasible: bool
    status: str
    values: dict
    design: Any
    objective: str
    objective_value: float
    start_objective: float | None
    starts: tuple
    n_reached_best: int
    constraints: tuple
    mode_rounds: int
    recheck_sigma_rel: float
    recheck_margin_db: float
    analysis: Any = None
    start_analysis: Any = None
    modes: Any = None
    start_modes: Any = None
    stability: Any = None
    wall_s: float = 0.0
    hessian: str = HESSIAN

    def raise_for_status(self) -> TableOptimizationResult:
        """Raise :class:`~isodesign.errors.SolverError` unless feasible; return self."""
        if not self.feasible:
            raise SolverError(f"table optimization: no feasible design (IPOPT: {self.status}); "
                              f"violations: {self.constraints}")
        return self

    def to_frame(self):
        """One row per design variable: start and optimum."""
        import pandas as pd

        start = {v.name: v.start for v in self.study.variables}
        return pd.DataFrame({"variable": list(self.values),
                             "start": [start[k] for k in self.values],
                             "optimum": list(self.values.values())})  # fmt: skip

    def _summary_items(self) -> list[tuple[str, str]]:
        items = [("", "feasible" if self.feasible else "INFEASIBLE"),
                 ("objective", f"{self.objective} {self.objective_value:.4g}"),
                 ("starts at best", f"{self.n_reached_best} of {len(self.starts)}"),
                 ("wall", f"{self.wall_s:.3g} s")]
        if self.analysis is not None:
            items.append(("analysis", self.analysis.verdict()))
        return items


def optimize_table(study, *, workers=None, analyze: bool = True, progress=None,
                   problem=None) -> TableOptimizationResult:
    """Optimize the isolators of a table study in three axes.

    Parameters
    ----------
    study : Study
        With a ``[table]``.
    workers : int, optional
        Worker processes for the starts (default the study's ``solver.workers``).
    analyze : bool
        Run the fine-grid analyses of the optimum and the start (default).
    progress : callable, optional
        ``progress(done, total, result)`` after each start.
    problem : TableProblem, optional
        A prebuilt NLP of the study.

    Returns
    -------
    TableOptimizationResult

    Raises
    ------
    SolverError
        The NLP's optimum and the NumPy closure disagree (a bug, never a silently wrong
        design), or no start could be initialized.
    """
    from isodesign.table.problem import TableProblem

    if getattr(study, "table", None) is None:
        raise InputError("study: has no [table]; use isodesign.optimize")
    t0 = time.perf_counter()
    prob = problem if problem is not None else TableProblem(study, hessian=HESSIAN)
    starts = start_points(study, prob.scaling)
    d0 = study.design_at(starts[0])
    modes0 = _modes_at(prob, d0)
    prob.set_modes(modes0)
    outs = run_starts(prob, starts, workers=workers or study.solver.get("workers"),
                      progress=progress)
    recs, good = [], {}
    for i, out in enumerate(outs):
        if isinstance(out, str):
            recs.append((i, f"initial guess failed: {out}", False, 0, 0.0, math.nan))
            continue
        recs.append((i, out.status, out.feasible, out.iterations, out.wall_s, out.objective))
        if out.feasible:
            good[i] = out
    cand = [o for o in outs if not isinstance(o, str)]
    if not cand:
        raise SolverError("table optimization: no start could be initialized")
    best = min(good.values(), key=lambda s: s.objective) if good else \
        min(cand, key=lambda s: s.max_violation)
    n_best = sum(1 for s in good.values() if abs(s.objective - best.objective) <= 1e-4)
    rounds = 0
    modes = None
    zmin = study.constraints.get("min_damping_ratio") or 0.0
    while best.feasible and rounds < _MODE_ROUNDS:
        modes = _modes_at(prob, study.design_at(best.values), prob.sigma(best.x),
                          prob.tube_rms(best.x))
        low = np.isfinite(modes.frequency_hz) & (modes.frequency_hz < 5.0)
        rock = modes.energy_fraction[:, 3:5].sum(axis=1) >= 0.3
        f_lo = study.constraints.get("min_rocking_frequency_hz") or 0.0
        f_hi = study.constraints.get("max_rocking_frequency_hz") or np.inf
        fr = modes.frequency_hz[rock]
        missed = (np.any(modes.damping_ratio[low] < zmin)
                  or np.any(fr < f_lo * (1 - 1e-3)) or np.any(fr > f_hi * (1 + 1e-3)))
        if not missed or not _modes_moved(prob, modes):
            break  # the exact modes meet the bounds (or the frozen ones are the exact ones)
        prob.set_modes(modes)
        sol = prob.solve(best.x)
        rounds += 1
        if not sol.feasible:
            best = sol
            break
        best = sol
    d = study.design_at(best.values)
    sig_rel = margin_db = math.nan
    if best.feasible:
        sigma, sigma_u = prob.closure(d)
        sig_rel = float(max(np.max(np.abs(sigma / prob.sigma(best.x) - 1)),
                            np.max(np.abs(sigma_u / prob.tube_rms(best.x) - 1))))
        x = best.x.copy()
        x[prob.nz: prob.nz + prob.n] = np.log(sigma)
        x[prob.nz + prob.n: prob.nz + 2 * prob.n] = np.log(sigma_u)
        margin_db = abs(prob.worst_margin_db(x) - prob.worst_margin_db(best.x))
        if sig_rel > RECHECK_TOL or margin_db > RECHECK_TOL:
            raise SolverError(f"table optimization: the NLP and the NumPy closure disagree at "
                              f"the optimum (sigma {sig_rel:.3g} relative, worst margin "
                              f"{margin_db:.3g} dB)")
    j0 = None
    try:
        x00 = prob.initial_guess(starts[0])
        j0 = _natural(prob, x00, float(np.asarray(prob._j_fn(x00)).ravel()[0]))
    except SolverError:
        pass
    analysis = start_analysis = stab = None
    if analyze:
        analysis, modes, stab = _analyze(study, d)
        start_analysis, modes0, _ = _analyze(study, d0)
    return TableOptimizationResult(
        study=study, feasible=bool(best.feasible), status=best.status, values=best.values,
        design=d, objective=prob.objective,
        objective_value=_natural(prob, best.x, best.objective), start_objective=j0,
        starts=tuple(recs), n_reached_best=n_best, constraints=best.violations,
        mode_rounds=rounds, recheck_sigma_rel=sig_rel, recheck_margin_db=margin_db,
        analysis=analysis, start_analysis=start_analysis, modes=modes, start_modes=modes0,
        stability=stab, wall_s=time.perf_counter() - t0, hessian=HESSIAN,
    )


def _natural(prob, x, j: float) -> float:
    if prob.objective == "worst_band_margin":
        return prob.worst_margin_db(x)
    return math.exp(j)


def _model(study, d):
    from isodesign.table.model import table_model

    m = study.models
    return table_model(d, study.table, flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                       diaphragm=m["diaphragm"])


def _modes_at(prob, d, sigma=None, sigma_u=None):
    from isodesign.table.modes import table_modes

    if sigma is None:
        sigma, sigma_u = prob.closure(d)
    model = _model(prob.study, d)
    return table_modes(model, vertical=closure_springs(model, sigma, sigma_u))


def _modes_moved(prob, modes) -> bool:
    old = prob.mode_params.reshape(-1, 14)[:6]
    m = prob.geo.mass
    for j in range(6):
        f = modes.frequency_hz[j]
        active = bool(np.isfinite(f) and f < 5.0)
        if active != bool(old[j, 0]):
            return True
        if not active:
            continue
        if abs(2 * math.pi * f / old[j, 1] - 1) > 1e-3:
            return True
        phi0 = old[j, 2:8] + 1j * old[j, 8:14]
        phi = modes.shapes[:, j]
        corr = abs(np.vdot(phi0, m @ phi)) ** 2 / (np.real(np.vdot(phi0, m @ phi0))
                                                   * np.real(np.vdot(phi, m @ phi)))
        if corr < 0.999:
            return True
    return False


def _analyze(study, d):
    """Fine-grid band response, modes at its closure and rocking stability of a design."""
    import warnings

    from isodesign.table.modes import rocking_stability, table_modes
    from isodesign.table.response import table_band_response

    m = study.models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = table_band_response(d, study.table, study.floor_axes, study.target,
                                  bands=study.bands, flow=m["flow"],
                                  amplitude_mode=m["amplitude_mode"],
                                  diaphragm=m["diaphragm"], warn=False)  # fmt: skip
    model = res.model
    modes = table_modes(model, vertical=closure_springs(model, res.stroke_rms_m,
                                                        res.tube_velocity_rms_m_s))
    return res, modes, rocking_stability(model)
