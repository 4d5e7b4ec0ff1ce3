"""Hostile and mistaken inputs found by the held-out-style probe of issue 23 (second pass):
each is refused where it is read (an InputError naming the key or option as typed, exit 2
and one stderr line on the command line) or warned as a unit slip naming it. The studies
are the built-in table study, ``table_study()``, changed."""

from __future__ import annotations

import warnings
from importlib import resources

import pytest

from isodesign.cli import main
from isodesign.errors import InputError
from isodesign.io.plausible import UnitWarning

# (changes, fragments every one of which the message holds)
REFUSED = [
    # no isolator at all, and a flat list of coordinates: blamed on leveling_groups before
    ({"table.isolators_m": []}, ["table.toml: table.isolators_m", "at least 3 [x, y]"]),
    ({"table.isolators_m": [-0.6, -0.4, 0.6, -0.4, 0.6, 0.4, -0.6, 0.4]},
     ["table.toml: table.isolators_m", "at least 3 [x, y]"]),
    # one diaphragm radius without the other: the message had no file and no table
    ({"hardware.diaphragm_r1_m": 0.04},
     ["table.toml: hardware.diaphragm_r2_m", "diaphragm_r1_m and diaphragm_r2_m go together"]),
    # an option another objective reads: a string or a negative frequency passed unread
    ({"objective": {"kind": "total_volume", "frequency_hz": "5"}},
     ["table.toml: objective.frequency_hz must be a number, got '5'"]),
    ({"objective": {"kind": "worst_band_margin", "band_min_hz": -1.0}},
     ["table.toml: objective.band_min_hz: must be in (0, inf] Hz, got -1"]),
]


@pytest.mark.parametrize("changes, fragments", REFUSED, ids=[
    "isolators_empty", "isolators_flat", "diaphragm_r1_alone", "objective_option_string",
    "objective_option_negative"])
def test_refused_naming_the_key(refused_naming, changes, fragments):
    refused_naming(changes, fragments)


WARNED = [
    # a stroke of 5 m: millimetres typed as metres
    ({"constraints.max_stroke_m": 5.0},
     ["constraints.max_stroke_m = 5", "plausible range", "0.005 m"]),
    # a leveling valve's dead band of 5 m
    ({"table.leveling": {"dead_band_m": 5.0}},
     ["table.leveling.dead_band_m = 5", "plausible range", "0.005 m"]),
]


@pytest.mark.parametrize("changes, fragments", WARNED, ids=["max_stroke_mm", "dead_band_mm"])
def test_unit_slip_warns_naming_the_key(warned_naming, changes, fragments):
    warned_naming(changes, fragments)


def _cli(capsys, argv):
    status = main(argv)
    out, err = capsys.readouterr()
    return status, out, [ln for ln in err.splitlines() if ln.strip()]


CLI_REFUSED = [
    # a key given twice: the parser's message named the line and column only
    (["optimize", "{dup}", "-o", "{out}"], ["dup.toml", "malformed TOML", "line 3",
                                             "'mass_kg = 700'"]),
    # a diaphragm table that cannot be read: the message named no option
    (["transmissibility", "--diaphragm", "table:{missing}", "-o", "{out}.csv"],
     ["--diaphragm:", "cannot read"]),
    # the paper's flow model with the default amplitude mode: named the library argument
    (["transmissibility", "--flow", "zhao", "--acoustics", "lumped", "-o", "{out}.csv"],
     ["--amplitude-mode: 'self_consistent' is not defined for flow='zhao'"]),
    (["stiffness", "--flow", "zhao", "-o", "{out}.csv"], ["--amplitude-mode: 'self_consistent'"]),
    (["response", "--flow", "zhao", "-o", "{out}.csv"], ["--amplitude-mode: 'self_consistent'"]),
    # --acoustics lumped over a study with the chambers' heat exchange: named the study only
    (["optimize", "{heat}", "--acoustics", "lumped", "-o", "{out}"],
     ["--acoustics lumped: ", "heat.toml: models.acoustics = \"lumped\"",
      "chamber_heat_exchange"]),
]


@pytest.mark.parametrize("argv, fragments", CLI_REFUSED, ids=[
    "toml_duplicate_key", "diaphragm_missing", "transmissibility_zhao_amplitude_mode",
    "stiffness_zhao_amplitude_mode", "response_zhao_amplitude_mode", "acoustics_over_study"])
def test_cli_refuses_in_one_line_naming_it(tmp_path, capsys, argv, fragments):
    (tmp_path / "dup.toml").write_text("[payload]\nmass_kg = 600\nmass_kg = 700\n")
    (tmp_path / "heat.toml").write_text(
        (resources.files("isodesign") / "data" / "table_study.toml").read_text()
        + "\n[hardware]\nchamber_heat_exchange = true\n")
    names = {"dup": str(tmp_path / "dup.toml"), "out": str(tmp_path / "out"),
             "heat": str(tmp_path / "heat.toml"),
             "missing": str(tmp_path / "missing.csv")}
    status, _out, err = _cli(capsys, [a.format(**names) for a in argv])
    assert status == 2
    assert len(err) == 1 and err[0].startswith("isodesign: error: "), err
    for f in fragments:
        assert f in err[0]
    assert not (tmp_path / "out").exists()


CLI_WARNED = [
    (["--floor-amplitude", "5"], ["--floor-amplitude 5 m", "5um or 5mm"]),
    (["--payload-kg", "0.6"], ["--payload-kg 0.6 on 4 isolators", "0.6 t would be 600 kg"]),
]


@pytest.mark.parametrize("argv, fragments", CLI_WARNED, ids=["floor_amplitude_m",
                                                             "payload_tonnes"])
def test_cli_warns_of_a_unit_slip_naming_the_option(tmp_path, capsys, argv, fragments):
    status, _out, err = _cli(capsys, ["transmissibility", *argv, "--freq", "1:50:5",
                                      "-o", str(tmp_path / "t.csv")])
    assert status == 0
    warned = [ln for ln in err if ln.startswith("isodesign: warning: --")]
    assert any(all(f in ln for f in fragments) for ln in warned), err


@pytest.mark.parametrize("status", ["interrupted", "failed"])
@pytest.mark.parametrize("command", ["report", "modes"])
def test_a_run_that_did_not_finish_is_not_called_infeasible(tmp_path, capsys, builtin_table_run,
                                                            status, command):
    # the set-aside directory of an interrupted (or failed) optimize run: the message said
    # "the optimize run found no feasible design"
    import json
    import shutil

    _printed, run = builtin_table_run
    cut = tmp_path / f"o.{status}"
    shutil.copytree(run, cut)
    rec = json.loads((cut / "record.json").read_text())
    rec.update(run_status=status, feasible=False)
    (cut / "record.json").write_text(json.dumps(rec))
    (cut / "design.toml").unlink()
    out = tmp_path / ("r.html" if command == "report" else "m")
    code, _out, err = _cli(capsys, [command, str(cut), "-o", str(out)])
    assert code == 2 and len(err) == 1, err
    assert f"the optimize run was {status} (run_status {status})" in err[0]
    assert "no feasible design" not in err[0]
    assert not out.exists()


# robust table scenarios whose corner no valve can level: found after the nominal optimum
# (15 s), and named table.leveling_groups / table.supply_pressure_pa, not the scenario key
UNLEVELABLE = [
    ({"cg_offset_x_m": {"absolute": 0.35}},
     ["scenarios.cg_offset_x_m: the offset (-0.35, 0) m", "triangle of the leveling groups'",
      "valid: scenarios.cg_offset_x_m within (-0.3, 0.3) m"]),
    ({"cg_offset_x_m": {"absolute": 0.2}, "cg_offset_y_m": {"absolute": 0.2}},
     ["scenarios.cg_offset_x_m and scenarios.cg_offset_y_m", "triangle"]),
    ({"payload_mass_kg": {"min": 500.0, "max": 1400.0}},
     ["scenarios.payload_mass_kg: a payload of 1400 kg", "table.supply_pressure_pa",
      "valid: up to 1297.1 kg"]),
]


@pytest.mark.parametrize("scenarios, fragments", UNLEVELABLE,
                         ids=["cg_x_beyond_groups", "cg_xy_corner", "payload_above_supply"])
def test_robust_table_refuses_an_unlevelable_corner_before_any_solve(monkeypatch, scenarios,
                                                                     fragments):
    import isodesign
    from isodesign.optimization import table_driver
    from isodesign.optimization.study import table_study

    def _no_solve(*a, **k):
        raise AssertionError("the nominal optimum started before the refusal")

    monkeypatch.setattr(table_driver, "optimize_table", _no_solve)
    st = table_study().with_changes({"scenarios": scenarios})
    with pytest.raises(InputError) as err:
        isodesign.optimize(st)
    for f in fragments:
        assert f in str(err.value)


def test_robust_table_within_the_groups_triangle_is_not_refused():
    from isodesign.optimization.robust_table import check_robust_table
    from isodesign.optimization.study import table_study

    check_robust_table(table_study().with_changes(
        {"scenarios": {"payload_mass_kg": {"min": 480.0, "max": 900.0},
                       "cg_offset_x_m": {"absolute": 0.05}, "cg_offset_y_m": {"absolute": 0.05}}}))


def test_cli_robust_table_unlevelable_corner_one_line(tmp_path, capsys, changed_table_study):
    text = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    f = tmp_path / "robust.toml"
    f.write_text(text + "\n[scenarios]\ncg_offset_x_m = {absolute = 0.35}\n")
    code, _out, err = _cli(capsys, ["optimize", str(f), "-o", str(tmp_path / "o")])
    assert code == 2 and len(err) == 1, err
    assert "robust.toml: scenarios.cg_offset_x_m" in err[0] and "(-0.3, 0.3) m" in err[0]
    assert not (tmp_path / "o").exists()


def _free_lever_robust_study():
    from isodesign.optimization.study import table_study

    return table_study().with_changes({
        "variables.pendulum_length_m": {"fixed": False, "lower": 0.05, "upper": 0.4},
        "variables.lateral_stiffness_n_per_m": {"fixed": False, "lower": 2e3, "upper": 5e4},
        "scenarios": {"payload_mass_kg": {"min": 550.0, "max": 650.0},
                      "cg_offset_x_m": {"absolute": 0.02}}})


LEVERS = {"pendulum_length_m": 0.3, "lateral_stiffness_n_per_m": 8000.0}


def test_api_yield_takes_a_codesigned_optimums_lever_values():
    # res.values of a co-designed optimum name its levers: refused before as "unknown
    # design variable 'pendulum_length_m'"; now the table with those levers is judged
    from isodesign.optimization.yields import estimate_yield

    st = _free_lever_robust_study()
    spring = {v.name: v.start for v in st.variables}
    got = estimate_yield(st, {**spring, **LEVERS}, samples=3, workers=1)
    want = estimate_yield(st.with_levers_fixed(LEVERS), spring, samples=3, workers=1)
    assert got.fraction == want.fraction
    assert got.worst_margin_db() == pytest.approx(want.worst_margin_db(), abs=1e-9)
    other = estimate_yield(st.with_levers_fixed({**LEVERS, "pendulum_length_m": 0.1}),
                           spring, samples=3, workers=1)
    assert abs(other.worst_margin_db() - got.worst_margin_db()) > 1e-3  # the levers count
    with pytest.raises(InputError, match=r"values\['pendulum_length_m'\] = 0.2, but "
                       r"variables.pendulum_length_m is fixed at 0.3"):
        estimate_yield(st.with_levers_fixed(LEVERS), {**spring, **LEVERS,
                                                      "pendulum_length_m": 0.2}, samples=3)
    with pytest.raises(InputError, match="the free lever lateral_stiffness_n_per_m has no "
                                         "value"):
        estimate_yield(st, {**spring, "pendulum_length_m": 0.3}, samples=3)


def test_cli_yield_of_a_codesigned_run_fixes_the_studys_free_levers_at_its_values(
        tmp_path, capsys, builtin_table_run):
    # `yield RUN --study S` with S's levers free: refused before ("fix the levers"); the
    # run's optimum (design.json) says which table was built
    import json
    import shutil

    from isodesign.optimization.yields import estimate_yield

    _printed, run = builtin_table_run
    cd = tmp_path / "codesigned"
    shutil.copytree(run, cd)
    dj = json.loads((cd / "design.json").read_text())
    for k, v in LEVERS.items():
        dj["variables"][k] = {"value": v, "fixed": False}
    (cd / "design.json").write_text(json.dumps(dj))
    st = _free_lever_robust_study()
    f = tmp_path / "robust.toml"
    f.write_text((resources.files("isodesign") / "data" / "table_study.toml").read_text()
                 + "\n[variables.pendulum_length_m]\nfixed = false\nlower = 0.05\nupper = 0.4\n"
                 "[variables.lateral_stiffness_n_per_m]\nfixed = false\nlower = 2e3\n"
                 "upper = 5e4\n[scenarios]\npayload_mass_kg = {min = 550.0, max = 650.0}\n"
                 "cg_offset_x_m = {absolute = 0.02}\n")
    code, _out, err = _cli(capsys, ["yield", str(cd), "--study", str(f), "--samples", "3",
                                    "--workers", "1", "--no-plots", "-o", str(tmp_path / "y")])
    assert code == 0, err
    y = json.loads((tmp_path / "y" / "yield.json").read_text())
    spring = {k: dj["variables"][k]["value"] for k in ("volume_ratio", "top_volume_m3",
                                                       "capillary_length_m",
                                                       "capillary_diameter_m")}
    want = estimate_yield(st.with_levers_fixed(LEVERS), spring, samples=3, workers=1)
    assert y["fraction"] == want.fraction
    assert y["worst_margin_db"] == pytest.approx(want.worst_margin_db(), abs=1e-9)


POLY = [[-0.75, -0.5], [0.75, -0.5], [0.75, 0.5], [-0.75, 0.5]]


def test_sweep_varies_the_position_levers_keys(tmp_path):
    # variables.isolator_positions_m.{fixed,start,polygon_m} are study keys: --vary and the
    # API refused them as "unknown key"
    import isodesign
    from isodesign.optimization.study import table_study

    start = [[-0.5, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]]
    free = {"variables.isolator_positions_m.fixed": False,
            "variables.isolator_positions_m.polygon_m": POLY,
            "variables.isolator_positions_m.start": start}
    res = isodesign.sweep(table_study(), points=[free], output=tmp_path / "s",
                          task="response", charts=False, scheduler="serial")
    assert res.failed == 0 and len(res.table) == 1
    # the point is the table with its isolator 1 moved, not the base
    want = isodesign.analyze(table_study().with_changes(free))
    assert res.table["objective_value"].iloc[0] == pytest.approx(want.worst_margin_db,
                                                                 abs=1e-9)
    base = isodesign.analyze(table_study())
    assert abs(want.worst_margin_db - base.worst_margin_db) > 1e-3
    with pytest.raises(InputError, match=r"isolator_positions_m\.polygon_m"):
        isodesign.sweep(table_study(), {"variables.isolator_positions_m.polygon_m":
                                        [POLY[:2]]}, output=tmp_path / "s2", task="response",
                        charts=False, scheduler="serial")


def test_sweep_refuses_a_point_the_vary_made_robust_before_any_runs(tmp_path):
    # a --vary that adds [scenarios] to a response sweep: every point failed one by one
    import isodesign
    from isodesign.optimization.study import table_study

    with pytest.raises(InputError) as err:
        isodesign.sweep(table_study(), {"scenarios.cg_offset_x_m.absolute": [0.02, 0.04]},
                        output=tmp_path / "s", task="response", charts=False,
                        scheduler="serial")
    msg = str(err.value)
    assert "[scenarios]: isodesign response does not answer a robust study" in msg
    assert "(at the point scenarios.cg_offset_x_m.absolute=0.02)" in msg
    assert not (tmp_path / "s").exists()


def test_sweep_unit_slip_of_a_point_is_named_as_the_point():
    # a --vary value in tonnes was warned as if the base file held it ("table_study.toml:
    # payload.mass_kg = 0.5 kg"); a slip of the base file itself keeps the file's name
    from isodesign.optimization.study import table_study
    from isodesign.sweeps.spec import build_points

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        build_points(table_study(), [{"payload.mass_kg": 0.5}, {"payload.mass_kg": 600.0}])
    msgs = [str(w.message) for w in caught if issubclass(w.category, UnitWarning)]
    assert len(msgs) == 1, msgs
    assert msgs[0].startswith("--vary payload.mass_kg=0.5: payload.mass_kg = 0.5 kg on 4 "
                              "isolators"), msgs
