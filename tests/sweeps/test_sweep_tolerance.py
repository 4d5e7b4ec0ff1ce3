"""A sweep of a ``[scenarios]`` range (a tolerance swept, docs/sweep.md "Sweeping a
tolerance"): each point's answer is the robust optimum for that point's ranges, as a direct
robust ``isodesign.optimize`` of the point's study gives it; the worker builds the robust
NLPs once (the ranges are not part of them) and the row says how many it built; the CLI and
the Python API give the same table; an invalid range at one point is refused before any
solve, naming the key as typed and the point.

The study is ``vertical_study()`` on a coarse grid with one start (and no yield draws), its
``[scenarios]`` the payload +-5 % and the capillary's diameter, whose tolerance is swept."""

from __future__ import annotations

import json

import pytest

import isodesign
from isodesign.cli import main
from isodesign.errors import InputError
from isodesign.io.record import study_toml
from isodesign.optimization.exchange import robust_optimize
from isodesign.optimization.robust import RobustBuilds, scenario_structure_key
from isodesign.optimization.study import load_study, vertical_study
from isodesign.sweeps.continuation import robust_seeds
from isodesign.sweeps.table import read_table

KEY = "scenarios.capillary_diameter_m.relative"
TOLERANCES = (0.01, 0.03)


def _study(tol: float = 0.01):
    """The vertical study, coarse, one start, with a small [scenarios]."""
    return vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 10},
        solver={"starts": 1, "tie_break": False},
        scenarios={"payload_mass_kg": {"relative": 0.05},
                   "capillary_diameter_m": {"relative": tol}})


@pytest.fixture(scope="module")
def api_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("tol") / "api"
    res = isodesign.sweep(_study(), vary={KEY: list(TOLERANCES)}, output=out,
                          scheduler="serial", options={"yield_samples": 0}, charts=False)
    return out, res


@pytest.mark.slow
def test_each_point_is_the_robust_optimum_of_its_own_tolerance(api_sweep):
    out, res = api_sweep
    df = read_table(out).sort_values(KEY)
    assert list(df["status"]) == ["complete", "complete"]
    assert list(df["question"]) == ["robust", "robust"]
    # built once on the worker: the nominal NLP, the scenario block and its stacks at the
    # first point; the second point (another range, the same scenario count or fewer)
    # builds only a stack with more scenarios than the first needed
    first, second = (int(n) for n in df["nlp_builds"])
    assert first >= 3
    assert res.nlp_builds == first + second
    worst = []
    for _, row in df.iterrows():
        tol = float(row[KEY])
        direct = isodesign.optimize(_study(tol))
        assert direct.kind == "robust"
        assert row["objective_value"] == pytest.approx(direct.objective_value, abs=0.01)
        for name in ("volume_ratio", "top_volume_m3", "capillary_length_m",
                     "capillary_diameter_m"):
            assert row[name] == pytest.approx(direct.values[name], rel=1e-3)
        run = out / row["run_dir"]
        rob = json.loads((run / "robust.json").read_text())
        assert rob["worst_case_objective"] == pytest.approx(row["objective_value"], abs=1e-9)
        assert f"capillary_diameter_m -{100 * tol:g} .. +{100 * tol:g} %" in rob["parameters"]
        # the point's study_resolved.toml holds the point's ranges (replayable)
        # the re-optimized sensitivities (lam_p of the last stacked solve): the reused
        # stack's are the fresh one's, on the same exchange (a continued point's: from its
        # neighbour's optimum, scenarios and peaks, docs/sweep.md section 7, as the sweep's)
        if int(row["neighbour_starts"]):
            prev = df[df[KEY] < tol].iloc[-1].to_dict()
            st = _study(tol)
            starts, thetas, peaks = robust_seeds([prev], st.scenarios, st.payload.mass_kg)
            direct = robust_optimize(st, extra_starts=starts, seed_scenarios=thetas,
                                     seed_peaks_hz=peaks)
            assert rob["continuation"]["seeded_scenarios"] == \
                direct.extra["continuation"]["seeded_scenarios"]
            assert row["objective_value"] == pytest.approx(direct.objective_value, abs=1e-6)
        lam = direct.reoptimized_sensitivities()
        assert set(rob["reoptimized_sensitivities"]) == {str(k) for k in lam}
        for k, per in lam.items():
            for name, v in per.items():
                assert rob["reoptimized_sensitivities"][str(k)][name] == pytest.approx(
                    v, rel=1e-3, abs=1e-6)
        replay = load_study(run / "study_resolved.toml")
        assert replay.scenarios.parameter("capillary_diameter_m").hi == pytest.approx(tol)
        worst.append(float(row["objective_value"]))
    # a wider tolerance never gives a better worst case (the margin is maximized)
    assert worst[1] <= worst[0] + 1e-6
    rows = [json.loads((out / r / "robust.json").read_text()) for r in df["run_dir"]]
    assert sum(sum(r["nlp_builds"].values()) for r in rows) <= res.nlp_builds


@pytest.mark.slow
def test_the_cli_gives_the_api_table(api_sweep, tmp_path, capsys):
    out, _ = api_sweep
    f = tmp_path / "robust.toml"
    f.write_text(study_toml(_study()))
    pts = tmp_path / "points.csv"
    pts.write_text(KEY + "\n" + "\n".join(str(t) for t in TOLERANCES) + "\n")
    status = main(["sweep", str(f), "--points-file", str(pts), "--yield-samples", "0",
                   "--scheduler", "serial", "-o", str(tmp_path / "cli")])
    text = capsys.readouterr().out
    assert status == 0
    # serial: in this process, whose NLPs the API's sweep built (the same structure)
    assert "NLPs built: 0 for 2 points run now" in text
    assert "a robust point's nominal NLP, scenario block and stacked NLPs" in text
    # the second tolerance continued from the first (docs/sweep.md, section 7)
    assert "robust points continued from a neighbour: 1 of 2 (" in text
    api = read_table(out).sort_values(KEY).reset_index(drop=True)
    cli = read_table(tmp_path / "cli").sort_values(KEY).reset_index(drop=True)
    assert list(cli["study_hash"]) == list(api["study_hash"])
    for col in ("objective_value", "volume_ratio", "top_volume_m3", "capillary_length_m",
                "capillary_diameter_m"):
        assert list(cli[col]) == pytest.approx(list(api[col]), rel=1e-9, abs=1e-9)
    assert list(cli["binding"]) == list(api["binding"])


def test_the_ranges_are_not_part_of_the_robust_nlp():
    a, b = _study(0.01), _study(0.03)
    assert scenario_structure_key(a) == scenario_structure_key(b)
    # how a tolerance applies is: an absolute tolerance builds its own block
    c = vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 10},
        solver={"starts": 1, "tie_break": False},
        scenarios={"payload_mass_kg": {"relative": 0.05},
                   "capillary_diameter_m": {"absolute": 2e-5}})
    assert scenario_structure_key(c) != scenario_structure_key(a)
    builds = RobustBuilds()
    block = builds.block(a)
    assert builds.block(b) is block and builds.builds == 1
    # rebound to the second study's ranges: its box is the point's
    assert block.space is b.scenarios
    assert block.space.parameter("capillary_diameter_m").hi == pytest.approx(0.03)
    prob, new = builds.stacked(block, [block.space.center()])
    again, new2 = builds.stacked(block, [block.space.upper()])
    assert new and not new2 and again is prob and builds.builds == 2
    assert prob.thetas[0] == pytest.approx(block.space.upper())


@pytest.mark.parametrize(("argv", "line"), [
    (["--vary", f"{KEY}=0.01,-0.02"],
     f"--vary {KEY}=-0.02: {KEY} must be > 0 (a +- tolerance), got -0.02"),
    (["--vary", "scenarios.payload_mass_kg.relative=0.05,0"],
     "--vary scenarios.payload_mass_kg.relative=0: scenarios.payload_mass_kg.relative must "
     "be > 0 (a +- tolerance), got 0"),
])
def test_an_invalid_range_is_refused_before_any_solve(tmp_path, capsys, argv, line):
    f = tmp_path / "robust.toml"
    f.write_text(study_toml(_study()))
    out = tmp_path / "sw"
    status = main(["sweep", str(f), *argv, "--scheduler", "serial", "-o", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert err == [f"isodesign: error: {line}"]
    assert not out.exists()
    # the Python API: the same line
    key, values = argv[1].split("=")
    with pytest.raises(InputError) as api:
        isodesign.sweep(_study(), vary={key: values},
                        output=tmp_path / "api", scheduler="serial")
    assert str(api.value) == line
    assert not (tmp_path / "api").exists()


def test_an_inverted_range_in_a_points_table_names_the_point(tmp_path, capsys):
    f = tmp_path / "robust.toml"
    f.write_text(study_toml(_study()))
    pts = tmp_path / "points.toml"
    pts.write_text(f"[[point]]\n{KEY} = 0.02\n\n[[point]]\n{KEY} = [0.03, 0.01]\n")
    status = main(["sweep", str(f), "--points-file", str(pts), "--scheduler", "serial",
                   "-o", str(tmp_path / "sw")])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert err == [f"isodesign: error: --points-file {KEY}=[0.03, 0.01]: {KEY}: inverted "
                   "range, lower (0.03) exceeds upper (0.01)"]
    assert not (tmp_path / "sw").exists()
    with pytest.raises(InputError, match=r"inverted range, lower \(0.03\)"):
        isodesign.sweep(_study(), points=[{KEY: 0.02}, {KEY: [0.03, 0.01]}],
                        output=tmp_path / "api", scheduler="serial")


@pytest.mark.slow
def test_a_robust_table_point_is_its_own_robust_optimum(tmp_path):
    """A robust table study (``table_study()``, coarse, one start), two tolerances: its
    scenario NLPs compile the payload and CG, so each point builds them again, and the row
    counts them; the second point continues from the first (its optima as starts, its
    active scenarios in its set); each answer is the direct robust optimize's of the
    point's study within the sweep's 0.01 dB."""
    import copy

    from isodesign.optimization.study import study_from_dict, table_study

    raw = copy.deepcopy(table_study().raw)
    raw["scenarios"] = {"payload_mass_kg": {"min": 560.0, "max": 640.0},
                        "cg_offset_y_m": {"absolute": 0.02}}
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    st = study_from_dict(raw, source="t.toml", fill_defaults=False)
    key = "scenarios.cg_offset_y_m.absolute"
    res = isodesign.sweep(st, vary={key: [0.02, 0.03]}, output=tmp_path / "sw",
                          scheduler="serial", options={"yield_samples": 0}, charts=False)
    df = read_table(tmp_path / "sw").sort_values(key).reset_index(drop=True)
    assert list(df["status"]) == ["complete"] * 2 and set(df["question"]) == {"robust table"}
    # the second point continued from the first (docs/sweep.md, section 7)
    assert list(df["neighbour_starts"]) == [0, 1]
    assert res.nlp_builds == int(df["nlp_builds"].sum())
    for _, row in df.iterrows():
        direct = isodesign.optimize(st.with_changes(
            scenarios={"cg_offset_y_m": {"absolute": float(row[key])}}))
        assert row["objective_value"] == pytest.approx(direct.objective_value, abs=0.01)
        rob = json.loads((tmp_path / "sw" / row["run_dir"] / "robust.json").read_text())
        built = rob["nlp_builds"]
        assert built["scenarios"] >= 1 and built["stacks"] >= 1
        # the row counts the exchange's scenario NLPs and stacks, and the nominal table NLP
        # where the point built it: the first (the second's is the same, reused)
        own = int(row["nlp_builds"]) - built["scenarios"] - built["stacks"]
        assert own == (1 if row[key] == 0.02 else 0)
        assert rob["continuation"]["extra_starts"] == int(row["neighbour_starts"])


def test_a_range_given_as_a_number_and_as_a_pair_is_one_text_column(tmp_path):
    """``relative = 0.02`` at one point, ``[0.0, 0.05]`` (a drill cutting oversize only) at
    another: the table's column holds both as JSON text and is written (pyarrow refused the
    mixed column after every point had run)."""
    from isodesign.sweeps.table import frame

    rows = [{"point": "a", "changes": {KEY: 0.02}, "status": "complete"},
            {"point": "b", "changes": {KEY: [0.0, 0.05]}, "status": "complete"}]
    df = frame(rows, [KEY])
    assert list(df[KEY]) == ["0.02", "[0.0, 0.05]"]
    df.to_parquet(tmp_path / "t.parquet")
    assert [json.loads(v) for v in df[KEY]] == [0.02, [0.0, 0.05]]


def test_an_implausible_tolerance_warns_once_naming_the_point(tmp_path, capsys):
    """A 60 % drill tolerance (a percentage typed for a fraction?) is a warning of the
    point, printed once: the worker's rebuild of the point's study warned again, as
    ``<dict>``."""
    f = tmp_path / "robust.toml"
    f.write_text(study_toml(_study()))
    status = main(["sweep", str(f), "--task", "yield", "--vary", f"{KEY}=0.6",
                   "--yield-samples", "4", "--scheduler", "serial", "--quiet",
                   "-o", str(tmp_path / "sw")])
    err = [ln for ln in capsys.readouterr().err.splitlines() if "warning" in ln]
    assert status == 0
    assert err == [f"isodesign: warning: --vary {KEY}=0.6: {KEY}: a deviation of 60 % is far "
                   "above a tolerance (relative is a fraction: 0.05 is 5 %)"]


@pytest.mark.slow
def test_on_dask_each_worker_builds_the_robust_nlps_once(dask_processes, tmp_path):
    """Two Dask workers, three tolerances (one worker solves two): each worker builds its
    nominal NLP and scenario block once, and a stack once per number of scenarios its
    points' exchanges reached; the sweep's count is the rows' sum."""
    res = isodesign.sweep(_study(), vary={KEY: [0.01, 0.02, 0.03]},
                          output=tmp_path / "sw", scheduler=dask_processes.address,
                          options={"yield_samples": 0}, charts=False)
    df = read_table(tmp_path / "sw")
    assert list(df["status"]) == ["complete"] * 3
    assert res.nlp_builds == int(df["nlp_builds"].sum())
    for _, g in df.groupby("worker"):
        robs = [json.loads((tmp_path / "sw" / r / "robust.json").read_text())
                for r in g["run_dir"]]
        blocks = sum(r["nlp_builds"]["scenario_blocks"] for r in robs)
        stacks = sum(r["nlp_builds"]["stacks"] for r in robs)
        sizes = {x["scenarios"] for r in robs for x in r["rounds"]}
        assert blocks == 1
        assert stacks == len(sizes)
        assert int(g["nlp_builds"].sum()) == 1 + blocks + stacks  # the nominal NLP once
