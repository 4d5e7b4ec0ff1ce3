"""Hostile and mistaken inputs on the table, scenario, sweep and yield surfaces (issue 23).

Each case is a change to the built-in table study (``[table]``, ``[scenarios]``, ...) that
must end in one :class:`~isodesign.errors.InputError` naming the key as the user typed it
(``table.cg_m``), or, for a value that is valid but implausible, in a
:class:`~isodesign.io.plausible.UnitWarning` naming the key and the likely unit slip. The
CLI cases require exit status 2 and one ``isodesign: error:`` line, never a traceback.
"""

from __future__ import annotations

import copy
import warnings

import pytest

from isodesign.cli import main
from isodesign.errors import InputError
from isodesign.io.plausible import UnitWarning
from isodesign.optimization.study import study_from_dict, table_study


@pytest.fixture(scope="module")
def base() -> dict:
    raw = copy.deepcopy(table_study().raw)
    raw.pop("name")
    raw.pop("description")
    return raw


def _set(raw: dict, dotted: str, value) -> dict:
    """``raw`` with ``dotted`` (``table.horizontal.pendulum_length_m``) set; ``None``
    deletes it."""
    raw = copy.deepcopy(raw)
    *path, last = dotted.split(".")
    t = raw
    for p in path:
        t = t.setdefault(p, {})
    if value is None:
        t.pop(last, None)
    else:
        t[last] = value
    return raw


def _mm(rows):
    return [[1000.0 * v for v in r] for r in rows]


#: (changes as {dotted key: value}, fragments of the error)
TABLE_ERRORS = [
    # types: strings, booleans and tables where numbers belong
    ({"table.cg_m": {"x": 0.0, "y": 0.0, "z": 0.35}}, ["table.cg_m", "table"]),
    ({"table.cg_m": ["0", "0", "0.35"]}, ["table.cg_m", "string '0'"]),
    ({"table.cg_m": [0.0, 0.0, True]}, ["table.cg_m", "boolean"]),
    ({"table.cg_m": "0.35"}, ["table.cg_m", "string"]),
    ({"table.cg_m": [0.0, 0.0, float("nan")]}, ["table.cg_m", "finite"]),
    ({"table.cg_m": [0.0, 0.0, float("inf")]}, ["table.cg_m", "finite"]),
    ({"table.isolators_m": "corners"}, ["table.isolators_m"]),
    ({"table.isolators_m": [["-0.6", -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]]},
     ["table.isolators_m", "string"]),
    ({"table.isolators_m": [[True, 0], [1, 0], [1, 1], [0, 1]]}, ["table.isolators_m",
                                                                 "boolean"]),
    ({"table.isolators_m": {"a": 1}}, ["table.isolators_m"]),
    ({"table.box_m": "abc"}, ["table.box_m", "string"]),
    ({"table.box_m": {"a": 1}}, ["table.box_m"]),
    ({"table.box_m": None, "table.inertia_kg_m2": "abc"}, ["table.inertia_kg_m2"]),
    ({"table.box_m": None, "table.inertia_kg_m2": {"a": 1}}, ["table.inertia_kg_m2"]),
    ({"table.box_m": None, "table.inertia_kg_m2": [[1, 2], [3]]}, ["table.inertia_kg_m2"]),
    ({"table.box_m": None, "table.inertia_kg_m2": [True, 1, 1]}, ["table.inertia_kg_m2",
                                                                  "boolean"]),
    ({"table.instrument_points_m": [["0", 0, 0.7]]}, ["table.instrument_points_m", "string"]),
    ({"table.point_names": 5}, ["table.point_names", "names"]),
    ({"table.point_names": True}, ["table.point_names"]),
    ({"table.point_names": 0.5}, ["table.point_names"]),
    ({"table.point_names": [1, 2]}, ["table.point_names"]),
    ({"table.point_names": ["a", ""]}, ["table.point_names"]),
    ({"table.supply_pressure_pa": "7e5"}, ["table.supply_pressure_pa", "string"]),
    ({"table.supply_pressure_pa": True}, ["table.supply_pressure_pa", "boolean"]),
    ({"table.supply_pressure_pa": 7}, ["table.supply_pressure_pa", "bar"]),
    ({"table.supply_pressure_pa": 1e30}, ["table.supply_pressure_pa", "1e+08"]),
    ({"table.horizontal.pendulum_length_m": "0.15"}, ["table.horizontal.pendulum_length_m"]),
    ({"table.horizontal.pendulum_length_m": 1e30}, ["table.horizontal.pendulum_length_m"]),
    ({"table.horizontal.lateral_loss_factor": 1e30}, ["table.horizontal.lateral_loss_factor"]),
    ({"table.horizontal.lateral_stiffness_n_per_m": 1e30},
     ["table.horizontal.lateral_stiffness_n_per_m"]),
    ({"table.horizontal.elastic_centre_height_m": -1e30},
     ["table.horizontal.elastic_centre_height_m"]),
    # beyond any table: an error, not a warning
    ({"table.box_m": [1e30, 1.0, 1.0]}, ["table.box_m", "radius of gyration"]),
    ({"table.box_m": None, "table.inertia_kg_m2": [1e30, 1e30, 1e30]},
     ["table.inertia_kg_m2", "beyond any table"]),
    ({"table.cg_m": [0.0, 0.0, 3500.0]}, ["table.cg_m", "1000 m"]),
    ({"table.isolators_m": [[-1e308, -0.4], [1e308, -0.4], [0.6, 0.4], [-0.6, 0.4]]},
     ["table.isolators_m", "1000 m"]),
    ({"table.instrument_points_m": [[0.0, 0.0, 1e300]], "table.point_names": ["a"]},
     ["table.instrument_points_m", "1000 m"]),
    # geometry: the isolators' own fault is named, in the user's 1-based numbering
    ({"table.isolators_m": [[0, 0], [1, 0], [2, 0], [3, 0]]},
     ["table.isolators_m", "one line"]),
    ({"table.isolators_m": [[0, 0], [1, 0], [1, 0], [0, 1]]},
     ["table.isolators_m", "isolators 2 and 3"]),
    ({"table.leveling_groups": [[0, 1], [2], [3]]}, ["table.leveling_groups", "from 1 to 4"]),
    ({"table.leveling_groups": [[1, 2], [2], [4]]},
     ["table.leveling_groups", "1..4", "missing 3", "twice 2"]),
    ({"table.leveling_groups": [[1, 2], [3, 4]]}, ["table.leveling_groups", "three groups"]),
    ({"table.leveling_groups": 5}, ["table.leveling_groups"]),
]


@pytest.mark.parametrize("changes, fragments", TABLE_ERRORS,
                         ids=[f"{i}-{next(iter(c))}" for i, (c, _) in enumerate(TABLE_ERRORS)])
def test_table_input_refused_by_key(base, changes, fragments):
    raw = base
    for k, v in changes.items():
        raw = _set(raw, k, v)
    with pytest.raises(InputError) as exc:
        study_from_dict(raw, source="s.toml")
    msg = str(exc.value)
    assert msg.startswith("s.toml: ")
    for f in fragments:
        assert f in msg, msg
    assert "\n" not in msg


#: (changes, the key the warning names, a fragment of the likely slip)
TABLE_WARNINGS = [
    ({"table.isolators_m": _mm([[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]])},
     "table.isolators_m", "600 mm would be 0.6 m"),
    ({"table.cg_m": [0.0, 0.0, 350.0]}, "table.cg_m", "350 mm would be 0.35 m"),
    ({"table.instrument_points_m": [[0.0, 0.0, 700.0]], "table.point_names": ["c"]},
     "table.instrument_points_m", "700 mm would be 0.7 m"),
    ({"table.horizontal.pendulum_length_m": 150.0}, "table.horizontal.pendulum_length_m",
     "150 mm would be 0.15 m"),
    ({"table.horizontal.elastic_centre_height_m": 50.0},
     "table.horizontal.elastic_centre_height_m", "mm"),
    ({"table.horizontal.lateral_loss_factor": 5.0}, "table.horizontal.lateral_loss_factor",
     "plausible"),
    ({"table.box_m": None, "table.inertia_kg_m2": [1e8, 1.5e8, 2e8]}, "table.inertia_kg_m2",
     "radius of gyration"),
    ({"table.supply_pressure_pa": 5e7}, "table.supply_pressure_pa", "plausible"),
    ({"table.isolators_m": [[-6e-4, -4e-4], [6e-4, -4e-4], [6e-4, 4e-4], [-6e-4, 4e-4]]},
     "table.isolators_m", "plausible span"),
]


@pytest.mark.parametrize("changes, key, slip", TABLE_WARNINGS, ids=[k for _, k, _ in
                                                                    TABLE_WARNINGS])
def test_table_implausible_value_warns_naming_key(base, changes, key, slip):
    raw = base
    for k, v in changes.items():
        raw = _set(raw, k, v)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        study_from_dict(raw, source="s.toml")
    msgs = [str(x.message) for x in w if issubclass(x.category, UnitWarning)]
    assert any(key in m and slip in m for m in msgs), msgs


def test_whole_table_in_millimetres_warns_for_every_length(base):
    raw = copy.deepcopy(base)
    t = raw["table"]
    t["isolators_m"] = _mm(t["isolators_m"])
    t["cg_m"] = [1000.0 * v for v in t["cg_m"]]
    t["box_m"] = [1000.0 * v for v in t["box_m"]]
    t["instrument_points_m"] = _mm(t["instrument_points_m"])
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        study_from_dict(raw, source="s.toml")
    msgs = " | ".join(str(x.message) for x in w)
    for key in ("table.isolators_m", "table.cg_m", "table.instrument_points_m"):
        assert key in msgs
    assert "350 mm would be 0.35 m" in msgs


def test_plausible_table_gives_no_warning(base):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        study_from_dict(copy.deepcopy(base), source="s.toml")
    assert not [x for x in w if issubclass(x.category, UnitWarning)]


def test_with_changes_warns_on_a_changed_table():
    st = table_study()
    with pytest.warns(UnitWarning, match=r"table\.cg_m"):
        st.with_changes(table={"cg_m": [0.0, 0.0, 350.0]})


def _study_file(tmp_path, text: str) -> str:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return str(p)


TABLE_TOML = """\
[payload]
mass_kg = 600.0
isolators = 4
spacing_m = 0.8
cg_height_m = 0.35
[table]
isolators_m = [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]]
box_m = [1.5, 1.0, 0.7]
"""


@pytest.mark.parametrize("line, fragments", [
    ("cg_m = {x = 0.0, y = 0.0, z = 0.35}", ["table.cg_m"]),
    ("cg_m = [0.0, 0.0, 0.35]\npoint_names = 5", ["table.point_names"]),
    ('cg_m = ["0", "0", "0.35"]', ["table.cg_m", "string"]),
    ("cg_m = [0.0, 0.0, 0.35]\nleveling_groups = [[0, 1], [2], [3]]",
     ["table.leveling_groups", "from 1 to 4"]),
])
def test_modes_cli_one_line(tmp_path, capsys, line, fragments):
    path = _study_file(tmp_path, TABLE_TOML + line + "\n")
    assert main(["modes", path, "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("isodesign: error: "), err
    for f in fragments:
        assert f in err[0]


@pytest.mark.parametrize("command, extra, fragments", [
    ("sweep", "[constraints]\nmax_isolator_load_n = 1.0\n",
     ["constraints.max_isolator_load_n: isolator 1 (from 1)"]),
    ("optimize", "[constraints]\nsupply_margin_pa = 9.0e5\n",
     ["constraints.supply_margin_pa (900000 Pa) must be below table.supply_pressure_pa"]),
    ("pareto", "[variables.layout_length_m]\nfixed = false\n[constraints]\n"
     "footprint_m = [[-0.1, -0.1], [0.1, 0.1]]\n",
     ["constraints.footprint_m: no layout_length_m in its bounds"]),
    ("optimize", "[variables.layout_width_m]\nfixed = false\nupper = 800\n",
     ["variables.layout_width_m.upper = 800 m", "800 mm would be 0.8 m"]),
    ("sweep", "[variables.volume_ratio_group4]\nfixed = false\n",
     ["variables.volume_ratio_group4: group '4'", "k = 1, 2 or 3"]),
])
def test_layout_and_load_contradictions_end_in_one_line_before_any_run(
        tmp_path, capsys, command, extra, fragments):
    """Settings no design can meet (docs/table.md section 15) are refused by the study,
    so every entry point stops before solving anything (a sweep before its cluster)."""
    path = _study_file(tmp_path, TABLE_TOML + "cg_m = [0.0, 0.0, 0.35]\n" + extra)
    argv = [command, path, "-o", str(tmp_path / "out")]
    if command == "sweep":
        argv += ["--vary", "payload.mass_kg=500,600"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("isodesign: error: "), err
    for f in fragments:
        assert f in err[0]
    assert not (tmp_path / "out").exists()


# -- [scenarios]: ranges in another unit ---------------------------------------------------

SCENARIO_ERRORS = [
    ("vertical", {"ambient_pressure_pa": {"min": 95, "max": 105}},
     ["scenarios.ambient_pressure_pa", "95 .. 105 kPa would be 95000 .. 105000 Pa"]),
    ("vertical", {"ambient_pressure_pa": {"min": 0.95, "max": 1.05}},
     ["scenarios.ambient_pressure_pa", "bar"]),
    ("vertical", {"ambient_pressure_pa": {"values": [1e9]}}, ["scenarios.ambient_pressure_pa"]),
    ("vertical", {"temperature_k": {"min": 15, "max": 30}},
     ["scenarios.temperature_k", "15 .. 30 degC would be 288.15 .. 303.15 K"]),
    ("vertical", {"temperature_k": {"values": [20.0]}}, ["scenarios.temperature_k", "degC"]),
    ("vertical", {"payload_mass_kg": {"min": 0.5, "max": 0.7}},
     ["scenarios.payload_mass_kg", "tonnes", "500 .. 700 kg"]),
    ("vertical", {"payload_mass_kg": {"min": 0.8, "max": 1.2}},
     ["scenarios.payload_mass_kg", "fraction", "relative = [-0.2, 0.2]"]),
    ("vertical", {"payload_mass_kg": {"min": 5e5, "max": 7e5}},
     ["scenarios.payload_mass_kg", "grams"]),
    ("vertical", {"payload_mass_kg": {"min": "500", "max": 700}},
     ["scenarios.payload_mass_kg.min"]),
    ("vertical", {"payload_mass_kg": {"min": True, "max": 700}},
     ["scenarios.payload_mass_kg.min"]),
    ("vertical", {"capillary_diameter_m": {"relative": [0, 5]}},
     ["scenarios.capillary_diameter_m.relative", "fraction"]),
    ("vertical", {"diaphragm_stiffness": {"relative": [0.0, 50.0]}},
     ["scenarios.diaphragm_stiffness.relative"]),
    ("vertical", {"capillary_length_m": {"absolute": [-0.001, 5.0]}},
     ["scenarios.capillary_length_m.absolute", "mm"]),
    ("vertical", {"cg_offset_x_m": {"min": -0.05, "max": 0.05}},
     ["scenarios.cg_offset_x_m", "[table]"]),
    ("table", {"cg_offset_x_m": {"min": -50, "max": 50}},
     ["scenarios.cg_offset_x_m", "support polygon", "-50 mm would be -0.05 m"]),
    ("table", {"cg_offset_y_m": {"min": -5, "max": 5}},
     ["scenarios.cg_offset_y_m", "support polygon"]),
    ("table", {"cg_offset_x_m": {"relative": 0.05}},
     ["scenarios.cg_offset_x_m.relative", "no relative form"]),
    ("table", {"temperature_k": {"min": 15, "max": 30}}, ["scenarios.temperature_k", "degC"]),
]


@pytest.mark.parametrize("which, scen, fragments", SCENARIO_ERRORS,
                         ids=[f"{i}-{w}-{next(iter(s))}" for i, (w, s, _) in
                              enumerate(SCENARIO_ERRORS)])
def test_scenario_range_in_another_unit_refused(base, which, scen, fragments):
    raw = copy.deepcopy(base) if which == "table" else {}
    raw["scenarios"] = scen
    with pytest.raises(InputError) as exc:
        study_from_dict(raw, source="s.toml")
    for f in fragments:
        assert f in str(exc.value), str(exc.value)


@pytest.mark.parametrize("scen, key", [
    ({"payload_mass_kg": {"relative": 0.9}}, "scenarios.payload_mass_kg.relative"),
    ({"ambient_pressure_pa": {"min": 2e4, "max": 1e5}}, "scenarios.ambient_pressure_pa"),
    ({"temperature_k": {"min": 360.0, "max": 380.0}}, "scenarios.temperature_k"),
])
def test_scenario_implausible_range_warns(scen, key):
    with pytest.warns(UnitWarning, match=key.replace(".", r"\.")):
        study_from_dict({"scenarios": scen}, source="s.toml")


def test_plausible_scenarios_accepted_without_warning(base):
    raw = copy.deepcopy(base)
    raw["scenarios"] = {"payload_mass_kg": {"relative": 0.2},
                        "cg_offset_x_m": {"absolute": 0.05},
                        "temperature_k": {"min": 288.15, "max": 303.15},
                        "capillary_diameter_m": {"relative": 0.05}}
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        st = study_from_dict(raw, source="s.toml")
    assert st.scenarios.size == 4
    assert not [x for x in w if issubclass(x.category, UnitWarning)]


# -- acoustics: the model in force is the model computed ------------------------------------

DESIGN_HX = """\
volume_ratio = 1.851851851851852
top_volume_m3 = 0.00081
capillary_length_m = 0.012
capillary_diameter_m = 0.0009
piston_area_m2 = 0.0053
pressure_pa = 493000.0
chamber_heat_exchange = true
"""


@pytest.mark.parametrize("options, fragments", [
    (["--acoustics", "lumped"], ["--acoustics lumped", "chamber_heat_exchange"]),
    (["--acoustics", "distributed", "--flow", "zhao"], ["--acoustics distributed",
                                                       "--flow zhao"]),
    (["--acoustics", "distributed", "--flow", "zhao_turbulent"], ["--flow zhao_turbulent"]),
    (["--flow", "poiseuille"], ["--flow poiseuille", "chamber_heat_exchange"]),
])
def test_stiffness_acoustics_refused_naming_both(tmp_path, capsys, options, fragments):
    design = tmp_path / "d.toml"
    design.write_text(DESIGN_HX)
    out = tmp_path / "k.csv"
    rc = main(["stiffness", str(design), "--freq", "1,10", "--amplitude", "1um", "-o", str(out),
               *options])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("isodesign: error: "), err
    for f in fragments:
        assert f in err[0]
    assert not out.exists()


def test_design_file_lumped_with_heat_exchange_warns(tmp_path):
    from isodesign.errors import ModelValidityWarning
    from isodesign.io.designfile import load_design

    p = tmp_path / "d.toml"
    p.write_text(DESIGN_HX + 'acoustics = "lumped"\n')
    with pytest.warns(ModelValidityWarning, match=r"acoustics = \"lumped\" with "
                      "chamber_heat_exchange"):
        load_design(p)


def test_stiffness_of_a_lumped_design_file_with_heat_exchange_is_one_line(tmp_path, capsys):
    """The file's warning and the refusal said the same thing twice: one line (the error)."""
    design = tmp_path / "d.toml"
    design.write_text(DESIGN_HX + 'acoustics = "lumped"\n')
    out = tmp_path / "k.csv"
    rc = main(["stiffness", str(design), "--freq", "1,10", "--amplitude", "1um", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("isodesign: error: "), err
    assert "acoustics = 'lumped'" in err[0] and "chamber_heat_exchange" in err[0]
    assert not out.exists()
    # --acoustics distributed computes the heat exchange: the file's warning is moot
    rc = main(["stiffness", str(design), "--freq", "1,10", "--amplitude", "1um", "-o", str(out),
               "--acoustics", "distributed"])
    err = capsys.readouterr().err
    assert rc == 0 and "chamber_heat_exchange" not in err, err


@pytest.mark.parametrize("study, fragments", [
    ({"models": {"acoustics": "lumped"}, "hardware": {"chamber_heat_exchange": True}},
     ["models.acoustics", "hardware.chamber_heat_exchange"]),
    ({"models": {"acoustics": "distributed", "flow": "poiseuille"}},
     ["models.acoustics", "models.flow"]),
    ({"models": {"flow": "poiseuille"}, "hardware": {"chamber_heat_exchange": True}},
     ["models.flow", "hardware.chamber_heat_exchange"]),
])
def test_study_acoustics_refused_naming_both(study, fragments):
    with pytest.raises(InputError) as exc:
        study_from_dict(study, source="s.toml")
    for f in fragments:
        assert f in str(exc.value)


def test_study_lumped_flow_recorded_as_lumped():
    from isodesign.optimization.study import vertical_study

    st = study_from_dict({"models": {"flow": "poiseuille"}}, source="s.toml")
    assert st.models["acoustics"] == "lumped" == st.raw["models"]["acoustics"]
    assert st.start_design().acoustics == "lumped"
    with pytest.raises(InputError, match=r"models\.flow"):
        st.with_changes(models={"acoustics": "distributed"})
    hx = vertical_study().with_changes(hardware={"chamber_heat_exchange": True})
    with pytest.raises(InputError, match=r"hardware\.chamber_heat_exchange"):
        hx.with_changes(models={"acoustics": "lumped"})


# -- yield: a run's robust.json read as input -----------------------------------------------
@pytest.mark.parametrize("content, fragments", [
    (b'{"feasible": true}', ["robust.json: values", "expected a table"]),
    (b'{"feasible": true, "values": {"volume_ratio": 2.0}}', ["values: missing",
                                                              "top_volume_m3"]),
    (b'{"feasible": true, "values": {"volume_ratio": "2", "top_volume_m3": 8e-4, '
     b'"capillary_length_m": 0.012, "capillary_diameter_m": 9e-4}}',
     ["values: volume_ratio", "number"]),
    (b'{"feasible": tru', ["robust.json file", "malformed JSON"]),
    (bytes(range(256)), ["robust.json file", "UTF-8"]),
    (b"[1, 2]", ["robust.json file", "JSON object"]),
])
def test_yield_of_a_run_with_a_broken_robust_json_is_one_line(tmp_path, capsys, content,
                                                              fragments):
    run = tmp_path / "run"
    run.mkdir()
    (run / "robust.json").write_bytes(content)
    study = tmp_path / "s.toml"
    study.write_text("[scenarios]\npayload_mass_kg = {relative = 0.1}\n")
    out = tmp_path / "y"
    rc = main(["yield", str(run), "--study", str(study), "--samples", "10", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("isodesign: error: "), err
    for f in fragments:
        assert f in err[0], err[0]
    assert not out.exists()


# -- codec and JSON messages name the file and key -----------------------------------------
FLOOR_X = TABLE_TOML + 'cg_m = [0.0, 0.0, 0.35]\n[floor]\ncriterion = "VC-A"\n[floor.x]\n'


@pytest.mark.parametrize("case, fragments", [
    ("points_binary", ["--points-file", "not a UTF-8 text file"]),
    ("points_latin1", ["--points-file", "not a UTF-8 text file"]),
    # the key as the user typed it: floor.x.csv, not "[floor.x]: floor.csv"
    ("floor_x_csv_number", ["floor.x.csv must be a file name"]),
    ("floor_x_record_binary", ["floor.x.record", "not a UTF-8 text file"]),
    ("floor_x_csv_binary", ["floor.x.csv", "bin.csv"]),
    ("run_record_list", ["record.json", "JSON object"]),
    ("run_record_binary", ["record.json", "cannot read the run record"]),
])
def test_codec_and_json_errors_name_the_file(tmp_path, capsys, case, fragments):
    (tmp_path / "bin.csv").write_bytes(bytes(range(256)) * 4)
    (tmp_path / "lat.csv").write_bytes("payload.mass_kg\n5\xe9\n".encode("latin-1"))
    study = tmp_path / "s.toml"
    out = tmp_path / "out"
    if case.startswith("points"):
        f = "bin.csv" if case == "points_binary" else "lat.csv"
        argv = ["sweep", "--points-file", str(tmp_path / f), "--scheduler", "serial", "-o",
                str(out)]
    elif case.startswith("floor_x"):
        line = {"floor_x_csv_number": "csv = 5", "floor_x_record_binary": 'record = "bin.csv"',
                "floor_x_csv_binary": 'csv = "bin.csv"'}[case]
        study.write_text(FLOOR_X + line + "\n")
        argv = ["modes", str(study), "-o", str(out)]
    else:
        run = tmp_path / "run"
        run.mkdir()
        (run / "record.json").write_bytes(b"[1, 2]" if case == "run_record_list"
                                          else b"\xff\xfe{")
        argv = ["modes", str(run), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("isodesign: error: "), err
    for f in fragments:
        assert f in err[0], err[0]
    assert "internal error" not in err[0] and "[floor.x]: floor." not in err[0]
    assert not out.exists()
