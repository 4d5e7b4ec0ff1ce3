"""The NLP of a table study in three axes (CasADi SX, IPOPT, exact derivatives).

Built on the machinery every NLP shares (:class:`~isodesign.optimization.nlp.NLP`: IPOPT
options, the parameter head, constraint rows, one ``solve``, ``params``, ``values``,
``violations``), like the vertical :class:`~isodesign.optimization.problem.Problem`, so the
multi-start machinery runs either unchanged. Decision variables: the
scaled design ``z`` (N, V_t0, L_c, D_c; identical isolators), and per isolator
``s_i = ln sigma_i`` and ``y_i = ln sigma_u,i`` of the statistical closure, solved inside
the NLP as equality constraints::

    exp(2 s_i) = sum_a sum_j sw_a[j] |S_ia(f_j)|^2
    exp(2 y_i) = sum_a sum_j sw_a[j] |S_ia(f_j)|^2 |U/X|_i^2(f_j)

with the strokes ``S_ia`` from the same 6x6 assembly and the same spring functions the
NumPy analysis uses (:mod:`isodesign.table.assembly`, :mod:`isodesign.spring`). The
per-frequency physics is one SX Function (spring of every isolator, assembly, the 12x12
real solve, the squared outputs) mapped over the grid.

Objective: the worst margin over every instrument point, axis and band (an epigraph
``t <= margin``; ``J = -t``), or the total volume. Constraints (docs/table.md, section 11):

* ``max_total_volume_m3`` on ``V_t0 (1 + N)``;
* ``min_natural_frequency_hz``/``max_natural_frequency_hz`` on the vertical mode,
  ``sqrt(sum K0_i / m)``;
* ``min_tilt_margin`` on every rocking direction with the gravity term:
  ``A / (W h) - mu I`` positive semidefinite (``A`` the rocking stiffness with the vertical
  translation condensed, sealed springs at the quasi-static 1 mHz: the analysis's
  verdict), written smoothly as its two diagonal entries and its determinant ``>= 0``
  (no eigenvalue, no ``min``);
* ``max_peak_transmissibility_db`` on ``|T_p,aa|`` at every point and axis on the grid up
  to :data:`PEAK_ROWS_MAX_HZ` or twice the highest rigid-body frequency (the analysis
  checks the whole fine grid);
* ``min_damping_ratio`` on every mode below 5 Hz: ``phi^H K'' phi >= 2 zeta_min phi^H K'
  phi`` with the mode's shape ``phi`` and frequency frozen (NLP parameters) at the last
  solution of the nonlinear eigenproblem: a Rayleigh quotient, stationary in the shape, so
  smooth and first-order exact; the driver re-solves the modes at the optimum and repeats
  while they move (these rows and the rocking ones: :mod:`.mode_rows`);
* ``min_rocking_frequency_hz``/``max_rocking_frequency_hz`` on every rocking mode (rx + ry
  energy >= 30 %): the Rayleigh quotient ``phi^H K' phi`` (``phi^H M phi = 1``) of the
  frozen mode, the same way;
* ``min_leveling_gain_margin_db`` (with a bound, docs/table.md section 12): the first-order
  real part of the leveling loop's least stable poles at the raised gain ``G 10^(gm/20)``
  (every valve, and each alone), their eigenvectors frozen (NLP parameters) and linear in
  the plant's ``A`` (:func:`~isodesign.table.leveling.plant_matrix` on symbols); switched
  on and frozen again by the driver (:meth:`TableProblem.set_loop`).
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.optimization import lever_nlp, nlp
from isodesign.optimization.constraint_registry import TABLE_ROWS, constraint_rows_of
from isodesign.optimization.distortion_rows import TableDistortionMixin
from isodesign.optimization.loop_rows import (
    LOOP_MARGIN_EPS,
    LOOP_POLES_MIMO,
    frozen_poles,
    loop_rows,
)
from isodesign.optimization.mode_rows import (
    DAMPED_MODE_LIMIT_HZ,
    PEAK_ROWS_MAX_HZ,
    ROCKING_ENERGY_FRACTION,
    TableModeRows,
)
from isodesign.optimization.nlp import NLP
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.table_constraints import validity_quantities
from isodesign.optimization.variables import (
    CODESIGN_LEVERS,
    DESIGN_VARIABLES,
    GROUP_SPRING_LEVERS,
    lever_scaling,
    log_scaling,
)
from isodesign.response.isolator import static_stiffness
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR
from isodesign.spring.capillary import statistical_resistance_function
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness, tube_velocity_gain2
from isodesign.table import inertia_base as slab_terms
from isodesign.table.assembly import dynamic_stiffness, geometry, solve_complex
from isodesign.table.floor import table_grid
from isodesign.table.layout import horizontal_stiffness, layout_extent, layout_scale
from isodesign.table.lever_geometry import (
    layout_rows,
    lever_directions,
    lever_stiffness,
    vertical_vectors,
)
from isodesign.table.statics import level

__all__ = ["DAMPED_MODE_LIMIT_HZ", "LOOP_MARGIN_EPS", "LOOP_POLES_MIMO", "PEAK_ROWS_MAX_HZ",
           "PEAK_SLOTS_PER_ROUND", "ROCKING_ENERGY_FRACTION", "TABLE_OBJECTIVES",
           "TABLE_PEAK_ROUNDS", "TableProblem", "add_peak_frequencies"]

#: Movable peak frequencies (NLP parameters, no rebuild) placed by the continuous peak
#: refinement (:mod:`isodesign.table.peaks`): per round, three frequencies around each of
#: at most three peaks, for :data:`TABLE_PEAK_ROUNDS` rounds.
PEAK_SLOTS_PER_ROUND = 9
TABLE_PEAK_ROUNDS = 4
#: Objectives of the table NLP: those of the one registry with a table form
#: (:attr:`~isodesign.optimization.objectives.Objective.table`).
TABLE_OBJECTIVES = tuple(k for k, o in OBJECTIVES.items() if o.table is not None)
_LN10 = math.log(10.0)


class TableProblem(TableModeRows, NLP):
    """The NLP of a study with a ``[table]``, built once and solved from many starts.

    Parameters
    ----------
    study : Study
        With ``table`` and ``floor_axes``.
    objectives : tuple of str, optional
        ``worst_band_margin`` (default), ``total_volume`` and/or ``footprint_area`` (a free
        layout's ``L W``).
    hessian : {'limited-memory', 'exact'}, optional
        IPOPT's Hessian of the Lagrangian (gradient and Jacobian are exact either way);
        default: the rule's (:func:`~isodesign.optimization.hessian.hessian_choice`).
    peak_slots : int
        Movable peak frequencies (:meth:`set_slots`; used only with a peak bound). The
        continuous peak refinement builds the NLP again with
        :data:`PEAK_SLOTS_PER_ROUND` x :data:`TABLE_PEAK_ROUNDS` of them
        (:meth:`with_peak_slots`) when a peak lies above the bound between the grid's
        frequencies: the rows cost a quarter of a solve's time, so a study that needs no
        refinement does not carry them.
    """

    def __new__(cls, study=None, *args, **kwargs):
        # models.distortion: the table's NLP with the distortion power's rows
        # (optimization.distortion_rows); a subclass of another NLP refuses it in __init__
        if cls is TableProblem and study is not None and study.models.get("distortion"):
            return super().__new__(TableDistortionProblem)
        return super().__new__(cls)

    def __init__(self, study, objectives: tuple | None = None, *,
                 hessian: str | None = None, peak_slots: int = 0, _point=None):
        import casadi as ca

        # the grid's point function of an NLP of the same study (with_peak_slots), reused
        self._reused_point = _point

        if study.models.get("distortion") and not getattr(self, "distortion", False):
            raise InputError("models.distortion = true: this NLP does not carry the "
                             "distortion power yet; set models.distortion = false")

        from isodesign.optimization.hessian import hessian_choice

        self._rule = hessian_choice(study)
        self.hessian = self._rule["hessian"] if hessian is None else hessian

        if study.table is None:
            raise InputError("study: has no [table]; use isodesign.optimization.Problem")
        self.study = study
        self.objectives = tuple(objectives or (study.objective["kind"],))
        for kind in self.objectives:
            if kind not in TABLE_OBJECTIVES:
                raise InputError(f"objective.kind: {kind!r} is not available for a table study; "
                                 f"valid: {', '.join(TABLE_OBJECTIVES)}")
        self.objective = self.objectives[0]
        m = study.models
        if m["random_method"] != "statistical":
            raise InputError("models.random_method: a table study uses 'statistical'")
        self.flow = m["flow"]
        self.dia = diaphragm_model(m["diaphragm"])
        self.scaling = log_scaling(study)
        # the horizontal element's free levers (docs/table.md, "Co-design levers"): linear
        # scaled variables after the spring's, evaluated through horizontal_stiffness and
        # the assembly's elastic-centre terms; the NLP's table holds their start values
        self.lever_scaling = lever_scaling(study)
        self.n_levers = len(self.lever_scaling.names)
        if "footprint_area" in self.objectives and not self._layout_free():
            raise InputError("objectives: footprint_area needs a free layout "
                             "(variables.layout_length_m or layout_width_m, fixed = false; "
                             "docs/table.md section 15)")
        self.table = study.table_at(None)
        lever_nlp.check_base_objectives(self)  # added_mass: a free inertia base's
        # per-group springs (docs/table.md, section 15): each group's four variables after
        # the levers, when the study names one or its table holds a group's own spring
        self.grouped = any(v.name in GROUP_SPRING_LEVERS for v in study.levers) or \
            any(self.table.group_springs)
        self.grid = table_grid(study.floor_axes, study.bands, target=study.target,
                               points_per_band=m["points_per_band"])
        self.leveling = level(self.table, study.hardware["piston_area_m2"])
        lever_nlp.check_base_start_loads(self, study)  # NLP rows with a free inertia base
        self.geo = geometry(self.table, self.leveling.load_n)
        self.lever_dirs = lever_directions(self.geo, self.table)
        self.n = self.table.n_isolators
        self.k = self.table.instrument_points_m.shape[0]
        self.kh_re, self.kh_im = self._kh_params(self.grid.omega)
        self.n_modes = 6
        from isodesign.table.study import objective_selection

        self.objective_axes, self.objective_points = objective_selection(
            study.raw.get("table", {}), self.table)
        # per mode [active, w, phi_re(6), phi_im(6)]; an inactive mode keeps w = 2 pi rad/s
        # damping block then rocking block, 6 modes x 14 each
        self.mode_params = np.tile(np.r_[0.0, 2 * math.pi, np.zeros(12)], 2 * self.n_modes)
        pk = study.constraints.get("max_peak_transmissibility_db")
        self.n_slots = int(peak_slots) if pk is not None and pk is not False else 0
        # unused slots repeat the grid's first frequency (rows the grid already has)
        self.set_slots(np.full(self.n_slots, float(self.grid.frequency_hz[0])))
        from isodesign.table.leveling import leveling_margin_bounds, leveling_of_study

        self.loop_bound_db = leveling_margin_bounds(study)[0]
        if self.grouped and leveling_margin_bounds(study) != (None, None):
            raise InputError("constraints.min_leveling_gain_margin_db: the leveling loop's "
                             "margin bounds are not yet held with per-group springs; set "
                             "min_leveling_gain_margin_db and min_leveling_phase_margin_deg "
                             "to false (docs/table.md, sections 12 and 14)")
        lever_nlp.refuse_free_base_with_loop(study)
        self.loop_system = leveling_of_study(study)
        self.n_states = 12 + 2 * self.n
        self.n_loop = LOOP_POLES_MIMO + 3 if self.loop_bound_db is not None else 0
        self.clear_loop()
        self._build(ca)

    def with_peak_slots(self, n: int = PEAK_SLOTS_PER_ROUND * TABLE_PEAK_ROUNDS) -> TableProblem:
        """The same NLP built with ``n`` movable peak frequencies (its frozen modes kept).

        Parameters
        ----------
        n : int
            Movable frequencies (default :data:`PEAK_SLOTS_PER_ROUND` x
            :data:`TABLE_PEAK_ROUNDS`).

        Returns
        -------
        TableProblem
            Its decision variables are this one's (a solution's ``x`` carries over).
        """
        new = type(self)(self.study, self.objectives, hessian=self.hessian, peak_slots=n,
                         _point=getattr(self, "_point", None))
        new.mode_params = self.mode_params.copy()
        new.loop_params = self.loop_params.copy()
        return new

    # -- the horizontal element ---------------------------------------------------
    def _kh_params(self, w):
        """The horizontal stiffness the NLP takes as parameters, ``(re, im)`` (n, len(w)):
        all of it with the levers fixed; with free levers only a lateral model's (else 0),
        the rest is symbolic (:meth:`_kh`)."""
        w = np.asarray(w, float)
        h = self.table.horizontal
        if self.n_levers and h.lateral_model is None:
            z = np.zeros((self.n, w.size))
            return z, z.copy()
        if self.n_levers:
            kh = [h.lateral_stiffness(w) for _ in range(self.n)]
        else:
            kh = [h.stiffness(w, float(ld)) for ld in self.leveling.load_n]
        re = np.stack([np.broadcast_to(np.asarray(c.re, float), w.shape) for c in kh])
        im = np.stack([np.broadcast_to(np.asarray(c.im, float), w.shape) for c in kh])
        return re, im

    def _lever_free(self, name: str) -> bool:
        return name in self.lever_scaling.names

    def _layout_free(self) -> bool:
        return self._lever_free("layout_length_m") or self._lever_free("layout_width_m")

    def _scale(self, dv) -> tuple:
        """The layout's stretch ``(s_x, s_y)`` from the design vector (1.0 when fixed)."""
        if not self._layout_free():
            return 1.0, 1.0
        nd = len(DESIGN_VARIABLES) + CODESIGN_LEVERS.index("layout_length_m")
        return layout_scale(self.table, dv[nd], dv[nd + 1])

    def _terms(self, dv, shift) -> list:
        """The geometric levers' ``(t_k, C_k)`` (:mod:`~isodesign.table.lever_geometry`)."""
        terms = [] if shift is None else [(shift, self.lever_dirs["elastic_centre_height_m"])]
        sx, sy = self._scale(dv)
        for name, sk in (("layout_length_m", sx), ("layout_width_m", sy)):
            if self._lever_free(name):
                terms.append((sk - 1.0, self.lever_dirs[name]))
        return terms + lever_nlp.position_terms(self, dv)  # free positions

    def _assemble(self, dv, kv, kh, w, shift):
        """``D(w)``, ``B(w)`` with the free geometric levers (today's path without a free
        layout lever)."""
        d, b = dynamic_stiffness(self.geo, kv, kh, w, shift) if not (
            self._layout_free() or lever_nlp.positions_free(self)) else \
            lever_stiffness(self.geo, self._terms(dv, shift), kv, kh, w)
        return slab_terms.base_stiffness(d, w, self._base(dv)), b

    def _kh(self, dv, w, khr, khi):
        """Each isolator's horizontal stiffness (list of Cx) and the elastic-centre shift
        (None with the lever fixed) from the design vector ``dv`` (spring, then every
        co-design lever when any is free) and the parameters ``khr``, ``khi``."""
        if not self.n_levers:
            return [Cx(khr[i], khi[i]) for i in range(self.n)], None
        nd = len(DESIGN_VARIABLES)
        lp, ec, kl, eta = (dv[nd + j] for j in range(4))  # CODESIGN_LEVERS order
        h = self.table.horizontal
        if h.pendulum_length_m is None and not self._lever_free("pendulum_length_m"):
            lp = None
        out = []
        base = self._base(dv)  # the slab: loads scale, CG rises; free positions: loads move
        for i, ld in enumerate(lever_nlp.isolator_loads(self, dv)):
            if h.lateral_model is None:
                out.append(horizontal_stiffness(w, ld, lp, kl, eta))
            else:
                out.append(Cx(khr[i], khi[i]) + (0.0 if lp is None else ld / lp))
        shift = (ec - h.elastic_centre_height_m) if self._lever_free(
            "elastic_centre_height_m") else None
        return out, slab_terms.centre_shift(shift, base)

    def _base(self, dv):  # the inertia base's terms (docs/table.md s. 16; None: it is fixed)
        return lever_nlp.base_terms(self, dv)

    def _n_dv(self) -> int:  # spring, levers, groups' springs, free positions, payload
        return self._group_off() + (3 * len(DESIGN_VARIABLES) if self.grouped else 0) + \
            lever_nlp.n_position_values(self) + self._n_payload

    #: The payload's values the design vector carries last (a parametric NLP's mass, CG
    #: height, inertia and CG plan position, :meth:`_payload_values`; none here: numbers).
    _n_payload = 0

    def _payload_values(self, ca, X) -> list:
        """The design vector's payload entries (none: the payload is the table's numbers;
        :class:`~isodesign.optimization.table_parametric.TableParametricProblem` gives
        parameters)."""
        return []

    def _live_loads(self, dv):
        """Each isolator's static load as a function of the parameters (None: the table's
        leveling, or the levers' own path; :mod:`~isodesign.optimization.lever_nlp`)."""
        return None

    def _point_rows(self, p: int, dv) -> tuple:
        """Instrument point ``p``'s ``G_r`` rows (:func:`~isodesign.table.inertia_base.
        base_point_rows`)."""
        return slab_terms.base_point_rows(self.geo.points[p], self._base(dv))

    def _tilt_bound(self, slab, mu) -> tuple:
        """``(W h, mu)`` of the tilt rows (:func:`~isodesign.table.inertia_base.tilt_bound`)."""
        return slab_terms.tilt_bound(self.table, slab, mu)

    def _group_off(self) -> int:
        return len(DESIGN_VARIABLES) + (len(CODESIGN_LEVERS) if self.n_levers else 0)

    def _designs(self, dv) -> tuple:
        """The shared spring and each isolator's (its p0; its group's own variables when
        grouped: ``dv`` holds every group's four after the levers)."""
        base = self.study.design_at({n: dv[i] for i, n in enumerate(DESIGN_VARIABLES)})
        lv = self.leveling
        pressures = lever_nlp.isolator_pressures(self, dv)  # the slab's, the positions'
        if not self.grouped:
            return base, [base.replace(pressure_pa=p) for p in pressures]
        off, nd = self._group_off(), len(DESIGN_VARIABLES)
        own = [{n: dv[off + nd * g + j] for j, n in enumerate(DESIGN_VARIABLES)}
               for g in range(3)]
        return base, [base.replace(pressure_pa=p, **own[int(g)])
                      for p, g in zip(pressures, lv.group_of, strict=True)]

    # -- the per-frequency physics ------------------------------------------------
    def _springs(self, ca, dv, s, y, w):
        base, designs = self._designs(dv)
        kv, g2 = [], []
        for i in range(self.n):
            d = designs[i]
            c = statistical_resistance_function(self.flow, d, w)(ca.exp(y[i]))
            k = spring_stiffness(air_stiffness(d, w, c, self.flow),
                                 self.dia.stiffness(w, EQUIVALENT_AMPLITUDE_FACTOR * ca.exp(s[i])))
            kv.append(k)
            g2.append(tube_velocity_gain2(d, w, c, self.flow))
        return base, kv, g2

    def _body(self, ca, dv, s, y, w, khr, khi):
        """The table's motion per unit floor motion at one frequency: ``(q_re, q_im, g2)``."""
        _, kv, g2 = self._springs(ca, dv, s, y, w)
        kh, shift = self._kh(dv, w, khr, khi)
        d, b = self._assemble(dv, kv, kh, w, shift)
        q = solve_complex(d, b)
        qr = [[q.re[0, r * 3 + a] for a in range(3)] for r in range(6)]
        qi = [[q.im[0, r * 3 + a] for a in range(3)] for r in range(6)]
        return qr, qi, g2

    def _peak_function(self, ca, ahead=None):
        """``|T_p,aa|^2`` at one (movable) frequency, per point and axis
        (:func:`~isodesign.optimization.nlp.point_function`)."""
        n = self.n
        dv = ca.SX.sym("design", self._n_dv())
        s, y, w = ca.SX.sym("s", n), ca.SX.sym("y", n), ca.SX.sym("w")
        khr, khi = ca.SX.sym("khr", n), ca.SX.sym("khi", n)
        qr, qi, _ = self._body(ca, dv, s, y, w, khr, khi)
        diag = []
        for p in range(self.k):
            gp, nzp = self._point_rows(p, dv)
            for bb in range(3):
                re = sum(gp[bb][r] * qr[r][bb] for r in range(6) if nzp[bb][r])
                im = sum(gp[bb][r] * qi[r][bb] for r in range(6) if nzp[bb][r])
                diag.append(re * re + im * im)
        return nlp.point_function(ca, "table_peak", [dv, s, y, w, khr, khi],
                                  ca.vertcat(*diag), ahead=ahead)

    def _point_function(self, ca, ahead=None):
        """One frequency's physics (:func:`~isodesign.optimization.nlp.point_function`).

        Inputs: design, ``s``, ``y``, ``w`` and the horizontal stiffnesses. Outputs, one
        column: ``|z_i,a|^2`` (3 n: each isolator's stroke per unit floor motion in axis
        ``a``, ``i`` major), ``|U/X|_i^2`` (n: each tube's velocity gain), then ``|T_p,ba|^2``
        (9 k: point ``p``, table axis ``b``, floor axis ``a``, in that order). What the floor
        weighs them with is applied over the grid outside (:meth:`_grid_sums`), so the
        Jacobian IPOPT evaluates at every frequency is this function's alone.
        """
        n, k = self.n, self.k
        dv = ca.SX.sym("design", self._n_dv())
        s, y, w = ca.SX.sym("s", n), ca.SX.sym("y", n), ca.SX.sym("w")
        khr, khi = ca.SX.sym("khr", n), ca.SX.sym("khi", n)
        qr, qi, g2 = self._body(ca, dv, s, y, w, khr, khi)
        t2 = []
        for p in range(k):
            gp, nzp = self._point_rows(p, dv)
            for bb in range(3):
                for a in range(3):
                    re = sum(gp[bb][r] * qr[r][a] for r in range(6) if nzp[bb][r])
                    im = sum(gp[bb][r] * qi[r][a] for r in range(6) if nzp[bb][r])
                    t2.append(re * re + im * im)
        z2 = []
        gzs = vertical_vectors(self.geo, self._terms(dv, None))
        for i in range(n):
            gz = gzs[i]
            nz = [r for r in range(6) if not (isinstance(gz[r], float) and gz[r] == 0)]
            for a in range(3):
                re = sum(gz[r] * qr[r][a] for r in nz) - (a == 2)
                im = sum(gz[r] * qi[r][a] for r in nz)
                z2.append(re * re + im * im)
        return nlp.point_function(ca, "table_point", [dv, s, y, w, khr, khi],
                                  ca.vertcat(*z2, *g2, *t2), constant=(3, 4, 5), ahead=ahead)

    def _grid_sums(self, ca, out, stroke_weight, band_weight):
        """The grid's sums of :meth:`_point_function`'s columns ``out`` ((4 n + 9 k) x nf).

        Returns ``red``: ``sigma_i^2 = sum_f sum_a sw_a |z_i,a|^2`` (n), ``sigma_u,i^2 =
        sum_f |U/X|_i^2 sum_a sw_a |z_i,a|^2`` (n), then every band's mean square ``sum_f
        sum_a bw_a,j |T_p,ba|^2`` (point, axis, band), and ``diag``: ``|T_p,bb|^2``
        (3 k x nf). ``stroke_weight`` (3, nf) and ``band_weight`` (3 nb, nf) are numbers or
        a parametric NLP's parameters.
        """
        n, k, nb = self.n, self.k, self.grid.n_bands
        s2, u2 = [], []
        for i in range(n):
            zi = ca.sum1(out[3 * i: 3 * i + 3, :] * stroke_weight)  # (1, nf)
            s2.append(ca.sum2(zi))
            u2.append(ca.sum2(zi * out[3 * n + i, :]))
        t2 = out[4 * n:, :]
        ms = 0
        for a in range(3):  # (3 k, nb): point and table axis, band
            rows = [9 * p + 3 * bb + a for p in range(k) for bb in range(3)]
            ms = ms + ca.mtimes(t2[rows, :], band_weight[a * nb: (a + 1) * nb, :].T)
        diag = t2[[9 * p + 4 * bb for p in range(k) for bb in range(3)], :]
        return ca.vertcat(*s2, *u2, ca.vec(ms.T)), diag

    def _stiffness_function(self, ca):
        """``(design, s, y, w) -> (K' flat, K'' flat)``: the isolators' 6x6 stiffness."""
        dv = ca.SX.sym("design", self._n_dv())
        s, y, w = ca.SX.sym("s", self.n), ca.SX.sym("y", self.n), ca.SX.sym("w")
        khr, khi = ca.SX.sym("khr", self.n), ca.SX.sym("khi", self.n)
        _, kv, _ = self._springs(ca, dv, s, y, w)
        kh, shift = self._kh(dv, w, khr, khi)
        d, _ = self._assemble(dv, kv, kh, w, shift)
        mass = slab_terms.base_mass_row(self.geo, self._base(dv))
        # its subexpressions merged (nlp.SX_CSE), its derivative the plain forward one: it
        # is called at the few frozen modes, where merging its Jacobian's would cost more
        # to generate (0.45 s) than it saves
        return ca.Function("table_k", [dv, s, y, w, khr, khi],
                           [(d.re + w * w * mass).T, d.im.T], {"cse": True})

    # -- the NLP ---------------------------------------------------------------------
    def _build(self, ca) -> None:
        st, n, k, g = self.study, self.n, self.k, self.grid
        nf = g.n_points
        # MX outside, the SX point function mapped inside: the derivatives are built on one
        # point's graph (an unrolled SX map of ~100 copies took a minute to differentiate)
        X = ca.MX
        nzs = len(self.scaling.names)
        z = X.sym("z", nzs + self.n_levers)
        s, y = X.sym("s", n), X.sym("y", n)
        t = X.sym("t", 1 if self.objective == "worst_band_margin" or
                  "worst_band_margin" in self.objectives else 0)
        vals = nlp.design_values(ca, X, z, self.scaling, st)
        if self.n_levers:
            ls = self.lever_scaling
            for name in CODESIGN_LEVERS:
                if name in ls.names:
                    i = ls.names.index(name)
                    vals.append(ls.center[i] + ls.half[i] * z[nzs + i])
                else:
                    start = next(lv.start for lv in st.levers if lv.name == name)
                    vals.append(X(0.0 if start is None else start))
        if self.grouped:  # each group's four: its free lever, its own value, or the shared
            from isodesign.optimization.lever_nlp import group_values

            vals += group_values(self, ca, z[nzs:], vals)
        if lever_nlp.positions_free(self):  # each isolator's x and y, last
            vals += lever_nlp.position_values(self, z[nzs:])
        vals += self._payload_values(ca, X)  # a parametric NLP's payload, last
        v = ca.vertcat(*vals)
        # the distortion power's terms (models.distortion, optimization.distortion_rows):
        # parameters, the minor loss's gain as the resistance's ln sigma_u shift y_k - y
        p_dist, added, y_k = self._distortion_parts(ca, X, z, y)
        from isodesign.optimization.executor import parallel_allowed

        threads = parallel_allowed(self.study.solver["workers"])
        ahead = [] if threads else None  # the point functions' Jacobians, in threads
        # the same study's point function (and the Jacobian CasADi generated for it), when
        # this NLP is another's with movable peak frequencies: the same SX graph
        point = self._reused_point or self._point_function(ca, ahead)
        self._point = point
        nb = g.n_bands
        bw = np.concatenate([g.band_weight[a] for a in range(3)], axis=0)  # (3 nb, nf)
        head = self._parameter_head(ca, X, bw)  # the floor, limits and references
        cols = point.map("table_map", "serial", nf, [0, 1, 2], [])(
            v, s, y_k, ca.DM(g.omega).T, ca.DM(self.kh_re), ca.DM(self.kh_im))
        red, diag = self._grid_sums(ca, cols, head["stroke_weight"], head["band_weight"])
        if added is not None:  # [stroke, tube velocity variances, band mean squares]
            red = red + added
        self._n_t = 9 * k
        rows_eq = []
        for i in range(n):
            rows_eq.append((ca.exp(2 * s[i]) - red[i]) * head["k_s"][i])
            rows_eq.append((ca.exp(2 * y[i]) - red[n + i]) * head["k_u"][i])
        margins = (10.0 / _LN10) * (head["ln_limit2"] - ca.log(red[2 * n: 2 * n + 3 * k * nb]))
        # the objective's axes and points ([table] objective_axes / objective_points)
        axes, pts = self.objective_axes, self.objective_points
        keep = [(p * 3 + b) * nb + j for p in pts for b in axes for j in range(nb)]
        judged = margins[keep] if len(keep) < 3 * k * nb else margins
        out = diag  # (3k x nf): |T_p,aa|^2
        self.n_margins = int(margins.numel())
        ns = self.n_slots
        p_slot = X.sym("slots", ns * (1 + 2 * n))
        out_slots = None
        if ns:
            pw = ca.reshape(p_slot[:ns], 1, ns)
            pkr = ca.reshape(p_slot[ns: ns + n * ns], n, ns)
            pki = ca.reshape(p_slot[ns + n * ns:], n, ns)
            out_slots = self._peak_function(ca, ahead).map("table_peak_map", "serial", ns,
                                                    [0, 1, 2], [])(v, s, y_k, pw, pkr, pki)
        d = st.design_at({nm: vals[i] for i, nm in enumerate(DESIGN_VARIABLES)})
        cons = self._constraints(ca, d, v, s, y, out, out_slots)
        _, designs = self._designs(v)
        # the objectives' quantities; their forms are the registry's (objectives.OBJECTIVES)
        # the total volume per isolator: the mean over the isolators with per-group springs
        q = {"ln_total_volume": ca.log(d.total_volume_m3) if not self.grouped else
             ca.log(sum(di.total_volume_m3 for di in designs) / n), "margins_db": judged,
             "t_worst_band_margin": t[0] if t.numel() else None}
        if "footprint_area" in self.objectives:  # ln (L W) of the stretched layout
            sx, sy = self._scale(v)
            ex, ey = layout_extent(self.table)
            q["ln_footprint_area"] = ca.log(sx * sy * (ex * ey))
        slab_parts = lever_nlp.base_objective_parts(self, v)  # added_mass (t)
        if slab_parts:
            q["added_mass_t"] = slab_parts["added_mass"]
        js, obj_cons = [], []
        for kind in self.objectives:
            jk, ocons = OBJECTIVES[kind].table(q)
            js.append(jk)
            obj_cons += ocons
        cons[:0] = obj_cons  # the epigraph rows first
        p_w = X.sym("weights", len(self.objectives))
        p_wd = X.sym("w_diameter")
        p_eps = X.sym("eps", len(self.objectives))
        p_modes = X.sym("modes", self.mode_params.size)
        self._p_modes_sym = p_modes
        cons += self._damping(ca, v, s, y_k, p_modes)
        p_loop = X.sym("loop", self.loop_params.size)
        cons += self._loop_rows(ca, v, p_loop)
        # the distortion's outer fixed point: its proximal term (zero at a fixed point)
        j_total = p_wd * ca.log(d.capillary_diameter_m) + self._outer_proximal(ca, z, p_dist)
        for i, jk in enumerate(js):
            j_total = j_total + p_w[i] * jk
            cons.append((f"bound_{self.objectives[i]}", jk - p_eps[i], -np.inf, 0.0))
        x = ca.vertcat(z, s, y, t)
        # the parameters: a parametric NLP's head last (p_dist is empty there: it refuses
        # models.distortion; head["q"] is empty on the distortion's NLP)
        pp = ca.vertcat(p_w, p_wd, p_eps, p_modes, p_slot, p_loop, p_dist, head["q"])
        gg = ca.vertcat(*rows_eq, *[c[1] for c in cons])
        self.n_eq = 2 * n
        self.lbg, self.ubg, self.con_rows = nlp.constraint_rows(
            self.n_eq, [(name, int(expr.numel()), lo, hi) for name, expr, lo, hi in cons])
        self.nz, self.nx = int(z.numel()), int(x.numel())
        self.lbx, self.ubx = nlp.variable_boxes(
            (self.nz, -1.0, 1.0),
            (n, math.log(nlp.SIGMA_BOUNDS_M[0]), math.log(nlp.SIGMA_BOUNDS_M[1])),
            (n, math.log(nlp.VELOCITY_BOUNDS_M_S[0]), math.log(nlp.VELOCITY_BOUNDS_M_S[1])),
            (int(t.numel()), -nlp.EPIGRAPH_BOUND, nlp.EPIGRAPH_BOUND))
        self._p_dist_sym = p_dist
        self._x_functions(ca, x, judged, margins, ca.vertcat(*js))
        self.eval_fn = ca.Function("eval", [x, pp], [j_total, gg])
        from types import SimpleNamespace

        funcs = {"x": x, "f": j_total, "g": gg, "p": pp}
        # the derivatives generated once, for the cold solver and the warm one of the peak
        # refinement's re-solves (built on first use: NLP.warm_solver_factory)
        opts = {**self.ipopt_options(), **nlp.derivative_functions(
            SimpleNamespace(ca=ca, x=x, p=pp, j_total=j_total, g=gg), threads,
            hessian=self.hessian == "exact", ahead=ahead or ())}
        self.solver = ca.nlpsol("isodesign_table", "ipopt", funcs, opts)
        self._warm_solver = self.warm_solver_factory(ca, funcs, opts)

    def _rows(self, q: dict) -> list:
        """The rows of the kinds whose quantities ``q`` holds, as ``(key, expr, lo, hi)``:
        the registry's (:func:`~.constraint_registry.constraint_rows_of`, the kinds
        :data:`~.constraint_registry.TABLE_ROWS` requests, in its order)."""
        return [(c.key, c.expr, c.lo, c.hi)
                for c in constraint_rows_of(self.study, q, TABLE_ROWS)]

    # -- the parameter head: what a parametric table NLP takes as parameters -----------
    def _parameter_head(self, ca, X, bw) -> dict:
        """The floor's weights (``stroke_weight`` (3, nf), ``band_weight`` (3 nb, nf)), the
        squared band limits (``ln_limit2``, every point and axis), the closure's references
        (``k_s = 1 / sigma_ref^2``, ``k_u = 1 / sigma_u,ref^2`` per isolator) and ``q``, the
        parameters they take: here numbers of this study (``q`` empty);
        :class:`~isodesign.optimization.table_parametric.TableParametricProblem` makes
        them parameters (docs/sweep.md, section 7)."""
        g = self.grid
        self.sigma_ref, self.tube_ref = self._reference_sigma()
        lim2 = np.tile(np.asarray(g.limit_velocity_m_s, float) ** 2, 3 * self.k)
        return {"stroke_weight": ca.DM(g.stroke_weight), "band_weight": ca.DM(bw),
                "ln_limit2": ca.log(ca.DM(lim2)), "k_s": 1.0 / self.sigma_ref ** 2,
                "k_u": 1.0 / self.tube_ref ** 2, "q": X(0, 1)}

    def _x_functions(self, ca, x, judged, margins, js) -> None:
        """The margins and objectives at ``x`` (Functions of ``x``; of ``x`` and the
        parameters on a parametric NLP)."""
        pd = self._p_dist_sym  # the distortion's parameters (none without it)
        self._margins_fn = self._bound(ca.Function("margins", [x, pd], [judged]))
        self._all_margins_fn = self._bound(ca.Function("all_margins", [x, pd], [margins]))
        self._j_fn = self._bound(ca.Function("objectives", [x, pd], [js]))

    def _constraints(self, ca, d, v, s, y, out, out_slots=None) -> list:
        """The rows on the design's quantities: volume, vertical mode, stroke, tilt,
        layout, loads, peak |T| (the registry's entries; this body measures them)."""
        c = self.study.constraints
        table, lv = self.table, self.leveling
        _, designs = self._designs(v)
        # every group's spring with per-group springs
        q = {"ln_total_volume": ca.log(d.total_volume_m3) if not self.grouped else ca.vertcat(*[
            ca.log(designs[list(lv.group_of).index(g)].total_volume_m3) for g in range(3)])}
        slab = self._base(v)  # the inertia base: loads and mass follow its lever
        k0 = [static_stiffness(di, self.dia, mi)
              for di, mi in zip(designs, lever_nlp.isolator_masses(self, v), strict=True)]
        q["ln_fn"] = 0.5 * ca.log(sum(k0) / slab_terms.body_mass(table, slab)
                                  / (2.0 * math.pi) ** 2)
        # peak factor x RMS vertical stroke of every isolator: ln, linear in s
        q["ln_stroke"] = s + math.log(c.get("stroke_peak_factor") or 3.0)
        mu = c.get("min_tilt_margin")
        if mu and (table.cg_height_m > 0 or slab is not None):  # the analysis's verdict
            from isodesign.table.statics import sealed_stiffness, tilt_margin_rows

            kq = [sealed_stiffness(di, self.dia, flow=self.flow) for di in designs]
            wh, mu = self._tilt_bound(slab, mu)
            q["tilt_rows"] = ca.vertcat(*tilt_margin_rows(
                kq, lever_nlp.tilt_points(self, v), wh, mu, self._scale(v)))
        # free positions: the footprint polygon and spacing (layout) and the loads and
        # supply of the live statics (loads), lever_nlp.position_rows; else the parametric
        # layout's rows and a free slab's loads
        pos = lever_nlp.position_rows(self, v)
        if pos:
            geo = ("footprint_polygon_m", "isolator_distance_m2")
            q["layout_rows"] = [r for r in pos if r[0] in geo]
            q["load_rows"] = [r for r in pos if r[0] not in geo]
        else:
            q["layout_rows"] = layout_rows(self.table, c, self._scale(v), self._layout_free())
            q["load_rows"] = lever_nlp.load_rows_of(lv, c, lever_nlp.base_terms(self, v))
        pk = c.get("max_peak_transmissibility_db")
        if pk is not None and pk is not False:
            # resonance peaks of a table on air springs lie at its rigid-body modes: the rows
            # stop at PEAK_ROWS_MAX_HZ (the analysis checks the whole grid, see
            # TableBandResponse.peak_transmissibility_db); inactive rows above only slowed
            # the quasi-Newton iterations (62 against 22 from one start)
            # the movable frequencies of the continuous peak refinement follow the grid's
            # rows (ln |T|^2 <= the bound's ln |T|^2: the form constraint_reports converts)
            cols = np.flatnonzero(self.grid.frequency_hz <= self._peak_cut_hz())
            rows = ca.vec(out[:, cols.tolist()].T)
            if out_slots is not None:
                rows = ca.vertcat(rows, ca.vec(out_slots.T))
            q["ln_T2_peak"] = ca.log(rows)
        if c.get("model_validity"):  # the Mach, Reynolds, Womersley numbers, the acoustics'
            q.update(validity_quantities(d, designs, y, float(np.max(self.grid.omega)),
                                         lv.group_of if self.grouped else None))
        return self._rows(q)

    # -- the leveling loop's gain margin (isodesign.optimization.loop_rows) -------------------
    def _loop_rows(self, ca, v, p_loop) -> list:
        """The gain-margin rows (:func:`~isodesign.optimization.loop_rows.loop_rows`; the
        registry's ``leveling_loop`` entry)."""
        return self._rows({"loop_rows": loop_rows(self, ca, v, p_loop)})

    def clear_loop(self) -> None:
        """Switch the gain-margin rows off (every frozen pole inactive)."""
        self.loop_params = np.zeros(self.n_loop * (2 + self.n_states ** 2))

    def set_loop(self, d) -> None:
        """Freeze the leveling loop's gain-margin rows at design ``d``'s poles
        (:func:`~isodesign.optimization.loop_rows.frozen_poles`).

        Parameters
        ----------
        d : SpringDesign
        """
        if not self.n_loop:
            return
        self.loop_system, self.loop_params = frozen_poles(self, d)

    # -- references, starts, solving ---------------------------------------------------
    def closure(self, d, values: dict | None = None):
        """NumPy closure of the design on the NLP's grid: ``(sigma (n,), sigma_u (n,))``.

        Parameters
        ----------
        d : SpringDesign
        values : dict, optional
            Lever values (the table at :meth:`Study.table_at`); default their starts.
        """
        from isodesign.table.model import table_model
        from isodesign.table.response import TableStatistical, solve_table_closure

        m = self.study.models
        table = self.table if values is None else self.study.table_at(values)
        model = table_model(d, table, flow=self.flow, amplitude_mode=m["amplitude_mode"],
                            diaphragm=self.dia)  # fmt: skip
        sigma, sigma_u, _ = solve_table_closure(TableStatistical(model, self.grid))
        return sigma, sigma_u

    @property
    def hessian_info(self) -> dict:
        """IPOPT's Hessian of this NLP and why: the rule's
        (:func:`~isodesign.optimization.hessian.hessian_choice`), or the caller's."""
        if self.hessian == self._rule["hessian"]:
            return dict(self._rule)
        return {"hessian": self.hessian, "reason": "the prebuilt NLP's choice"}

    def _param_tail(self) -> np.ndarray:
        """Frozen modes (:meth:`set_modes`), movable peak frequencies (:meth:`set_slots`),
        frozen loop poles (:meth:`set_loop`), after the objectives' parameters
        (:meth:`~.nlp.NLP.params`)."""
        return np.concatenate([self.mode_params, self.slot_params, self.loop_params,
                               self._current_dist()])

    # hooks of the distortion power's rows (:class:`~.distortion_rows.TableDistortionMixin`)
    def _distortion_parts(self, ca, X, z, y) -> tuple:
        """``(parameters, added reductions or None, y of the springs)``: none here."""
        return X.sym("distortion", 0), None, y

    def _outer_proximal(self, ca, z, p_dist):
        """The outer fixed point's proximal term of the objective (none here)."""
        return 0.0

    def _current_dist(self) -> np.ndarray:
        """The distortion's parameter values (none here)."""
        return np.zeros(0)

    def _bound(self, fn):
        """``fn(x, p_dist)`` as a function of ``x``, at :meth:`_current_dist`."""
        return lambda x: fn(x, self._current_dist())

    def set_slots(self, frequencies_hz) -> None:
        """Move the peak constraint's movable frequencies (NLP parameters, no rebuild).

        Parameters
        ----------
        frequencies_hz : sequence of float
            :attr:`n_slots` frequencies, Hz; each adds the peak rows ``|T_p,aa|^2`` of every
            point and axis at that frequency (the springs at the closure's RMS values, the
            horizontal element at that frequency).
        """
        f = np.asarray(frequencies_hz, float).ravel()
        if f.size != self.n_slots:
            raise ValueError(f"set_slots: need {self.n_slots} frequencies, got {f.size}")
        w = 2.0 * math.pi * f
        kr, ki = self._kh_params(w) if self.n_slots else (np.zeros((self.n, 0)),) * 2
        self.slot_hz = f.copy()
        # CasADi reshapes column-major: element (i, j) of the (n, n_slots) block at i + j n
        self.slot_params = np.concatenate([w, kr.ravel(order="F"), ki.ravel(order="F")])

    def _fill_guess(self, x0: np.ndarray, d, sigma, sigma_u) -> None:
        """ln sigma_i, ln sigma_u,i from the NumPy closure, the epigraph tight
        (:meth:`~.nlp.NLP.initial_guess`)."""
        x0[self.nz: self.nz + self.n] = np.log(sigma)
        x0[self.nz + self.n: self.nz + 2 * self.n] = np.log(sigma_u)
        if self.nx > self.nz + 2 * self.n:
            x0[-1] = float(np.min(np.asarray(self._margins_fn(x0))))

    def objective_values(self, x: np.ndarray) -> np.ndarray:
        """Internal values J of every objective at ``x``.

        Parameters
        ----------
        x : ndarray
        """
        return np.asarray(self._j_fn(x)).ravel()

    def lever_sensitivities(self, x: np.ndarray, sol=None) -> tuple:
        """The re-optimized sensitivity of the worst margin to each free lever's bounds
        (:func:`~isodesign.optimization.lever_nlp.lever_sensitivities`).

        Parameters
        ----------
        x : ndarray
            The optimum.
        sol : Solution, optional
            The solve that ended there (its multipliers; default: IPOPT solves again).
        """
        from isodesign.optimization.lever_nlp import lever_sensitivities

        return lever_sensitivities(self, x, sol)

    def worst_margin_db(self, x: np.ndarray) -> float:
        """Worst margin over points, axes and bands at ``x`` (dB).

        Parameters
        ----------
        x : ndarray
        """
        return float(np.min(np.asarray(self._margins_fn(x))))

    def sigma(self, x: np.ndarray) -> np.ndarray:
        """Stroke RMS per isolator at ``x``, m.

        Parameters
        ----------
        x : ndarray
        """
        return np.exp(x[self.nz: self.nz + self.n])

    def tube_rms(self, x: np.ndarray) -> np.ndarray:
        """Tube-velocity RMS per isolator at ``x``, m/s.

        Parameters
        ----------
        x : ndarray
        """
        return np.exp(x[self.nz + self.n: self.nz + 2 * self.n])


class TableDistortionProblem(TableDistortionMixin, TableProblem):
    """The table's NLP with the distortion power's rows (``models.distortion = true``)."""


#: Refinement frequencies placed around each peak above the bound (relative).
_PEAK_SHIFTS = (0.995, 1.0, 1.005)


def add_peak_frequencies(prob, over, used) -> tuple:
    """Place movable peak frequencies around the peaks above the bound.

    Parameters
    ----------
    prob : TableProblem
        Built again with movable frequencies (:meth:`~.table_problem.TableProblem.with_peak_slots`)
        if it has none.
    over : list of (float, float)
        ``(excess dB, frequency Hz)`` of the peaks above the bound, worst first
        (:meth:`~isodesign.table.peaks.TablePeaks.above`).
    used : list of float
        The frequencies placed so far (kept).

    Returns
    -------
    (TableProblem, list of float)
        The NLP with ``used`` and the new frequencies set, and the new frequencies: 0.995, 1
        and 1.005 times each of at most three distinct peak frequencies (none when every
        movable frequency is taken).
    """
    new: list[float] = []
    for _, f in over:  # the worst peaks, three frequencies around each distinct one
        if any(abs(f / g - 1) < 2e-3 for g in new[1::3]):
            continue
        new += [f * r for r in _PEAK_SHIFTS]
        if len(new) >= PEAK_SLOTS_PER_ROUND:
            break
    if not prob.n_slots:  # the NLP with movable peak frequencies, built when needed
        prob = prob.with_peak_slots()
    new = new[: max(0, prob.n_slots - len(used))]
    f0 = float(prob.grid.frequency_hz[0])
    prob.set_slots(list(used) + new + [f0] * (prob.n_slots - len(used) - len(new)))
    return prob, new
