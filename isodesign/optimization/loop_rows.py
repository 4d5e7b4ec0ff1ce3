"""The leveling loop's gain-margin rows of the table NLP (frozen poles; docs/table.md, 12).

The loop closed at the raised gain ``G* = G 10^(gm/20)`` (``gm`` the study's
``min_leveling_gain_margin_db``) by every valve, and by each valve alone with the other two
at ``G``, must be stable. For the :data:`LOOP_POLES_MIMO` least
stable poles of the first and the least stable one of each of the others (one of each
complex pair), with right and left eigenvectors ``v``, ``w`` frozen, the first-order pole
``Re (w^H A_cl(x) v) / (w^H v)`` is linear in the plant's ``A(x)``:
``sum_jk R_jk A_jk(x) - c0`` with ``R = Re(conj(w) v^T) / (w^H v)`` and ``c0`` the valves'
part. Exact at the design the poles are frozen at and to first order about it (the
eigenvalue's derivative); the driver (:mod:`.table_driver`) freezes them again at
each new design. The plant's ``A`` is :func:`isodesign.table.leveling.plant_matrix`, the
analysis' own assembly, evaluated on CasADi symbols here.
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.optimization.variables import DESIGN_VARIABLES

__all__ = ["LOOP_MARGIN_EPS", "LOOP_POLES_MIMO", "frozen_poles", "loop_rows", "plant_function"]

#: The leveling loop's gain-margin rows freeze the least stable poles of the loop closed at
#: the raised gain ``G 10^(gm/20)``: this many with every valve raised, and one with each
#: valve raised alone (the other two at ``G``).
LOOP_POLES_MIMO = 3
#: The rows ask ``Re lambda <= -LOOP_MARGIN_EPS |lambda|`` of each frozen pole at the raised
#: gain (a small cushion for the first-order error; the exact margins are checked after).
LOOP_MARGIN_EPS = 1e-4


def plant_function(prob, ca):
    """``design -> vec(A)``: the leveling plant's ``A`` (valves closed) as an SX Function.

    Parameters
    ----------
    prob : TableProblem
    ca : module
        CasADi.

    Returns
    -------
    casadi.Function
        Of the four spring variables.
    """
    from isodesign.table.leveling import isolator_constants, plant_matrix
    from isodesign.table.model import table_model

    dv = ca.SX.sym("design", len(DESIGN_VARIABLES))
    base = prob.study.design_at({nm: dv[i] for i, nm in enumerate(DESIGN_VARIABLES)})
    consts = np.empty((prob.n, 10), dtype=object)
    for i, p in enumerate(prob.leveling.pressure_pa):
        for j, val in enumerate(isolator_constants(base.replace(pressure_pa=float(p)),
                                                   prob.dia, prob.flow)):
            consts[i, j] = val
    model = table_model(prob.study.start_design(), prob.table, flow=prob.flow,
                        diaphragm=prob.dia)  # its geometry and horizontal elements
    a = plant_matrix(model, prob.loop_system, consts)
    ns = prob.n_states
    out = ca.SX(ns, ns)
    for r in range(ns):
        for c in range(ns):
            e = a[r, c]
            if not (isinstance(e, int | float | np.number) and e == 0):
                out[r, c] = e
    return ca.Function("leveling_a", [dv], [ca.vec(out)])


def loop_rows(prob, ca, v, p_loop) -> list:
    """The gain-margin rows: per frozen pole ``(sum R o A(x) - c0) / s + eps <= 0``.

    Parameters
    ----------
    prob : TableProblem
    ca : module
        CasADi.
    v : casadi.SX
        The spring variables.
    p_loop : casadi.SX
        The frozen poles' parameters (:func:`frozen_poles`).

    Returns
    -------
    list
        ``[(name, rows, lower, upper)]``, empty without a bound on the gain margin.
    """
    if not prob.n_loop:
        return []
    a = plant_function(prob, ca)(v)
    m = 2 + prob.n_states ** 2
    rows = [p_loop[j * m] * (ca.dot(p_loop[j * m + 2: (j + 1) * m], a) + p_loop[j * m + 1])
            for j in range(prob.n_loop)]
    return [("min_leveling_gain_margin_db", ca.vertcat(*rows), -np.inf, 0.0)]


def frozen_poles(prob, d) -> tuple:
    """The valves and the frozen poles' parameters of the gain-margin rows at design ``d``.

    Parameters
    ----------
    prob : TableProblem
    d : SpringDesign

    Returns
    -------
    (LevelingSystem, ndarray)
        The study's valves at ``d`` (a free valve gain: its choice there) and the rows'
        parameters (one block per frozen pole: active flag, offset, ``R / s``).
    """
    from scipy.linalg import eig

    from isodesign.table.leveling import leveling_plant
    from isodesign.table.leveling_loop import study_valves
    from isodesign.table.model import table_model

    system = study_valves(prob.study, d)
    model = table_model(d, prob.table, flow=prob.flow, diaphragm=prob.dia)
    plant = leveling_plant(model, system)
    g = system.gain_kg_s_per_m
    g_up = g * 10.0 ** (prob.loop_bound_db / 20.0)
    patterns = [(np.full(3, g_up), LOOP_POLES_MIMO)]
    patterns += [(np.where(np.arange(3) == k, g_up, g), 1) for k in range(3)]
    blocks = []
    for gains, count in patterns:
        bkc = plant.b @ np.diag(gains) @ plant.c
        lam, vl, vr = eig(plant.a - bkc, left=True, right=True)
        keep = np.flatnonzero(lam.imag >= -1e-12 * np.abs(lam))
        for i in keep[np.argsort(-lam.real[keep])][:count]:
            den = np.vdot(vl[:, i], vr[:, i])
            if abs(den) <= 1e-10 * np.linalg.norm(vl[:, i]) * np.linalg.norm(vr[:, i]):
                continue  # a defective eigenvalue has no first-order form: no row
            mm = np.outer(np.conj(vl[:, i]), vr[:, i]) / den
            scale = max(abs(lam[i]), 2.0 * math.pi * 0.01)
            c0 = float(np.sum(mm.real * bkc))
            blocks.append(np.r_[1.0, -c0 / scale + LOOP_MARGIN_EPS,
                                (mm.real / scale).ravel(order="F")])
    p = np.zeros(prob.n_loop * (2 + prob.n_states ** 2))
    flat = np.concatenate(blocks)[: p.size] if blocks else np.zeros(0)
    p[: flat.size] = flat
    return system, p
