"""Public API calls with wrong types end in one InputError naming the parameter (issue 23).

Never a raw TypeError, ValueError or AttributeError from inside: the error names the
parameter as the caller wrote it and what it accepts.
"""

from __future__ import annotations

import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.optimization.study import table_study, vertical_study
from isodesign.table import leveling as lv
from isodesign.table import leveling_loop as ll
from isodesign.table import modes as md
from isodesign.table.model import table_model
from isodesign.table.statics import level


@pytest.fixture(scope="module")
def parts():
    st = table_study()
    design = st.start_design()
    model = table_model(design, st.table)
    system = lv.leveling_of_study(st)
    return {"study": st, "design": design, "model": model, "system": system,
            "plant": lv.leveling_plant(model, system), "loop": ll.leveling_loop(model, system)}


def _refused(call, *fragments):
    with pytest.raises(InputError) as exc:
        call()
    msg = str(exc.value)
    assert "\n" not in msg
    for f in fragments:
        assert f in msg, msg


def test_optimize_progress_must_be_callable():
    _refused(lambda: isodesign.optimize(vertical_study(), progress=5), "progress:", "callable")


def test_report_inputs_must_be_paths():
    _refused(lambda: isodesign.report(5), "inputs:", "int")
    _refused(lambda: isodesign.report([5]), "inputs:")


@pytest.mark.parametrize("bad", ["x", None, -1.0, float("nan"), [1, 2]])
def test_level_piston_area(parts, bad):
    _refused(lambda: level(parts["study"].table, bad), "piston_area_m2:", "> 0")


BAD_OBJECTS = ["x", 5, -1.0, [1, 2], True]


@pytest.mark.parametrize("bad", BAD_OBJECTS)
@pytest.mark.parametrize("name, call", [
    ("model", lambda p, b: lv.leveling_plant(b, p["system"])),
    ("system", lambda p, b: lv.leveling_plant(p["model"], b)),
    ("plant", lambda p, b: lv.simulate_leveling(b, 1.0)),
    ("study", lambda p, b: lv.leveling_of_study(b)),
    ("study", lambda p, b: lv.valve_gain_bounds(b)),
    ("study", lambda p, b: lv.leveling_margin_bounds(b)),
    ("table", lambda p, b: lv.leveling_from_dict({}, b)),
    ("model", lambda p, b: ll.leveling_loop(b, p["system"])),
    ("system", lambda p, b: ll.leveling_loop(p["model"], b)),
    ("model", lambda p, b: ll.max_valve_gain(b, p["system"], 6.0, 45.0)),
    ("system", lambda p, b: ll.max_valve_gain(p["model"], b, 6.0, 45.0)),
    ("design", lambda p, b: ll.study_valves(p["study"], b)),
    ("loop", lambda p, b: ll.load_step(b, 10.0, [0.0, 0.0, 0.7])),
    ("system", lambda p, b: ll.describing_function(1e-4, b)),
    ("loop", lambda p, b: ll.limit_cycle(b)),
    ("loop", lambda p, b: ll.leveling_transmissibility(b, [1.0])),
    ("model", lambda p, b: md.table_modes(b)),
    ("model", lambda p, b: md.rocking_stability(b)),
    ("model", lambda p, b: md.mode_solutions(b)),
])  # fmt: skip
def test_table_api_refuses_wrong_objects_by_name(parts, name, call, bad):
    _refused(lambda: call(parts, bad), f"{name}:", "expected")


@pytest.mark.parametrize("bad", ["x", -1.0, 0.0, float("nan"), float("inf")])
@pytest.mark.parametrize("name, call", [
    ("duration_s", lambda p, b: lv.simulate_leveling(p["plant"], b)),
    ("mass_kg", lambda p, b: ll.load_step(p["loop"], b, [0.0, 0.0, 0.7])),
    ("duration_s", lambda p, b: ll.load_step(p["loop"], 10.0, [0.0, 0.0, 0.7], b)),
    ("amplitude_m", lambda p, b: ll.describing_function(b, p["system"])),
    ("amplitude_m", lambda p, b: ll.describing_function([1e-4, b], p["system"])),
    ("frequency_hz", lambda p, b: ll.leveling_transmissibility(p["loop"], b)),
    ("frequency_hz", lambda p, b: ll.leveling_transmissibility(p["loop"], [1.0, b])),
    ("amplitude_m", lambda p, b: md.table_modes(p["model"], amplitude_m=b)),
    ("frequency_hz", lambda p, b: md.rocking_stability(p["model"], frequency_hz=b)),
])  # fmt: skip
def test_table_api_refuses_bad_numbers_by_name(parts, name, call, bad):
    _refused(lambda: call(parts, bad), f"{name}:")


@pytest.mark.parametrize("kwargs, key", [
    ({"rank": "x"}, "rank:"), ({"rank": -1}, "rank:"), ({"rank": 1.5}, "rank:"),
    ({"rank": True}, "rank:"), ({"frequency_range_hz": 5}, "frequency_range_hz:"),
    ({"frequency_range_hz": (20.0, 1.0)}, "frequency_range_hz:"),
    ({"frequency_range_hz": ("a", 1.0)}, "frequency_range_hz:"),
    ({"frequency_range_hz": (-1.0, 1.0)}, "frequency_range_hz:"),
])  # fmt: skip
def test_mode_solutions_refuses_bad_arguments_by_name(parts, kwargs, key):
    _refused(lambda: md.mode_solutions(parts["model"], **kwargs), key)


@pytest.mark.parametrize("position", ["x", None, [1, 2], [0.0, 0.0, float("nan")],
                                      [0.0, "a", 0.7]])
def test_load_step_position(parts, position):
    _refused(lambda: ll.load_step(parts["loop"], 10.0, position), "position_m:")


@pytest.mark.parametrize("margins", [("x", 45.0), (6.0, [1]), (-3.0, 45.0)])
def test_max_valve_gain_margins(parts, margins):
    _refused(lambda: ll.max_valve_gain(parts["model"], parts["system"], *margins), "margin")


def test_stability_module_refuses_wrong_objects_by_name():
    from isodesign.response.stability import stability_figures, stability_of_model
    from isodesign.table.stability_report import stability_section, static_verdict

    st = vertical_study()
    _refused(lambda: stability_of_model("x", st.payload), "model:", "SpringModel")
    _refused(lambda: stability_figures("x", st.payload), "design:")
    _refused(lambda: stability_figures(st.start_design(), 5), "payload:")
    _refused(lambda: stability_section("x"), "model:", "TableModel")
    _refused(lambda: static_verdict("x"), "stab:", "RockingStability")
