"""The one constraint registry: every kind's NLP rows re-checked on the NumPy path, on both
bodies (the vertical z reduction and the six-degree-of-freedom table).

At a design (the start, whose implicit unknowns the NumPy closure solves), each row the NLP
holds is the registry's expression on CasADi quantities; the re-check evaluates the same
kind on the NumPy analysis's quantities (:func:`isodesign.optimization.recheck.
evaluate_design` for the vertical body, :func:`isodesign.optimization.table_constraints.
table_quantities` for the table: |T| from the model's outputs, the closure, the leveled
springs). They agree to 1e-9 in the NLP's units (a log or ln |T|^2; measured: 1e-13). The
table's frozen-mode rows, with the modes frozen at the design's own exact modes, give back
the exact modes' damping ratios and rocking frequencies (:attr:`ConstraintKind.exact`) to
1e-6 relative (measured: 1e-8).
"""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.optimization.constraint_registry import (
    CONSTRAINTS,
    TABLE_ROWS,
    VERTICAL_ROWS,
    constraint_rows_of,
)
from isodesign.optimization.study import table_study, vertical_study

#: Agreement of an NLP row and its NumPy re-check (NLP units: logs, ln |T|^2).
ROW_TOL = 1e-9
#: Agreement of a frozen-mode row's exact quantity with the exact modes' (relative).
EXACT_RTOL = 1e-6


def _starts(study) -> dict:
    return {v.name: v.start for v in study.variables}


def _g(prob, values) -> np.ndarray:
    x = prob.initial_guess(values)
    _, g = prob.eval_fn(x, prob.params())
    return np.asarray(g, float).ravel(), x


def test_registry_is_one_table_of_kinds():
    # every requested kind is an entry; the shared kinds are the same entries for both
    for name in (*VERTICAL_ROWS, *TABLE_ROWS):
        assert CONSTRAINTS[name].name == name
    shared = set(VERTICAL_ROWS) & set(TABLE_ROWS)
    assert {"total_volume", "natural_frequency", "peak_transmissibility", "mach", "laminar",
            "quasi_steady_alpha", "lumped_tube", "plane_wave_top_chamber"} <= shared
    # rows only the table holds are entries the vertical body does not request
    for name in ("min_rocking_frequency", "max_rocking_frequency", "layout", "loads",
                 "leveling_loop", "stroke"):
        assert name in TABLE_ROWS and name not in VERTICAL_ROWS
    for k in CONSTRAINTS.values():
        assert k.form in ("log", "db", "surrogate", "given")
        assert k.unit and k.describe and k.key
        assert (k.bounds is not None) == (k.form in ("log", "db"))
        assert (k.exact is not None) <= (k.form == "surrogate")


@pytest.mark.parametrize("changes", [{}, {"models.acoustics": "lumped"},
                                     {"models.flow": "quasi_steady"}],
                         ids=["vertical_study", "lumped", "quasi_steady"])
def test_vertical_rows_recheck_on_numpy(changes):
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.recheck import evaluate_design

    study = vertical_study().with_changes(changes) if changes else vertical_study()
    prob = Problem(study)
    values = _starts(study)
    g, _ = _g(prob, values)
    numpy_rows = evaluate_design(study, values, grid=prob.grid)["constraints"]
    seen = set()
    for c, row, n in prob.con_rows:
        if c.name.startswith(("epigraph_", "bound_")):
            continue
        assert c.kind == c.name and c.kind in VERTICAL_ROWS  # every row is a registry kind
        v = np.atleast_1d(numpy_rows[c.name]["value"])
        assert v.size == n
        np.testing.assert_allclose(g[row: row + n], v, rtol=0, atol=ROW_TOL, err_msg=c.name)
        seen.add(c.name)
    expected = {"total_volume", "tilt_margin", "natural_frequency", "peak_transmissibility",
                "damping_ratio"}
    expected |= {"lumped_tube"} if changes.get("models.acoustics") == "lumped" else \
        {"plane_wave_top_chamber"}
    expected |= {"quasi_steady_alpha"} if changes.get("models.flow") else {"laminar"}
    expected |= {"tube_end_length"}  # the box admits L_c = 2 mm with D_c = 3 mm
    assert expected <= seen


@pytest.mark.parametrize("changes", [{}, {"models.acoustics": "lumped"},
                                     {"models.flow": "quasi_steady"}],
                         ids=["table_study", "lumped", "quasi_steady"])
def test_table_rows_recheck_on_numpy(changes):
    from isodesign.optimization.table_constraints import table_quantities
    from isodesign.optimization.table_problem import TableProblem

    study = table_study().with_changes({"constraints.max_stroke_m": 0.01, **changes})
    prob = TableProblem(study)
    values = _starts(study)
    g, _ = _g(prob, values)
    rows = {c.key: c for c in constraint_rows_of(study, table_quantities(prob, values),
                                                 TABLE_ROWS)}
    checked = set()
    for key, row, n in prob.con_rows:
        if key in rows:
            v = np.atleast_1d(np.asarray(rows[key].expr, float))
            assert v.size == n
            np.testing.assert_allclose(g[row: row + n], v, rtol=0, atol=ROW_TOL, err_msg=key)
            checked.add(rows[key].kind)
    validity = {"lumped_tube", "lumped_top_chamber", "lumped_bottom_chamber"} \
        if changes.get("models.acoustics") else {"plane_wave_top_chamber",
                                                 "plane_wave_bottom_chamber"}
    validity |= {"quasi_steady_alpha"} if changes.get("models.flow") else {"laminar"}
    validity |= {"tube_end_length"}  # the box admits L_c = 2 mm with D_c = 3 mm
    assert checked == {"total_volume", "natural_frequency", "stroke", "tilt_margin_rows",
                       "peak_transmissibility", "mach"} | validity


@pytest.mark.parametrize("body", ["vertical", "table"])
def test_the_tube_rows_follow_the_box_and_the_end_correction(body):
    # D_c / L_c <= 0.49 (0.98 of the end correction's 4 bore radii) where the box admits a
    # shorter tube; D_c / L_c < 0.98 with the end correction off; no row where the box
    # keeps the tube long (L_c >= 10 mm with D_c <= 3 mm) or fixes both
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.table_problem import TableProblem

    base = vertical_study() if body == "vertical" else table_study()
    build = Problem if body == "vertical" else TableProblem

    def rows(study):
        prob = build(study)
        return {c.name if body == "vertical" else c: (row, n) for c, row, n in prob.con_rows}, \
            prob

    for changes, kind, limit in (
            ({}, "tube_end_length", 0.5),
            ({"hardware.tube_end_correction": False}, "tube_length", 1.0),
            ({"variables.capillary_length_m.lower": 0.01}, None, None),
            ({"variables.capillary_length_m.fixed": True,
              "variables.capillary_diameter_m.fixed": True}, None, None)):
        study = base.with_changes(changes) if changes else base
        found, prob = rows(study)
        names = {k for k in found if k in ("tube_end_length", "tube_length")}
        assert names == ({kind} if kind else set()), changes
        if kind is None:
            continue
        k = CONSTRAINTS[kind]
        assert k.validity and k.on(study)
        lo, hi = k.nlp_bounds(study)
        assert lo == -np.inf and hi == pytest.approx(np.log(0.98 * limit), abs=1e-15)
        # the row is ln(D_c / L_c) of the design
        values = _starts(study)
        g, _ = _g(prob, values)
        row, n = found[kind]
        d = study.design_at(values)
        np.testing.assert_allclose(g[row: row + n], np.log(d.capillary_diameter_m
                                                         / d.capillary_length_m),
                                   rtol=0, atol=ROW_TOL)


def test_table_frozen_mode_rows_give_the_exact_modes():
    from isodesign.optimization.table_driver import _modes_at
    from isodesign.optimization.table_problem import TableProblem

    study = table_study().with_changes({"constraints.min_rocking_frequency_hz": 0.5,
                                        "constraints.max_rocking_frequency_hz": 5.0})
    prob = TableProblem(study)
    values = _starts(study)
    _, x = _g(prob, values)
    modes = _modes_at(prob, study.design_at(values), prob.sigma(x), prob.tube_rms(x), values)
    prob.set_modes(modes)
    g, _ = _g(prob, values)
    c = study.constraints
    rows = {key: (row, n) for key, row, n in prob.con_rows}
    # per mode: the damping block's then the rocking block's active flag
    active = prob.mode_params[0: 14 * 6: 14] > 0
    rocking = prob.mode_params[14 * 6:: 14] > 0
    assert active.any() and rocking.any()
    row, n = rows["min_damping_ratio"]
    zeta = CONSTRAINTS["damping_rows"].exact(g[row: row + n], c)
    np.testing.assert_allclose(zeta[active], modes.damping_ratio[active], rtol=EXACT_RTOL)
    for name, key in (("min_rocking_frequency", "min_rocking_frequency_hz"),
                      ("max_rocking_frequency", "max_rocking_frequency_hz")):
        row, n = rows[key]
        f = CONSTRAINTS[name].exact(g[row: row + n], c)
        np.testing.assert_allclose(f[rocking], modes.frequency_hz[rocking], rtol=EXACT_RTOL)


def test_both_bodies_report_the_shared_kinds_alike():
    # the table's row-reported kinds carry the registry's name, unit and words, as the
    # vertical body's rows do
    from isodesign.optimization.constraints import constraint_reports
    from isodesign.optimization.problem import Problem
    from isodesign.optimization.table_constraints import row_reports
    from isodesign.optimization.table_problem import TableProblem

    vs, ts = vertical_study(), table_study()
    vp, tp = Problem(vs), TableProblem(ts)
    vr = {r.name: r for r in constraint_reports(vp.con_rows, _g(vp, _starts(vs))[0])}
    tr = {r.name: r for r in row_reports(tp, _g(tp, _starts(ts))[0])}
    for name in ("total_volume", "natural_frequency", "peak_transmissibility"):
        k = CONSTRAINTS[name]
        assert vr[name].unit == tr[name].unit == k.unit
        assert vr[name].description == tr[name].description == k.describe


def test_binding_explanation_names_every_kinds_study_key():
    # one binding explanation: its study keys and model-validity limits are the registry's
    from isodesign.optimization.explain import MODEL_VALIDITY_CONSTRAINTS, STUDY_KEYS

    for k in CONSTRAINTS.values():
        if k.form in ("log", "db") and k.key != "model_validity":
            assert STUDY_KEYS[k.name].startswith("constraints.")
        assert (k.name in MODEL_VALIDITY_CONSTRAINTS) == k.validity
    assert STUDY_KEYS["stroke"] == "constraints.max_stroke_m"
    assert STUDY_KEYS["natural_frequency"] == "constraints.min/max_natural_frequency_hz"
    assert STUDY_KEYS["rocking_frequency"] == "constraints.min/max_rocking_frequency_hz"
