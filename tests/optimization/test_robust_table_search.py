"""The robust table's search of the box (issue 23): a scenario scored by the NumPy analysis
alone (``table_search.score_table_scenario``) agrees with the scenario's compiled NLP
(``robust_table._Scenarios.check``), and the search with uniform samples and a local
maximization finds an interior worst case that the corners miss."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from isodesign.optimization import robust_table
from isodesign.optimization.study import study_from_dict, table_study
from isodesign.optimization.table_search import score_table_scenario

#: The scorer against the NLP check: the objective J (minus the worst margin, dB) and
#: every constraint group's worst violation (the NLP's units). Both evaluate the same
#: physics at the same NumPy closure; measured 1e-13 dB.
SAME_J_DB = 1e-9
SAME_ROW = 1e-9


def robust_table_study(scenarios, distortion=True, **constraints):
    """``table_study()`` (the built-in table) on a coarse grid, one start, in this process,
    with ``[scenarios]`` and the constraints given."""
    raw = copy.deepcopy(table_study().raw)
    raw["models"]["distortion"] = distortion
    raw["scenarios"] = scenarios
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["constraints"].update(constraints)
    return study_from_dict(raw, source="t.toml", fill_defaults=False)


def _agree(st, values, thetas):
    sc = robust_table._Scenarios(st)
    violated = []
    for th in thetas:
        c = sc.check(th, values, -1.0)
        s = score_table_scenario(st, th, values, -1.0, n_slots=sc.n_slots)
        assert s["j"] == pytest.approx(c["j"], abs=SAME_J_DB)
        assert s["margin_db"] == pytest.approx(c["margin_db"], abs=SAME_J_DB)
        assert s["gap"] == pytest.approx(c["gap"], abs=SAME_J_DB)
        nlp = {n: v for n, v in c["violations"] if n != "implicit_equations"}
        mine = dict(s["violations"])
        assert set(mine) == set(nlp)  # the same rows, by name
        for n, v in nlp.items():
            assert mine[n] == pytest.approx(v, abs=SAME_ROW), n
        # the closure's equations: solved by the NumPy closure the NLP check starts from
        assert dict(c["violations"]).get("implicit_equations", 0.0) < 1e-8
        violated.append(sorted(n for n, v in mine.items() if v > 1e-6))
    return violated


@pytest.mark.parametrize("distortion", [True, False])
def test_scorer_agrees_with_the_nlp_check_on_table_study_corners(distortion):
    """``table_study()`` with payload +-20 %, the built capillary's diameter +-5 % (a
    tolerance: the built spring) and CG offsets +-50 mm, constraints tightened
    so that rows of every kind are violated (peak |T| on the grid, the frozen modes'
    damping and rocking rows, the natural frequency): the same J and the same violated
    rows as the compiled scenario NLP, at two corners, with and without the distortion
    power (``models.distortion``: the NLP's outer fixed point's NumPy terms)."""
    st = robust_table_study({"payload_mass_kg": {"relative": 0.2},
                             "capillary_diameter_m": {"relative": 0.05},
                             "cg_offset_x_m": {"absolute": 0.05},
                             "cg_offset_y_m": {"absolute": 0.05}},
                            distortion, max_peak_transmissibility_db=12.0, min_damping_ratio=0.05,
                            min_rocking_frequency_hz=1.9, max_rocking_frequency_hz=2.6,
                            max_natural_frequency_hz=1.5)
    values = {v.name: v.start for v in st.variables}
    corners = st.scenarios.corners()
    violated = _agree(st, values, [corners[0], corners[11]])
    assert "max_peak_transmissibility_db" in violated[0]
    assert "natural_frequency_hz" in violated[0]
    assert any("rocking" in n for n in violated[0] + violated[1])


def test_search_with_samples_finds_an_interior_worst_case_the_corners_miss():
    """``table_study()`` with the payload in 740-900 kg at its start design: the peak |T|
    row on the NLP's grid (its frequencies fixed) is worst where a resonance meets a grid
    frequency, at about 803 kg, inside the box (a bound of 13.94 dB is exceeded there by
    about 0.014 dB, and not at the corners or at the centre). The search with samples and
    the local maximization finds a violation at least as large as the largest of 81
    scenarios 2 kg apart (a held-out dense sample), and the scenario's compiled NLP
    confirms it; the corners and the centre alone find no violation."""
    from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
    from isodesign.optimization.table_search import search_box

    st = robust_table_study({"payload_mass_kg": {"min": 740.0, "max": 900.0}},
                            max_peak_transmissibility_db=13.94)
    values = {v.name: v.start for v in st.variables}
    sc = robust_table._Scenarios(st)
    space = st.scenarios
    cands = np.vstack([space.corners(limit=robust_table.MAX_CORNERS), space.center()[None, :]])
    ref = 100.0  # no objective shortfall: the constraint alone scores
    key = "max_peak_transmissibility_db"
    masses = np.linspace(740.0, 900.0, 81)
    dense = [score_table_scenario(st, np.array([m]), values, ref,
                                  n_slots=sc.n_slots)["excess"][key] for m in masses]
    assert 0.0 < max(dense) and masses[int(np.argmax(dense))] not in (740.0, 820.0, 900.0)
    kw = {"seed": 0, "tol": 0.01, "feas_tol": FEASIBILITY_TOLERANCE, "n_slots": sc.n_slots}
    corners_only = search_box(st, values, ref, sc.check, cands, samples=0, **kw)
    assert corners_only["score"] <= 1.0  # nothing added: the corners miss it
    found = search_box(st, values, ref, sc.check, cands, samples=16, **kw)
    assert found["score"] > 1.0 and found["which"] == f"constraint:{key}"
    assert found["source"] in ("sample", "refined")
    assert found["check"]["excess"][key] >= max(dense) - 1e-9
    assert 740.0 < found["theta"][0] < 900.0
    ev = found["evaluations"]
    assert ev["samples"] == 16 and 0 < ev["refinements"] <= 3
    assert ev["refinement"] <= 3 * (1 + 40)  # the cap: 40 per refinement (+ a corner's scoring)
    # the scenario's compiled NLP: the same violation
    nlp = dict(sc.check(found["theta"], values, ref)["violations"])[key]
    assert nlp == pytest.approx(found["check"]["excess"][key], abs=SAME_ROW)


def test_no_samples_is_corners_and_centre_alone_in_the_vertical_search_too():
    """``scenarios.search_samples = 0`` (valid since the table's search uses it) means the
    same in ``vertical_study()``'s exchange (``exchange.worst_case``): the corners and the
    centre scored, no sample and no local maximization; 2 samples add 2 evaluations and
    the maximization's."""
    from isodesign.optimization.exchange import worst_case
    from isodesign.optimization.study import vertical_study

    raw = copy.deepcopy(vertical_study().raw)
    raw["scenarios"] = {"payload_mass_kg": {"relative": 0.1},
                        "capillary_diameter_m": {"relative": 0.05}, "search_samples": 0}
    st = study_from_dict(raw, source="t.toml", fill_defaults=False)
    assert st.scenarios.settings["search_samples"] == 0
    values = {v.name: v.start for v in st.variables}
    none = worst_case(st, values, 0.0, samples=0)
    assert none["evaluations"] == len(st.scenarios.corners()) + 1
    some = worst_case(st, values, 0.0, samples=2)
    assert some["evaluations"] > len(st.scenarios.corners()) + 1 + 2
    assert some["score"] >= none["score"]


def test_the_search_in_forked_workers_finds_what_it_finds_in_one_process(monkeypatch):
    """The samples and the maximizations of ``search_box`` run in the forked workers the
    study allows (``solver.workers = 2``) and find the same worst scenario, score and counts
    as in one process (``workers = 1``): each task depends on its scenario alone."""
    from isodesign.optimization import executor
    from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
    from isodesign.optimization.table_search import search_box

    st1 = robust_table_study({"payload_mass_kg": {"min": 740.0, "max": 900.0}},
                             max_peak_transmissibility_db=13.94)
    st2 = st1.with_changes(solver={"workers": 2})
    values = {v.name: v.start for v in st1.variables}
    sc = robust_table._Scenarios(st1)
    space = st1.scenarios
    cands = np.vstack([space.corners(limit=robust_table.MAX_CORNERS), space.center()[None, :]])
    kw = {"samples": 16, "seed": 0, "tol": 0.01, "feas_tol": FEASIBILITY_TOLERANCE,
          "n_slots": sc.n_slots}
    import os

    # two cores, whatever this machine has (map_in_workers caps the workers by them)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    maps = []
    real = executor.ForkExecutor.map_unordered

    def counted(self, fn, items):
        maps.append(fn)
        return real(self, fn, items)

    monkeypatch.setattr(executor.ForkExecutor, "map_unordered", counted)
    one = search_box(st1, values, 100.0, sc.check, cands, **kw)
    assert not maps  # one worker: in this process
    two = search_box(st2, values, 100.0, sc.check, cands, **kw)
    assert len(maps) == 2  # the samples, then the maximizations
    assert two["score"] == one["score"] and two["which"] == one["which"]
    assert two["source"] == one["source"] and two["evaluations"] == one["evaluations"]
    np.testing.assert_array_equal(two["theta"], one["theta"])
