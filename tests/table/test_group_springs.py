"""Per-group springs (docs/table.md, section 15): each leveling group's N, V_t0, L_c, D_c as
optional design variables ``<variable>_group<k>``; a group the study does not name shares
the spring."""

from __future__ import annotations

import pathlib
import re
import tempfile

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import load_study, table_study, vertical_study
from isodesign.optimization.variables import GROUP_SPRING_LEVERS, lever_scaling
from isodesign.table.model import table_model
from isodesign.table.statics import level

FREE = {"volume_ratio_group2": {"fixed": False}, "capillary_diameter_m_group3": {"fixed": False}}
VALUES = {"volume_ratio_group2": 4.0, "capillary_diameter_m_group3": 1.3e-3}


def _held_out(text, **changes):
    with tempfile.TemporaryDirectory() as tmp:
        p = pathlib.Path(tmp) / "five.toml"
        p.write_text(text)
        st = load_study(p)
    return st.with_changes(**changes) if changes else st


def test_a_group_lever_takes_the_shared_variables_start_and_bounds():
    st = table_study()
    assert not any(v.name in GROUP_SPRING_LEVERS for v in st.levers)  # shared by default
    free = st.with_changes(variables=FREE)
    spec = {v.name: v for v in free.levers}
    n, d = free.variable("volume_ratio"), free.variable("capillary_diameter_m")
    assert (spec["volume_ratio_group2"].start, spec["volume_ratio_group2"].lower,
            spec["volume_ratio_group2"].upper) == (n.start, n.lower, n.upper)
    assert spec["capillary_diameter_m_group3"].start == d.start
    ls = lever_scaling(free)
    assert ls.is_log(ls.names.index("volume_ratio_group2"))
    z = ls.to_z({"volume_ratio_group2": 4.0, "capillary_diameter_m_group3": 1e-3})
    assert ls.to_values(z)["volume_ratio_group2"] == pytest.approx(4.0, rel=1e-14)
    t = free.table_at(VALUES)
    assert t.group_springs == ({}, {"volume_ratio": 4.0}, {"capillary_diameter_m": 1.3e-3})
    assert free.table_at(None).group_springs == (  # a named group lever: its own value
        {}, {"volume_ratio": n.start}, {"capillary_diameter_m": d.start})


@pytest.mark.parametrize("spec, key", [
    ({"volume_ratio_group2": {"fixed": False, "lower": 5.0, "upper": 2.0}},
     "variables.volume_ratio_group2"),
    ({"volume_ratio_group2": {"fixed": False, "start": 9.0}},
     "variables.volume_ratio_group2.start"),
    ({"capillary_diameter_m_group1": {"fixed": True, "start": 5.0}},
     "variables.capillary_diameter_m_group1.start"),
    ({"top_volume_m3_group3": {"fixed": False, "lower": -1.0}},
     "variables.top_volume_m3_group3.lower"),
    ({"volume_ratio_group2": {"fixed": "yes"}}, "variables.volume_ratio_group2.fixed"),
    ({"volume_ratio_group2": {"lower": 50.0, "upper": 60.0}},
     "variables.volume_ratio_group2.start (1.85185) is fixed outside its own bounds"),
])
def test_bad_group_levers_name_the_key(spec, key):
    with pytest.raises(InputError, match=re.escape(key)):
        table_study().with_changes(variables=spec)


@pytest.mark.parametrize("name", ["volume_ratio_group0", "volume_ratio_group4",
                                  "capillary_diameter_m_group-1"])
def test_a_group_number_outside_1_to_3_names_the_key_and_the_groups(name):
    with pytest.raises(InputError, match=re.escape(f"variables.{name}: group ") +
                       r".* k = 1, 2 or 3 \(numbered from 1"):
        table_study().with_changes(variables={name: {"fixed": False}})


@pytest.mark.parametrize("group, key", [
    ({"volume_ratio": "2"}, "table.group_springs: group 2: volume_ratio: expected a number"),
    ({"volume_ratio": True}, "table.group_springs: group 2: volume_ratio: expected a number"),
    ({"volume_ratio": 1e6}, "table.group_springs: group 2: volume_ratio: must be in [0.001, "),
    ({"capillary_diameter_m": 1.2},  # mm typed as m: outside the models' domain
     "table.group_springs: group 2: capillary_diameter_m: must be in [1e-08, 1] m"),
])
def test_a_bad_group_spring_value_names_the_group_and_the_field(group, key):
    with pytest.raises(InputError, match=re.escape(key)):
        table_study().with_changes(table={"group_springs": [{}, group, {}]})


def test_a_vertical_study_refuses_a_group_lever_and_a_bad_group_spring_names_its_key():
    with pytest.raises(InputError, match=r"variables\.volume_ratio_group2"):
        vertical_study().with_changes(variables={"volume_ratio_group2": {"fixed": False}})
    with pytest.raises(InputError, match=r"table\.group_springs: group 2: unknown field"):
        table_study().with_changes(table={"group_springs": [{}, {"n": 2.0}, {}]})
    with pytest.raises(InputError, match=r"table\.group_springs: expected three tables"):
        table_study().with_changes(table={"group_springs": [{}, {}]})


def test_each_isolator_has_its_groups_spring_and_equal_p0_stays_apart():
    """The built-in table's groups 2 and 3 share p0: with group 3's own capillary they are
    two isolators of the closure, not one (the representatives per (p0, spring))."""
    st = table_study().with_changes(variables=FREE)
    t = st.table_at(VALUES)
    lv = level(t, st.hardware["piston_area_m2"])
    assert lv.pressure_pa[2] == lv.pressure_pa[3]
    m = table_model(st.start_design(), t)
    assert [d.volume_ratio for d in m.designs] == [st.start_design().volume_ratio] * 2 + \
        [4.0, st.start_design().volume_ratio]
    assert m.designs[3].capillary_diameter_m == 1.3e-3
    assert m.designs[2].capillary_diameter_m == st.start_design().capillary_diameter_m
    first, inv = m.unique_isolators()
    assert len(first) == 3 and inv[2] != inv[3] and inv[0] == inv[1]
    shared = table_model(st.start_design(), st.table)
    # today's: one per p0 (equal within P0_SHARE_RTOL: the built-in table levels all four
    # isolators to one p0 up to rounding)
    p0 = shared.leveling.pressure_pa
    distinct = [p for i, p in enumerate(p0)
                if all(abs(p - q) > shared.P0_SHARE_RTOL * q for q in p0[:i])]
    assert len(shared.unique_isolators()[0]) == len(distinct)


def test_the_nlp_with_free_group_levers_is_the_numpy_closure_and_the_fixed_nlp(held_out_toml):
    """Five isolators, CG off centre: at group values V the NLP's implicit equations hold at
    the NumPy closure of the table with V (to 1e-10, the physics written once), and every
    row equals the NLP of the study with V fixed (``with_levers_fixed``)."""
    from isodesign.optimization.table_problem import TableProblem

    free = _held_out(held_out_toml, variables=FREE, constraints={"min_tilt_margin": 1.5,
                                                                 "max_total_volume_m3": 0.02})
    fixed = free.with_levers_fixed(VALUES)
    assert fixed.table.group_springs[1] == {"volume_ratio": 4.0}
    p1, p2 = TableProblem(free), TableProblem(fixed)
    vals = {v.name: v.start for v in free.variables}
    x1, x2 = p1.initial_guess({**vals, **VALUES}), p2.initial_guess(vals)
    assert p1.values(x1)["volume_ratio_group2"] == pytest.approx(4.0)
    g1 = np.asarray(p1.eval_fn(x1, p1.params())[1]).ravel()
    g2 = np.asarray(p2.eval_fn(x2, p2.params())[1]).ravel()
    assert np.max(np.abs(g1[: p1.n_eq])) < 1e-10
    np.testing.assert_allclose(g1, g2, rtol=1e-9, atol=1e-9)
    rows = {name: (row, m) for name, row, m in p1.con_rows}
    row, m = rows["max_total_volume_m3"]
    assert m == 3  # every group's spring against the envelope
    d = free.start_design()
    want = [d.total_volume_m3, d.top_volume_m3 * 5.0, d.total_volume_m3]
    np.testing.assert_allclose(np.exp(g1[row: row + m]), want, rtol=1e-12)
    p0 = TableProblem(_held_out(held_out_toml))
    x0 = p0.initial_guess(vals)
    assert np.max(np.abs(p1.sigma(x1) / p0.sigma(x0) - 1)) > 0.01  # the groups' own springs


def test_group_levers_at_the_shared_values_reproduce_todays_nlp():
    """Every group lever named, fixed at the shared spring: the rows of today's NLP (the
    plain closure: the distortion's NumPy closure is solved to 1e-11, not 1e-13)."""
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes({"models.distortion": False})
    named = st.with_changes(variables={n: {"fixed": True} for n in GROUP_SPRING_LEVERS})
    p0, p1 = TableProblem(st), TableProblem(named)
    assert p1.grouped and not p0.grouped
    vals = {v.name: v.start for v in st.variables}
    x0, x1 = p0.initial_guess(vals), p1.initial_guess(vals)
    np.testing.assert_allclose(x1, x0, rtol=1e-13, atol=1e-13)
    g0 = np.asarray(p0.eval_fn(x0, p0.params())[1]).ravel()
    g1 = np.asarray(p1.eval_fn(x1, p1.params())[1]).ravel()
    np.testing.assert_allclose(g1[: p1.n_eq], g0[: p0.n_eq], atol=1e-12)
    r0 = {name: g0[row: row + m] for name, row, m in p0.con_rows}
    r1 = {name: g1[row: row + m] for name, row, m in p1.con_rows}
    assert r1.keys() == r0.keys()
    for name, v0 in r0.items():  # the volume: one row per group, each today's
        v1 = r1[name]
        np.testing.assert_allclose(v1, np.resize(v0, v1.shape), rtol=1e-12, atol=1e-12)


def test_group_springs_with_leveling_loop_bounds_are_refused_naming_the_key():
    from isodesign.optimization.table_problem import TableProblem

    st = table_study().with_changes(variables=FREE, constraints={
        "min_leveling_gain_margin_db": 6.0})
    with pytest.raises(InputError, match=r"constraints\.min_leveling_gain_margin_db"):
        TableProblem(st)


def test_the_command_lines_lever_lines_name_a_group_lever_by_its_group():
    from types import SimpleNamespace

    from isodesign.commands.table_optimize import lever_lines

    st = table_study().with_changes(variables=FREE)
    res = SimpleNamespace(study=st, values={**VALUES},
                          lever_notes=lambda: {"volume_ratio_group2": "inside its bounds"})
    lines = lever_lines(res)
    assert lines[0].split()[:3] == ["N", "group", "2"] and "inside its bounds" in lines[0]
    assert lines[1].split()[:4] == ["D_c", "group", "3", "(m)"]
    assert float(lines[1].split()[-1]) == pytest.approx(1.3e-3)


@pytest.mark.slow
def test_a_group_levers_sensitivity_against_a_central_difference_of_the_reoptimized_design():
    """The built-in table (one start) with group 3's capillary diameter free: it stops on
    its 3 mm upper bound; the bound multiplier of the log-scaled lever, lam / (h v), gives
    77.15 dB per m of the bound, and the re-optimized designs with the bound at 2.985 and
    3.015 mm give 77.17 dB/m (a central difference; within 2 %). Without the distortion
    power: with it the one start ends on another local optimum, group 3's diameter inside
    its box at 0.47 mm (-4.96 dB), where no bound binds; the envelope theorem through the
    distortion's expansion is checked on the footprint's edge
    (tests/table/test_position_lever.py)."""
    from isodesign.optimization.table_driver import optimize_table

    st = table_study().with_changes(solver={"starts": 1}, models={"distortion": False})

    def run(upper):
        return optimize_table(st.with_changes(variables={"capillary_diameter_m_group3": {
            "fixed": False, "upper": upper}}), workers=1, analyze=False)

    r = run(3.0e-3)
    s = r.lever_sensitivity[0]
    assert s["name"] == "capillary_diameter_m_group3" and s["at_bound"] == "upper"
    lo, hi = run(2.985e-3), run(3.015e-3)
    fd = (hi.objective_value - lo.objective_value) / 0.03e-3
    assert s["db_per_unit"] == pytest.approx(fd, rel=0.02)
    assert s["db_per_unit"] == pytest.approx(77.1, abs=1.0)


def test_a_run_directorys_study_with_group_springs_round_trips_and_the_report_names_them(
        tmp_path):
    """``Study.with_levers_fixed`` writes each group's own spring to ``table.group_springs``
    (a list of tables): the run directory's ``study_resolved.toml`` holds it as inline
    tables and reads back the same study, and the report's table rows name each valve's
    spring (docs/table.md section 15; the default study frees groups 2 and 3)."""
    from types import SimpleNamespace

    from isodesign.io.record import study_toml
    from isodesign.reporting.table_section import table_job_rows
    from isodesign.table.response import table_band_response

    st = table_study().with_changes(variables={
        "volume_ratio_group2": {"fixed": False}, "capillary_diameter_m_group3": {
            "fixed": False}})
    fixed = st.with_levers_fixed({"volume_ratio_group2": 3.5,
                                  "capillary_diameter_m_group3": 1.2e-3})
    assert fixed.table.group_springs == ({}, {"volume_ratio": 3.5},
                                         {"capillary_diameter_m": 1.2e-3})
    path = tmp_path / "study_resolved.toml"
    path.write_text(study_toml(fixed), encoding="utf-8")
    assert "group_springs = [{}, {volume_ratio = 3.5}, {capillary_diameter_m = 0.0012}]" \
        in path.read_text(encoding="utf-8")
    back = load_study(path)
    assert back.raw == fixed.raw and back.table.group_springs == fixed.table.group_springs
    res = table_band_response(fixed.start_design(), fixed.table, fixed.floor_axes,
                              fixed.target, bands=fixed.bands, warn=False)
    rows = dict(table_job_rows(SimpleNamespace(study=fixed), {"response": res}))
    assert rows["spring per leveling group"] == (
        "valve 1: the shared spring (the design section's); valve 2: N = 3.5 (the others the "
        "shared spring's); valve 3: D_c 1.2 mm (the others the shared spring's)")
