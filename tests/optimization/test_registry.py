"""The objective registry and the typed optimizer solution."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization import FEASIBILITY_TOLERANCE, OBJECTIVES, Solution
from isodesign.optimization.objectives import objective
from isodesign.optimization.study import vertical_study


def _solution(violations) -> Solution:
    return Solution(x=np.zeros(3), values={}, objective=0.0, objectives=np.zeros(1),
                    g=np.zeros(0), violations=tuple(violations), status="Solve_Succeeded",
                    success=True, iterations=1, wall_s=0.0)


def test_feasible_is_judged_by_the_one_tolerance():
    assert _solution([("a", 0.0), ("b", FEASIBILITY_TOLERANCE)]).feasible
    s = _solution([("implicit_equations", 3e-7), ("b", 2.0 * FEASIBILITY_TOLERANCE),
                   ("c", 0.5)])
    assert not s.feasible
    assert s.max_violation == 0.5
    assert s.equation_residual == 3e-7
    assert s.violated() == (("c", 0.5), ("b", 2.0 * FEASIBILITY_TOLERANCE))
    assert _solution([]).feasible and _solution([]).max_violation == 0.0


def test_every_study_objective_is_registered_with_its_sense_and_unit():
    assert list(OBJECTIVES) == ["worst_band_margin", "rms_velocity", "peak_transmissibility",
                                "transmissibility_at", "total_volume", "footprint_area",
                                "added_mass"]
    assert [k for k, o in OBJECTIVES.items() if o.maximized] == ["worst_band_margin"]
    assert {k: o.unit for k, o in OBJECTIVES.items()} == {
        "worst_band_margin": "dB", "rms_velocity": "m/s", "peak_transmissibility": "dB",
        "transmissibility_at": "dB", "total_volume": "m^3", "footprint_area": "m^2",
        "added_mass": "kg"}
    for kind in OBJECTIVES:  # every registered objective is a valid study objective
        st = vertical_study().with_changes(objective={"kind": kind, "frequency_hz": 10.0})
        assert st.objective["kind"] == kind


@pytest.mark.parametrize("kind,natural", [
    ("worst_band_margin", 5.0), ("worst_band_margin", -3.0), ("peak_transmissibility", 14.0),
    ("transmissibility_at", -20.0), ("rms_velocity", 3e-6), ("total_volume", 6e-3),
    ("added_mass", 250.0)])
def test_internal_and_natural_values_are_inverse(kind, natural):
    o = OBJECTIVES[kind]
    j = o.from_natural(natural)
    assert o.to_natural(j) == pytest.approx(natural, rel=1e-12)
    # J is minimized: a better natural value has a smaller J
    better = natural + (1.0 if o.maximized else -0.5 * abs(natural))
    assert o.from_natural(better) < j


def test_log_objectives_reject_non_positive_bounds():
    with pytest.raises(InputError, match="total_volume must be > 0"):
        OBJECTIVES["total_volume"].from_natural(0.0)
    with pytest.raises(InputError, match=r"objective\.kind: unknown 'foo'"):
        objective("foo")


def test_display_formats():
    assert OBJECTIVES["worst_band_margin"].format(5.0) == "+5.000 dB"
    assert OBJECTIVES["total_volume"].format(6e-3) == "6 L"
    assert OBJECTIVES["rms_velocity"].format(1.234e-6) == "1.234 um/s"
    assert OBJECTIVES["peak_transmissibility"].format(None) == "n/a"
    assert math.isclose(OBJECTIVES["total_volume"].display_scale, 1e3)
