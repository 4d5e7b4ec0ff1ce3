"""The co-design levers in the table NLP: per-group springs and the levers' sensitivities.

:func:`group_values` writes each leveling group's four spring variables into the NLP's
design vector (docs/table.md, section 15); :func:`lever_sensitivities` reads the worst
margin's exact sensitivity to every free lever's active bound from IPOPT's bound
multipliers (section 13).
"""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError
from isodesign.optimization.variables import CODESIGN_LEVERS, DESIGN_VARIABLES
from isodesign.table.inertia_base import BASE_LEVER, base_lever_terms
from isodesign.table.layout import POSITION_LEVER, is_position_lever, position_lever_names

__all__ = ["MIN_GROUP_LOAD_FRACTION", "SAFE_LOAD_FRACTION", "SCREEN_MIN", "SCREEN_PER_START",
           "SUPPLY_ROW_MARGIN_PA",
           "base_objective_parts",
           "base_terms", "check_base_objectives", "check_base_start_loads", "draw_positions",
           "group_values",
           "isolator_loads", "isolator_masses", "isolator_pressures", "lever_sensitivities",
           "live_mass_quotient",
           "load_rows_of", "n_position_values", "position_rows", "position_rows_numpy",
           "position_sensitivities",
           "position_terms",
           "position_values", "positions", "positions_free", "refuse_free_base_with_loop",
           "safe_load",
           "tilt_points"]


def group_values(prob, ca, z_levers, shared: list) -> list:
    """Each group's four spring variables, groups 1..3: its free lever (log-scaled), the
    study's fixed value of its lever, the table's own value (``Table.group_springs``) or
    the shared variable.

    Parameters
    ----------
    prob : TableProblem
    ca : module
        CasADi.
    z_levers : MX
        The scaled free levers (``prob.lever_scaling`` order).
    shared : list
        The design vector so far (the shared spring's four first).

    Returns
    -------
    list
        12 entries, group by group in :data:`DESIGN_VARIABLES` order.
    """
    ls = prob.lever_scaling
    named = {lv.name: lv for lv in prob.study.levers}
    out = []
    for g in range(3):
        for j, field in enumerate(DESIGN_VARIABLES):
            name = f"{field}_group{g + 1}"
            if name in ls.names:
                i = ls.names.index(name)
                out.append(ca.exp(ls.center[i] + ls.half[i] * z_levers[i]))
            elif name in named:
                out.append(ca.MX(named[name].start))
            elif field in prob.table.group_springs[g]:
                out.append(ca.MX(prob.table.group_springs[g][field]))
            else:
                out.append(shared[j])
    return out


def lever_sensitivities(prob, x: np.ndarray, sol=None) -> tuple:
    """The re-optimized sensitivity of the worst margin to each free lever's bounds.

    The bound multipliers ``lam_x`` of IPOPT's solve that ended at the optimum ``x`` (``sol``,
    solved with the NLP's default parameters: the worst margin alone; without it IPOPT
    solves again from ``x``) give, by the envelope theorem, the derivative of
    the optimal objective ``J = -t`` with respect to each bound of the scaled lever ``z``:
    ``dJ*/dbound = -lam_x``, so the worst margin moves by ``lam_x / (dv/dz)`` dB per unit of
    the lever's active bound, ``dv/dz = h`` for a linear lever (``v = c + h z``) and
    ``h v`` for a log-scaled per-group spring lever (``ln v = c + h z``); zero for a lever
    inside its bounds (docs/table.md, sections 13 and 14).

    Parameters
    ----------
    prob : TableProblem
    x : ndarray
        The optimum.
    sol : Solution, optional
        The solve that ended at ``x`` with the NLP's default parameters (its multipliers;
        the table optimizer's last solve: its peak refinement's, or the distortion's
        converged round, whose proximal term vanishes with its gradient there).

    Returns
    -------
    tuple of dict
        Per free lever: ``name``, ``value``, ``lower``, ``upper``, ``at_bound``
        (``"lower"``, ``"upper"`` or None), ``db_per_unit`` (dB of worst margin per unit
        of the active bound, SI), ``status`` of the solve.
    """
    if not prob.n_levers or "worst_band_margin" != prob.objective:
        return ()
    if sol is not None and sol.lam_x is not None and sol.lam_g is not None:
        res = {"x": sol.x, "lam_x": sol.lam_x, "g": sol.g, "lam_g": sol.lam_g}
        status = sol.status
    else:
        res = prob.solver(x0=x, lbx=prob.lbx, ubx=prob.ubx, lbg=prob.lbg, ubg=prob.ubg,
                          p=prob.params())
        status = prob.solver.stats().get("return_status", "unknown")
    lam = np.asarray(res["lam_x"]).ravel()
    xs = np.asarray(res["x"]).ravel()
    nzs = len(prob.scaling.names)
    ls = prob.lever_scaling
    vals = ls.to_values(np.clip(xs[nzs: prob.nz], -1.0, 1.0))
    out = []
    for i, name in enumerate(ls.names):
        if is_position_lever(name):  # its box never binds: the footprint's rows (below)
            continue
        zi = xs[nzs + i]
        at = "upper" if zi > 1 - 1e-6 else "lower" if zi < -1 + 1e-6 else None
        spec = next(v for v in prob.study.levers if v.name == name)
        dv_dz = ls.half[i] * (vals[name] if ls.is_log(i) else 1.0)
        out.append({"name": name, "value": vals[name], "lower": spec.lower,
                    "upper": spec.upper, "at_bound": at,
                    "db_per_unit": float(lam[nzs + i] / dv_dz), "status": status})
    out += position_sensitivities(prob, np.asarray(res["g"]).ravel(),
                                  np.asarray(res["lam_g"]).ravel(), status)
    return tuple(out)


#: A footprint or spacing row within this of its bound binds (m, m^2).
BINDING_TOL = 1e-6


def position_sensitivities(prob, g: np.ndarray, lam_g: np.ndarray, status: str) -> list:
    """The free positions' binding rows in words and the worst margin's exact sensitivity
    to each (docs/table.md, section 15): an edge of the footprint polygon moved outward by
    ``delta`` lowers its rows' bound to ``-delta``, so the margin moves by ``-sum lam_g`` dB
    per m (the edge's rows); the minimum distance's rows are ``d_ij^2 >= d_min^2``, so it
    moves by ``2 d_min sum lam_g`` dB per m of ``min_isolator_distance_m`` (envelope
    theorem, as the levers' bounds). Only binding rows are listed.

    Parameters
    ----------
    prob : TableProblem
    g, lam_g : ndarray
        The re-solve's constraint values and multipliers.
    status : str
        The re-solve's status.

    Returns
    -------
    list of dict
        ``name`` (``footprint_edge_<k>``, ``min_isolator_distance_m``), ``value`` (the
        edge's two vertices, or the distance, m), ``binding`` (words), ``db_per_unit``,
        ``at_bound`` (``"binding"``), ``lower``/``upper`` (None), ``status``.
    """
    if not positions_free(prob):
        return []
    from isodesign.table.study import position_polygon

    st, n = prob.study, prob.table.n_isolators
    spec = (st.raw.get("variables") or {}).get(POSITION_LEVER) or {}
    poly = position_polygon(spec, st.constraints, f"variables.{POSITION_LEVER}")
    rows = {name: (row, m) for name, row, m in prob.con_rows}
    out = []
    if "footprint_polygon_m" in rows:
        row, m = rows["footprint_polygon_m"]
        ne = len(poly)
        gv, lv = g[row: row + m].reshape(n, ne), lam_g[row: row + m].reshape(n, ne)
        for k in range(ne):
            on = [i for i in range(n) if gv[i, k] < BINDING_TOL]
            if not on:
                continue
            a, b = poly[k], poly[(k + 1) % ne]
            who = ", ".join(str(i + 1) for i in on)
            out.append({"name": f"footprint_edge_{k + 1}", "value": (tuple(a), tuple(b)),
                        "lower": None, "upper": None, "at_bound": "binding",
                        "binding": f"isolator{'s' if len(on) > 1 else ''} {who} on the "
                                   f"footprint's edge {k + 1}, ({a[0]:.4g}, {a[1]:.4g}) to "
                                   f"({b[0]:.4g}, {b[1]:.4g}) m",
                        "db_per_unit": float(-np.sum(lv[:, k])), "status": status})
    if "isolator_distance_m2" in rows:
        row, m = rows["isolator_distance_m2"]
        dmin = float(st.constraints["min_isolator_distance_m"])
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        on = [p for p, v in zip(pairs, g[row: row + m], strict=True)
              if v < dmin * dmin + BINDING_TOL]
        if on:
            who = ", ".join(f"{i + 1}-{j + 1}" for i, j in on)
            out.append({"name": "min_isolator_distance_m", "value": dmin, "lower": None,
                        "upper": None, "at_bound": "binding",
                        "binding": f"isolators {who} at the minimum distance {dmin:g} m",
                        "db_per_unit": float(2.0 * dmin * np.sum(lam_g[row: row + m])),
                        "status": status})
    return out


# -- the inertia base's NLP terms (docs/table.md, section 16) ----------------------------
def base_terms(prob, dv):
    """:func:`base_lever_terms` of a table NLP at its design vector ``dv`` (spring, then every
    co-design lever); None with the slab's lever fixed.

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    if BASE_LEVER not in prob.lever_scaling.names:
        return None
    return base_lever_terms(prob.table, dv[len(DESIGN_VARIABLES) + CODESIGN_LEVERS.index(
        BASE_LEVER)])


def live_mass_quotient(prob, ca, dv, blk, q_r):
    """A frozen mode's Rayleigh quotient with the live mass matrix (docs/table.md,
    section 16): ``phi^H K' phi / phi^H M(m_s) phi`` with ``M(m_s)`` the combined body's at
    the slab's lever (:func:`~isodesign.table.inertia_base.base_mass_row`, on symbols), so
    the rocking-frequency rows hold ``Re mu = w^2`` of the mode at the design, whatever the
    slab the mode was frozen at (its shape normalized with another mass). ``q_r`` itself
    (``phi^H M_start phi = 1``) with the slab fixed.

    Parameters
    ----------
    prob : TableProblem
    ca : module
        CasADi.
    dv : CasADi column
        The design vector.
    blk : MX
        The frozen mode's 14 parameters ``[active, w, phi_re (6), phi_im (6)]``.
    q_r : MX
        ``phi^H K' phi``.
    """
    base = prob._base(dv)
    if base is None:
        return q_r
    from isodesign.table.inertia_base import base_mass_row

    m = ca.reshape(base_mass_row(prob.geo, base), 6, 6).T
    phr, phi = blk[2:8], blk[8:14]
    q_m = ca.mtimes([phr.T, m, phr]) + ca.mtimes([phi.T, m, phi])
    return q_r / (q_m + (1.0 - blk[0]))  # an inactive mode (phi = 0): its q_r, no 0 / 0


def check_base_start_loads(prob, study) -> None:
    """The start table's loads and p0 against the study's load and supply constraints
    (refused naming the key); with a free slab they are NLP rows (:func:`load_rows_of`).

    Parameters
    ----------
    prob : TableProblem
    study : Study
    """
    from isodesign.table.statics import check_load_constraints

    if BASE_LEVER not in prob.lever_scaling.names and not positions_free(prob):
        check_load_constraints(prob.leveling, study.constraints)


def check_base_objectives(prob) -> None:
    """``added_mass`` needs a free slab (refused naming ``objectives``).

    Parameters
    ----------
    prob : TableProblem
    """
    if "added_mass" in prob.objectives and BASE_LEVER not in prob.lever_scaling.names:
        raise InputError("objectives: added_mass needs a free inertia base "
                         "(variables.inertia_base_mass_kg, fixed = false; docs/table.md "
                         "section 16)")


def base_objective_parts(prob, dv) -> dict:
    """The NLP's ``added_mass`` objective: the slab's mass in tonnes (linear, 0 allowed;
    :data:`~isodesign.optimization.objectives.OBJECTIVES` converts it to kg).

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    if "added_mass" not in prob.objectives:
        return {}
    return {"added_mass": dv[len(DESIGN_VARIABLES) + CODESIGN_LEVERS.index(BASE_LEVER)] / 1e3}


def refuse_free_base_with_loop(study) -> None:
    """A free slab or free positions with the leveling loop's margin bounds: refused naming
    the key (its rows hold the start table's loads and layout).

    Parameters
    ----------
    study : Study

    Raises
    ------
    InputError
        ``constraints.min_leveling_gain_margin_db: ...`` when both are asked for.
    """
    from isodesign.table.leveling import leveling_margin_bounds

    moved = any(is_position_lever(v.name) and v.free for v in study.levers)
    if moved and leveling_margin_bounds(study) != (None, None):  # the plant's geometry
        raise InputError("constraints.min_leveling_gain_margin_db: the leveling loop's margin "
                         "bounds are not yet held with free isolator positions "
                         "(variables.isolator_positions_m); set min_leveling_gain_margin_db "
                         "and min_leveling_phase_margin_deg to false (docs/table.md, "
                         "section 15)")
    free = any(v.name == BASE_LEVER and v.free for v in study.levers)
    if free and leveling_margin_bounds(study) != (None, None):
        raise InputError("constraints.min_leveling_gain_margin_db: the leveling loop's margin "
                         "bounds are not yet held with a free inertia base "
                         "(variables.inertia_base_mass_kg); set min_leveling_gain_margin_db "
                         "and min_leveling_phase_margin_deg to false (docs/table.md, "
                         "section 16)")


def load_rows_of(leveling, constraints: dict, terms) -> list:
    """The load and supply rows with a free slab (:func:`~isodesign.table.statics.
    load_rows` at its load scale); none without.

    Parameters
    ----------
    leveling : Leveling
    constraints : dict
    terms : BaseTerms or None
    """
    if terms is None:
        return []
    from isodesign.table.statics import load_rows

    return load_rows(leveling, constraints, terms.load_scale)


# -- free isolator positions in a footprint polygon (docs/table.md, section 15) -----------
def positions_free(prob) -> bool:
    """The study frees the isolators' positions (``variables.isolator_positions_m``).

    Parameters
    ----------
    prob : TableProblem
    """
    return any(is_position_lever(n) for n in prob.lever_scaling.names)


def n_position_values(prob) -> int:
    """Entries of the positions at the end of the NLP's design vector (``2 n`` or 0).

    Parameters
    ----------
    prob : TableProblem
    """
    return 2 * prob.table.n_isolators if positions_free(prob) else 0


def position_values(prob, z_levers) -> list:
    """Each isolator's x and y from the scaled free levers (``v = c + h z``), isolator by
    isolator: the design vector's last ``2 n`` entries.

    Parameters
    ----------
    prob : TableProblem
    z_levers : MX
        The scaled free levers (``prob.lever_scaling`` order).
    """
    ls = prob.lever_scaling
    out = []
    for name in position_lever_names(prob.table.n_isolators):
        i = ls.names.index(name)
        out.append(ls.center[i] + ls.half[i] * z_levers[i])
    return out


def positions(prob, dv) -> list:
    """Each isolator's ``(x, y)`` in the design vector ``dv`` (symbols), m.

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    n = prob.table.n_isolators
    off = prob._n_dv() - 2 * n
    return [(dv[off + 2 * i], dv[off + 2 * i + 1]) for i in range(n)]


def position_terms(prob, dv) -> list:
    """The positions' ``(t_k, C_k)`` for :func:`~isodesign.table.lever_geometry.
    lever_stiffness`: each isolator's move from the start table, ``x_i - x_i0`` and
    ``y_i - y_i0``, with :func:`~isodesign.table.lever_geometry.position_directions`; none
    with the positions fixed.

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    if not positions_free(prob):
        return []
    from isodesign.table.lever_geometry import position_directions

    dirs = position_directions(prob.geo)
    xy0 = prob.table.isolators_m
    out = []
    for i, (x, y) in enumerate(positions(prob, dv)):
        out += [(x - float(xy0[i, 0]), dirs[2 * i]), (y - float(xy0[i, 1]), dirs[2 * i + 1])]
    return out


def _group_loads(prob, dv) -> list:
    """Each group's load per isolator at the design's positions (and slab), N."""
    from isodesign.table.inertia_base import load_scale
    from isodesign.table.statics import group_loads_at

    lam = load_scale(prob._base(dv))
    return [lam * p for p in group_loads_at(prob.table, positions(prob, dv))]


def isolator_loads(prob, dv) -> list:
    """Each isolator's static load at the design, N: the start's times the slab's load
    scale, or with free positions its group's load from the leveling at the positions
    (:func:`~isodesign.table.statics.group_loads_at`), safeguarded.

    A group's load is a rational function of the positions that IPOPT's trial steps can
    drive negative, where p0 and the vertical mode's ``sqrt(K / m)`` are NaN. The load the
    physics takes (p0, the carried mass, the pendulums) is then :func:`safe_load`: equal
    to the exact one wherever it is above :data:`SAFE_LOAD_FRACTION` of the mean (every
    design that meets the ``group_load_kn`` rows, at twice that), positive, finite and C1
    below. The rows on the loads (:func:`position_rows`) take the exact loads.

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    from isodesign.table.inertia_base import load_scale

    live = getattr(prob, "_live_loads", lambda _: None)(dv)  # a parametric payload's
    if live is not None:
        return live
    if not positions_free(prob):
        lam = load_scale(prob._base(dv))
        return [float(ld) * lam for ld in prob.leveling.load_n]
    floor = SAFE_LOAD_FRACTION * prob.table.weight_n / prob.table.n_isolators
    p = [safe_load(pg, floor) for pg in _group_loads(prob, dv)]
    return [p[int(g)] for g in prob.leveling.group_of]


def _exact_isolator_loads(prob, dv) -> list:
    """Each isolator's exact load with free positions (its group's), N: the rows'."""
    p = _group_loads(prob, dv)
    return [p[int(g)] for g in prob.leveling.group_of]


def isolator_pressures(prob, dv) -> list:
    """Each isolator's absolute p0 at the design, Pa: ``p_atm + W_i / A_p``.

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    from isodesign.table.inertia_base import scaled_pressures

    lv = prob.leveling
    if not positions_free(prob) and getattr(prob, "_live_loads", lambda _: None)(dv) is None:
        return scaled_pressures(prob._base(dv), lv.pressure_pa)
    p_atm = float(np.mean(lv.pressure_pa - lv.load_n / lv.piston_area_m2))
    return [p_atm + w / lv.piston_area_m2 for w in isolator_loads(prob, dv)]


def isolator_masses(prob, dv) -> list:
    """Each isolator's statically carried mass ``W_i / g`` at the design, kg (the
    safeguarded load with free positions, :func:`isolator_loads`).

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    return [w / prob.table.g_m_s2 for w in isolator_loads(prob, dv)]


def safe_load(w, floor: float):
    """``w`` where ``w >= floor``, ``floor exp(w / floor - 1)`` below: positive, finite,
    continuous with its first derivative at ``floor``, any backend (a switch between two
    branches that agree there, :func:`isodesign.numerics.backend.where`; the exponential's
    argument is 0 on the other branch, so neither branch overflows).

    Parameters
    ----------
    w : float, ndarray or CasADi expression
        The exact load (N; any positive quantity).
    floor : float
        Where the two branches meet (> 0).

    Returns
    -------
    same type as ``w``
    """
    from isodesign.numerics import backend as bk

    above = w >= floor
    u = bk.where(above, 0.0, w / floor - 1.0)
    return bk.where(above, w, floor * bk.exp(u))


def tilt_points(prob, dv):
    """The vertical-force points for the tilt rows: the table's, or with free positions
    each isolator's plan offset from the CG (symbols).

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column
    """
    live = getattr(prob, "_live_points", lambda _: None)(dv)  # a parametric CG's
    if live is not None:
        return live
    if not positions_free(prob):
        return prob.table.vertical_points_m
    cx, cy = (float(v) for v in prob.table.cg_m[:2])
    return [(x - cx, y - cy) for x, y in positions(prob, dv)]


#: The free positions' supply rows stop this far below the supply (Pa): an optimum on
#: them, within the solver's tolerance, is still leveled by the analysis (``level``).
SUPPLY_ROW_MARGIN_PA = 100.0
#: The smallest load of a leveling group with free positions, as a fraction of the mean
#: isolator load (``group_load_kn``'s lower bound): every valve carries load.
MIN_GROUP_LOAD_FRACTION = 0.02
#: Below this fraction of the mean isolator load (half the ``group_load_kn`` rows' bound)
#: the physics takes the safeguarded load (:func:`isolator_loads`, :func:`safe_load`).
SAFE_LOAD_FRACTION = 0.5 * MIN_GROUP_LOAD_FRACTION


def position_rows(prob, dv) -> list:
    """The free positions' rows (none with them fixed): containment in the footprint
    polygon and the minimum distance (:func:`~isodesign.table.lever_geometry.
    position_rows`), every group's load per isolator ``group_load_kn`` (kN, at least
    :data:`MIN_GROUP_LOAD_FRACTION` of the mean), the load range per isolator
    (``isolator_load_n``, kN) and the supply per group (``supply_pressure_pa``, gauge bar),
    each a rational function of the positions (and linear in a free slab's scale).

    Parameters
    ----------
    prob : TableProblem
    dv : CasADi column

    Returns
    -------
    list of (name, expression, lower, upper)
    """
    if not positions_free(prob):
        return []
    return _position_rows_from(prob, positions(prob, dv), _group_loads(prob, dv),
                               _exact_isolator_loads(prob, dv))


def position_rows_numpy(prob, table, leveling) -> list:
    """The free positions' rows (:func:`position_rows`) on the NumPy analysis path: the
    table at the design's positions and its leveling solved by
    :func:`~isodesign.table.statics.level` (the analysis's statics, not the NLP's closed
    form), with the same bounds (none with the positions fixed). Their re-check
    (:func:`~isodesign.optimization.table_constraints.table_quantities`).

    Parameters
    ----------
    prob : TableProblem
    table : Table
        The table at the design (``study.table_at(values)``).
    leveling : Leveling
        Its leveling (:func:`~isodesign.table.statics.level`); a fixed inertia base.

    Returns
    -------
    list of (name, ndarray, lower, upper)
    """
    if not positions_free(prob):
        return []
    import casadi as ca

    xy = [(float(x), float(y)) for x, y in np.asarray(table.isolators_m, float)[:, :2]]
    rows = _position_rows_from(prob, xy, [float(p) for p in leveling.group_load_n],
                               [float(w) for w in leveling.load_n])
    return [(name, np.asarray(ca.DM(expr), float).ravel(), lo, hi)
            for name, expr, lo, hi in rows]


def _position_rows_from(prob, xy, group_loads, loads) -> list:
    """The free positions' rows from the positions, each group's load per isolator and each
    isolator's load (N), any backend: :func:`position_rows` and its NumPy re-check."""
    import casadi as ca

    from isodesign.table.lever_geometry import position_rows as geometric_rows
    from isodesign.table.study import position_polygon

    st, c, lv = prob.study, prob.study.constraints, prob.leveling
    spec = (st.raw.get("variables") or {}).get(POSITION_LEVER) or {}
    poly = position_polygon(spec, c, f"variables.{POSITION_LEVER}")
    out = geometric_rows(xy, poly, c.get("min_isolator_distance_m"))
    p = group_loads
    mean = prob.table.weight_n / prob.table.n_isolators
    out.append(("group_load_kn", ca.vertcat(*[pg / 1e3 for pg in p]),
                MIN_GROUP_LOAD_FRACTION * mean / 1e3, np.inf))
    lo, hi = c.get("min_isolator_load_n"), c.get("max_isolator_load_n")
    if lo or hi:
        out.append(("isolator_load_n", ca.vertcat(*[w / 1e3 for w in loads]),
                    lo / 1e3 if lo else -np.inf, hi / 1e3 if hi else np.inf))
    p_atm = float(np.mean(lv.pressure_pa - lv.load_n / lv.piston_area_m2))
    cap = lv.supply_pressure_pa - (c.get("supply_margin_pa") or 0.0) - p_atm
    out.append(("supply_pressure_pa", ca.vertcat(*[pg / lv.piston_area_m2 / 1e5 for pg in p]),
                -np.inf, (cap - SUPPLY_ROW_MARGIN_PA) / 1e5))
    return out


#: Feasible layouts the multi-start screens per drawn start (at least
#: :data:`SCREEN_MIN`): the best by the analysis's worst margin become the starts.
SCREEN_PER_START = 20
SCREEN_MIN = 40


def draw_positions(study, n: int, seed) -> list:
    """``n`` starts of a study's free positions for the multi-start: feasible layouts
    drawn uniformly in the footprint polygon (every pair at least
    ``min_isolator_distance_m`` apart, the table leveled there with every group loaded, by
    rejection), ``max(SCREEN_MIN, SCREEN_PER_START n)`` of them judged by the NumPy
    analysis's worst margin (``table_band_response``, the springs at the study's start) and
    the best ``n`` kept: the layout's optima are many (docs/table.md, section 15), and a
    screened start reaches a better one than a blind draw.

    Parameters
    ----------
    study : Study
    n : int
    seed : int or sequence of int
        NumPy's generator seed.

    Returns
    -------
    list of dict
        The position levers' values, one dict per start, best first (empty without free
        positions; fewer than ``n`` when fewer feasible layouts were found).
    """
    from isodesign.errors import InputError as _Err
    from isodesign.table.layout import with_positions
    from isodesign.table.lever_geometry import point_in_polygon
    from isodesign.table.response import table_band_response
    from isodesign.table.statics import level
    from isodesign.table.study import position_polygon

    names = [v.name for v in study.levers if v.free and is_position_lever(v.name)]
    if not names or n <= 0:
        return []
    spec = (study.raw.get("variables") or {}).get(POSITION_LEVER) or {}
    poly = position_polygon(spec, study.constraints, f"variables.{POSITION_LEVER}")
    dmin = study.constraints.get("min_isolator_distance_m") or 0.0
    table = study.table_at(None)
    k = table.n_isolators
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    rng = np.random.default_rng(seed)
    d, m = study.start_design(), study.models
    want = max(SCREEN_MIN, SCREEN_PER_START * n)
    judged = []
    for _try in range(200 * want):
        if len(judged) >= want:
            break
        xy = lo + (hi - lo) * rng.random((k, 2))
        if np.min(point_in_polygon(poly, xy)) < 0.0:
            continue
        dist = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
        if k > 1 and np.min(dist[np.triu_indices(k, 1)]) < dmin:
            continue
        t = with_positions(table, xy)
        try:
            lv = level(t, study.hardware["piston_area_m2"])
            if np.min(lv.group_load_n) < 2 * MIN_GROUP_LOAD_FRACTION * table.weight_n / k:
                continue
            r = table_band_response(d, t, study.floor_axes, study.target, bands=study.bands,
                                    points_per_band=m["points_per_band"], flow=m["flow"],
                                    amplitude_mode=m["amplitude_mode"],
                                    diaphragm=m["diaphragm"], warn=False, strict=False)
        except _Err:
            continue
        judged.append((float(np.min(r.margin_db)), xy))
    judged.sort(key=lambda j: -j[0])
    return [dict(zip(names, xy.ravel().tolist(), strict=True)) for _, xy in judged[:n]]
