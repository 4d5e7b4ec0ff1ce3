"""Study files: the default study, one precise error per mistake, with_changes, TOML round trip."""

from __future__ import annotations

import copy
import re

import pytest

from isodesign.errors import InputError
from isodesign.io.record import dumps_toml
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.study import (
    load_study,
    study_from_dict,
    vertical_study,
)
from isodesign.optimization.variables import (
    CODESIGN_LEVERS,
    DESIGN_VARIABLES,
    GROUP_SPRING_LEVERS,
)
from isodesign.spring.gas import G_STANDARD, P_ATM

SRC = "bad_study.toml"


def _error(d: dict, source: str = SRC) -> str:
    """The message of the InputError that validating ``d`` raises."""
    with pytest.raises(InputError) as exc:
        study_from_dict(d, source=source)
    return str(exc.value)


def _valid_list(msg: str) -> set[str]:
    """The comma-separated names after 'valid:' in a message."""
    m = re.search(r"valid: (.*)$", msg, flags=re.IGNORECASE)
    assert m, f"no list of valid values in {msg!r}"
    return {s.strip() for s in m.group(1).split(",")}


# --------------------------------------------------------------------------------------------
# the default study
# --------------------------------------------------------------------------------------------
def test_default_study_loads_and_p0_carries_the_payload():
    st = vertical_study()
    assert st.source == "<default>"
    assert [v.name for v in st.variables] == list(DESIGN_VARIABLES)
    m, n, ap = 600.0, 4, 5.3e-3  # the default study's payload and piston (paper Table 1)
    assert st.payload.mass_kg == m and st.payload.isolators == n
    assert st.hardware["piston_area_m2"] == ap
    d = st.start_design()
    # Eq. 1, by hand: p0 = p_atm + m g / (n A_p)
    assert d.pressure_pa == pytest.approx(P_ATM + m * G_STANDARD / (n * ap), rel=1e-12)
    assert d.load_n == pytest.approx(m * G_STANDARD / n, rel=1e-12)
    for v in st.variables:
        assert v.lower <= v.start <= v.upper
        assert getattr(d, v.name) == v.start
    assert st.objective["kind"] in OBJECTIVES
    # an empty study file means the vertical study (under the name "default")
    assert study_from_dict({}, source="empty.toml").raw == {**st.raw, "name": "default"}


def test_default_study_file_loads(tmp_path):
    p = tmp_path / "default.toml"
    p.write_text(dumps_toml(vertical_study().raw), encoding="utf-8")
    st = load_study(p)
    assert st.source == str(p)
    assert st.start_design().pressure_pa == vertical_study().start_design().pressure_pa


# --------------------------------------------------------------------------------------------
# unknown keys
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("d", "key", "where", "valid"),
    [
        ({"bogus": 1}, "bogus", "top level",
         {"name", "description", "payload", "hardware", "floor", "target", "models",
          "variables", "constraints", "objective", "solver", "table", "scenarios"}),
        ({"payload": {"mass": 600.0}}, "mass", "[payload]",
         {"mass_kg", "isolators", "spacing_m", "cg_height_m"}),
        ({"models": {"flow_model": "womersley"}}, "flow_model", "[models]",
         {"flow", "amplitude_mode", "diaphragm", "random_method", "points_per_band",
          "peak_points", "acoustics", "distortion"}),
        ({"constraints": {"max_volume": 1e-3}}, "max_volume", "[constraints]",
         {"max_total_volume_m3", "min_capillary_diameter_m", "min_tilt_margin",
          "min_natural_frequency_hz", "max_natural_frequency_hz",
          "max_peak_transmissibility_db", "min_damping_ratio", "max_mach", "max_pressure_pa",
          "model_validity", "min_rocking_frequency_hz", "max_rocking_frequency_hz",
          "min_leveling_gain_margin_db", "min_leveling_phase_margin_deg",
          "max_stroke_m", "stroke_peak_factor", "footprint_m", "min_isolator_distance_m",
          "min_isolator_load_n", "max_isolator_load_n", "supply_margin_pa"}),
        ({"solver": {"iterations": 10}}, "iterations", "[solver]",
         {"starts", "seed", "max_iter", "tol", "tie_break", "workers"}),
        ({"variables": {"n": {"start": 1.0}}}, "n", "[variables]",
         set(DESIGN_VARIABLES) | set(CODESIGN_LEVERS) | set(GROUP_SPRING_LEVERS)
         | {"isolator_positions_m"}),
        ({"variables": {"volume_ratio": {"begin": 1.0}}}, "begin", "variables.volume_ratio",
         {"start", "lower", "upper", "fixed"}),
        ({"hardware": {"gas": {"gamma": 1.4}}}, "gamma", "[hardware.gas]",
         {"name", "gas_constant_j_per_kg_k", "heat_capacity_ratio", "viscosity_pa_s"}),
    ],
    ids=["top", "payload", "models", "constraints", "solver", "variables", "variable",
         "gas"],
)
def test_unknown_key_is_named_with_the_valid_keys(d, key, where, valid):
    msg = _error(d)
    assert SRC in msg
    assert f"unknown key {key!r}" in msg
    assert where in msg
    assert _valid_list(msg) == valid


# --------------------------------------------------------------------------------------------
# wrong types and values
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("d", "fragment"),
    [
        ({"payload": {"mass_kg": "600"}}, "payload.mass_kg must be a number, got '600'"),
        ({"payload": {"mass_kg": True}}, "payload.mass_kg must be a number, got True"),
        ({"payload": 5}, "[payload] must be a table"),
        ({"hardware": {"piston_area_m2": [5e-3]}}, "hardware.piston_area_m2 must be a number"),
        ({"constraints": {"max_mach": "0.3"}}, "constraints.max_mach must be a number"),
        ({"constraints": {"max_mach": True}}, "constraints.max_mach must be a number"),
        ({"constraints": {"model_validity": "yes"}},
         "constraints.model_validity must be true or false"),
        ({"variables": {"volume_ratio": {"fixed": "yes"}}},
         "variables.volume_ratio.fixed must be true or false"),
        ({"models": {"peak_points": 50.0}}, "models.peak_points must be an integer"),
        ({"models": {"points_per_band": True}}, "models.points_per_band must be an integer"),
        ({"models": {"diaphragm": 3}}, "models.diaphragm must be a string"),
        ({"solver": {"starts": 2.0}}, "solver.starts must be an integer"),
        ({"solver": {"tie_break": 1}}, "solver.tie_break must be true or false"),
        ({"name": 5}, "name must be a string"),
    ],
)
def test_wrong_type_is_named(d, fragment):
    msg = _error(d)
    assert SRC in msg
    assert fragment in msg


@pytest.mark.parametrize(
    ("d", "fragment"),
    [
        ({"payload": {"mass_kg": -1.0}}, "payload.mass_kg: must be in (0, inf]"),
        ({"hardware": {"temperature_k": -3.0}}, "hardware.temperature_k: must be in (1, 1000]"),
        ({"constraints": {"max_mach": -0.3}}, "constraints.max_mach: must be in (0, inf]"),
        ({"models": {"points_per_band": 2}}, "models.points_per_band must be an integer in [3,"),
        ({"models": {"peak_points": 5000}}, "models.peak_points must be an integer in [10, 2000]"),
        ({"solver": {"starts": 0}}, "solver.starts must be an integer in [1, 256]"),
        ({"solver": {"tol": 1.0}}, "solver.tol: must be in [1e-14, 0.01]"),
        ({"target": {"band_min_hz": 50.0, "band_max_hz": 10.0}},
         "target.band_min_hz (50) must not exceed band_max_hz (10)"),
        ({"constraints": {"min_natural_frequency_hz": 3.0, "max_natural_frequency_hz": 2.0}},
         "min_natural_frequency_hz must be below max_natural_frequency_hz"),
        ({"variables": {"capillary_diameter_m": {"start": 2.5e-3},
                        "capillary_length_m": {"start": 2.1e-3}}},
         "start design: capillary_diameter_m: must be smaller than capillary_length_m"),
    ],
)
def test_value_out_of_range_is_named(d, fragment):
    msg = _error(d)
    assert SRC in msg
    assert fragment in msg


@pytest.mark.parametrize(
    ("name", "key", "value"),
    [("top_volume_m3", "start", "1e-3"), ("volume_ratio", "start", True),
     ("top_volume_m3", "upper", True), ("top_volume_m3", "lower", "2e-4")],
)
def test_variable_bound_of_wrong_type_is_refused(name, key, value):
    msg = _error({"variables": {name: {key: value}}})
    assert SRC in msg and f"variables.{name}.{key}" in msg


def test_lower_above_upper():
    msg = _error({"variables": {"volume_ratio": {"lower": 5.0, "upper": 1.0, "start": 2.0}}})
    assert SRC in msg and "variables.volume_ratio" in msg
    assert "lower (5) must be below upper (1)" in msg
    # equal bounds are refused too (fix the variable instead)
    msg = _error({"variables": {"volume_ratio": {"lower": 2.0, "upper": 2.0, "start": 2.0}}})
    assert "lower (2) must be below upper (2)" in msg


@pytest.mark.parametrize("start", [0.4, 9.0])
def test_start_outside_bounds(start):
    msg = _error({"variables": {"volume_ratio": {"start": start}}})
    assert SRC in msg
    assert f"variables.volume_ratio.start ({start:g}) must lie in [lower, upper] = [0.5, 8]" in msg


def test_fixed_variable_ignores_bounds():
    st = study_from_dict({"variables": {"volume_ratio": {"start": 9.0, "fixed": True}}})
    v = st.variable("volume_ratio")
    assert v.fixed and not v.free
    assert v.start == v.lower == v.upper == 9.0


# --------------------------------------------------------------------------------------------
# floor, target, models, objective, constraints
# --------------------------------------------------------------------------------------------
def test_floor_with_both_criterion_and_csv():
    msg = _error({"floor": {"criterion": "VC-A", "csv": "floor.csv"}})
    assert SRC in msg and "[floor] needs exactly one of criterion" in msg and "csv" in msg
    # ... and with neither
    assert "[floor] needs exactly one of" in _error({"floor": {}})


def test_floor_criterion_with_csv_only_keys():
    msg = _error({"floor": {"criterion": "VC-A", "unit": "m/s"}})
    assert "[floor] keys unit only apply to csv" in msg


@pytest.mark.parametrize("table", ["floor", "target"])
def test_unknown_criterion(table):
    msg = _error({table: {"criterion": "VC-Z"}})
    assert "'VC-Z'" in msg
    assert {"VC-A", "VC-C", "VC-G", "NIST-A", "ISO-office"} <= _valid_list(msg)


@pytest.mark.parametrize("table", ["floor", "target"])
def test_unknown_criterion_names_the_file_and_table(table):
    msg = _error({table: {"criterion": "VC-Z"}})
    assert SRC in msg and f"{table}.criterion" in msg


@pytest.mark.parametrize(("key", "value"), [("isolators", 2.5), ("spacing_m", -1.0)])
def test_payload_error_names_the_file_and_table(key, value):
    msg = _error({"payload": {key: value}})
    assert SRC in msg and f"payload.{key}" in msg


@pytest.mark.parametrize("flow", ["zhao", "zhao_turbulent"])
def test_zhao_flow_refused_with_the_reason(flow):
    msg = _error({"models": {"flow": flow}})
    assert SRC in msg and f"models.flow = {flow!r}" in msg
    # why: the paper's literal friction has a pole and is non-passive near it
    assert "singular at Re_w = 3.673" in msg
    assert "non-passive" in msg
    assert "cannot be optimized" in msg
    assert _valid_list(msg) == {"quasi_steady", "womersley", "poiseuille"}


@pytest.mark.parametrize(
    ("key", "value", "valid"),
    [
        ("flow", "darcy", {"quasi_steady", "womersley", "poiseuille"}),
        ("amplitude_mode", "linear", {"self_consistent", "kinematic"}),
        ("random_method", "monte_carlo", {"statistical", "equivalent_amplitude"}),
    ],
)
def test_unknown_model_choice(key, value, valid):
    msg = _error({"models": {key: value}})
    assert SRC in msg and f"models.{key}" in msg and repr(value) in msg
    assert _valid_list(msg) == valid


def test_unknown_diaphragm_model_refused_at_load():
    msg = _error({"models": {"diaphragm": "bogus"}})
    assert SRC in msg and "models.diaphragm" in msg and "'bogus'" in msg


def test_unknown_objective():
    msg = _error({"objective": {"kind": "cost"}})
    assert SRC in msg and "objective.kind" in msg and "'cost'" in msg
    assert _valid_list(msg) == set(OBJECTIVES)


def test_transmissibility_at_needs_a_frequency():
    msg = _error({"objective": {"kind": "transmissibility_at"}})
    assert SRC in msg and "objective.frequency_hz must be a number, got None" in msg
    msg = _error({"objective": {"kind": "transmissibility_at", "frequency_hz": -5.0}})
    assert "objective.frequency_hz: must be in (0, inf]" in msg
    st = study_from_dict({"objective": {"kind": "transmissibility_at", "frequency_hz": 12.5}})
    assert st.objective == {"kind": "transmissibility_at", "frequency_hz": 12.5}


def test_min_tilt_margin_needs_spacing_and_cg_height():
    for missing in ("spacing_m", "cg_height_m"):
        raw = copy.deepcopy(vertical_study().raw)
        del raw["payload"][missing]
        with pytest.raises(InputError) as exc:
            study_from_dict(raw, source=SRC, fill_defaults=False)
        msg = str(exc.value)
        assert SRC in msg
        assert "constraints.min_tilt_margin needs payload.spacing_m and payload.cg_height_m" in msg
        # without the constraint the same payload is fine
        raw["constraints"]["min_tilt_margin"] = False
        st = study_from_dict(raw, source=SRC, fill_defaults=False)
        assert st.constraints["min_tilt_margin"] is None


def test_numeric_constraints_switch_off_with_false():
    st = study_from_dict({"constraints": {"max_mach": False, "min_damping_ratio": False,
                                          "model_validity": False}})
    assert st.constraints["max_mach"] is None
    assert st.constraints["min_damping_ratio"] is None
    assert st.constraints["model_validity"] is False
    assert st.constraints["max_total_volume_m3"] == 6e-3


# --------------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------------
def test_malformed_toml_file(tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text("[payload]\nmass_kg = = 600\n", encoding="utf-8")
    with pytest.raises(InputError, match="malformed TOML") as exc:
        load_study(p)
    assert str(p) in str(exc.value) and "study file" in str(exc.value)


def test_missing_file(tmp_path):
    p = tmp_path / "nope.toml"
    with pytest.raises(InputError, match="cannot read") as exc:
        load_study(p)
    assert str(p) in str(exc.value)


def test_error_in_a_file_names_the_file(tmp_path):
    p = tmp_path / "study.toml"
    p.write_text('[objective]\nkind = "transmissibility_at"\n', encoding="utf-8")
    with pytest.raises(InputError) as exc:
        load_study(p)
    assert str(p) in str(exc.value) and "objective.frequency_hz" in str(exc.value)


def test_a_partial_file_takes_the_defaults(tmp_path):
    p = tmp_path / "study.toml"
    p.write_text("[variables.capillary_diameter_m]\nupper = 1.2e-3\n\n"
                 "[constraints]\nmax_mach = false\n", encoding="utf-8")
    st = load_study(p)
    d0 = vertical_study()
    v = st.variable("capillary_diameter_m")
    assert (v.start, v.lower, v.upper) == (d0.variable("capillary_diameter_m").start,
                                           d0.variable("capillary_diameter_m").lower, 1.2e-3)
    assert st.constraints["max_mach"] is None
    assert st.constraints["max_total_volume_m3"] == d0.constraints["max_total_volume_m3"]


# --------------------------------------------------------------------------------------------
# with_changes
# --------------------------------------------------------------------------------------------
def test_with_changes_validates_again():
    st = vertical_study()
    raw_before = copy.deepcopy(st.raw)
    with pytest.raises(InputError, match="singular at Re_w"):
        st.with_changes(models={"flow": "zhao"})
    with pytest.raises(InputError, match=r"variables\.volume_ratio\.start \(100\)"):
        st.with_changes(variables={"volume_ratio": {"start": 100.0, "lower": 0.5, "upper": 8.0}})
    with pytest.raises(InputError, match="unknown key 'bogus' in \\[solver\\]"):
        st.with_changes(solver={"bogus": 1})
    with pytest.raises(InputError, match=r"objective\.frequency_hz"):
        st.with_changes(objective={"kind": "transmissibility_at"})
    assert st.raw == raw_before  # the original is untouched


def test_with_changes_updates_a_copy():
    st = vertical_study()
    new = st.with_changes(models={"points_per_band": 4}, objective={"kind": "total_volume"},
                          constraints={"max_mach": False})
    assert new.models["points_per_band"] == 4
    assert new.models["flow"] == st.models["flow"]  # the rest of the table is kept
    assert new.objective == {"kind": "total_volume"}
    assert new.constraints["max_mach"] is None
    assert new.constraints["min_damping_ratio"] == st.constraints["min_damping_ratio"]
    assert st.models["points_per_band"] == 6 and st.objective["kind"] == "worst_band_margin"
    assert new.source == st.source


def test_with_changes_merges_a_variable_like_a_study_file():
    st = vertical_study()
    change = {"capillary_diameter_m": {"upper": 1.2e-3}}
    from_file = study_from_dict({"variables": change})
    new = st.with_changes(variables=change)
    assert new.variable("capillary_diameter_m") == from_file.variable("capillary_diameter_m")


# --------------------------------------------------------------------------------------------
# TOML round trip
# --------------------------------------------------------------------------------------------
def _modified_raw() -> dict:
    # through study_from_dict (defaults filled in), the way a resolved study is recorded
    return study_from_dict(dict(
        name="round trip",
        description='quotes " and \\ backslash, unicode µ',
        hardware={"gas": {"name": "nitrogen", "gas_constant_j_per_kg_k": 296.8,
                          "heat_capacity_ratio": 1.4, "viscosity_pa_s": 1.76e-5},
                  "polytropic_index": 1.3},
        models={"flow": "poiseuille", "diaphragm": "none", "peak_points": 123},
        variables={"volume_ratio": {"start": 1.0 / 3.0, "fixed": True}},
        constraints={"max_mach": False, "min_tilt_margin": False, "model_validity": False,
                     "max_total_volume_m3": 1.0e-2 / 3.0},
        objective={"kind": "transmissibility_at", "frequency_hz": 7.3},
        solver={"starts": 3, "seed": 11, "tie_break": False},
    )).raw


@pytest.mark.parametrize("raw", [vertical_study().raw, _modified_raw()],
                         ids=["default", "modified"])
def test_toml_round_trip(tmp_path, raw):
    p = tmp_path / "study_resolved.toml"
    p.write_text(dumps_toml(raw), encoding="utf-8")
    st = load_study(p)
    assert st.raw == raw
    # and the resolved study is the same study
    orig = study_from_dict(raw, source="<dict>")
    assert st.variables == orig.variables
    assert st.models == orig.models and st.objective == orig.objective
    assert st.constraints == orig.constraints and st.solver == orig.solver
    assert st.start_design() == orig.start_design()


def test_acoustics_and_chamber_keys():
    """[models] acoustics and the chamber shape reach the design; bad values are named."""
    st = vertical_study().with_changes(models={"acoustics": "lumped"},
                                      hardware={"chamber_aspect_ratio": 2.0})
    d = st.start_design()
    assert d.acoustics == "lumped" and d.chamber_aspect_ratio == 2.0
    st = vertical_study().with_changes(hardware={"chamber_heat_exchange": True})
    assert st.start_design().chamber_heat_exchange
    # the lumped chambers have no heat exchange: refused naming both keys (issue 23)
    with pytest.raises(InputError, match=r"models\.acoustics.*hardware\.chamber_heat_exchange"):
        vertical_study().with_changes(models={"acoustics": "lumped"},
                                     hardware={"chamber_heat_exchange": True})
    assert vertical_study().start_design().acoustics == "distributed"
    with pytest.raises(InputError, match=r"models\.acoustics"):
        vertical_study().with_changes(models={"acoustics": "wave"})
    with pytest.raises(InputError, match=r"hardware\.chamber_aspect_ratio"):
        vertical_study().with_changes(hardware={"chamber_aspect_ratio": 0.0})
    with pytest.raises(InputError, match="chamber_heat_exchange"):
        vertical_study().with_changes(hardware={"chamber_heat_exchange": True,
                                               "polytropic_index": 1.2})
