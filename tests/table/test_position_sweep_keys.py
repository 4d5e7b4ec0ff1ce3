"""Sweeping the free-positions lever (docs/table.md, section 15; docs/sweep.md): ``isodesign
sweep`` takes ``variables.isolator_positions_m.fixed`` in ``--vary`` and every key of the
lever in a points file; ``--vary`` of its list-valued keys (``polygon_m``, ``start``) is
refused in one line naming the key and why; a point's polygon is checked by the study."""

from __future__ import annotations

import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import table_study
from isodesign.sweeps.spec import build_points, parse_vary, read_points

RECT = [[-0.75, -0.5], [0.75, -0.5], [0.75, 0.5], [-0.75, 0.5]]
CUT = [[-0.75, -0.25], [-0.5, -0.5], [0.75, -0.5], [0.75, 0.5], [-0.75, 0.5]]


def _base():
    """The built-in table (table_study()) with a footprint polygon for its positions."""
    return table_study().with_changes(
        variables={"isolator_positions_m": {"polygon_m": RECT}},
        constraints={"min_isolator_distance_m": 0.5})


def test_vary_frees_the_positions_point_by_point():
    key, values = parse_vary("variables.isolator_positions_m.fixed=true,false")
    assert key == "variables.isolator_positions_m.fixed" and values == [True, False]
    points, dropped = build_points(_base(), [{key: v} for v in values])
    assert dropped == 0
    free = [[v.name for v in p.study.levers if v.free] for p in points]
    assert free[0] == [] and free[1][:2] == ["isolator_1_x_m", "isolator_1_y_m"]
    assert len(free[1]) == 8


@pytest.mark.parametrize("field", ["polygon_m", "start"])
def test_vary_of_a_list_valued_position_key_is_refused_naming_it(field):
    with pytest.raises(InputError) as e:
        parse_vary(f"variables.isolator_positions_m.{field}=0.5,0.6")
    msg = str(e.value)
    assert msg.startswith(f"--vary variables.isolator_positions_m.{field}: takes a list of "
                          "[x, y] pairs")
    assert "--points-file" in msg and "\n" not in msg


def test_a_points_file_sweeps_the_polygon_and_the_study_checks_each(tmp_path):
    p = tmp_path / "points.toml"
    p.write_text("[[point]]\nvariables.isolator_positions_m.fixed = false\n"
                 f"variables.isolator_positions_m.polygon_m = {RECT}\n"
                 "[[point]]\nvariables.isolator_positions_m.fixed = false\n"
                 f"variables.isolator_positions_m.polygon_m = {CUT}\n", encoding="utf-8")
    tables = read_points(p)
    points, _ = build_points(_base(), tables, option="--points-file")
    boxes = [{v.name: (v.lower, v.upper) for v in pt.study.levers if v.free}
             for pt in points]
    assert boxes[0]["isolator_1_x_m"] == pytest.approx((-0.765, 0.765))
    assert len(points) == 2 and points[0].study_hash != points[1].study_hash
    assert points[1].study.raw["variables"]["isolator_positions_m"]["polygon_m"] == CUT
    bad = tmp_path / "bad.toml"  # a non-convex polygon: refused naming the key
    bad.write_text("[[point]]\nvariables.isolator_positions_m.fixed = false\n"
                   "variables.isolator_positions_m.polygon_m = [[-0.75, -0.5], [0.75, -0.5], "
                   "[0.0, 0.0], [0.75, 0.5], [-0.75, 0.5]]\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"variables\.isolator_positions_m\.polygon_m: the "
                                         r"polygon is not convex"):
        build_points(_base(), read_points(bad), option="--points-file")
