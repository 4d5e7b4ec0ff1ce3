"""A payload per isolator below any pneumatic isolator's: tonnes typed as kg (issue 23).

``sweep --vary payload.mass_kg=0.5,0.6`` (600 kg meant) ran without a word: the mass alone is
within its plausible range, the load per isolator is not. One UnitWarning per point, by the
plausibility path every study goes through (the loader and ``with_changes``).
"""

from __future__ import annotations

import warnings

import pytest

from isodesign.io.plausible import MIN_LOAD_PER_ISOLATOR_KG, UnitWarning, unit_slips
from isodesign.optimization.study import study_from_dict, vertical_study
from isodesign.sweeps.spec import build_points


def _unit_warnings(call) -> list[str]:
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        call()
    return [str(w.message) for w in rec if issubclass(w.category, UnitWarning)]


def test_sweep_points_in_tonnes_warn_per_point():
    msgs = _unit_warnings(lambda: build_points(
        vertical_study(), [{"payload.mass_kg": 0.5}, {"payload.mass_kg": 0.6}]))
    assert len(msgs) == 2, msgs
    assert "payload.mass_kg = 0.5 kg on 4 isolators" in msgs[0]
    assert "0.125 kg per isolator" in msgs[0] and "0.5 t would be 500 kg" in msgs[0]
    assert "0.6 t would be 600 kg" in msgs[1]


def test_realistic_payloads_do_not_warn():
    assert not _unit_warnings(lambda: build_points(
        vertical_study(), [{"payload.mass_kg": 500.0}, {"payload.mass_kg": 600.0}]))
    assert not _unit_warnings(lambda: study_from_dict({"payload": {"mass_kg": 8.0}}))


def test_the_study_loader_uses_the_studys_isolators():
    # 12 kg is plausible on one isolator, not on eight (given in the file or the base study)
    assert _unit_warnings(lambda: study_from_dict(
        {"payload": {"mass_kg": 12.0, "isolators": 8}}, source="s.toml"))
    st = vertical_study().with_changes({"payload.isolators": 8})
    msgs = _unit_warnings(lambda: st.with_changes({"payload.mass_kg": 12.0}))
    assert any("on 8 isolators is 1.5 kg per isolator" in m for m in msgs), msgs


@pytest.mark.parametrize("table", ["payload", "load"])
def test_unit_slips_names_the_table(table):
    msgs = unit_slips({table: {"mass_kg": 1.0, "isolators": 4}}, "f.toml")
    assert msgs and msgs[0].startswith(f"f.toml: {table}.mass_kg = 1 kg on 4 isolators")
    assert not unit_slips({table: {"mass_kg": 4 * MIN_LOAD_PER_ISOLATOR_KG, "isolators": 4}})
