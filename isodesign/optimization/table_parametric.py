"""One table NLP for many table studies: the floor, the limits and the references as parameters.

A table sweep's points that differ in the floor (its level in each axis, or any floor
spectrum on the same frequency grid), the target's criterion (its band limits) or the
spring's start (a continued point starts from its neighbour's optimum) share one NLP: a
:class:`TableParametricProblem` is :class:`~.table_problem.TableProblem` whose parameter
head (:meth:`~.table_problem.TableProblem._parameter_head`) is CasADi parameters:

* the floor's stroke weights ``sw`` (3 axes x nf frequencies) and band weights ``bw``
  (3 n_bands x nf): the quadrature of the strokes' variances and of the band mean squares,
  linear in each axis's floor PSD;
* ``ln lim_b^2``: the target's squared band limits (n_bands);
* ``k_s = 1 / sigma_ref,i^2`` and ``k_u = 1 / sigma_u,ref,i^2``: the scaling of the closure
  rows, from the point's start design (as a fresh build takes them).
* the payload's mass ``m``, CG height ``h`` and principal inertia ``I_xx, I_yy, I_zz``
  (:func:`payload_parametric`) and the CG's plan position ``c_x, c_y``
  (:func:`cg_plan_parametric`): the design vector's last entries, so every function of it
  (the per-frequency physics, the tilt, damping and rocking rows) takes them; the NLP
  evaluates them as the change from the built table
  (:func:`~isodesign.table.statics.payload_terms`, the inertia base's path): loads and p0
  scale, the mass matrix, the overturning ``-W h``, the body points' heights, the pendulum;
  the plan position as the free positions' path (every isolator moved by ``-(c - c_0)``:
  the leveling's closed form, the position levers' directions).

The values of the constraints whose rows hold only their bounds (:data:`BOUND_KINDS`) are
the point's ``lbg``/``ubg``, set by :meth:`TableParametricProblem.at`.

:meth:`TableParametricProblem.at` gives the problem of another study (a shallow copy that
shares the built IPOPT solver, with the point's study, grid and parameter values). What is
not a parameter is the NLP's structure (:func:`table_structure_key`): the CG height's
sign, the products of inertia, the CG's plan position with a free layout lever, the
payload altogether with a free inertia base, free positions or the leveling loop's
margin rows, the isolators and their layout, the horizontal element, the levers and which
are free, the objectives, the models, the variables' boxes, which constraints are on and
the values of those inside their rows (tilt, damping, rocking), the frequency grid and the
peak rows' count; a study that differs there builds its own NLP
(:class:`~.parametric.ProblemCache` counts the builds). With these the parametric NLP is,
at every point, the same function as a fresh build of that point's study
(tests/optimization/test_table_parametric.py solves both). See ``docs/sweep.md``.
"""

from __future__ import annotations

import copy
import hashlib
import json

import numpy as np

from isodesign.errors import InputError
from isodesign.optimization.distortion_rows import TableDistortionMixin
from isodesign.optimization.table_problem import (
    PEAK_SLOTS_PER_ROUND,
    TABLE_PEAK_ROUNDS,
    TableProblem,
)

__all__ = ["BOUND_KINDS", "TableParametricProblem", "cg_plan_parametric", "payload_parametric",
           "table_structure_key"]

#: Tables of the resolved study that enter the table NLP through its parameters only.
_PARAMETER_TABLES = ("floor", "target")
#: Solver settings that are the NLP's (starts, seed, workers, tie-break are not).
_SOLVER_NLP_KEYS = ("max_iter", "tol")
#: The table's constraint kinds whose study values enter only their rows' bounds
#: (``lbg``/``ubg``, IPOPT's per solve): which are on is structure, their values are not
#: (:meth:`TableParametricProblem.at` sets the point's bounds). The surrogate rows (tilt,
#: damping, rocking) hold their bound inside the row: their values stay structure.
BOUND_KINDS = ("total_volume", "natural_frequency", "stroke", "peak_transmissibility")


def _bound_keys() -> dict:
    """Study key (``constraints.<key>``) -> whether a value switches it on, for the keys of
    :data:`BOUND_KINDS`."""
    from isodesign.optimization.constraint_registry import _given

    return {"max_total_volume_m3": bool, "min_natural_frequency_hz": bool,
            "max_natural_frequency_hz": bool, "max_stroke_m": bool,
            "max_peak_transmissibility_db":
                lambda v: _given({"k": v}, "k")}


def payload_parametric(study) -> bool:
    """Whether the table NLP of ``study`` takes the payload's mass, CG height and principal
    inertia as parameters: not with a free inertia base (its lever moves them), free
    isolator positions (their leveling solves the loads), the leveling loop's margin rows
    (their plant is the start's) or a CG at or below the support plane (no tilt rows).

    Parameters
    ----------
    study : Study
        A table study.

    Returns
    -------
    bool
    """
    from isodesign.table.inertia_base import BASE_LEVER
    from isodesign.table.layout import is_position_lever
    from isodesign.table.leveling import leveling_margin_bounds

    free = {v.name for v in study.levers if v.free}
    return not (BASE_LEVER in free or any(is_position_lever(n) for n in free)
                or leveling_margin_bounds(study)[0] is not None
                or not study.table.cg_height_m > 0)


def cg_plan_parametric(study) -> bool:
    """Whether the CG's plan position ``(c_x, c_y)`` is a parameter too: with the payload's
    (:func:`payload_parametric`) unless a layout lever is free (it stretches the layout
    about the CG).

    Parameters
    ----------
    study : Study

    Returns
    -------
    bool
    """
    free = {v.name for v in study.levers if v.free}
    return payload_parametric(study) and not free & {"layout_length_m", "layout_width_m"}


def _payload_structure(d: dict, plan: bool) -> None:
    """The resolved study ``d`` without the payload's parameters: its mass and CG height
    (its height's sign stays), the CG's plan position when ``plan``, the principal inertia
    (the products of inertia stay), and the table's supply pressure."""
    pay = dict(d.get("payload") or {})
    pay.pop("mass_kg", None)
    if pay.get("cg_height_m") is not None:
        pay["cg_height_m"] = "above"
    d["payload"] = pay
    tab = dict(d.get("table") or {})
    cg = tab.get("cg_m")
    if isinstance(cg, list | tuple) and len(cg) == 3:
        tab["cg_m"] = ["plan", "plan", "above"] if plan else [cg[0], cg[1], "above"]
    # the supply (group) pressure: no NLP row holds it on this path (free positions' supply
    # rows are theirs); at() levels the point's table and checks its loads and supply
    tab.pop("supply_pressure_pa", None)
    inert = tab.get("inertia_kg_m2")
    if inert is not None:
        a = np.asarray(inert, float)
        tab["inertia_kg_m2"] = "principal" if a.ndim == 1 else \
            (a - np.diag(np.diag(a))).tolist()
    d["table"] = tab


def table_structure_key(study, objectives: tuple = (), peak_slots: int = 0,
                        payload: bool = True) -> str:
    """The part of a table study that shapes its NLP: equal keys, one
    :class:`TableParametricProblem` (given the same frequency grid and peak rows, which
    :meth:`TableParametricProblem.at` checks).

    Parameters
    ----------
    study : Study
        With ``[table]``, without ``[scenarios]``.
    objectives : tuple of str
        The NLP's objectives (default: the study's).
    peak_slots : int
        Movable peak frequencies.
    payload : bool
        The payload as parameters where :func:`payload_parametric` allows (default); False:
        its numbers folded into the NLP (a sweep that varies no payload key, whose solves
        are then as fast as a fresh build's: docs/sweep.md section 7).

    Returns
    -------
    str
        A hash of the resolved study without its name, description, floor and target
        tables, the starts of its free design variables and the solver's starts, seed,
        workers and tie-break; of the objectives and the peak slots.
    """
    from isodesign.io.record import resolved_study_dict

    objectives = tuple(objectives or (study.objective["kind"],))
    d = resolved_study_dict(study)
    # a robust table study's nominal NLP: its [scenarios] never reach it
    for k in ("name", "description", "scenarios", *_PARAMETER_TABLES):
        d.pop(k, None)
    free = {v.name for v in study.variables if v.free}
    d["variables"] = {k: ({kk: vv for kk, vv in v.items() if kk != "start"}
                          if k in free and isinstance(v, dict) else v)
                      for k, v in (d.get("variables") or {}).items()}
    d["solver"] = {k: (d.get("solver") or {}).get(k) for k in _SOLVER_NLP_KEYS}
    cons = dict(d.get("constraints") or {})
    for k, on in _bound_keys().items():  # the rows' bounds: on or off only
        if k in cons:
            cons[k] = "on" if on(cons[k]) else "off"
    d["constraints"] = cons
    on = bool(payload) and payload_parametric(study)
    if on:
        _payload_structure(d, cg_plan_parametric(study))
    text = json.dumps({"study": d, "objectives": list(objectives),
                       "peak_slots": int(peak_slots), "payload": on},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class TableParametricProblem(TableProblem):
    """:class:`~.table_problem.TableProblem` whose floor, band limits and closure references
    are parameters (module doc); :meth:`at` gives another study's problem on it.

    Parameters
    ----------
    study : Study
        The base table study (no ``[scenarios]``).
    objectives : tuple of str, optional
    hessian : str, optional
    peak_slots : int
    family : dict, optional
        Shared by the problems of one structure (the one with movable peak frequencies
        is built once for all of them, :meth:`with_peak_slots`); ``family["on_build"]``,
        when given, is called once per NLP built.
    """

    def __new__(cls, study=None, *args, **kwargs):
        # models.distortion: with the distortion power's rows (TableParametricDistortionProblem)
        if cls is TableParametricProblem and study is not None \
                and study.models.get("distortion"):
            return super().__new__(TableParametricDistortionProblem)
        return super().__new__(cls)

    def __init__(self, study, objectives: tuple | None = None, *, hessian: str | None = None,
                 peak_slots: int = 0, family: dict | None = None, payload: bool = True):
        if getattr(study, "table", None) is None:
            raise InputError("study: has no [table]; the vertical study's parametric NLP is "
                             "isodesign.optimization.parametric.ParametricProblem")
        if getattr(study, "scenarios", None) is not None:
            raise InputError("[scenarios]: a robust table study builds its own NLPs")
        self._family = family if family is not None else {}
        self._payload = bool(payload)
        self._n_payload = (7 if cg_plan_parametric(study) else 5) \
            if payload and payload_parametric(study) else 0
        self._table0 = study.table_at(None)  # the table the geometry is built on
        super().__init__(study, objectives, hessian=hessian, peak_slots=peak_slots)
        self._leveling0 = self.leveling
        if self._family.get("on_build"):
            self._family["on_build"]()
        self.key = table_structure_key(study, self.objectives, self.n_slots, self._payload)
        self._n_peak_columns = self._peak_columns()
        self.q = self._point_values()

    # -- the parameter head ----------------------------------------------------------
    def _parameter_head(self, ca, X, bw) -> dict:
        g, n = self.grid, self.n
        nf, nb = g.n_points, g.n_bands
        self.sigma_ref, self.tube_ref = self._reference_sigma()
        sw = X.sym("floor_stroke_weight", 3, nf)
        bq = X.sym("floor_band_weight", 3 * nb, nf)
        lnl = X.sym("ln_limit2", nb)
        ks, ku = X.sym("k_s", n), X.sym("k_u", n)
        self._q_sym = ca.vertcat(ca.vec(sw), ca.vec(bq), lnl, ks, ku,
                                 *([self._payload_sym] if self._n_payload else []))
        return {"stroke_weight": sw, "band_weight": bq,
                "ln_limit2": ca.repmat(lnl, 3 * self.k, 1), "k_s": ks, "k_u": ku,
                "q": self._q_sym}

    # -- the payload: mass, CG height, principal inertia (table.statics.payload_terms) ----
    def _payload_values(self, ca, X) -> list:
        if not self._n_payload:
            return []
        self._payload_sym = X.sym("payload", self._n_payload)
        return [self._payload_sym[j] for j in range(self._n_payload)]

    def _base(self, dv):
        """The slab's terms (a free inertia base), else the payload's parameters as the same
        terms (:func:`~isodesign.table.statics.payload_terms` from the built table)."""
        if not self._n_payload:
            return super()._base(dv)
        from isodesign.table.statics import payload_terms

        k = self._n_dv() - self._n_payload
        return payload_terms(self._table0, dv[k], dv[k + 1], [dv[k + 2 + j] for j in range(3)])

    # -- the CG's plan position: every isolator and point moves by -(c - c_0) from the CG --
    def _cg_shift(self, dv):
        """``(c_x - c_x0, c_y - c_y0)`` on the parameters, or None (not a parameter)."""
        if self._n_payload < 7:
            return None
        k = self._n_dv() - self._n_payload
        t0 = self._table0
        return dv[k + 5] - float(t0.cg_m[0]), dv[k + 6] - float(t0.cg_m[1])

    def _live_loads(self, dv):
        """Each isolator's load with the CG at the parameters: the leveling's closed form at
        the isolators seen from the moved CG (:func:`~isodesign.table.statics.
        group_loads_at`, the free positions' path) times ``m / m_0``."""
        d = self._cg_shift(dv)
        if d is None:
            return None
        from isodesign.table.statics import group_loads_at

        t0 = self._table0
        xy = [(float(x) - d[0], float(y) - d[1]) for x, y in t0.isolators_m]
        lam = self._base(dv).load_scale
        pg = group_loads_at(t0, xy)
        return [lam * pg[int(g)] for g in t0.group_of]

    def _live_points(self, dv):
        """The vertical forces' plan offsets from the moved CG (the tilt rows' points)."""
        d = self._cg_shift(dv)
        if d is None:
            return None
        t0 = self._table0
        return [(float(x) - float(t0.cg_m[0]) - d[0], float(y) - float(t0.cg_m[1]) - d[1])
                for x, y in t0.isolators_m]

    def _terms(self, dv, shift) -> list:
        terms = super()._terms(dv, shift)
        d = self._cg_shift(dv)
        if d is None:
            return terms
        if getattr(self, "_cg_dirs", None) is None:
            from isodesign.table.lever_geometry import position_directions

            dirs = position_directions(self.geo)  # the built table's (every isolator's)
            self._cg_dirs = (-sum(dirs[0::2]), -sum(dirs[1::2]))
        return [*terms, (d[0], self._cg_dirs[0]), (d[1], self._cg_dirs[1])]

    def _assemble(self, dv, kv, kh, w, shift):
        if self._cg_shift(dv) is None:
            return super()._assemble(dv, kv, kh, w, shift)
        from isodesign.table import inertia_base as slab_terms
        from isodesign.table.lever_geometry import lever_stiffness

        d, b = lever_stiffness(self.geo, self._terms(dv, shift), kv, kh, w)
        return slab_terms.base_stiffness(d, w, self._base(dv)), b

    def _point_rows(self, p: int, dv) -> tuple:
        """``G_r = [I, -[r]x]`` with ``r = p - c``: ``r_x`` and ``r_y`` drop by the CG's
        shift (its height's, ``base_point_rows``)."""
        rows, nz = super()._point_rows(p, dv)
        d = self._cg_shift(dv)
        if d is None:
            return rows, nz
        dx, dy = d
        rows[1][5], rows[2][4] = rows[1][5] - dx, rows[2][4] + dx
        rows[0][5], rows[2][3] = rows[0][5] + dy, rows[2][3] - dy
        return rows, [[not (isinstance(v, float) and v == 0.0) for v in row] for row in rows]

    def _tilt_bound(self, slab, mu) -> tuple:
        if not self._n_payload:
            return super()._tilt_bound(slab, mu)
        return slab.weight_height, mu  # the rows A / (W h) - mu I of a fresh build

    def _kh(self, dv, w, khr, khi):
        """:meth:`TableProblem._kh`; without free levers the parameters hold the built
        table's pendulum ``W_i / L_p``: the payload's load scale moves it (linear in the
        load) and its CG height the elastic centres (as the slab's, ``centre_shift``)."""
        kh, shift = super()._kh(dv, w, khr, khi)
        if not self._n_payload or self.n_levers:  # the levers' path has the live loads
            return kh, shift
        from isodesign.table import inertia_base as slab_terms

        base = self._base(dv)
        lp = self.table.horizontal.pendulum_length_m
        if lp is not None:  # W_i / L_p: the parameters hold the built loads' W_i,0 / L_p
            w0 = [float(v) for v in self._leveling_built().load_n]
            live = self._live_loads(dv)
            dw = [base.load_scale * v - v for v in w0] if live is None else \
                [wi - v for wi, v in zip(live, w0, strict=True)]
            kh = [k + dwi / lp for k, dwi in zip(kh, dw, strict=True)]
        return kh, slab_terms.centre_shift(shift, base)

    def _leveling_built(self):
        return getattr(self, "_leveling0", None) or self.leveling

    def _kh_params(self, w):
        """The horizontal stiffness parameters at the built table's loads (the payload's
        scale is in :meth:`_kh`)."""
        lv0 = self._leveling_built()
        if lv0 is self.leveling:
            return super()._kh_params(w)
        view = copy.copy(self)
        view.leveling, view.table = lv0, self._table0
        return TableProblem._kh_params(view, w)

    def _x_functions(self, ca, x, judged, margins, js) -> None:
        q = self._q_sym
        self._margins_q = ca.Function("margins", [x, q], [judged])
        self._all_margins_q = ca.Function("all_margins", [x, q], [margins])
        self._j_q = ca.Function("objectives", [x, q], [js])

    def _margins_fn(self, x):
        return self._margins_q(x, self.q)

    def _all_margins_fn(self, x):
        return self._all_margins_q(x, self.q)

    def _j_fn(self, x):
        return self._j_q(x, self.q)

    def _param_tail(self) -> np.ndarray:
        return np.concatenate([super()._param_tail(), self.q])

    def _point_values(self) -> np.ndarray:
        """This problem's parameter values: its grid's floor weights and limits, its
        references."""
        g = self.grid
        bw = np.concatenate([g.band_weight[a] for a in range(3)], axis=0)
        t = self.table
        pay = np.r_[t.mass_kg, t.cg_height_m, np.diag(np.asarray(t.inertia_kg_m2, float)),
                    np.asarray(t.cg_m, float)[:2]][: self._n_payload]
        # CasADi's vec stacks the columns (column-major)
        return np.concatenate([np.asarray(g.stroke_weight, float).ravel(order="F"),
                               np.asarray(bw, float).ravel(order="F"),
                               2.0 * np.log(np.asarray(g.limit_velocity_m_s, float)),
                               1.0 / np.asarray(self.sigma_ref, float) ** 2,
                               1.0 / np.asarray(self.tube_ref, float) ** 2, pay])

    def _point_bounds(self, study) -> tuple:
        """``(lbg, ubg)`` of ``study``: this NLP's, with the rows of :data:`BOUND_KINDS` at
        the study's bounds (the registry's :meth:`~.constraint_registry.ConstraintKind.
        nlp_bounds`, as a fresh build takes them)."""
        from isodesign.optimization.constraint_registry import CONSTRAINTS

        lbg, ubg = self.lbg.copy(), self.ubg.copy()
        kinds = {CONSTRAINTS[k].row_key: CONSTRAINTS[k] for k in BOUND_KINDS}
        for key, row, n in self.con_rows:
            kind = kinds.get(key)
            if kind is not None:
                lbg[row: row + n], ubg[row: row + n] = kind.nlp_bounds(study)
        return lbg, ubg

    def _peak_columns(self) -> int:
        """The peak rows' frequencies (a structure: the start design sets their top)."""
        pk = self.study.constraints.get("max_peak_transmissibility_db")
        if pk is None or pk is False:
            return 0
        return int(np.sum(self.grid.frequency_hz <= self._peak_cut_hz()))

    # -- points ------------------------------------------------------------------------
    def at(self, study) -> TableParametricProblem | None:
        """The problem of ``study`` on this built NLP, or None when its structure differs.

        Parameters
        ----------
        study : Study
            A table study of the same :func:`table_structure_key` (the base with another
            floor, target criterion or start).

        Returns
        -------
        TableParametricProblem or None
            A shallow copy sharing the solver, with the point's study, grid, references
            and parameters (its frozen modes, loop poles and movable frequencies start as
            a fresh build's); None when ``study`` needs an NLP of its own (another
            structure, frequency grid or count of peak rows).
        """
        from isodesign.table.floor import table_grid

        if getattr(study, "table", None) is None or getattr(study, "scenarios", None) \
                is not None or table_structure_key(study, self.objectives, self.n_slots,
                                                   self._payload) != self.key:
            return None
        grid = table_grid(study.floor_axes, study.bands, target=study.target,
                          points_per_band=study.models["points_per_band"])
        g0 = self.grid
        if grid.omega.shape != g0.omega.shape or grid.n_bands != g0.n_bands \
                or not np.allclose(grid.omega, g0.omega, rtol=1e-12, atol=0.0):
            return None
        view = copy.copy(self)
        view.study, view.grid = study, grid
        if self._n_payload:  # the point's table, statics and geometry (its numbers)
            from isodesign.table.assembly import geometry
            from isodesign.table.statics import check_load_constraints, level

            view.table = study.table_at(None)
            view.leveling = level(view.table, study.hardware["piston_area_m2"])
            check_load_constraints(view.leveling, study.constraints)  # as a fresh build
            view.geo = geometry(view.table, view.leveling.load_n)
        if view._peak_columns() != self._n_peak_columns:
            return None
        view.sigma_ref, view.tube_ref = view._reference_sigma()
        view.q = view._point_values()
        view.lbg, view.ubg = self._point_bounds(study)
        view.mode_params = np.tile(np.r_[0.0, 2 * np.pi, np.zeros(12)], 2 * self.n_modes)
        if self.n_loop:
            from isodesign.table.leveling import leveling_of_study

            view.loop_system = leveling_of_study(study)
        view.clear_loop()
        view.set_slots(np.full(self.n_slots, float(grid.frequency_hz[0])))
        return view

    def with_peak_slots(self, n: int = PEAK_SLOTS_PER_ROUND * TABLE_PEAK_ROUNDS
                        ) -> TableParametricProblem:
        """This study's problem with ``n`` movable peak frequencies: the family's NLP with
        them, built on the first call of any study of this structure (its frozen modes and
        loop poles this one's).

        Parameters
        ----------
        n : int

        Returns
        -------
        TableParametricProblem
        """
        slotted = self._family.get(("slots", n))
        if slotted is None:
            slotted = TableParametricProblem(self.study, self.objectives, hessian=self.hessian,
                                             peak_slots=n, family=self._family,
                                             payload=self._payload)
            self._family[("slots", n)] = slotted
        view = slotted.at(self.study)
        if view is None:  # pragma: no cover - the same structure but its slots
            view = TableParametricProblem(self.study, self.objectives, hessian=self.hessian,
                                          peak_slots=n, family=self._family,
                                          payload=self._payload)
        view.mode_params = self.mode_params.copy()
        view.loop_params = self.loop_params.copy()
        return view


class TableParametricDistortionProblem(TableDistortionMixin, TableParametricProblem):
    """:class:`TableParametricProblem` with the distortion power's rows (``models.distortion
    = true``; :class:`~.distortion_rows.TableDistortionMixin`): each point's terms are the
    NumPy closure's of its own study, expanded about each outer round's design. The
    parameters are ``[..., the distortion's, the point's q]`` (:meth:`_param_tail`)."""

    def _x_functions(self, ca, x, judged, margins, js) -> None:
        q, pd = self._q_sym, self._p_dist_sym
        self._margins_qd = ca.Function("margins", [x, pd, q], [judged])
        self._all_margins_qd = ca.Function("all_margins", [x, pd, q], [margins])
        self._j_qd = ca.Function("objectives", [x, pd, q], [js])

    def _n_after_dist(self) -> int:
        return int(self.q.size)

    def _margins_fn(self, x):
        return self._margins_qd(x, self._dist_for(x), self.q)

    def _all_margins_fn(self, x):
        return self._all_margins_qd(x, self._dist_for(x), self.q)

    def _j_fn(self, x):
        return self._j_qd(x, self._dist_for(x), self.q)

    def at(self, study) -> TableParametricDistortionProblem | None:
        """:meth:`TableParametricProblem.at`, the point starting with its own terms."""
        view = super().at(study)
        if view is not None:
            view._dist_p = None
        return view
