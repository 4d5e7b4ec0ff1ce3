"""One NLP for many studies: what a sweep varies enters the NLP as parameters.

A sweep's points differ in numbers that do not change the NLP's structure: the payload
mass and CG height, the floor's level (a floor spectrum that is the base one times a
factor), the target criterion's band limits, the constraints' bounds. A
:class:`ParametricProblem` is :class:`~.problem.Problem` with these numbers as CasADi
parameters, built once; :meth:`ParametricProblem.at` returns the problem of one point
(a shallow copy that shares the built IPOPT solver and carries the point's study, grid,
parameter values and constraint bounds), on which :func:`~.driver.optimize_vertical` runs
unchanged. A :class:`ProblemCache` keeps one built problem per *structure*
(:func:`structure_key`: everything that is not a parameter, such as the number of
isolators, the objective, the models, the variables' boxes, the frequency grid's shape)
and counts the builds. See ``docs/sweep.md``.

The parameters, after :meth:`~.problem.Problem.params`' weights, bounds and peak slots:

* ``m``, ``h``: payload mass (kg) and CG height (m);
* ``f``: the floor scale, the point's floor PSD over the base one (the weights of the
  stroke variance and of the band mean squares are linear in the PSD);
* ``k_s = 1 / sigma_ref^2`` and ``k_u = 1 / sigma_u,ref^2``: the stroke chain's reference
  of the point (its start design's RMS stroke, as a fresh build uses);
* ``ln lim_b^2``: the target's squared band limits;
* the fixed peak-grid frequencies (rad/s): the peak grid spans the point's natural
  frequency, which moves with the mass.

With these the parametric NLP is, at every point, the same function as a fresh build of
that point's study (tests/optimization/test_parametric.py solves both).
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import math
from types import SimpleNamespace

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.optimization.constraints import build_constraints
from isodesign.optimization.distortion_rows import DistortionMixin
from isodesign.optimization.grid import build_grid
from isodesign.optimization.problem import _COMPOSED, PEAK_SLOTS, Problem
from isodesign.spring.gas import P_ATM

__all__ = ["FLOOR_SCALE_RTOL", "ParametricProblem", "ProblemCache", "structure_key"]

#: A point's floor weights must be the base ones times one factor to this relative
#: tolerance (else the point needs an NLP of its own).
FLOOR_SCALE_RTOL = 1e-9
#: Keys of the resolved study whose values are NLP parameters (their presence is not).
_PARAMETER_KEYS = {("payload", "mass_kg"), ("payload", "cg_height_m")}
#: Tables of the resolved study that never reach the NLP's structure: the floor and the
#: target enter through the grid (compared by shape and normalized weights), the
#: constraints through their bounds (which constraints exist is kept).
_GRID_TABLES = ("floor", "target")
#: Solver settings that are not the NLP's (starts, seed, workers, tie-break).
_SOLVER_NLP_KEYS = ("max_iter", "tol")


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.asarray(a, float).ravel()
        h.update(str(a.shape).encode())
        # 10 significant digits: a grid computed twice from the same inputs matches
        # (mantissa rounded to 10 digits and the decimal exponent, as integers: the
        # text of the numbers costed 40 ms a point)
        m = np.abs(a)
        e = np.floor(np.log10(np.where(np.isfinite(m) & (m > 0), m, 1.0)))
        q = np.round(np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0) * 10.0 ** (9 - e))
        h.update(q.astype(np.int64).tobytes())
        h.update(e.astype(np.int64).tobytes())
        h.update(np.isfinite(a).tobytes())
    return h.hexdigest()[:16]


def _floor_weights(grid) -> tuple[np.ndarray, np.ndarray]:
    r = grid.response
    return np.asarray(r.stroke_weight, float), np.asarray(r.band_weight, float)


def structure_key(study, objectives: tuple = (), extra_peak_hz: tuple = (), grid=None) -> str:
    """The part of a study that shapes its NLP: equal keys, one :class:`ParametricProblem`.

    Parameters
    ----------
    study : Study
        A vertical study (no ``[table]``; a study's ``[scenarios]`` are left out: its
        nominal NLP is the same for any ranges).
    objectives : tuple of str
        The NLP's objectives (default: the study's).
    extra_peak_hz : tuple of float
        Fixed peak-grid frequencies.
    grid : Grid, optional
        The study's grid (built here by default).

    Returns
    -------
    str
        A hash of: the resolved study without its parameters (payload mass and CG height,
        the floor and target tables, the constraints' values but not which are on, the
        starts, seed and workers), the objectives, and the grid's shape, floor
        frequencies and floor weights normalized to sum 1 (a floor that is the base one
        times a factor has the same key).
    """
    from isodesign.io.record import resolved_study_dict

    objectives = tuple(objectives or (study.objective["kind"],))
    d = resolved_study_dict(study)
    d.pop("name", None)
    d.pop("description", None)
    # a robust study's nominal NLP: its [scenarios] never reach it (robust.RobustBuilds)
    d.pop("scenarios", None)
    for t, k in _PARAMETER_KEYS:
        if isinstance(d.get(t), dict) and k in d[t]:
            d[t][k] = d[t][k] is not None  # present or not: structure
    for t in _GRID_TABLES:
        d.pop(t, None)
    d["constraints"] = {k: bool(v) if not isinstance(v, bool) else v
                        for k, v in (d.get("constraints") or {}).items()}
    d["solver"] = {k: (d.get("solver") or {}).get(k) for k in _SOLVER_NLP_KEYS}
    g = grid if grid is not None else build_grid(study, objectives=objectives,
                                                 extra_peak_hz=extra_peak_hz, slots=PEAK_SLOTS)
    sw, bw = _floor_weights(g)
    shape = {"n_floor": g.n_floor, "n_peak": g.n_peak, "point": g.point_index,
             "n_bands": int(bw.shape[0]), "w_max": float(np.max(g.omega)),
             "floor": _digest(g.omega[g.floor_slice], sw / sw.sum(), bw / bw.sum(),
                              g.response.bands.nominal_hz, g.target_band_rows)}
    text = json.dumps({"study": d, "objectives": list(objectives),
                       "extra_peak_hz": [float(f) for f in extra_peak_hz], "grid": shape},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class _SweepStudy:
    """A study whose payload mass and CG height are CasADi symbols (the NLP's view).

    ``design_at`` gives the spring with ``p0 = p_atm + m g / (n A_p)`` (Eq. 1, as
    :func:`isodesign.spring.gas.pressure_from_load`) at the symbolic mass; every other
    attribute is the base study's.
    """

    def __init__(self, study, mass, cg_height):
        self.base = study
        p = study.payload
        self.payload = SimpleNamespace(
            mass_kg=mass, isolators=p.isolators, spacing_m=p.spacing_m,
            cg_height_m=cg_height if p.cg_height_m is not None else None, g_m_s2=p.g_m_s2,
            mass_per_isolator_kg=mass / p.isolators,
            load_per_isolator_n=mass * p.g_m_s2 / p.isolators)

    def __getattr__(self, name: str):
        return getattr(self.base, name)

    def design_at(self, values: dict):
        d = self.base.design_at(values)
        pl = self.payload
        p0 = P_ATM + pl.mass_kg * pl.g_m_s2 / (int(pl.isolators) * d.piston_area_m2)
        return dataclasses.replace(d, pressure_pa=p0)

    def start_design(self):
        return self.design_at({v.name: v.start for v in self.base.variables})


class ParametricProblem(Problem):
    """:class:`~.problem.Problem` whose sweep-varied numbers are parameters (module doc).

    Built on a base study; :meth:`at` gives the problem of another study of the same
    :func:`structure_key` without building anything.

    Parameters
    ----------
    study : Study
        The base study (vertical: no ``[table]``, no ``[scenarios]``).
    objectives : tuple of str, optional
    extra_peak_hz : tuple of float
    """

    def __init__(self, study, objectives: tuple | None = None, extra_peak_hz: tuple = ()):
        if getattr(study, "table", None) is not None or getattr(study, "scenarios",
                                                                 None) is not None:
            raise InputError("[table]/[scenarios]: the parametric NLP is the vertical "
                             "study's; a table or robust study builds its own")
        super().__init__(study, objectives=objectives, extra_peak_hz=extra_peak_hz)
        self.key = structure_key(study, self.objectives, self.extra_peak_hz, self.grid)
        self._base_weights = _floor_weights(self.grid)
        self._n_cons = len(build_constraints(study, self._mt, self.grid.omega.size))
        self.q = self._point_values(study, self.grid, 1.0, self.sigma_ref, self.tube_rms_ref)

    # -- construction hooks ------------------------------------------------------------
    def _decision_variables(self, nlp) -> None:
        super()._decision_variables(nlp)
        X = nlp.X
        nb = len(self.grid.target_limit_m_s)
        self.n_fixed_peak = self.grid.n_peak - self.grid.n_slots
        nlp.q_mass, nlp.q_cg = X.sym("mass_kg"), X.sym("cg_height_m")
        nlp.q_floor, nlp.q_ks, nlp.q_ku = X.sym("floor_scale"), X.sym("k_s"), X.sym("k_u")
        nlp.q_lim = X.sym("ln_limit2", nb)
        nlp.q_peak = X.sym("peak_omega", self.n_fixed_peak)
        nlp.q = nlp.ca.vertcat(nlp.q_mass, nlp.q_cg, nlp.q_floor, nlp.q_ks, nlp.q_ku,
                               nlp.q_lim, nlp.q_peak)

    def _point_inputs(self, ca) -> list:
        return [ca.SX.sym("mass_kg")]

    def _point_study(self, extra):
        return _SweepStudy(self.study, extra[0], self.study.payload.cg_height_m)

    def _point_args(self, nlp) -> list:
        return [nlp.q_mass]

    def _nlp_study(self, nlp):
        return _SweepStudy(self.study, nlp.q_mass, nlp.q_cg)

    def _omega_column(self, nlp):
        ca = nlp.ca
        w, sl = self.grid.omega, self.grid.slot_slice
        return ca.vertcat(ca.DM(w[: self.grid.n_floor]), nlp.q_peak, nlp.p_slot,
                          ca.DM(w[sl.stop:]))

    def _adjust_metrics(self, nlp) -> None:
        mt, f = nlp.mt, nlp.q_floor
        # the floor weights times f: sigma^2, sigma_u^2 and the band mean squares scale
        for k in ("stroke_variance", "ms_all", "tube_velocity_variance"):
            if k in mt:
                mt[k] = f * mt[k]
        mt["ln_ms_band"] = mt["ln_ms_band"] + bk.log(f)
        mt["ln_limit2"] = nlp.q_lim
        self._mt = mt

    def _chain_factors(self, nlp) -> tuple:
        self.sigma_ref, self.tube_rms_ref = self._reference_sigma()
        return nlp.q_floor, nlp.q_ks, nlp.q_ku

    def _assemble(self, nlp) -> None:
        super()._assemble(nlp)
        nlp.p = nlp.ca.vertcat(nlp.p, nlp.q)
        self.np = int(nlp.p.numel())

    def _fn_param_sym(self, nlp):
        return nlp.ca.vertcat(nlp.p_slot, nlp.q)

    def _fn_params(self) -> np.ndarray:
        return np.concatenate([self._slot_omega(), self.q])

    def params(self, weights=None, diameter_weight: float = 0.0, eps=None) -> np.ndarray:
        """:meth:`Problem.params <isodesign.optimization.problem.Problem.params>` followed
        by the point's parameters."""
        return np.concatenate([super().params(weights, diameter_weight, eps), self.q])

    # -- points --------------------------------------------------------------------------
    def _point_values(self, study, grid, scale, sigma_ref, tube_ref) -> np.ndarray:
        p = study.payload
        cg = p.cg_height_m if p.cg_height_m is not None else 1.0
        peak = grid.omega[grid.n_floor: grid.n_floor + self.n_fixed_peak]
        return np.concatenate([[p.mass_kg, cg, scale, 1.0 / sigma_ref**2,
                                1.0 / tube_ref**2 if tube_ref else 1.0],
                               2.0 * np.log(grid.target_limit_m_s), peak])

    def at(self, study, *, grid=None, key: str | None = None) -> ParametricProblem | None:
        """The problem of ``study`` on this built NLP, or None when its structure differs.

        Parameters
        ----------
        study : Study
            A study of the same :func:`structure_key` (e.g. the base with another payload
            mass, floor level or target criterion).
        grid, key : optional
            The study's grid and :func:`structure_key` when the caller has them
            (:meth:`ProblemCache.get`: computed once a point).

        Returns
        -------
        ParametricProblem or None
            A shallow copy sharing the solver, with the point's study, grid, peak slots,
            references, parameters and constraint bounds; None when ``study`` needs an NLP
            of its own (another structure, or a floor that is not the base one scaled).
        """
        if grid is None:
            grid = build_grid(study, objectives=self.objectives,
                              extra_peak_hz=self.extra_peak_hz, slots=PEAK_SLOTS)
        if key is None:
            key = structure_key(study, self.objectives, self.extra_peak_hz, grid)
        if key != self.key:
            return None
        sw, bw = _floor_weights(grid)
        sw0, bw0 = self._base_weights
        scale = float(sw.sum() / sw0.sum())
        if not (np.allclose(sw, scale * sw0, rtol=FLOOR_SCALE_RTOL, atol=0.0)
                and np.allclose(bw, scale * bw0, rtol=FLOOR_SCALE_RTOL, atol=0.0)):
            return None
        cons = build_constraints(study, self._mt, grid.omega.size)
        mine = self.constraints[: self._n_cons]
        if [(c.name, c.size) for c in cons] != [(c.name, c.size) for c in mine]:
            return None
        view = copy.copy(self)
        view.study = study
        view.grid = grid
        view.slot_hz = grid.omega[grid.slot_slice] / (2.0 * math.pi)
        view.constraints = [dataclasses.replace(c, expr=m.expr) for c, m in zip(cons, mine,
                                                                                 strict=True)]
        view.constraints += self.constraints[self._n_cons:]
        view.lbg, view.ubg, view.con_rows = view._constraint_rows(view.constraints)
        view.sigma_ref, view.tube_rms_ref = view._reference_sigma()
        view.q = view._point_values(study, grid, scale, view.sigma_ref, view.tube_rms_ref)
        return view


class ProblemCache:
    """Built :class:`ParametricProblem` s by structure: one build per structure.

    A sweep worker (or a process) keeps one and asks it for every point's problem;
    ``builds`` counts the NLPs built (what the sweep reports). A table study's problems are
    :class:`~isodesign.optimization.table_parametric.TableParametricProblem` s, kept the
    same way (with the factory's default), their NLPs with movable peak frequencies
    counted too.

    Parameters
    ----------
    factory : callable, optional
        ``factory(study, objectives, extra_peak_hz)`` builds a problem (default
        :class:`ParametricProblem`).
    """

    def __init__(self, factory=None):
        self._factory = factory or ParametricProblem
        self._built: dict[tuple, object] = {}
        self.builds = 0

    def get(self, study, objectives: tuple | None = None,
            extra_peak_hz: tuple = (), payload: bool = True) -> ParametricProblem:
        """The problem of ``study`` (built on the first study of its structure).

        Parameters
        ----------
        study : Study
        objectives : tuple of str, optional
        extra_peak_hz : tuple of float
        payload : bool
            A table study: its payload as parameters where the table NLP allows (default);
            False folds its numbers (a sweep that varies no payload key:
            :func:`~isodesign.sweeps.points.payload_varies`).

        Returns
        -------
        ParametricProblem
            Ready for :func:`~.driver.optimize_vertical` (``problem=``).
        """
        objectives = tuple(objectives or (study.objective["kind"],))
        if getattr(study, "table", None) is not None and self._factory is ParametricProblem:
            return self._table(study, objectives, payload)
        extra = tuple(extra_peak_hz)
        grid = build_grid(study, objectives=objectives, extra_peak_hz=extra, slots=PEAK_SLOTS)
        skey = structure_key(study, objectives, extra, grid)
        key = (skey, objectives, extra)
        prob = self._built.get(key)
        if prob is not None:
            view = prob.at(study, grid=grid, key=skey)
            if view is not None:
                return view
        prob = self._factory(study, objectives, extra)
        self.builds += 1
        self._built[key] = prob
        return prob.at(study, grid=grid, key=skey) or prob

    def _table(self, study, objectives: tuple, payload: bool = True):
        """A table study's problem (:class:`~.table_parametric.TableParametricProblem`):
        one NLP per structure, and one more with movable peak frequencies when a point's
        refinement needs them (both counted)."""
        from isodesign.optimization.table_parametric import (
            TableParametricProblem,
            table_structure_key,
        )

        key = ("table", table_structure_key(study, objectives, payload=payload), objectives)
        # the same key, another grid or count of peak rows (checked by at): kept side by side
        for i in range(len(self._built.get(key, ()))):
            view = self._built[key][i].at(study)
            if view is not None:
                return view

        def count():
            self.builds += 1

        prob = TableParametricProblem(study, objectives, family={"on_build": count},
                                      payload=payload)
        self._built.setdefault(key, []).append(prob)
        return prob.at(study) or prob

    def robust(self):
        """This cache's robust vertical NLPs (:class:`~.robust.RobustBuilds`: scenario
        blocks and stacked NLPs, one per structure and number of scenarios), counted in
        ``builds``.

        Returns
        -------
        RobustBuilds
        """
        rb = getattr(self, "_robust", None)
        if rb is None:
            from isodesign.optimization.robust import RobustBuilds

            def count():
                self.builds += 1

            rb = self._robust = RobustBuilds(on_build=count)
        return rb

    def __len__(self) -> int:
        return len(self._built)


class ParametricDistortionProblem(DistortionMixin, ParametricProblem):
    """:class:`ParametricProblem` with the distortion power's rows (``models.distortion =
    true``; :mod:`.distortion_rows`): each point's terms are the NumPy closure's of its own
    study (payload, floor, grid), expanded about each outer round's design. The parameters
    are ``[Problem's, the point's q, the distortion's]``."""

    def _param_tail(self) -> np.ndarray:
        return Problem._param_tail(self)  # the distortion's after the point's (params)

    def params(self, weights=None, diameter_weight: float = 0.0, eps=None) -> np.ndarray:
        """:meth:`ParametricProblem.params` followed by the distortion's expansion."""
        return np.concatenate([super().params(weights, diameter_weight, eps),
                               self._current_dist()])

    def at(self, study, *, grid=None, key: str | None = None):
        """:meth:`ParametricProblem.at`, the point starting with its own terms."""
        view = super().at(study, grid=grid, key=key)
        if view is not None:
            view._dist_p = None
        return view


_COMPOSED[ParametricProblem] = ParametricDistortionProblem
