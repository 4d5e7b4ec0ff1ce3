"""Hostile and mistaken inputs on the co-design surfaces (issue 23): the levers of
``[variables.<lever>]``, the layout's constraints, per-group springs and the Python calls
that take lever values. Each is refused where the study is read (an InputError naming the
key as the user typed it and its range) or warned as a unit slip, never run as another
question. Every study here is the built-in table study, ``table_study()``, changed."""

from __future__ import annotations

import copy

import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.optimization.study import default_study, table_study
from isodesign.optimization.yields import estimate_yield

V = "variables."
LAYOUT_FREE = {V + "layout_length_m": {"fixed": False}, V + "layout_width_m": {"fixed": False}}

# (changes, fragments every one of which the message holds)
REFUSED = [
    # a fixed horizontal lever outside its element's physical range (it built the table
    # only when a problem was made, or never: a negative loss factor ran)
    ({V + "pendulum_length_m": {"fixed": True, "start": -0.1}},
     ["variables.pendulum_length_m.start = -0.1", "> 0 m"]),
    ({V + "pendulum_length_m": {"fixed": True, "start": 0.0}},
     ["variables.pendulum_length_m.start", "> 0 m"]),
    ({V + "lateral_stiffness_n_per_m": {"fixed": True, "start": -100.0}},
     ["variables.lateral_stiffness_n_per_m.start = -100", ">= 0"]),
    ({V + "lateral_loss_factor": {"fixed": True, "start": -0.1}},
     ["variables.lateral_loss_factor.start = -0.1", ">= 0"]),
    # a footprint of TOML strings was read as numbers
    ({"constraints.footprint_m": [["-0.75", "-0.5"], ["0.75", "0.5"]]},
     ["constraints.footprint_m", "[[x_min, y_min], [x_max, y_max]]"]),
    # a fixed layout that breaks its own footprint or distance: refused when read (every
    # entry point, a sweep before it runs), not by the optimizer alone
    ({"constraints.footprint_m": [[-0.3, -0.2], [0.3, 0.2]]},
     ["table.toml: constraints.footprint_m: isolator 1 (from 1)", "layout is fixed"]),
    ({"constraints.min_isolator_distance_m": 1.0},
     ["table.toml: constraints.min_isolator_distance_m: isolators 1 and 4 (from 1)",
      "layout is fixed"]),
    ({"constraints.min_isolator_distance_m": 1.0, V + "layout_length_m": {"fixed": True,
                                                                          "start": 1.5}},
     ["constraints.min_isolator_distance_m", "below 1 m"]),
    # a group's own capillary against min_capillary_diameter_m, as the shared one's
    ({V + "capillary_diameter_m_group2": {"start": 0.2e-3}},
     ["variables.capillary_diameter_m_group2 is fixed at 0.0002 m",
      "constraints.min_capillary_diameter_m (0.0003 m)"]),
    ({V + "capillary_diameter_m_group2": {"fixed": False, "lower": 0.31e-3, "upper": 0.35e-3,
                                          "start": 0.32e-3},
      "constraints.min_capillary_diameter_m": 0.4e-3},
     ["variables.capillary_diameter_m_group2.upper (0.00035 m)",
      "must exceed constraints.min_capillary_diameter_m"]),
    ({"table.group_springs": [{}, {}, {"capillary_diameter_m": 0.2e-3}]},
     ["table.group_springs: group 3: capillary_diameter_m is fixed at 0.0002 m",
      "min_capillary_diameter_m"]),
    # the rocking band reversed
    ({"constraints.min_rocking_frequency_hz": 5.0, "constraints.max_rocking_frequency_hz": 2.0},
     ["constraints.min_rocking_frequency_hz must be below max_rocking_frequency_hz",
      "5 >= 2 Hz"]),
]


@pytest.mark.parametrize("changes, fragments", REFUSED,
                         ids=[f[0].split(" ")[0] + f"-{i}" for i, (_, f) in enumerate(REFUSED)])
def test_codesign_input_refused_naming_the_key(refused_naming, changes, fragments):
    refused_naming(changes, fragments)


def test_a_free_layout_within_its_footprint_is_accepted(changed_table_study):
    st = changed_table_study({**LAYOUT_FREE, "constraints.footprint_m": [[-0.75, -0.5],
                                                                       [0.75, 0.5]],
                            "constraints.min_isolator_distance_m": 0.5})
    assert [v.name for v in st.levers if v.free] == ["layout_length_m", "layout_width_m"]


WARNED = [
    ({"constraints.supply_margin_pa": 50.0},
     ["constraints.supply_margin_pa = 50", "kPa", "50000 Pa"]),
    ({V + "capillary_diameter_m_group2": {"start": 0.9}},
     ["variables.capillary_diameter_m_group2.start = 0.9", "mm", "0.0009 m"]),
    ({"table.group_springs": [{}, {"capillary_diameter_m": 0.9}, {}]},
     ["table.group_springs: group 2: capillary_diameter_m = 0.9", "0.0009 m"]),
]


@pytest.mark.parametrize("changes, fragments", WARNED, ids=["supply_margin_kpa",
                                                            "group_lever_mm", "group_springs_mm"])
def test_codesign_unit_slip_warns_naming_the_key(warned_naming, changes, fragments):
    warned_naming(changes, fragments)


@pytest.fixture(scope="module")
def robust_table():
    return table_study().with_changes(
        {"scenarios": {"payload_mass_kg": {"min": 500.0, "max": 700.0},
                       "cg_offset_x_m": {"absolute": 0.05}}})


def _values(st):
    return {v.name: v.start for v in st.variables}


# (call, fragments): the Python calls that take lever values, scenarios and counts
API = [
    (lambda r: isodesign.analyze(r, None, ["600", "0"]), ["scenario: expected 2 numbers"]),
    (lambda r: isodesign.analyze(r, None, [True, False]), ["scenario: expected 2 numbers"]),
    (lambda r: isodesign.analyze(table_study(), bands=(80.0, 4.0)),
     ["bands: expected (f_min_hz, f_max_hz)", "(80.0, 4.0)"]),
    (lambda r: isodesign.analyze(table_study(), bands=(4.0, 8.0, 16.0)), ["bands: expected"]),
    (lambda r: isodesign.analyze(table_study(), strict="no"), ["strict: expected True or"]),
    (lambda r: isodesign.analyze(default_study(), {"pendulum_length_m": 150.0}),
     ["values['pendulum_length_m'] = 150", "mm", "0.15 m"]),
    (lambda r: isodesign.analyze(
        table_study().with_changes({"variables.volume_ratio_group2.fixed": False}),
        {"volume_ratio_group2": -2.0}),
     ["values['volume_ratio_group2'] = -2", "domain"]),
    (lambda r: default_study().table_at({"pendulum_lenght_m": 0.2}),
     ["values: unknown name 'pendulum_lenght_m'", "pendulum_length_m"]),
    (lambda r: default_study().with_levers_fixed(  # every free lever given, and a typo
        {**{v.name: v.start for v in default_study().levers if v.free},
         "lateral_los_factor": 0.3}), ["values: unknown name 'lateral_los_factor'"]),
    (lambda r: table_study().variable("pendulum_lenght_m"),
     ["name: unknown design variable 'pendulum_lenght_m'", "pendulum_length_m"]),
    (lambda r: isodesign.optimize(table_study(), analyze="no"), ["analyze: expected true"]),
    (lambda r: isodesign.pareto_front(table_study(), points=10**9),
     ["points: must be an integer >= 2 and <= 500"]),
    (lambda r: estimate_yield(r, _values(r), samples=4,
                                                            workers=-2),
     ["workers: must be an integer in [1, 64]"]),
    (lambda r: estimate_yield(r, _values(r), samples=4,
                                                            seed=-1),
     ["seed: must be an integer >= 0"]),
    (lambda r: estimate_yield(r, _values(r), samples=4,
                                                            confidence="95%"),
     ["confidence: must be in (0, 1)"]),
]
API_IDS = ["scenario_strings", "scenario_bools", "bands_reversed", "bands_three",
           "strict_string", "lever_mm", "group_lever_negative", "table_at_typo",
           "with_levers_fixed_typo", "variable_typo",
           "optimize_analyze_string", "pareto_points_huge", "yield_workers", "yield_seed",
           "yield_confidence"]


@pytest.mark.parametrize("call, fragments", API, ids=API_IDS)
def test_api_refuses_naming_the_argument(robust_table, call, fragments):
    with pytest.raises(InputError) as err:
        call(robust_table)
    msg = str(err.value)
    for f in fragments:
        assert f in msg


def test_variable_finds_a_lever():
    st = default_study()
    assert st.variable("pendulum_length_m").free
    assert st.variable("volume_ratio").name == "volume_ratio"


@pytest.mark.parametrize("command, inside", [
    (["modes", "--builtin", "table"], "points"),
    (["stability", "--builtin", "table"], "points"),
    (["modes", "--builtin", "table"], "points/0123456789abcdef"),
    (["optimize", "--builtin", "table"], "charts"),
])
def test_no_command_writes_inside_a_sweeps_directory(tmp_path, capsys, command, inside):
    """``modes -o SWEEP/points --overwrite`` wrote a run among the sweep's points (issue
    23: a sweep directory is the sweep's whole): one line naming --output, nothing
    written."""
    import json

    from isodesign.cli import main

    sweep = tmp_path / "sweep"
    (sweep / "points" / "0123456789abcdef").mkdir(parents=True)
    (sweep / "record.json").write_text(json.dumps({"kind": "isodesign sweep",
                                                   "run_status": "complete"}))
    (sweep / "points" / "0123456789abcdef" / "record.json").write_text(
        json.dumps({"kind": "isodesign optimize", "run_status": "complete"}))
    before = sorted(str(p) for p in sweep.rglob("*"))
    assert main([*command, "-o", str(sweep / inside), "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("isodesign: error: --output: "), err
    assert "isodesign sweep" in err[0]
    assert sorted(str(p) for p in sweep.rglob("*")) == before


SCENARIOS = {"payload_mass_kg": {"min": 480.0, "max": 720.0}, "cg_offset_x_m": {"absolute": 0.05}}


def test_a_robust_table_with_free_levers_is_refused_before_the_nominal(monkeypatch, tmp_path):
    """The co-designed default study with [scenarios]: the nominal co-design ran for minutes
    before the robust optimizer refused the free levers; a sweep ran every point so. Both
    refuse first, naming the lever's key."""
    import isodesign.optimization.table_driver as table_optimize

    monkeypatch.setattr(table_optimize, "optimize_table",
                        lambda *a, **k: pytest.fail("the nominal optimum ran"))
    st = default_study().with_changes({"scenarios": SCENARIOS})
    with pytest.raises(InputError, match=r"variables\.pendulum_length_m\.fixed: robust design"):
        isodesign.optimize(st)
    with pytest.raises(InputError, match=r"variables\.pendulum_length_m\.fixed: robust design"
                                         r".*\(at the point payload\.mass_kg=600"):
        isodesign.sweep(st, {"payload.mass_kg": [600.0]}, output=str(tmp_path / "sweep"))
    assert not (tmp_path / "sweep").exists()


@pytest.fixture(scope="module")
def table_run(tmp_path_factory):
    """A table optimize run (one start), written by the command line."""
    from isodesign.cli import main

    out = tmp_path_factory.mktemp("run") / "opt"
    assert main(["optimize", "--builtin", "table", "--starts", "1", "--no-plots", "--quiet",
                 "-o", str(out)]) == 0
    return out


def _robust_table_file(tmp_path):
    from isodesign.io.record import dumps_toml

    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = SCENARIOS
    p = tmp_path / "robust_table.toml"
    p.write_text(dumps_toml(raw))
    return p


@pytest.mark.parametrize("argv", [
    ["yield", "{run}", "--study", "{robust}", "--samples", "4", "-o", "{run}", "--overwrite"],
    ["yield", "{run}/design.toml", "--study", "{robust}", "--samples", "4", "-o", "{run}",
     "--overwrite"],
    ["modes", "{run}", "-o", "{run}", "--overwrite"],
    ["stability", "{run}", "-o", "{run}", "--overwrite"],
], ids=["yield_run", "yield_design_file", "modes", "stability"])
def test_a_command_never_overwrites_the_run_it_reads(table_run, tmp_path, capsys, argv):
    """``yield RUN -o RUN --overwrite`` replaced the optimize run by its yield (no design
    left: every later command failed on it): one line naming --output, the run untouched."""
    from isodesign.cli import main

    robust = _robust_table_file(tmp_path)
    before = {p.name: p.read_bytes() for p in table_run.iterdir() if p.is_file()}
    args = [a.format(run=table_run, robust=robust) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--output: " in err[0] and "its own input" in err[0], err
    assert {p.name: p.read_bytes() for p in table_run.iterdir() if p.is_file()} == before


@pytest.mark.parametrize("inputs, study, fragments", [
    (["{run}"], "{robust}", ["--study: the job of a design file only", "optimize input"]),
    (["{robust}"], None, ["robust_table.toml: [scenarios]: the report of a design or study "
                          "file is its nominal response"]),
    (["{run}/design.toml"], "{robust}", ["--study: [scenarios]"]),
], ids=["study_with_a_run", "robust_study_file", "design_with_a_robust_study"])
def test_report_never_answers_nominal_for_a_robust_or_ignored_study(table_run, tmp_path, capsys,
                                                                     inputs, study, fragments):
    """``report RUN --study robust.toml`` ignored the study without a word; a study file
    or a design judged by a study with [scenarios] got the nominal verdict."""
    from isodesign.cli import main

    robust = _robust_table_file(tmp_path)
    fmt = {"run": table_run, "robust": robust}
    argv = ["report", *(i.format(**fmt) for i in inputs), "-o", str(tmp_path / "r.html")]
    if study:
        argv += ["--study", study.format(**fmt)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    for f in fragments:
        assert f in err[0]
    assert not (tmp_path / "r.html").exists()


@pytest.mark.parametrize("content, fragments", [
    (b"payload.mass_kg,payload.mass_kg\n600,700\n", ["the header names payload.mass_kg twice"]),
    (b"payload.mass_kg;floor.criterion\n600;VC-A\n", ["one cell", "commas, not semicolons"]),
], ids=["column_twice", "semicolons"])
def test_a_points_csv_that_would_be_misread_is_refused(tmp_path, content, fragments):
    """A key named twice (which value would the point take?) ran silently; a spreadsheet's
    semicolon CSV gave an unknown-key message."""
    from isodesign.sweeps.spec import read_points

    p = tmp_path / "points.csv"
    p.write_bytes(content)
    with pytest.raises(InputError) as err:
        read_points(p)
    for f in fragments:
        assert f in str(err.value)


def test_a_points_csv_saved_with_a_byte_order_mark_is_read():
    """A spreadsheet's UTF-8 CSV starts with a BOM: its first key was '\\ufeffpayload...'."""
    import tempfile
    from pathlib import Path

    from isodesign.sweeps.spec import read_points

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "points.csv"
        p.write_bytes("\ufeffpayload.mass_kg,floor.criterion\n600,VC-B\n".encode())
        assert read_points(p) == [{"payload.mass_kg": 600, "floor.criterion": "VC-B"}]


@pytest.mark.parametrize("changes, fragments", [
    ({V + "pendulum_lenght_m": {"fixed": False}},
     ["unknown key 'pendulum_lenght_m' in [variables] (did you mean 'pendulum_length_m'?)"]),
    ({V + "Layout_Width_m": {"fixed": False}}, ["(did you mean 'layout_width_m'?)"]),
    ({"constraints.footprint": [[-0.75, -0.5], [0.75, 0.5]]},
     ["unknown key 'footprint' in [constraints] (did you mean 'footprint_m'?)"]),
    ({"constraints.min_isolator_distance": 0.5}, ["(did you mean 'min_isolator_distance_m'?)"]),
    ({"table.group_spring": [{}, {}, {}]},
     ["unknown key 'group_spring' in [table] (did you mean 'group_springs'?)"]),
    ({"table.horizontal.pendulum": 0.2},
     ["unknown key 'pendulum' in [table.horizontal] (did you mean 'pendulum_length_m'?)"]),
    ({V + "volume_ratio_group2": {"fixd": False}},
     ["unknown key 'fixd' in [variable] (did you mean 'fixed'?)"]),
    ({"constraints.bogus_key": 1.0}, ["unknown key 'bogus_key' in [constraints]; valid: "]),
], ids=["lever", "layout_case", "footprint", "min_distance", "group_springs", "horizontal",
        "variable_field", "no_close_key"])
def test_an_unknown_key_suggests_the_closest(changed_table_study, changes, fragments):
    with pytest.raises(InputError) as err:
        changed_table_study(changes)
    for f in fragments:
        assert f in str(err.value)
    if "bogus_key" in fragments[0]:  # nothing close: no guess
        assert "did you mean" not in str(err.value)


def test_a_co_designed_layout_on_its_footprint_bound_is_read_again():
    """The fixed layout's check when a study is read keeps a solver's tolerance: an optimum
    on the footprint (1e-7 m outside, as IPOPT may end) fixed by ``with_levers_fixed`` (what
    ``report``, ``modes`` and ``response`` of a run read) loads; 0.1 mm outside is refused
    with the study's own bounds."""
    st = table_study().with_changes({"variables.layout_length_m.fixed": False,
                                     "variables.layout_length_m.upper": 1.6,
                                     "constraints.footprint_m": [[-0.75, -0.5], [0.75, 0.5]],
                                     "constraints.min_isolator_distance_m": 0.8})
    fixed = st.with_levers_fixed({"layout_length_m": 1.5 + 2e-7})
    assert fixed.table.isolators_m[0, 0] == pytest.approx(-0.75, abs=1e-6)
    with pytest.raises(InputError, match=r"constraints\.footprint_m: isolator 1 \(from 1\) at "
                                         r"\(-0\.75, -0\.4\) m lies outside the footprint x "
                                         r"-0\.75\.\.0\.75 m"):
        st.with_levers_fixed({"layout_length_m": 1.5 + 1e-4})


def test_a_group_capillary_optimum_on_the_minimum_diameter_is_read_again():
    """A group's capillary free down to min_capillary_diameter_m, fixed at an optimum on it
    (IPOPT relaxes bounds by 1e-8): loads; 1 % below is refused."""
    st = table_study().with_changes({V + "capillary_diameter_m_group2": {"fixed": False}})
    dmin = st.constraints["min_capillary_diameter_m"]
    free = [v.name for v in st.levers if v.free]
    assert free == ["capillary_diameter_m_group2"]
    fixed = st.with_levers_fixed({"capillary_diameter_m_group2": dmin * (1 - 1e-8)})
    assert fixed.table.group_springs[1]["capillary_diameter_m"] == pytest.approx(dmin)
    with pytest.raises(InputError, match=r"variables\.capillary_diameter_m_group2 is fixed at"):
        st.with_levers_fixed({"capillary_diameter_m_group2": dmin * 0.99})


HUGE = 10**400  # a Python integer no float holds (TOML integers are 64-bit; the API takes any)


@pytest.mark.parametrize("call, fragment", [
    (lambda: table_study().with_changes(
        {V + "lateral_stiffness_n_per_m": {"fixed": False, "upper": HUGE}}),
     "variables.lateral_stiffness_n_per_m.upper: expected a finite number, got an integer of "
     "401 digits"),
    (lambda: table_study().with_changes({V + "layout_length_m": {"fixed": False,
                                                                 "upper": HUGE}}),
     "variables.layout_length_m.upper"),
    (lambda: table_study().with_changes({"constraints.footprint_m": [[-HUGE, -1], [1, 1]]}),
     "constraints.footprint_m"),
    (lambda: table_study().with_changes({V + "volume_ratio_group2": {"fixed": False,
                                                                     "upper": HUGE}}),
     "variables.volume_ratio_group2.upper"),
    (lambda: table_study().with_changes({"table.group_springs": [{}, {"volume_ratio": HUGE},
                                                                 {}]}),
     "table.group_springs: group 2: volume_ratio"),
    (lambda: isodesign.analyze(table_study(), {"volume_ratio": HUGE}),
     "values['volume_ratio']: expected a finite number"),
    (lambda: isodesign.analyze(default_study(), {"pendulum_length_m": HUGE}),
     "values['pendulum_length_m']"),
    (lambda: default_study().table_at({"pendulum_length_m": HUGE}),
     "values['pendulum_length_m']: expected a finite number"),
], ids=["lever", "layout", "footprint", "group_lever", "group_springs", "analyze_variable",
        "analyze_lever", "table_at"])
def test_a_huge_integer_is_an_input_error_naming_the_key(call, fragment):
    """A 400-digit integer ended in a raw OverflowError (float conversion)."""
    with pytest.raises(InputError) as err:
        call()
    assert fragment in str(err.value)


def test_a_huge_integer_scenario_is_an_input_error(robust_table):
    with pytest.raises(InputError, match=r"^scenario: expected 2 numbers"):
        isodesign.analyze(robust_table, None, [HUGE, 0])


@pytest.mark.parametrize("lever", [
    {"pendulum_length_m": {"fixed": True, "start": 0.4}},
    {"layout_length_m": {"fixed": True, "start": 1.5}},
], ids=["pendulum", "layout"])
def test_response_answers_the_table_with_its_fixed_levers(tmp_path, capsys, lever):
    """A lever fixed at a value other than [table.horizontal]'s (or the isolators' extent):
    ``isodesign response`` answered the table as written (-8.25 dB) while isodesign.analyze
    and the optimizer used the lever (-4.47 dB with the pendulum at 0.4 m). Both now answer
    the table with the lever, to 1e-9 dB."""
    import pandas as pd

    from isodesign.cli import main
    from isodesign.io.record import dumps_toml

    raw = copy.deepcopy(table_study().raw)
    raw["variables"].update(copy.deepcopy(lever))
    study_file = tmp_path / "lever.toml"
    study_file.write_text(dumps_toml(raw))
    st = isodesign.load_study(study_file)
    want = isodesign.analyze(st).worst_margin_db
    assert abs(want - isodesign.analyze(table_study()).worst_margin_db) > 0.1  # another table
    out = tmp_path / "bands.csv"
    assert main(["response", str(study_file), "-o", str(out)]) == 0
    capsys.readouterr()
    frame = pd.read_csv(out)
    got = frame[frame["band_hz"].between(4.0, 80.0)]["margin_db"].min()
    assert got == pytest.approx(want, abs=1e-9)


def test_yield_of_a_co_designed_run_refuses_a_study_with_other_lever_values(table_run,
                                                                           tmp_path, capsys):
    """``yield RUN --study robust.toml`` of a co-designed run read the spring from
    design.toml and dropped the run's levers: the draws judged the study's table (its
    pendulum at 0.15 m) instead of the optimum's (0.4 m), and said "yield of optimum of
    RUN". Refused naming the lever and the run's value; the same study with the lever fixed
    at the run's value is judged."""
    import json
    import shutil

    from isodesign.cli import main

    run = tmp_path / "codesigned"
    shutil.copytree(table_run, run)
    dj = json.loads((run / "design.json").read_text())
    dj["variables"]["pendulum_length_m"] = {"value": 0.4, "lower": 0.05, "upper": 0.4,
                                            "fixed": False}
    (run / "design.json").write_text(json.dumps(dj))
    robust = _robust_table_file(tmp_path)
    assert main(["yield", str(run), "--study", str(robust), "--samples", "2", "-o",
                 str(tmp_path / "y1")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--study: variables.pendulum_length_m is fixed at 0.15" in err[0]
    assert "pendulum_length_m = 0.4" in err[0] and not (tmp_path / "y1").exists()
    robust.write_text(robust.read_text() + "\n[variables.pendulum_length_m]\nfixed = true\n"
                      "start = 0.4\n")
    assert main(["yield", str(run), "--study", str(robust), "--samples", "2", "--no-plots",
                 "-o", str(tmp_path / "y2")]) in (0, 1)
    assert (tmp_path / "y2" / "yield.json").is_file()


def test_no_sweep_is_written_inside_another_sweeps_directory(tmp_path):
    """``sweep -o SWEEP/inner`` nested a sweep among another's points and table."""
    import json

    outer = tmp_path / "sweep"
    outer.mkdir()
    (outer / "record.json").write_text(json.dumps({"kind": "isodesign sweep",
                                                   "run_status": "complete"}))
    with pytest.raises(InputError, match=r"^--output: .*inner is inside the directory of a run "
                                         r"that owns it whole \(isodesign sweep"):
        isodesign.sweep(table_study(), {"payload.mass_kg": [600.0]}, task="response",
                        output=str(outer / "inner"))
    assert sorted(p.name for p in outer.iterdir()) == ["record.json"]
