"""The table study's parametric NLP (isodesign.optimization.table_parametric): a point solved
on the shared NLP is the point's own freshly built NLP (the same function, the same
optimum), and the cache builds one NLP per structure (docs/sweep.md, section 7)."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.optimization.parametric import ProblemCache
from isodesign.optimization.table_parametric import TableParametricProblem
from isodesign.optimization.table_problem import TableProblem

#: What a table sweep varies without changing the NLP's structure.
CHANGES = [{"floor.criterion": "VC-B"},
           {"floor.x": {"scale": 0.5}},  # one axis's level
           {"target.criterion": "VC-D"},
           {"variables.capillary_length_m.start": 0.02},  # a continued point's start
           # the constraints' bounds: only the rows' lbg/ubg (set per point)
           {"constraints.max_natural_frequency_hz": 2.0},
           # the payload: its mass, CG height, both (the loads, p0, mass matrix, tilt rows,
           # pendulum and body points follow as parameters)
           {"payload.mass_kg": 650.0, "table.cg_m": [0.0, 0.0, 0.25]},
           # the CG's plan position: the leveling's load fractions, every lever arm
           {"payload.mass_kg": 560.0, "table.cg_m": [-0.05, 0.03, 0.45]},
           # the supply (group) pressure: the point's leveling checks it, no row holds it
           {"table.supply_pressure_pa": 650000.0},
           # the same kinds once more each, in the slow phase
           *(pytest.param(c, marks=pytest.mark.slow) for c in (
               {"constraints.max_total_volume_m3": 0.004},
               {"constraints.min_natural_frequency_hz": 1.2},
               {"constraints.max_peak_transmissibility_db": 12.0},
               {"payload.mass_kg": 700.0},
               {"payload.mass_kg": 480.0},
               {"table.cg_m": [0.0, 0.0, 0.5]},
               {"table.cg_m": [0.06, -0.04, 0.35]}))]


@pytest.fixture(scope="module")
def base(small_table_study):
    return small_table_study()  # table_study(), 3 points per band, 4-20 Hz


@pytest.fixture(scope="module")
def cache(base):
    c = ProblemCache()
    c.get(base)
    return c


def _start(study):
    return {v.name: v.start for v in study.variables}


@pytest.mark.parametrize("change", CHANGES, ids=lambda c: next(iter(c)))
def test_a_table_point_on_the_shared_nlp_is_its_own_fresh_nlp(base, cache, change):
    st = base.with_changes(change)
    view = cache.get(st)
    assert isinstance(view, TableParametricProblem) and cache.builds == 1
    fresh = TableProblem(st)
    x0v, x0f = view.initial_guess(_start(st)), fresh.initial_guess(_start(st))
    np.testing.assert_allclose(x0v, x0f, rtol=1e-12, atol=1e-12)
    jv, gv = view.eval_fn(x0v, view.params())
    jf, gf = fresh.eval_fn(x0f, fresh.params())
    assert float(jv) == pytest.approx(float(jf), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(np.asarray(gv), np.asarray(gf), rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(view.lbg, fresh.lbg)
    np.testing.assert_array_equal(view.ubg, fresh.ubg)
    sv, sf = view.solve(x0v), fresh.solve(x0f)
    assert sv.feasible and sf.feasible
    # the same optimum: the worst margin in dB to 1e-6 dB, the design to 1e-6 relative
    assert view.worst_margin_db(sv.x) == pytest.approx(fresh.worst_margin_db(sf.x), abs=1e-6)
    for k, v in sf.values.items():
        assert sv.values[k] == pytest.approx(v, rel=1e-6), k


def test_the_cache_builds_one_table_nlp_per_structure(base):
    c = ProblemCache()
    for ch in [{}, *(c if isinstance(c, dict) else c.values[0] for c in CHANGES)]:
        c.get(base.with_changes(ch))
    assert c.builds == 1 and len(c) == 1
    # the payload's mass: a parameter; another isolator count, another objective: another
    # structure each
    c.get(base.with_changes({"payload.mass_kg": 700.0}))
    assert c.builds == 1
    c.get(base.with_changes(table={**base.raw["table"], "isolators_m": [
        [-0.6, -0.4], [0.6, -0.4], [0.6, 0.4], [-0.6, 0.4], [0.0, 0.45]],
        "leveling_groups": [[1, 2], [3, 5], [4]]}))
    assert c.builds == 2
    c.get(base.with_changes({"objective.kind": "total_volume"}))
    assert c.builds == 3
    # back to the first structure: no build
    c.get(base.with_changes({"floor.criterion": "VC-C"}))
    assert c.builds == 3 and len(c) == 3
    # a bound switched on or off adds or drops rows: another structure; its value alone not
    on = c.get(base.with_changes({"constraints.max_stroke_m": 0.01}))
    assert c.builds == 4
    assert c.get(base.with_changes({"constraints.max_stroke_m": 0.02})).key == on.key
    assert c.builds == 4
    c.get(base.with_changes({"constraints.max_natural_frequency_hz": None}))
    assert c.builds == 5


def test_a_grid_of_other_frequencies_is_another_structure(base, cache):
    prob = cache.get(base)
    assert prob.at(base.with_changes({"models.points_per_band": 4})) is None
    assert prob.at(base.with_changes({"target.band_max_hz": 40.0})) is None


def test_a_vertical_or_robust_study_is_not_a_table_parametric_nlp(base):
    from isodesign.optimization.study import vertical_study

    with pytest.raises(InputError, match=r"\[table\]"):
        TableParametricProblem(vertical_study())
    assert TableParametricProblem.at(ProblemCache().get(base), vertical_study()) is None


@pytest.mark.slow
@pytest.mark.parametrize("change", [{"floor.criterion": "VC-B"},
                                    {"payload.mass_kg": 700.0, "table.cg_m": [0.04, -0.03, 0.5]}],
                         ids=["floor", "payload"])
def test_the_whole_table_optimize_on_a_view_is_the_fresh_optimize(base, cache, change):
    from isodesign.optimization.table_driver import optimize_table

    st = base.with_changes(change)
    a = optimize_table(st, workers=1, analyze=False, problem=cache.get(st))
    b = optimize_table(st, workers=1, analyze=False)
    assert a.feasible and b.feasible
    assert a.objective_value == pytest.approx(b.objective_value, abs=1e-6)
    for k, v in b.values.items():
        assert a.values[k] == pytest.approx(v, rel=1e-5), k


def test_a_table_optimize_builds_its_nlp_once_in_its_process(base, tmp_path, monkeypatch):
    """The multi-start's workers (forked) inherit the built NLP: every build is the
    calling process's, one per structure (the NLP, and the one with movable peak
    frequencies when the refinement needs it)."""
    import os

    from isodesign.optimization.table_driver import optimize_table

    log = tmp_path / "builds.txt"
    real = TableProblem._build

    def counted(self, ca):
        with open(log, "a", encoding="utf-8") as fh:  # forked workers append here too
            fh.write(f"{os.getpid()} {self.n_slots}\n")
        return real(self, ca)

    monkeypatch.setattr(TableProblem, "_build", counted)
    res = optimize_table(base.with_changes(solver={"starts": 3, "workers": 2}), workers=2,
                         analyze=False)
    builds = [line.split() for line in log.read_text(encoding="utf-8").splitlines()]
    assert {pid for pid, _ in builds} == {str(os.getpid())}
    slots = [int(n) for _, n in builds]
    assert slots[0] == 0 and len(slots) == 1 + (res.peak["rounds"] > 0)


def test_the_payload_on_the_co_designed_tables_nlp_is_its_fresh_nlp():
    """default_study() (four horizontal levers free: the loads enter the pendulum and the
    elastic centres through the levers' path): a heavier payload with a lower CG on the
    shared NLP is its fresh build (every row to 1e-10, the optimum to 1e-6 dB)."""
    import copy

    from isodesign.optimization.study import default_study, study_from_dict

    raw = copy.deepcopy(default_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    base = study_from_dict(raw, source="small_codesign.toml", fill_defaults=False)
    assert any(v.free for v in base.levers)
    c = ProblemCache()
    c.get(base)
    st = base.with_changes({"payload.mass_kg": 720.0, "table.cg_m": [0.0, 0.0, 0.25]})
    view, fresh = c.get(st), TableProblem(st)
    assert c.builds == 1
    x0 = view.initial_guess(_start(st))
    np.testing.assert_allclose(x0, fresh.initial_guess(_start(st)), rtol=1e-12, atol=1e-12)
    jv, gv = view.eval_fn(x0, view.params())
    jf, gf = fresh.eval_fn(x0, fresh.params())
    assert float(jv) == pytest.approx(float(jf), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(np.asarray(gv), np.asarray(gf), rtol=1e-10, atol=1e-12)
    sv, sf = view.solve(x0), fresh.solve(x0)
    assert sv.feasible and sf.feasible
    assert view.worst_margin_db(sv.x) == pytest.approx(fresh.worst_margin_db(sf.x), abs=1e-6)


def test_the_payload_is_structure_where_its_own_path_holds_the_start_loads(base):
    """A free inertia base moves the mass and CG through its lever (and its rows hold the
    start's loads): there the payload's values are structure; a free layout lever stretches
    the layout about the CG: there the CG's plan position is structure."""
    from isodesign.optimization.table_parametric import (
        cg_plan_parametric,
        payload_parametric,
        table_structure_key,
    )

    assert payload_parametric(base) and cg_plan_parametric(base)
    k0 = table_structure_key(base)
    assert table_structure_key(base.with_changes({"payload.mass_kg": 700.0,
                                                  "table.cg_m": [0.05, 0.0, 0.5]})) == k0
    lay = base.with_changes(variables={"layout_length_m": {"fixed": False}})
    assert payload_parametric(lay) and not cg_plan_parametric(lay)
    assert table_structure_key(lay.with_changes({"table.cg_m": [0.05, 0.0, 0.35]})) != \
        table_structure_key(lay)
    slab = base.with_changes(variables={"inertia_base_mass_kg": {"fixed": False}})
    assert not payload_parametric(slab)
    assert table_structure_key(slab.with_changes({"payload.mass_kg": 700.0})) != \
        table_structure_key(slab)


def test_the_supply_pressure_is_the_points_on_the_shared_nlp(base, cache):
    st = base.with_changes({"table.supply_pressure_pa": 650000.0})
    view = cache.get(st)
    assert cache.builds == 1  # no second NLP: no row holds the supply on this path
    # the point's own table and leveling: the load and supply checks and reports are its
    assert view.table.supply_pressure_pa == 650000.0
    assert view.leveling.supply_pressure_pa == pytest.approx(650000.0)
    fresh = TableProblem(st)
    np.testing.assert_allclose(view.leveling.pressure_pa, fresh.leveling.pressure_pa,
                               rtol=1e-12)


def test_a_sweep_that_varies_no_payload_key_folds_the_payload_into_its_nlp(base):
    import casadi as ca

    from isodesign.sweeps.tasks import payload_varies

    assert not payload_varies({"floor.criterion": "VC-B", "floor.x": {"scale": 0.5},
                               "target.criterion": "VC-D", "constraints.max_stroke_m": 1e-3,
                               "variables.capillary_length_m.start": 0.02})
    assert payload_varies({"floor.criterion": "VC-B", "payload.mass_kg": 650.0})
    assert payload_varies({"table.supply_pressure_pa": 650000.0})
    c = ProblemCache()
    st = base.with_changes({"floor.criterion": "VC-B"})
    view = c.get(st, payload=False)
    assert c.builds == 1 and view._n_payload == 0
    fresh = TableProblem(st)
    # the per-frequency physics is the fresh build's (the payload's numbers folded)
    assert view._point_function(ca).n_instructions() == \
        fresh._point_function(ca).n_instructions()
    x0v, x0f = view.initial_guess(_start(st)), fresh.initial_guess(_start(st))
    jv, gv = view.eval_fn(x0v, view.params())
    jf, gf = fresh.eval_fn(x0f, fresh.params())
    assert float(jv) == pytest.approx(float(jf), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(np.asarray(gv), np.asarray(gf), rtol=1e-10, atol=1e-12)
    # another floor on the same NLP; another payload is another structure there
    assert c.get(base.with_changes({"floor.criterion": "VC-C"}), payload=False) is not None
    assert c.builds == 1
    c.get(base.with_changes({"payload.mass_kg": 650.0}), payload=False)
    assert c.builds == 2
