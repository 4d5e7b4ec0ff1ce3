"""Hostile studies and the optimizer's Python edge: one clear InputError naming the key or
parameter (never an AttributeError or OverflowError), and the max_pressure_pa constraint."""

from __future__ import annotations

import pytest

from isodesign.errors import InputError
from isodesign.optimization.driver import optimize
from isodesign.optimization.pareto import pareto_front
from isodesign.optimization.study import study_from_dict, vertical_study
from isodesign.spring.diagnostics import MAX_STATIC_PRESSURE_PA

ALL_FIXED = {"variables": {
    "volume_ratio": {"start": 1.85, "fixed": True},
    "top_volume_m3": {"start": 8.1e-4, "fixed": True},
    "capillary_length_m": {"start": 1.2e-2, "fixed": True},
    "capillary_diameter_m": {"start": 0.9e-3, "fixed": True},
}}


def test_a_study_with_every_variable_fixed_is_refused():
    with pytest.raises(InputError, match=r"every design variable is fixed"):
        study_from_dict(ALL_FIXED)


def test_three_fixed_variables_are_fine():
    d = {"variables": dict(ALL_FIXED["variables"])}
    d["variables"]["volume_ratio"] = {"start": 1.85, "lower": 0.5, "upper": 8.0}
    st = study_from_dict(d)
    assert [v.name for v in st.variables if not v.fixed] == ["volume_ratio"]


@pytest.mark.parametrize(("spec", "match"), [
    ({"start": 9.0, "lower": 0.5, "upper": 8.0, "fixed": True},
     r"variables.volume_ratio.start \(9\) .*fixed.* \[0.5, 8\]"),
    ({"start": 0.1, "lower": 0.5, "fixed": True}, r"variables.volume_ratio.start \(0.1\)"),
    ({"start": 9.0, "upper": 8.0, "fixed": True}, r"variables.volume_ratio.start \(9\)"),
])
def test_a_fixed_variable_outside_its_own_bounds_is_refused(spec, match):
    with pytest.raises(InputError, match=match):
        study_from_dict({"variables": {"volume_ratio": spec}})


def test_a_fixed_variable_inside_its_bounds_is_fine():
    st = study_from_dict({"variables": {"volume_ratio": {"start": 2.0, "lower": 0.5,
                                                         "upper": 8.0, "fixed": True}}})
    assert st.variable("volume_ratio").fixed


def test_an_overflowing_payload_is_named_as_the_payload():
    with pytest.raises(InputError, match=r"payload.mass_kg") as ei:
        study_from_dict({"payload": {"mass_kg": 1e308}})
    assert "pressure_pa" not in str(ei.value)


def test_max_pressure_pa_defaults_to_the_validity_bound_and_is_checked():
    # issue 14: a payload beyond the model's validity must not PASS; by default the study
    # refuses it (the bound is the model's), false switches the bound off
    st = vertical_study()
    assert st.constraints["max_pressure_pa"] == MAX_STATIC_PRESSURE_PA
    off = study_from_dict({"constraints": {"max_pressure_pa": False}})
    assert off.constraints["max_pressure_pa"] is None
    with pytest.raises(InputError, match=r"constraints.max_pressure_pa = 1e\+06 Pa \(the "
                       r"model's validity bound.*needs p0 = 5\.652e\+06 Pa"):
        study_from_dict({"payload": {"mass_kg": 12000.0}})
    p0 = st.start_design().pressure_pa
    ok = study_from_dict({"constraints": {"max_pressure_pa": MAX_STATIC_PRESSURE_PA}})
    assert ok.constraints["max_pressure_pa"] == MAX_STATIC_PRESSURE_PA
    with pytest.raises(InputError, match=r"constraints.max_pressure_pa.*payload") as ei:
        study_from_dict({"constraints": {"max_pressure_pa": 0.9 * p0}})
    assert f"{p0:.4g}" in str(ei.value)
    with pytest.raises(InputError, match=r"constraints.max_pressure_pa"):
        study_from_dict({"constraints": {"max_pressure_pa": "1e6"}})
    with pytest.raises(InputError, match=r"constraints.max_pressure_pa"):
        study_from_dict({"constraints": {"max_pressure_pa": -1.0}})


@pytest.mark.parametrize("study", ["default", None, 3, {"name": "x"}])
def test_optimize_and_pareto_name_the_study_parameter(study):
    with pytest.raises(InputError, match=r"^study: expected a Study"):
        optimize(study)
    with pytest.raises(InputError, match=r"^study: expected a Study"):
        pareto_front(study)


def test_max_pressure_pa_is_reported_as_a_constraint_of_the_run():
    st = study_from_dict({
        "models": {"points_per_band": 4, "peak_points": 30},
        "solver": {"starts": 1, "workers": 1},
        "constraints": {"max_pressure_pa": MAX_STATIC_PRESSURE_PA},
    })
    res = optimize(st, analyze=False)
    assert res.feasible
    row = next(c for c in res.constraints if c.name == "chamber_pressure")
    p0 = st.start_design().pressure_pa
    assert row.value == pytest.approx(p0, rel=1e-9)
    assert row.upper == pytest.approx(MAX_STATIC_PRESSURE_PA)
    assert row.unit == "Pa" and not row.active


@pytest.mark.parametrize("bad", ["not a dict", 3, None, ["payload"]])
def test_study_from_dict_names_its_argument(bad):
    # issue 14: 'not a dict' was reported as '<dict>: [] must be a table'
    with pytest.raises(InputError, match=r"^study_from_dict: d must be a dict of study tables"):
        study_from_dict(bad)


def test_variable_bounds_outside_the_models_domain_name_the_key():
    with pytest.raises(InputError, match=r"variables.volume_ratio.upper = 1e\+10 is outside "
                                         r"the models' domain \[0.001, 1000\]"):
        study_from_dict({"variables": {"volume_ratio": {"start": 2.0, "lower": 0.5,
                                                        "upper": 1e10}}})


# -- issue 23: with_changes takes the dotted keys of sweep --vary -------------------------
def test_with_changes_takes_dotted_keys():
    from isodesign.optimization.study import vertical_study

    st = vertical_study()
    a = st.with_changes({"payload.mass_kg": 800})
    b = st.with_changes(**{"payload.mass_kg": 800})
    c = st.with_changes(payload={"mass_kg": 800})
    assert a.payload.mass_kg == b.payload.mass_kg == c.payload.mass_kg == 800.0
    assert a.raw == c.raw
    d = st.with_changes({"payload.mass_kg": 800, "floor.criterion": "VC-B",
                         "variables.volume_ratio.start": 2.0}, payload={"isolators": 6})
    assert (d.payload.mass_kg, d.payload.isolators) == (800.0, 6)
    assert d.floor.name == "VC-B floor" and d.variable("volume_ratio").start == 2.0
    assert d.payload.isolators == 6 and st.payload.mass_kg == 600.0  # the base unchanged


@pytest.mark.parametrize("changes, words", [
    ({"payload.mas_kg": 5}, ["unknown key 'mas_kg' in [payload]", "mass_kg"]),
    ({"payload.mass_kg": "800"}, ["payload.mass_kg"]),
    ({"payload.mass_kg": True}, ["payload.mass_kg"]),
    ({"payload..mass_kg": 1}, ["'payload..mass_kg' is not a study key"]),
    ({1: 2}, ["keys must be strings"]),
    ([("payload.mass_kg", 800)], ["changes must be a dict"]),
    ("payload.mass_kg=800", ["changes must be a dict"]),
])
def test_with_changes_bad_changes_are_input_errors(changes, words):
    from isodesign.optimization.study import vertical_study

    with pytest.raises(InputError) as exc:
        vertical_study().with_changes(changes)
    for w in words:
        assert w in str(exc.value)


# -- issue 23: the public API refuses wrong types with InputError, naming the argument -----
def _api_cases():
    import isodesign
    from isodesign.optimization.pareto import pareto_front
    from isodesign.optimization.study import load_study
    from isodesign.optimization.yields import estimate_yield
    from isodesign.table import Table

    st = vertical_study()
    rob = st.with_changes(scenarios={"payload_mass_kg": {"relative": 0.1}})
    good = {"volume_ratio": 1.85, "top_volume_m3": 8.1e-4, "capillary_length_m": 0.012,
            "capillary_diameter_m": 9e-4}
    return [
        (lambda: load_study(5), "path"),
        (lambda: load_study(None), "path"),
        (lambda: load_study(["a.toml"]), "path"),
        (lambda: load_study(""), "path"),
        (lambda: isodesign.sweep(5, {"payload.mass_kg": [1, 2]}, output="x"), "study"),
        (lambda: isodesign.sweep(None, 5, output="x"), "vary"),
        (lambda: isodesign.sweep(None, {"payload.mass_kg": 5}, output="x"), "payload.mass_kg"),
        (lambda: isodesign.sweep(None, {5: [1, 2]}, output="x"), "vary"),
        (lambda: isodesign.sweep(None, points=5, output="x"), "points"),
        (lambda: isodesign.sweep(None, points=[5], output="x"), "points"),
        (lambda: isodesign.sweep(None, points=[{"payload.mas_kg": 5}], output="x"),
         "payload.mas_kg"),
        (lambda: estimate_yield(5, good), "study"),
        (lambda: estimate_yield(rob, 5), "values"),
        (lambda: estimate_yield(rob, {}), "values: missing"),
        (lambda: estimate_yield(rob, {**good, "volume_ratio": "a"}), "values: volume_ratio"),
        (lambda: estimate_yield(rob, {**good, "volume_ratio": True}), "values: volume_ratio"),
        (lambda: estimate_yield(rob, {**good, "colour": 1}), "unknown design variable"),
        (lambda: pareto_front(st, objectives=5), "objectives"),
        (lambda: pareto_front(st, objectives="worst_band_margin"), "objectives"),
        (lambda: Table.symmetric(10.0, "a", 1.0, 0.3), "spacing_x_m"),
        (lambda: Table(mass_kg=10.0, isolators_m=[[0, 0], [1, 0], [0, 1]],
                       cg_m=["0.2", 0.2, 0.3], inertia_kg_m2=[1, 1, 1]), "cg_m"),
        (lambda: Table(mass_kg=10.0, isolators_m=[[0, 0], [1, 0], [0, 1]],
                       cg_m=[0.2, 0.2, 0.3], inertia_kg_m2=[1, 1, 1], point_names=5),
         "point_names"),
    ]


@pytest.mark.parametrize("i", range(22))
def test_public_api_wrong_types_are_input_errors(i, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    call, name = _api_cases()[i]
    with pytest.raises(InputError) as exc:
        call()
    assert name in str(exc.value)
    assert not (tmp_path / "x").exists()


def _analyze_cases():
    """``isodesign.analyze`` and ``vertical_band_response`` misused: (call, words)."""
    import isodesign
    from isodesign.optimization.analyze import vertical_band_response
    from isodesign.optimization.study import table_study

    v, t = vertical_study(), table_study()
    s = v.with_changes(scenarios={"payload_mass_kg": {"min": 480.0, "max": 720.0}})
    free = t.with_changes(variables={"layout_length_m": {"fixed": False}})
    return [
        (lambda: isodesign.analyze("study.toml"), "study: expected an isodesign Study"),
        (lambda: isodesign.analyze(None), "study: expected an isodesign Study"),
        (lambda: isodesign.analyze(v, [1.0, 2.0]), "values: expected a dict"),
        (lambda: isodesign.analyze(v, {"colour": 1.0}), "values: unknown name 'colour'"),
        (lambda: isodesign.analyze(v, {"volume_ratio": "2"}), "values['volume_ratio']"),
        (lambda: isodesign.analyze(v, {"volume_ratio": float("nan")}), "values['volume_ratio']"),
        # a fixed lever at another value would answer for the fixed design, silently
        (lambda: isodesign.analyze(t, {"layout_length_m": 1.4}),
         "variables.layout_length_m is fixed at 1.2"),
        (lambda: isodesign.analyze(t, {"volume_ratio_group2": 3.0}),
         "unknown name 'volume_ratio_group2'"),
        (lambda: isodesign.analyze(free, {"layout_length_m": 1500.0}), "a unit slip"),
        (lambda: isodesign.analyze(s, None, "abc"), "scenario: expected 1 numbers"),
        (lambda: isodesign.analyze(s, None, {"payload_mass_kg": 600.0}), "scenario: expected"),
        (lambda: isodesign.analyze(s, None, [6000.0]), "payload_mass_kg = 6000 is outside"),
        (lambda: isodesign.analyze(s, None, [float("nan")]), "payload_mass_kg = nan"),
        (lambda: vertical_band_response(None, v.payload, v.floor, v.target),
         "design: expected an isodesign SpringDesign"),
    ]


@pytest.mark.parametrize("i", range(14))
def test_analyze_misuse_is_an_input_error_naming_the_argument(i):
    call, words = _analyze_cases()[i]
    with pytest.raises(InputError) as exc:
        call()
    assert words in str(exc.value)


def test_analyze_takes_a_fixed_lever_at_its_own_value():
    import isodesign
    from isodesign.optimization.study import table_study

    t = table_study()
    a = isodesign.analyze(t.with_changes(models={"points_per_band": 4}), points_per_band=4)
    b = isodesign.analyze(t.with_changes(models={"points_per_band": 4}),
                          {"layout_length_m": 1.2, "layout_width_m": 0.8}, points_per_band=4)
    assert a.worst_margin_db == b.worst_margin_db
