"""Study files with a [table]: the built-in table study, per-axis floors, errors naming keys."""

from __future__ import annotations

import math

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.study import study_from_dict, table_study, vertical_study

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
    assert vertical_study().table is None and vertical_study().floor_axes is None


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


# -- issue 23: a [payload] and a [table] that disagree on geometry --------------------------
@pytest.mark.parametrize("payload, keys", [
    ({"isolators": 6}, ("payload.isolators", "table.isolators_m")),
    ({"cg_height_m": 0.5}, ("payload.cg_height_m", "table.cg_m")),
    ({"spacing_m": 1.0}, ("payload.spacing_m", "table.isolators_m")),
])  # fmt: skip
def test_payload_disagreeing_with_table_names_both_keys(payload, keys):
    with pytest.raises(InputError) as exc:
        study_from_dict({"table": TABLE, "payload": {"mass_kg": 600.0, **payload}},
                        source="s.toml")
    msg = str(exc.value)
    assert msg.startswith("s.toml: ") and "\n" not in msg
    for k in keys:
        assert k in msg, msg


def test_payload_defaults_never_conflict_and_take_the_tables_geometry():
    six = {**TABLE, "isolators_m": [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4],
                                    [0.0, 0.45], [0.0, -0.45]],
           "cg_m": [0.0, 0.0, 0.5], "leveling_groups": [[1, 2], [3, 5], [4, 6]]}
    st = study_from_dict({"table": six, "payload": {"mass_kg": 900.0}}, source="s.toml")
    p = st.payload  # the defaults (4 isolators, 1.2 m, 0.35 m) are not the user's
    assert (p.mass_kg, p.isolators, p.cg_height_m) == (900.0, 6, 0.5)
    assert p.spacing_m == pytest.approx(math.hypot(0.6, 0.05))  # the narrowest distance
    assert st.raw["payload"]["isolators"] == 6 and st.raw["payload"]["cg_height_m"] == 0.5
    # agreeing keys given by the user are kept (any distance between two isolators)
    agree = {"mass_kg": 900.0, "isolators": 6, "spacing_m": 1.2, "cg_height_m": 0.5}
    assert study_from_dict({"table": six, "payload": agree}).payload.spacing_m == 1.2


def test_with_changes_refuses_a_payload_change_the_table_model_would_ignore():
    st = table_study()
    with pytest.raises(InputError, match=r"payload\.cg_height_m = 0\.5.*table\.cg_m"):
        st.with_changes({"payload.cg_height_m": 0.5})
    with pytest.raises(InputError, match=r"payload\.isolators = 5.*table\.isolators_m"):
        st.with_changes({"payload.isolators": 5})
    # a change of the table's geometry carries the payload keys it does not give
    moved = st.with_changes({"table.cg_m": [0.0, 0.0, 0.5]})
    assert moved.payload.cg_height_m == 0.5 and moved.table.cg_height_m == 0.5
    assert st.with_changes({"payload.mass_kg": 700.0}).table.mass_kg == 700.0


# -- issue 23: per-axis floors, relative paths and scale -----------------------------------
def _table_study_text(floor: str) -> str:
    return (
        "[payload]\nmass_kg = 600.0\nisolators = 4\nspacing_m = 0.8\ncg_height_m = 0.35\n"
        "[table]\nisolators_m = [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]]\n"
        "cg_m = [0.0, 0.0, 0.35]\nbox_m = [1.5, 1.0, 0.7]\n" + floor)


def test_relative_axis_floor_paths_are_absolute_in_the_resolved_study(tmp_path, monkeypatch):
    """``[floor.x]``/``[floor.y]`` CSV paths, relative to the study file, are written absolute
    so that the run's own ``study_resolved.toml`` loads from any directory."""
    from isodesign.floor import FloorSpectrum
    from isodesign.io.record import resolved_study_dict, study_toml
    from isodesign.optimization.study import load_study

    d = tmp_path / "job"
    (d / "floors").mkdir(parents=True)
    FloorSpectrum.from_criterion("VC-B").to_csv(d / "floors" / "fx.csv")
    FloorSpectrum.from_criterion("VC-C").to_csv(d / "floors" / "fy.csv")
    (d / "s.toml").write_text(_table_study_text(
        '[floor]\ncriterion = "VC-A"\n[floor.x]\ncsv = "floors/fx.csv"\n'
        '[floor.y]\ncsv = "floors/fy.csv"\n'))
    st = load_study(d / "s.toml")
    res = resolved_study_dict(st)
    for a, name in (("x", "fx.csv"), ("y", "fy.csv")):
        p = res["floor"][a]["csv"]
        assert p == str((d / "floors" / name).resolve())
    assert st.raw["floor"]["x"]["csv"] == "floors/fx.csv"  # the study itself unchanged
    out = tmp_path / "run"
    out.mkdir()
    (out / "study_resolved.toml").write_text(study_toml(st))
    monkeypatch.chdir(tmp_path)
    back = load_study(out / "study_resolved.toml")
    assert back.floor_axes.names == st.floor_axes.names


def test_axis_floor_as_a_fraction_of_another():
    """``[floor.x] scale = 0.3``: 30 % of the vertical floor's velocity (PSD x 0.09); with a
    criterion, 30 % of that criterion's."""
    from isodesign.floor import FloorSpectrum
    from isodesign.optimization.study import study_from_dict

    text = {"payload": {"mass_kg": 600.0, "isolators": 4, "spacing_m": 0.8,
                        "cg_height_m": 0.35},
            "table": {"isolators_m": [[-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4]],
                      "cg_m": [0.0, 0.0, 0.35], "box_m": [1.5, 1.0, 0.7]},
            "floor": {"criterion": "VC-A", "x": {"scale": 0.3},
                      "y": {"scale": 0.5, "criterion": "VC-B"}}}
    st = study_from_dict(text, source="s.toml")
    fx, fy, fz = st.floor_axes.spectra
    vcb = FloorSpectrum.from_criterion("VC-B")
    f = np.array([2.0, 8.0, 50.0])
    np.testing.assert_allclose(fx.psd_velocity(f), 0.09 * fz.psd_velocity(f), rtol=1e-12)
    np.testing.assert_allclose(fy.psd_velocity(f), 0.25 * vcb.psd_velocity(f), rtol=1e-12)
    assert st.floor_axes.names[0] == "0.3 x VC-A floor"
    for bad, words in (({"scale": "0.3"}, "floor.x.scale"), ({"scale": 0}, "(0, 10]"),
                       ({"scale": True}, "floor.x.scale"), ({"scale": 0.3, "colour": 1},
                                                            "unknown key 'colour' in [floor.x]")):
        t = {**text, "floor": {"criterion": "VC-A", "x": bad}}
        with pytest.raises(InputError) as exc:
            study_from_dict(t, source="s.toml")
        assert words in str(exc.value)
