"""The constraint table of a table optimum: the NLP's rows and the exact checks.

The constraints whose NLP rows are the log of a quantity (the total volume, the vertical
natural frequency, the stroke, ``ln |T|^2`` of the peak at the grid's and the refinement's
frequencies) are reported from those rows by
:func:`isodesign.optimization.constraints.constraint_reports`, under the registry's names,
units and words (:mod:`isodesign.optimization.constraint_registry`, the same entries as the
vertical body's, so :mod:`isodesign.optimization.explain` words them the same way). The
constraints the NLP writes in a smooth surrogate form (the rocking matrix, the frozen
modes' Rayleigh quotients) are reported from the exact quantities at the optimum: the
rocking margin with gravity (:func:`isodesign.table.modes.rocking_stability`),
the damping ratio and frequency of the exact modes, the continuous peak of |T| from
below the lowest mode (:mod:`isodesign.table.peaks`), and the leveling loop's gain and
phase margins (python-control, :mod:`isodesign.table.leveling_loop`). Binding: within
:data:`~isodesign.optimization.constraints.BINDING_TOL` of the bound in the log of the
quantity (0.5 %), or in ``ln |T|^2`` (0.022 dB).
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.optimization.constraint_registry import CONSTRAINTS, TABLE_ROWS, Constraint
from isodesign.optimization.constraints import (
    BINDING_TOL,
    ConstraintReport,
    constraint_reports,
)

#: The table body's kinds reported from their NLP rows (a log of the quantity, or
#: ``ln |T|^2``), by row key.
_ROW_KINDS = {CONSTRAINTS[k].row_key: CONSTRAINTS[k] for k in TABLE_ROWS
              if CONSTRAINTS[k].form in ("log", "db")}

__all__ = ["CONTINUOUS_PEAK", "LEVELING_GAIN_MARGIN", "LEVELING_PHASE_MARGIN",
           "leveling_reports", "row_reports", "table_constraint_reports",
           "table_quantities", "validity_quantities"]

#: Name of the continuous peak's row (and of its violation).
CONTINUOUS_PEAK = "continuous_peak_transmissibility"
#: Names of the leveling loop's margin rows (and of their violations).
LEVELING_GAIN_MARGIN = "leveling_gain_margin"
LEVELING_PHASE_MARGIN = "leveling_phase_margin"
_LN10 = math.log(10.0)


def _report(name, value, lower, upper, unit, margin, description) -> ConstraintReport:
    return ConstraintReport(name=name, value=float(value), lower=lower, upper=upper, unit=unit,
                            margin=float(margin), active=bool(margin < BINDING_TOL),
                            description=description)


def _log_margin(value, lower=None, upper=None) -> float:
    m = math.inf
    if lower:
        m = min(m, math.log(value / lower) if value > 0 else -math.inf)
    if upper:
        m = min(m, math.log(upper / value) if value > 0 else math.inf)
    return m


def leveling_reports(loop, gain_bound_db=None, phase_bound_deg=None) -> list[ConstraintReport]:
    """The leveling loop's gain and phase margin rows (docs/table.md, section 12).

    ``leveling_gain_margin``: the smallest of the MIMO gain margin ``20 log10(G_c / G)`` and
    the three valves' gain margins (the other two closed), dB; binding within 0.5 % of the
    gain ratio (0.043 dB). ``leveling_phase_margin``: the smallest of the three valves'
    phase margins, deg; binding within 0.5 % of the bound. The NLP holds no row of the
    loop (the driver checks it after the solve), so a margin below its bound is a
    violation, not a binding limit: binding means within the tolerance on either side. A
    bound of None: the margin is reported, not enforced.

    Parameters
    ----------
    loop : LevelingLoop
        :func:`~isodesign.table.leveling_loop.leveling_loop` of the design.
    gain_bound_db, phase_bound_deg : float or None
        :func:`~isodesign.table.leveling.leveling_margin_bounds`.

    Returns
    -------
    list of ConstraintReport
    """
    gm, pm = loop.worst_gain_margin_db, loop.worst_phase_margin_deg
    m_g = (gm - gain_bound_db) * _LN10 / 20.0 if gain_bound_db is not None else math.inf
    m_p = _log_margin(pm, lower=phase_bound_deg) if phase_bound_deg is not None \
        and math.isfinite(pm) else math.inf
    if phase_bound_deg is not None and pm < 0:
        m_p = -math.inf
    # the NLP holds no row of the loop: a margin below its bound is a violation, not a limit
    # that stopped the design (binding only within the tolerance on either side)
    return [_binding_either_side(r) for r in [
        _report(LEVELING_GAIN_MARGIN, gm, gain_bound_db, None, "dB", m_g,
                f"leveling loop, MIMO (onset {loop.critical_gain_kg_s_per_m:.4g} kg/s/m at "
                f"{loop.oscillation_frequency_hz:.3g} Hz) and per valve, valve gain "
                f"{loop.gain_kg_s_per_m:.4g} kg/s/m"
                + ("" if gain_bound_db is not None else "; reported, not enforced")),
        _report(LEVELING_PHASE_MARGIN, pm, phase_bound_deg, None, "deg", m_p,
                "leveling loop, per valve (the other two closed)"
                + ("" if phase_bound_deg is not None else "; reported, not enforced")),
    ]]


def _binding_either_side(r: ConstraintReport) -> ConstraintReport:
    import dataclasses

    return dataclasses.replace(r, active=bool(abs(r.margin) < BINDING_TOL))


def row_reports(prob, g) -> list[ConstraintReport]:
    """The table's constraints reported from their NLP rows, in row order: the registry's
    kinds in the log of the quantity or in ``ln |T|^2`` (total volume, vertical mode, stroke,
    peak |T| at the grid's and the refinement's frequencies), under the kind's name, unit
    and words (:func:`~isodesign.optimization.constraints.constraint_reports`).

    Parameters
    ----------
    prob : TableProblem
        Its ``con_rows``, ``lbg``, ``ubg`` and study.
    g : ndarray
        The NLP's constraint values at the design.

    Returns
    -------
    list of ConstraintReport
    """
    rows = []
    for key, row, m in prob.con_rows:
        k = _ROW_KINDS.get(key)
        if k is not None:
            rows.append((Constraint(k.name, None, float(prob.lbg[row]), float(prob.ubg[row]), m,
                                    k.words(prob.study), key=key, kind=k.name), row, m))
    return constraint_reports(rows, np.asarray(g, float))


def table_constraint_reports(prob, g, *, modes=None, stability=None, peaks=None,
                             leveling=None) -> list[ConstraintReport]:
    """The constraints of a table design, in natural units, with margins and binding flags.

    Parameters
    ----------
    prob : TableProblem
        Its ``con_rows``, ``lbg``, ``ubg`` and study (the bounds).
    g : ndarray
        The NLP's constraint values at the design (``Solution.g``).
    modes : TableModes, optional
        The design's exact modes (damping, rocking frequencies).
    stability : RockingStability, optional
        The design's rocking margins with gravity.
    peaks : TablePeaks, optional
        The design's continuous peak of |T|.
    leveling : tuple (LevelingLoop, float or None, float or None), optional
        The design's leveling loop and the bounds on its gain (dB) and phase (deg) margins
        (:func:`leveling_reports`).

    Returns
    -------
    list of ConstraintReport
    """
    c = prob.study.constraints
    out = row_reports(prob, g)
    pk = c.get("max_peak_transmissibility_db")
    if peaks is not None and pk is not None and pk is not False:
        p, a, v, f = peaks.worst()
        out.append(_report(CONTINUOUS_PEAK, v, None, float(pk), "dB", (pk - v) * _LN10 / 10.0,
                           f"|T| between the grid's frequencies, {peaks.f_low_hz:.3g}-"
                           f"{peaks.f_high_hz:.3g} Hz (worst {p} {a} at {f:.3g} Hz)"))
    for name, row, m in prob.con_rows:  # the layout's rows (docs/table.md, section 15)
        gi = np.asarray(g, float)[row: row + m]
        if name == "footprint_m":  # clearances x_i - x_min, x_max - x_i, ... (m)
            fp = c["footprint_m"]
            v = float(np.min(gi))
            out.append(_report("footprint", v, 0.0, None, "m",
                               v / max(fp[2] - fp[0], fp[3] - fp[1]),
                               "smallest clearance of an isolator inside the footprint"))
        elif name == "min_isolator_distance_m":  # ln d_ij >= ln d_min
            v = float(np.exp(np.min(gi)))
            dmin = float(c["min_isolator_distance_m"])
            out.append(_report("isolator_distance", v, dmin, None, "m", math.log(v / dmin),
                               "closest two isolators"))
    from isodesign.table.statics import leveling_of_rows, load_constraint_values

    lev = leveling_of_rows(prob, np.asarray(g, float))  # a free inertia base's loads
    for _, name, vals, lo, hi, unit in load_constraint_values(lev, c, lev is not prob.leveling):
        worst = float(np.min(vals)) if lo is not None and (
            hi is None or math.log(np.min(vals) / lo) < math.log(hi / np.max(vals))) \
            else float(np.max(vals))
        out.append(_report(name, worst, lo, hi, unit, _log_margin(worst, lower=lo, upper=hi),
                           "static load of the worst isolator" if unit == "N" else
                           "p0 of the worst leveling group, absolute, against the supply "
                           "pressure minus its margin"))
    mu = c.get("min_tilt_margin")
    if stability is not None and mu:
        v = float(np.min(stability.margin))
        out.append(_report("tilt_margin", v, float(mu), None, "-", _log_margin(v, lower=mu),
                           "weakest rocking direction with gravity, A / (W h) (z condensed, "
                           "sealed springs at 1 mHz)"))
    if modes is not None:
        f = np.asarray(modes.frequency_hz, float)
        zmin = c.get("min_damping_ratio")
        low = np.isfinite(f) & (f < 5.0)
        if zmin and np.any(low):
            v = float(np.min(modes.damping_ratio[low]))
            out.append(_report("damping_ratio", v, float(zmin), None, "-",
                               _log_margin(v, lower=zmin),
                               "least-damped exact mode below 5 Hz"))
        f_lo, f_hi = c.get("min_rocking_frequency_hz"), c.get("max_rocking_frequency_hz")
        rock = np.isfinite(f) & (modes.energy_fraction[:, 3:5].sum(axis=1) >= 0.3)
        if (f_lo or f_hi) and np.any(rock):
            fr = f[rock]
            v = float(fr.min()) if f_lo else float(fr.max())
            m = min(_log_margin(float(fr.min()), lower=f_lo or None),
                    _log_margin(float(fr.max()), upper=f_hi or None))
            out.append(_report("rocking_frequency", v, float(f_lo) if f_lo else None,
                               float(f_hi) if f_hi else None, "Hz", m,
                               "exact rocking modes (rx + ry energy >= 30 %)"))
    if leveling is not None:
        out += leveling_reports(*leveling)
    return out


def table_quantities(prob, values: dict | None = None) -> dict:
    """The table body's constraint quantities at a design, on the NumPy analysis path.

    The NumPy re-check of the registry's rows (:mod:`.constraint_registry`): the same kinds
    the NLP requests (:data:`~.constraint_registry.TABLE_ROWS`), on quantities the NumPy
    analysis measures: the closure (:func:`isodesign.table.response.solve_table_closure`),
    each isolator's leveled spring (:func:`isodesign.table.model.table_model`), ``|T_p,aa|``
    from the model's outputs (:meth:`~isodesign.table.model.TableModel.outputs`, as the
    continuous peak, :mod:`isodesign.table.peaks`) at the NLP's peak-row frequencies and
    movable slots, the tilt condition on the sealed springs. ``constraint_rows_of(study, q,
    TABLE_ROWS)`` on them gives each row's value to compare with the NLP's ``g``. The
    frozen-mode rows (damping, rocking) are re-checked by the exact modes
    (:func:`table_constraint_reports`), the loop rows by the exact loop; the free
    positions' layout and load rows here, on the table at the design's positions and its
    leveling by :func:`isodesign.table.statics.level`
    (:func:`~isodesign.optimization.lever_nlp.position_rows_numpy`), a stretched layout's
    rows on the stretched table (``study.table_at``) with no further stretch.

    Parameters
    ----------
    prob : TableProblem
        The NLP (its grid, peak rows' frequencies, slots and leveling).
    values : dict, optional
        Design-variable values (default: the study's starts). With a free inertia base the
        tilt rows take the slab's terms at its value, as the NLP; its load and supply rows
        are not re-checked here.

    Returns
    -------
    dict
        ``ln_total_volume``, ``ln_fn``, ``ln_stroke``, ``ln_T2_peak``, with a tilt bound
        and a CG above the supports ``tilt_rows``, with free positions ``layout_rows`` and
        ``load_rows`` (``(key, values, lower, upper)`` each), with ``model_validity`` the validity
        quantities (:func:`~isodesign.optimization.metrics.validity_quantities`, per spring,
        and per isolator the Womersley number and
        :func:`~isodesign.optimization.metrics.tube_flow_quantities` at ``sqrt(2)
        sigma_u``).
    """
    from isodesign.response.isolator import static_stiffness
    from isodesign.table import inertia_base as slab_terms
    from isodesign.table.model import table_model
    from isodesign.table.peaks import closure_springs
    from isodesign.table.statics import sealed_stiffness, tilt_margin_rows

    st = prob.study
    values = values or {v.name: v.start for v in st.variables}
    d = st.design_at(values)
    table = st.table_at(values)
    model = table_model(d, table, flow=prob.flow, amplitude_mode=st.models["amplitude_mode"],
                        diaphragm=prob.dia)
    lv = model.leveling
    designs = model.designs
    sigma, sigma_u = prob.closure(d, values)
    c = st.constraints
    q = {"ln_total_volume": math.log(d.total_volume_m3) if not prob.grouped else np.log([
        designs[list(lv.group_of).index(g)].total_volume_m3 for g in range(3)])}
    k0 = [static_stiffness(di, prob.dia, float(mi))
          for di, mi in zip(designs, lv.mass_per_isolator_kg, strict=True)]
    q["ln_fn"] = 0.5 * math.log(float(sum(k0)) / slab_terms.body_mass(table, None)
                                / (2.0 * math.pi) ** 2)
    q["ln_stroke"] = np.log(sigma) + math.log(c.get("stroke_peak_factor") or 3.0)
    mu = c.get("min_tilt_margin")
    slab = _free_slab(prob, values)  # a free inertia base: the NLP's terms at its value
    if mu and (table.cg_height_m > 0 or slab is not None):
        kq = [sealed_stiffness(di, prob.dia, flow=prob.flow) for di in designs]
        if slab is None:
            wh, mu = slab_terms.tilt_bound(table, None, mu)
            pts = table.vertical_points_m
        else:  # the start table with the slab's terms, as the NLP
            wh, mu = slab_terms.tilt_bound(prob.table, slab, mu)
            pts = prob.table.vertical_points_m
        q["tilt_rows"] = np.asarray(tilt_margin_rows(kq, pts, wh, mu), float)
    pk = c.get("max_peak_transmissibility_db")
    if pk is not None and pk is not False:
        f = prob.grid.frequency_hz
        f = np.concatenate([f[f <= prob._peak_cut_hz()], prob.slot_hz])
        w = 2.0 * math.pi * f
        # models.distortion: the springs at the minor loss's gain, as the NLP's (its y_k,
        # optimization.distortion_rows: sigma_u times the gain ratio of the NumPy terms)
        sig_u = sigma_u
        if getattr(prob, "distortion", False) and prob.flow != "poiseuille":
            n = prob.n
            sig_u = sigma_u * prob.distortion_terms(d, values)[2 * n:3 * n]
        out = model.outputs(closure_springs(model, sigma, sig_u)(w), w)
        diag = np.diagonal(out.points, axis1=2, axis2=3)  # (f, k, 3)
        t2 = (diag.real ** 2 + diag.imag ** 2).reshape(f.size, -1)  # (f, 3k), point-major
        n_grid = f.size - prob.slot_hz.size
        # the NLP's order: per point and axis, the grid's frequencies, then the slots'
        q["ln_T2_peak"] = np.log(np.concatenate([t2[:n_grid].T.ravel(),
                                                 t2[n_grid:].T.ravel()]))
    # free positions: the footprint, spacing, group loads and supply of the table at the
    # design's positions, leveled by the analysis's statics (lever_nlp.position_rows_numpy)
    from isodesign.optimization.lever_nlp import position_rows_numpy

    pos = position_rows_numpy(prob, table, lv)
    if pos:
        geo = ("footprint_polygon_m", "isolator_distance_m2")
        q["layout_rows"] = [r for r in pos if r[0] in geo]
        q["load_rows"] = [r for r in pos if r[0] not in geo]
    elif prob._layout_free():  # the stretched layout's rows on the stretched table itself
        import casadi as ca

        from isodesign.table.lever_geometry import layout_rows

        q["layout_rows"] = [(key, np.asarray(ca.DM(e), float).ravel(), lo, hi)
                            for key, e, lo, hi in layout_rows(table, c, (1.0, 1.0), True)]
    if c.get("model_validity"):
        q.update(validity_quantities(d, designs, np.log(sigma_u), float(np.max(prob.grid.omega)),
                                     lv.group_of if prob.grouped else None))
    return q


def _free_slab(prob, values: dict):
    """The inertia base's terms at a design whose slab is a free lever (None otherwise)."""
    from isodesign.optimization.lever_nlp import base_terms
    from isodesign.optimization.variables import CODESIGN_LEVERS, DESIGN_VARIABLES
    from isodesign.table.inertia_base import BASE_LEVER

    if BASE_LEVER not in prob.lever_scaling.names:
        return None
    dv = np.zeros(len(DESIGN_VARIABLES) + len(CODESIGN_LEVERS))
    dv[len(DESIGN_VARIABLES) + CODESIGN_LEVERS.index(BASE_LEVER)] = float(values[BASE_LEVER])
    return base_terms(prob, dv)


def validity_quantities(d, designs, ln_sigma_u, w_max: float, group_of=None) -> dict:
    """The table body's model-validity quantities, any backend (the NLP's rows and their
    NumPy re-check).

    Per isolator the tube's Mach and Reynolds numbers at the closure's velocity amplitude
    ``sqrt(2) sigma_u`` (the statistical closure's, as the vertical body's;
    :func:`~isodesign.optimization.metrics.tube_flow_quantities`) and the Womersley number at
    the grid's top; per spring (each group's with per-group springs) the acoustic
    compactness and the plane waves (:func:`~isodesign.optimization.metrics.
    validity_quantities`).

    Parameters
    ----------
    d : SpringDesign
        The shared spring.
    designs : sequence of SpringDesign
        Each isolator's (its p0, its group's spring).
    ln_sigma_u : sequence
        ``ln sigma_u`` per isolator (CasADi in the NLP, NumPy in the re-check).
    w_max : float
        The grid's highest angular frequency, rad/s.
    group_of : sequence of int, optional
        Each isolator's group, with per-group springs.

    Returns
    -------
    dict
        ``ln_plane_wave_*``, ``ln_lumped_*``, ``ln_bore_per_length`` (per spring), ``ln_mach``,
        ``ln_re``,
        ``ln_alpha_max`` (per isolator), column vectors.
    """
    from isodesign.numerics import backend as bk
    from isodesign.optimization.metrics import tube_flow_quantities
    from isodesign.optimization.metrics import validity_quantities as spring_validity

    def stack(xs):
        if any(bk.is_casadi(x) for x in xs):
            import casadi as ca

            return ca.vertcat(*xs)
        return np.array([float(x) for x in xs])

    springs = [designs[list(group_of).index(g)] for g in range(3)] if group_of is not None \
        else [d]
    per = [spring_validity(di, w_max) for di in springs]
    q = {f"ln_plane_wave_{ch}": stack([p["ln_plane_wave"][i] for p in per])
         for i, ch in enumerate(("top_chamber", "bottom_chamber"))}
    q.update({f"ln_lumped_{part}": stack([p["ln_lumped"][i] for p in per])
              for i, part in enumerate(("tube", "top_chamber", "bottom_chamber"))})
    flow = [tube_flow_quantities(di, math.sqrt(2.0) * bk.exp(ln_sigma_u[i]))
            for i, di in enumerate(designs)]
    q["ln_mach"] = stack([f["ln_mach"] for f in flow])
    q["ln_re"] = stack([f["ln_re"] for f in flow])
    q["ln_alpha_max"] = stack([spring_validity(di, w_max)["ln_alpha_max"]
                               for di in designs])
    q["ln_bore_per_length"] = stack([p["ln_bore_per_length"] for p in per])
    return q
