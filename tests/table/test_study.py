"""Study files with a [table]: the built-in table study, per-axis floors, errors naming keys."""

from __future__ import annotations

import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import default_study, study_from_dict, table_study

TABLE = {
    "isolators_m": [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]],
    "cg_m": [0.0, 0.0, 0.35],
    "box_m": [1.5, 1.0, 0.7],
}


def test_builtin_table_study():
    st = table_study()
    t = st.table
    assert st.name == "table" and t.n_isolators == 4 and t.mass_kg == 600.0
    assert t.cg_height_m == 0.35 and t.leveling_groups == ((0, 1), (2,), (3,))
    assert st.floor_axes.names == ("VC-A floor",) * 3
    assert "applied to x and y" in st.floor_axes.notes[0]
    assert st.target.name == "VC-C" and t.point_names == ("centre", "corner")
    assert default_study().table is None and default_study().floor_axes is None


def test_floor_per_axis_in_a_study():
    st = study_from_dict({"table": TABLE, "floor": {"criterion": "VC-A",
                                                    "x": {"criterion": "VC-B"}, "y": False}})
    assert st.floor_axes.names == ("VC-B floor", "none", "VC-A floor")
    assert st.floor_axes.notes == ()


@pytest.mark.parametrize("change, fragment", [
    ({"cg_m": [0.9, 0.0, 0.35]}, "table.cg_m: the centre of gravity"),
    ({"leveling_groups": [[1, 2], [3], [5]]}, "table.leveling_groups: isolator numbers run "
                                              "from 1 to 4"),
    ({"inertia_kg_m2": [1, 2, 3]}, "give inertia_kg_m2 or box_m"),
    ({"supply_pressure_pa": 2.0e5}, "table.supply_pressure_pa: isolator"),
    ({"horizontal": {"pendulum_length_m": -1.0}}, "table.horizontal.pendulum_length_m"),
    ({"horizontal": {"pendulum": 1.0}}, "unknown key 'pendulum' in [table.horizontal]"),
    ({"wheels": 4}, "unknown key 'wheels' in [table]"),
])  # fmt: skip
def test_table_errors_name_the_key(change, fragment):
    with pytest.raises(InputError) as exc:
        study_from_dict({"table": {**TABLE, **change}}, source="s.toml")
    assert str(exc.value).startswith("s.toml: ") and fragment in str(exc.value)


def test_isolator_count_must_match_and_axes_need_a_table():
    with pytest.raises(InputError, match=r"payload\.isolators = 3"):
        study_from_dict({"table": TABLE, "payload": {"isolators": 3}})
    with pytest.raises(InputError, match=r"floor\.x applies only to a study with a \[table\]"):
        study_from_dict({"floor": {"criterion": "VC-A", "x": {"criterion": "VC-B"}}})
