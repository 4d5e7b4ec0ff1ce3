"""A drawn design in one scenario of the tolerance box: :func:`scenario_check`.

The NumPy analysis (:func:`.recheck.evaluate_design` on :class:`.uncertainty.ScenarioStudy`)
of a design in a scenario, reduced to what the robust design needs: the objective and
its shortfall below a stated worst case, each constraint's signed worst-row excess, the
continuous peak of |T| and the criterion margin. Used by the exchange method
(:mod:`.exchange`), the robust result's checks (:mod:`.robust_result`) and the yield
estimate (:mod:`.yields`).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from isodesign.optimization.grid import build_grid
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.recheck import evaluate_design
from isodesign.optimization.refine import continuous_peak_db
from isodesign.optimization.uncertainty import ScenarioStudy
from isodesign.spring.diaphragm import diaphragm_model

__all__ = ["scenario_check"]


def scenario_check(study, values: dict, theta, *, grid=None, reference=None) -> dict:
    """One scenario at one drawn design, on the NumPy analysis path.

    Parameters
    ----------
    study : Study
        The nominal study, with ``scenarios``.
    values : dict
        The drawn design (SI).
    theta : array
        The scenario, in ``study.scenarios.names`` order.
    grid : Grid, optional
        Frequency grid (default: the nominal study's :func:`.grid.build_grid`).
    reference : float, optional
        The stated worst case J (internal units of the objective); the shortfall
        ``J - reference`` is returned.

    Returns
    -------
    dict
        ``objective`` (natural value), ``j`` (internal J), ``gap`` (``j - reference``),
        ``criterion_margin_db`` (the worst target band's margin, dB),
        ``violations`` (constraint -> signed worst-row excess over its bound, NLP units:
        negative when met), ``max_violation`` (the largest, clipped at 0),
        ``peak_db`` and ``peak_excess_db`` (continuous peak of |T| and its excess over the
        bound; None without a peak bound), ``sigma`` and ``tube_rms``.
    """
    space = study.scenarios
    sc = ScenarioStudy(study, space, np.asarray(theta, float))
    grid = grid or build_grid(study)
    ev = evaluate_design(sc, values, grid=grid)
    kind = study.objective["kind"]
    obj = OBJECTIVES[kind]
    val = ev["objectives"][kind]
    j = obj.from_natural(val)
    signed = {}
    for name, c in ev["constraints"].items():
        v = c["value"]
        ex = max(float(np.max(c["lower"] - v)) if math.isfinite(c["lower"]) else -math.inf,
                 float(np.max(v - c["upper"])) if math.isfinite(c["upper"]) else -math.inf)
        signed[name] = ex
    bound = study.constraints.get("max_peak_transmissibility_db")
    peak = excess = None
    if bound is not None:
        shim = SimpleNamespace(study=sc, dia=diaphragm_model(sc.models["diaphragm"]), grid=grid)
        terms = ev["distortion"]  # the closure's gain ratio, as the NLP's (None: off)
        peak, _ = continuous_peak_db(shim, values, ev["sigma"], ev["tube_rms"],
                                     gain_ratio=None if terms is None else terms.gain_ratio)
        excess = peak - bound
    mt = ev["metrics"]
    rows = grid.target_band_rows
    crit = float(np.min(10.0 / math.log(10.0) * (np.asarray(mt["ln_limit2"])[rows]
                                                  - np.asarray(mt["ln_ms_band"])[rows])))
    return {"objective": val, "j": j, "criterion_margin_db": crit,
            "gap": None if reference is None else j - reference,
            "violations": signed, "max_violation": max(0.0, max(signed.values(), default=0)),
            "peak_db": peak, "peak_excess_db": excess, "sigma": ev["sigma"],
            "tube_rms": ev["tube_rms"]}
