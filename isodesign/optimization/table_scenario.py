"""A table study under one scenario of its ``[scenarios]`` (docs/robust.md).

The one place that turns a scenario vector into the study it describes: the robust table's
exchange, the table yield's draws and ``analyze(study, values, scenario)`` all call it.
"""

from __future__ import annotations

import copy

from isodesign.optimization.study import study_from_dict
from isodesign.optimization.uncertainty import (
    OPERATING_PARAMETERS,
    ScenarioStudy,
    UncertaintySpace,
)

__all__ = ["table_scenario"]


def table_scenario(study, theta):
    """The table study under scenario ``theta`` (a study object the TableProblem takes).

    Parameters
    ----------
    study : Study
        With ``table`` and ``scenarios``.
    theta : array
        In ``study.scenarios.names`` order.

    Returns
    -------
    Study or ScenarioStudy
    """
    space = study.scenarios
    th = space.as_dict(theta)
    raw = copy.deepcopy(study.raw)
    raw.pop("scenarios", None)
    if "payload_mass_kg" in th:
        raw["payload"]["mass_kg"] = th["payload_mass_kg"]
    if "cg_offset_x_m" in th or "cg_offset_y_m" in th:
        cg = list(raw["table"]["cg_m"])
        cg[0] += th.get("cg_offset_x_m", 0.0)
        cg[1] += th.get("cg_offset_y_m", 0.0)
        raw["table"]["cg_m"] = cg
    if "temperature_k" in th:
        raw["hardware"]["temperature_k"] = th["temperature_k"]
    st = study_from_dict(raw, source=study.source, fill_defaults=False)
    tol = [p for p in space.parameters if p.name not in OPERATING_PARAMETERS]
    if not tol:
        return st
    sub = UncertaintySpace(tuple(tol), space.settings)
    return ScenarioStudy(st, sub, [th[p.name] for p in tol])
