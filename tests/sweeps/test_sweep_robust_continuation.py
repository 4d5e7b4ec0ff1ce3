"""Continuation of robust sweep points (docs/sweep.md, section 7, "Robust points"): a point
with ``[scenarios]`` starts its nominal multi-start from its neighbours' nominal optima, its
exchange's first solve from their robust optima, and its scenario set from their active
scenarios (placed by unit coordinates in its own box, their peak frequencies scaled to its
mass); its answer is the cold robust optimum's within the sweep's 0.01 dB."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

import isodesign
from isodesign.optimization.robust import add_scenarios
from isodesign.optimization.study import vertical_study
from isodesign.sweeps.continuation import PEAK_MASS_EXPONENT, robust_seeds, scenario_units
from isodesign.sweeps.robust_points import _neighbour_nominals
from isodesign.sweeps.table import read_table

VALUES = {"volume_ratio": 3.0, "top_volume_m3": 4e-4, "capillary_length_m": 0.2,
          "capillary_diameter_m": 2e-3}


def _study(**scen):
    return vertical_study().with_changes(
        models={"points_per_band": 3, "peak_points": 10},
        solver={"starts": 1, "tie_break": False},
        scenarios=scen or {"payload_mass_kg": {"relative": 0.05},
                           "capillary_diameter_m": {"relative": 0.02}})


def _row(units, names=("payload_mass_kg", "capillary_diameter_m"), peaks=None, mass=400.0,
         feasible=True, status="complete"):
    return {"feasible": feasible, "status": status, **VALUES,
            "scenario_units": json.dumps({"names": list(names), "units": units,
                                          "peak_hz": peaks or [None] * len(units),
                                          "payload_kg": mass})}


def test_unit_coordinates_keep_a_corner_a_corner_when_the_range_is_swept():
    narrow = _study().scenarios
    wide = _study(payload_mass_kg={"relative": 0.10},
                  capillary_diameter_m={"relative": 0.05}).scenarios
    # the payload's scenario is its mass (600 kg +-5 %), the diameter's its deviation
    corner = np.array([630.0, -0.02])  # a corner of the narrow box
    u = narrow.to_unit(corner)
    assert u == pytest.approx([1.0, 0.0])
    assert wide.from_unit(u) == pytest.approx([660.0, -0.05])
    assert narrow.from_unit(narrow.to_unit(narrow.center())) == pytest.approx(narrow.center())
    # outside [0, 1]: clipped into the box
    assert narrow.from_unit([1.7, -0.3]) == pytest.approx([630.0, -0.02])


def test_a_discrete_parameter_takes_its_nearest_listed_value():
    sp = _study(payload_mass_kg={"values": [380.0, 400.0, 460.0]}).scenarios
    assert sp.to_unit([400.0]) == pytest.approx([0.25])
    assert sp.from_unit([0.3]) == pytest.approx([400.0])
    assert sp.from_unit([0.9]) == pytest.approx([460.0])


def test_the_seeds_are_the_feasible_neighbours_optima_and_active_scenarios():
    sp = _study().scenarios
    rows = [_row([[0.5, 0.5], [1.0, 0.0]], peaks=[1.5, 1.6], mass=400.0),
            _row([[1.0, 0.0], [0.0, 1.0]], mass=420.0),  # one repeat, one new
            _row([[0.0, 0.0]], feasible=False),  # an infeasible neighbour: nothing
            _row([[0.0, 0.0]], status="failed"),
            _row([[0.0, 0.0]], names=("payload_mass_kg", "top_volume_m3")),  # another box
            None]
    starts, thetas, peaks = robust_seeds(rows, sp, mass_kg=440.0)
    # every feasible neighbour's optimum is a start (another box's too: a design is a design)
    assert starts == [VALUES] * 3
    assert [list(t) for t in thetas] == [pytest.approx(list(sp.center())),
                                        pytest.approx([630.0, -0.02]),
                                        pytest.approx([570.0, 0.02])]
    scale = (400.0 / 440.0) ** PEAK_MASS_EXPONENT
    assert peaks == [pytest.approx(1.5 * scale), pytest.approx(1.6 * scale), None]
    # a row without the field (an older sweep's) or with a broken one: starts only
    bad = dict(rows[0], scenario_units="not json")
    assert robust_seeds([bad, {**rows[0], "scenario_units": "[1, 2]"}], sp)[1] == []
    # a row read back from the sweep table of a run without the column (a resumed sweep)
    nan = dict(rows[0], scenario_units=float("nan"), nominal_row=float("nan"))
    assert robust_seeds([nan], sp)[1] == []
    assert _neighbour_nominals([nan, None, {"nominal_row": json.dumps(VALUES)}]) == [
        None, None, VALUES]


def test_a_robust_result_gives_its_active_scenarios_and_their_peaks():
    st = _study()
    sp = st.scenarios
    rows = [{"index": 0, "theta": sp.as_dict(sp.center()), "active": True},
            {"index": 1, "theta": sp.as_dict([630.0, 0.02]), "active": False},
            {"index": 2, "theta": sp.as_dict([570.0, 0.02]), "active": True}]
    res = SimpleNamespace(study=st, scenarios=rows,
                          extra={"continuation": {"peak_hz": [1.4, 1.5, 1.6]}})
    got = json.loads(scenario_units(res))
    assert got["names"] == list(sp.names)
    assert got["units"] == [pytest.approx([0.5, 0.5]), pytest.approx([0.0, 1.0])]
    assert got["peak_hz"] == [1.4, 1.6]
    assert got["payload_kg"] == pytest.approx(st.payload.mass_kg)
    # what it writes, the next point reads back
    _, thetas, peaks = robust_seeds([{"feasible": True, "status": "complete", **VALUES,
                                      "scenario_units": scenario_units(res)}], sp,
                                    st.payload.mass_kg)
    assert [list(t) for t in thetas] == [pytest.approx([600.0, 0.0]),
                                        pytest.approx([570.0, 0.02])]
    assert peaks == [pytest.approx(1.4), pytest.approx(1.6)]


def test_seeding_adds_only_new_scenarios():
    thetas = [np.array([0.0, 0.0]), np.array([0.05, 0.02])]
    n = add_scenarios(thetas, [np.array([0.05, 0.02]), [-0.05, 0.02], [-0.05, 0.02]])
    assert n == 1 and len(thetas) == 3
    assert list(thetas[-1]) == [-0.05, 0.02]


@pytest.fixture(scope="module")
def robust_line(tmp_path_factory):
    out = tmp_path_factory.mktemp("robust_line") / "s"
    isodesign.sweep(_study(), vary={"payload.mass_kg": [380.0, 400.0, 420.0]}, output=out,
                    scheduler="serial", options={"yield_samples": 0}, charts=False)
    return out, read_table(out).sort_values("payload.mass_kg").reset_index(drop=True)


@pytest.mark.slow
def test_a_continued_robust_point_is_the_cold_robust_optimum(robust_line):
    out, df = robust_line
    assert list(df["status"]) == ["complete"] * 3
    assert list(df["question"]) == ["robust"] * 3
    assert list(df["neighbour_starts"]) == [0, 1, 1]
    assert list(df["neighbours_given"]) == [0, 1, 1]
    assert (df["seeded_scenarios"][1:] >= 1).all() and df["seeded_scenarios"][0] == 0
    cold_rounds = 0
    for _, row in df.iterrows():
        cold = isodesign.optimize(_study().with_changes(
            payload={"mass_kg": float(row["payload.mass_kg"])}))
        assert cold.kind == "robust" and cold.converged
        assert bool(row["converged"])
        # the sweep's tolerance (docs/sweep.md, section 7)
        assert row["objective_value"] == pytest.approx(cold.objective_value, abs=0.01)
        cold_rounds += len(cold.rounds) if row["payload.mass_kg"] > 380.0 else 0
        rob = json.loads((out / row["run_dir"] / "robust.json").read_text())
        assert rob["continuation"]["extra_starts"] == row["neighbour_starts"]
        assert rob["continuation"]["seeded_scenarios"] == row["seeded_scenarios"]
        # the nominal optimum the next point continues from is this point's
        nom = json.loads(row["nominal_row"])
        assert nom["capillary_diameter_m"] == pytest.approx(
            rob["nominal_optimum"]["values"]["capillary_diameter_m"], rel=1e-12)
    # the neighbours' scenarios and peaks save exchange rounds (3 or 4 each, cold)
    assert int(df["rounds"][1:].sum()) < cold_rounds
