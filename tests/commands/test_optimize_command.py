"""``isodesign optimize``, ``isodesign pareto`` and ``isodesign demo``: files, summaries,
replay, exit codes, one-line errors.

The optimizer runs on a FAST study (2 starts, 4 points per band, 30 peak points),
a few seconds per run; the default study is only run by the demo test (slow).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import re

import pandas as pd
import pytest

from isodesign.cli import main
from isodesign.commands.optimize import OUTPUT_FILES
from isodesign.optimization.study import load_study, vertical_study

FAST_STUDY = """\
name = "fast"
description = "the default study on a coarse grid, 2 starts (tests)"

[models]
points_per_band = 4
peak_points = 30

[solver]
starts = 2
"""

INFEASIBLE_STUDY = FAST_STUDY.replace('name = "fast"', 'name = "infeasible"') + """
[constraints]
# below (1 + N_min) V_t0,min = 1.5 x 0.2 L: no design can meet it
max_total_volume_m3 = 1e-5
"""


def run(capsys, *argv: str) -> tuple[int, str, str]:
    """Run the CLI in-process; return (status, stdout, stderr)."""
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def run_captured(*argv: str) -> tuple[int, str, str]:
    """Run the CLI in-process outside a test (module fixtures): capture with StringIO."""
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        status = main(list(argv))
    return status, o.getvalue(), e.getvalue()


def assert_one_error_line(err: str, *fragments: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("isodesign: error: "), err
    assert "Traceback" not in err
    for f in fragments:
        assert f in lines[0], (f, lines[0])


@pytest.fixture(scope="module")
def fast_study(tmp_path_factory):
    p = tmp_path_factory.mktemp("study") / "fast.toml"
    p.write_text(FAST_STUDY, encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def optimized(fast_study, tmp_path_factory):
    """One optimize run of the fast study: (status, stdout, stderr, outdir)."""
    out = tmp_path_factory.mktemp("opt") / "run"
    status, stdout, stderr = run_captured("optimize", str(fast_study), "-o", str(out))
    return status, stdout, stderr, out


# -- the default study file -------------------------------------------------------------------
def test_vertical_study_file_is_the_builtin_vertical_study():
    from importlib import resources

    path = resources.files("isodesign") / "data" / "vertical_study.toml"
    assert load_study(path).raw == vertical_study().raw


def test_the_default_study_is_the_builtin_table_with_its_levers_free():
    """default_study() is table_study() with its co-design levers free within the bounds its
    file states (docs/table.md, section 13): the four horizontal levers, the layout's
    spacing inside the table top's footprint with the isolators 0.5 m apart, and the springs
    of leveling groups 2 and 3 (group 1 takes the shared spring); everything else is the
    built-in table's."""
    from isodesign.optimization.study import default_study, table_study
    from isodesign.optimization.variables import DESIGN_VARIABLES, LAYOUT_LEVERS, TABLE_LEVERS

    st, tb = default_study(), table_study()
    assert st.table is not None and st.name == "default"
    groups = [f"{v}_group{k}" for k in (2, 3) for v in DESIGN_VARIABLES]
    free = [v for v in st.levers if v.free]
    assert [v.name for v in free] == [*TABLE_LEVERS, *LAYOUT_LEVERS, *groups]
    assert all(v.name == "inertia_base_mass_kg" for v in st.levers if not v.free)
    bounds = {v.name: {"fixed": False, "lower": v.lower, "upper": v.upper} for v in free
              if v.name not in groups}
    same = tb.with_changes(
        name="default", description=st.raw["description"],
        variables={**bounds, **{n: {"fixed": False} for n in groups}},
        constraints={"footprint_m": [[-0.75, -0.5], [0.75, 0.5]],
                     "min_isolator_distance_m": 0.5},
        solver={"starts": 3})  # staged: 3 tied solves, 1 full (docs/table.md, section 13)
    assert same.raw == st.raw
    for v in free:  # each start is the table's, inside its practical bounds
        assert v.lower <= v.start <= v.upper
        if v.name in TABLE_LEVERS:
            assert v.start == getattr(tb.table.horizontal, v.name)
        elif v.name in groups:  # a group's spring starts at, and is bounded like, the shared
            shared = st.variable(v.name.rsplit("_group", 1)[0])
            assert (v.start, v.lower, v.upper) == (shared.start, shared.lower, shared.upper)
    xy = [p for p in tb.table.isolators_m]
    assert st.variable("layout_length_m").start == pytest.approx(max(p[0] for p in xy)
                                                                 - min(p[0] for p in xy))
    assert st.variable("layout_width_m").start == pytest.approx(max(p[1] for p in xy)
                                                                - min(p[1] for p in xy))


def test_resolved_study_toml_round_trips(tmp_path, fast_study):
    from isodesign.io.record import study_toml

    st = load_study(fast_study).with_changes(solver={"starts": 3, "seed": 7})
    p = tmp_path / "resolved.toml"
    p.write_text(study_toml(st, header="a header\nof two lines"), encoding="utf-8")
    assert load_study(p).raw == st.raw


NOMINAL_BANDS_HZ = (1, 1.25, 1.6, 2, 2.5, 3.15, 4, 5, 6.3, 8, 10, 12.5, 16, 20, 25, 31.5, 40,
                    50, 63, 80)


def test_resolved_study_makes_a_floor_csv_path_absolute(tmp_path):
    from isodesign.io.record import study_toml

    sub = tmp_path / "studies"
    sub.mkdir()
    rows = "\n".join(f"{f},50" for f in NOMINAL_BANDS_HZ)
    (sub / "floor.csv").write_text(
        "# quantity: velocity; kind: band_rms; unit: um/s\nfrequency_hz,value\n" + rows + "\n",
        encoding="utf-8")
    (sub / "s.toml").write_text('[floor]\ncsv = "floor.csv"\n', encoding="utf-8")
    st = load_study(sub / "s.toml")
    (tmp_path / "elsewhere.toml").write_text(study_toml(st), encoding="utf-8")
    again = load_study(tmp_path / "elsewhere.toml")
    assert again.raw["floor"]["csv"] == str((sub / "floor.csv").resolve())


# -- optimize: success ------------------------------------------------------------------------
def test_optimize_writes_every_file(optimized):
    status, _, err, outdir = optimized
    assert status == 0, err
    assert "Traceback" not in err
    for name in OUTPUT_FILES:
        assert (outdir / name).stat().st_size > 0, name
    design = json.loads((outdir / "design.json").read_text())
    assert design["feasible"] is True
    assert design["objective"]["kind"] == "worst_band_margin"
    assert set(design["variables"]) == {"volume_ratio", "top_volume_m3", "capillary_length_m",
                                        "capillary_diameter_m"}
    for key in ("single_chamber_stiffness_k_s_n_per_m", "static_stiffness_n_per_m",
                "natural_frequency_hz", "zener_damping_ratio", "tilt_margin",
                "total_volume_m3", "pressure_pa"):
        assert math.isfinite(design["derived"][key]), key
    assert design["verdict"].startswith(("PASS", "FAIL"))
    bands = pd.read_csv(outdir / "bands.csv")
    for col in ("nominal_hz", "payload_velocity_rms_m_s", "margin_db",
                "start_payload_velocity_rms_m_s", "start_margin_db"):
        assert col in bands.columns, col
    assert bands["margin_db"].min() == pytest.approx(design["derived"]["worst_band_margin_db"])
    starts = pd.read_csv(outdir / "starts.csv")
    assert len(starts) == 2
    assert {"status", "iterations", "wall_s", "objective", "final_volume_ratio"} <= set(starts)
    rec = json.loads((outdir / "record.json").read_text())
    for key in ("command_line", "isodesign_version", "environment", "study",
                "solver_settings", "starts", "constraints", "flat_direction",
                "recheck_max_rel_diff", "wall_s", "design", "objective_value"):
        assert key in rec, key
    assert rec["command_line"][:2] == ["isodesign", "optimize"]
    assert rec["environment"]["packages"]["casadi"]
    assert len(rec["starts"]) == 2
    assert rec["recheck_max_rel_diff"] <= 1e-6


def _summary_value(out: str, label: str) -> str:
    """The optimum column (last cell) of a summary row."""
    for line in out.splitlines():
        if line.strip().startswith(label):
            return line.split()[-1]
    raise AssertionError(f"no summary row {label!r} in:\n{out}")


def test_optimize_summary_matches_design_json(optimized):
    status, out, _, outdir = optimized
    assert status == 0
    d = json.loads((outdir / "design.json").read_text())
    v = {k: s["value"] for k, s in d["variables"].items()}
    checks = [
        ("N = V_b0/V_t0", v["volume_ratio"]),
        ("V_t0 (L)", v["top_volume_m3"] * 1e3),
        ("L_c (mm)", v["capillary_length_m"] * 1e3),
        ("D_c (mm)", v["capillary_diameter_m"] * 1e3),
        ("total volume (L)", d["derived"]["total_volume_m3"] * 1e3),
        ("natural frequency (Hz)", d["derived"]["natural_frequency_hz"]),
        ("tilt margin", d["derived"]["tilt_margin"]),
    ]
    for label, value in checks:
        assert float(_summary_value(out, label)) == pytest.approx(value, rel=5e-3), label
    m = re.search(r"objective worst_band_margin \(NLP grid\)\s+\S+ dB\s+([+-][\d.]+) dB", out)
    assert m, out
    assert float(m.group(1)) == pytest.approx(d["objective"]["value"], abs=5e-4)
    assert f"optimum: {d['verdict']}" in out
    # every constraint is listed, binding ones marked
    for c in d["constraints"]:
        assert c["name"] in out
        row = next(ln for ln in out.splitlines() if re.search(rf"\s{c['name']}\s", ln))
        assert row.strip().startswith("*") == c["binding"], row
    assert "reached the best design" in out
    assert "flat direction" in out and "tie-break" in out
    assert "re-check" in out


def test_optimize_quiet_prints_one_line(capsys, fast_study, tmp_path):
    status, out, err = run(capsys, "optimize", str(fast_study), "-o", str(tmp_path / "q"),
                           "--quiet", "--no-plots", "--starts", "1")
    assert status == 0, err
    assert len(out.strip().splitlines()) == 1
    assert "worst_band_margin" in out
    assert not (tmp_path / "q" / "response.png").exists()
    assert (tmp_path / "q" / "design.json").exists()


@pytest.mark.slow
def test_study_resolved_replays_the_run(optimized, capsys, tmp_path):
    status, _, _, outdir = optimized
    assert status == 0
    resolved = outdir / "study_resolved.toml"
    st = load_study(resolved)
    rec = json.loads((outdir / "record.json").read_text())
    assert st.raw == rec["study"]
    status2, _, err = run(capsys, "optimize", str(resolved), "-o", str(tmp_path / "replay"),
                          "--no-plots")
    assert status2 == 0, err
    a = json.loads((outdir / "design.json").read_text())
    b = json.loads((tmp_path / "replay" / "design.json").read_text())
    for k in a["variables"]:
        assert b["variables"][k]["value"] == pytest.approx(a["variables"][k]["value"],
                                                           rel=1e-8), k
    assert b["objective"]["value"] == pytest.approx(a["objective"]["value"], abs=1e-8)


# -- optimize: failure and bad input -----------------------------------------------------------
@pytest.mark.slow
def test_infeasible_study_exits_1_with_the_violations(capsys, tmp_path):
    p = tmp_path / "infeasible.toml"
    p.write_text(INFEASIBLE_STUDY, encoding="utf-8")
    outdir = tmp_path / "out"
    status, out, err = run(capsys, "optimize", str(p), "-o", str(outdir))
    assert status == 1
    assert_one_error_line(err, "no feasible design", "total_volume")
    assert "NO FEASIBLE DESIGN" in out
    assert "IPOPT status" in out
    assert "total_volume" in out and "best point found" in out
    assert (outdir / "record.json").exists() and (outdir / "starts.csv").exists()
    assert not (outdir / "design.json").exists()
    rec = json.loads((outdir / "record.json").read_text())
    assert rec["feasible"] is False
    assert rec["violations"][0]["name"] == "total_volume"


def test_bad_study_key_exits_2_naming_the_key(capsys, tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[payload]\nmasss_kg = 600\n", encoding="utf-8")
    status, _, err = run(capsys, "optimize", str(p), "-o", str(tmp_path / "out"))
    assert status == 2
    assert_one_error_line(err, "masss_kg", "[payload]")


def test_bad_study_value_exits_2(capsys, tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[solver]\nstarts = 0\n", encoding="utf-8")
    status, _, err = run(capsys, "optimize", str(p), "-o", str(tmp_path / "out"))
    assert status == 2
    assert_one_error_line(err, "solver.starts")


@pytest.mark.parametrize("argv, name", [
    (["--starts", "0"], "--starts"),
    (["--workers", "0"], "--workers"),
    (["--seed", "-1"], "--seed"),
    (["--starts", "x"], "--starts"),
])
def test_bad_options_exit_2(capsys, tmp_path, argv, name):
    status, _, err = run(capsys, "optimize", *argv, "-o", str(tmp_path / "out"))
    assert status == 2
    assert_one_error_line(err, name)


def test_missing_study_file_exits_2(capsys, tmp_path):
    status, _, err = run(capsys, "optimize", str(tmp_path / "nope.toml"), "-o", str(tmp_path))
    assert status == 2
    assert_one_error_line(err, "nope.toml")


def test_output_must_be_given(capsys):
    status, _, err = run(capsys, "optimize")
    assert status == 2
    assert_one_error_line(err, "-o")


# -- pareto ------------------------------------------------------------------------------------
def test_pareto_help_names_every_registered_objective():
    from isodesign.cli import build_parser
    from isodesign.optimization.objectives import OBJECTIVES

    sub = build_parser("pareto")._subparsers._group_actions[0].choices["pareto"]
    text = " ".join(sub.format_help().split())
    missing = [name for name in OBJECTIVES if name not in text]
    assert not missing, f"pareto --help does not name: {missing}"


@pytest.mark.slow
def test_pareto_writes_front_plot_and_hypervolume(capsys, fast_study, tmp_path):
    outdir = tmp_path / "pareto"
    status, out, err = run(capsys, "pareto", str(fast_study), "--points", "3", "-o", str(outdir))
    assert status == 0, err
    for name in ("pareto.csv", "pareto.png", "pareto.json", "record.json",
                 "study_resolved.toml"):
        assert (outdir / name).stat().st_size > 0, name
    df = pd.read_csv(outdir / "pareto.csv")
    assert len(df) == 3
    assert {"worst_band_margin", "total_volume", "volume_ratio", "nondominated"} <= set(df)
    js = json.loads((outdir / "pareto.json").read_text())
    assert 0.0 < js["hypervolume"] <= 1.0
    assert set(js["reference_point"]) == {"worst_band_margin", "total_volume"}
    # the reference point lies beyond the nadir of the front
    front = df[df["nondominated"]]
    assert js["reference_point"]["total_volume"] > front["total_volume"].max()
    assert js["reference_point"]["worst_band_margin"] < front["worst_band_margin"].min()
    assert f"hypervolume {js['hypervolume']:.4f}" in out
    assert "reference point" in out
    rec = json.loads((outdir / "record.json").read_text())
    assert rec["command_line"][:2] == ["isodesign", "pareto"]
    assert len(rec["points"]) == 3


@pytest.mark.parametrize("spec, name", [
    ("worst_band_margin,volume", "volume"),
    ("worst_band_margin", "A,B"),
    ("total_volume,total_volume", "different"),
])
def test_pareto_bad_objectives_exit_2(capsys, tmp_path, spec, name):
    status, _, err = run(capsys, "pareto", "--objectives", spec, "-o", str(tmp_path / "p"))
    assert status == 2
    assert_one_error_line(err, "--objectives", name)
    assert not (tmp_path / "p").exists()


def test_pareto_bad_points_exit_2(capsys, tmp_path):
    status, _, err = run(capsys, "pareto", "--points", "1", "-o", str(tmp_path / "p"))
    assert status == 2
    assert_one_error_line(err, "--points")


# -- demo: tests/docs/test_default_study_numbers.py (one run of the default study) ---------
