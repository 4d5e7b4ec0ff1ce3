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

__all__ = ["base_objective_parts", "base_terms", "check_base_objectives",
           "check_base_start_loads", "group_values", "lever_sensitivities", "load_rows_of",
           "refuse_free_base_with_loop"]


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


def lever_sensitivities(prob, x: np.ndarray) -> tuple:
    """The re-optimized sensitivity of the worst margin to each free lever's bounds.

    IPOPT solves again from the optimum ``x`` (default parameters: the worst margin alone)
    and its bound multipliers ``lam_x`` give, by the envelope theorem, the derivative of
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

    Returns
    -------
    tuple of dict
        Per free lever: ``name``, ``value``, ``lower``, ``upper``, ``at_bound``
        (``"lower"``, ``"upper"`` or None), ``db_per_unit`` (dB of worst margin per unit
        of the active bound, SI), ``status`` of the solve.
    """
    if not prob.n_levers or "worst_band_margin" != prob.objective:
        return ()
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
        zi = xs[nzs + i]
        at = "upper" if zi > 1 - 1e-6 else "lower" if zi < -1 + 1e-6 else None
        spec = next(v for v in prob.study.levers if v.name == name)
        dv_dz = ls.half[i] * (vals[name] if ls.is_log(i) else 1.0)
        out.append({"name": name, "value": vals[name], "lower": spec.lower,
                    "upper": spec.upper, "at_bound": at,
                    "db_per_unit": float(lam[nzs + i] / dv_dz), "status": status})
    return tuple(out)


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


def check_base_start_loads(prob, study) -> None:
    """The start table's loads and p0 against the study's load and supply constraints
    (refused naming the key); with a free slab they are NLP rows (:func:`load_rows_of`).

    Parameters
    ----------
    prob : TableProblem
    study : Study
    """
    from isodesign.table.statics import check_load_constraints

    if BASE_LEVER not in prob.lever_scaling.names:
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
    """A free slab with the leveling loop's margin bounds: refused naming the key (its rows
    hold the start table's loads).

    Parameters
    ----------
    study : Study

    Raises
    ------
    InputError
        ``constraints.min_leveling_gain_margin_db: ...`` when both are asked for.
    """
    from isodesign.table.leveling import leveling_margin_bounds

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
