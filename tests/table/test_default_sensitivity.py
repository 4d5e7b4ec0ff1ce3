"""The default study's levers (``default_study()``: the built-in table co-designed, its
springs per leveling group, its horizontal element and its spacing free, docs/table.md
section 13): the worst margin's exact sensitivity to every free lever's bound is reported,
and each active bound's is checked against a central difference of the re-optimized design
(the bound moved out and in, each solve from the optimum's design)."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.optimization.study import default_study
from isodesign.optimization.table_driver import optimize_table

#: The bound moves by this fraction of its value each way.
STEP = 0.005
#: The least change of the worst margin over 1 % of an active bound that is differenced, dB.
MATERIAL_DB = 0.007


def _small():
    """The default study on a coarse grid, one start (one solve)."""
    return default_study().with_changes(models={"points_per_band": 3, "peak_points": 30},
                                        solver={"starts": 1, "workers": 1})


def _from(st, values: dict, bounds: dict | None = None):
    """``st`` with every free variable and lever starting at ``values`` (clipped into its
    bounds, ``bounds`` changed first)."""
    bounds = bounds or {}
    changes = {}
    for v in (*st.variables, *st.levers):
        if v.fixed or v.name not in values:
            continue
        lo, hi = bounds.get(v.name, {}).get("lower", v.lower), \
            bounds.get(v.name, {}).get("upper", v.upper)
        changes[v.name] = {**bounds.get(v.name, {}),
                           "start": min(max(float(values[v.name]), lo), hi)}
    return st.with_changes(variables=changes)


@pytest.mark.slow
@pytest.mark.xfail(strict=False, reason=(
    "known failure since the tube rows of the model's validity (docs/table.md section 13, "
    "'The worst margin's exact sensitivity'): on this coarse grid the one-start optimum has "
    "valve 2's D_c on its 3 mm bound (800 dB per m); both re-optimizations with the bound "
    "0.5 % out and in meet every constraint, but the inward one lands 0.0035 dB low (one-sided "
    "differences 784 out, 1,035 in: central 910, 14 % off); at 1 % the outward one reaches "
    "another optimum 0.07 dB higher"))
def test_every_free_levers_sensitivity_against_a_central_difference_of_the_reoptimized_design():
    st = _small()
    r = optimize_table(st, workers=1, analyze=False)
    assert r.success and r.feasible
    free = [v.name for v in st.levers if v.free]
    sens = {s["name"]: s for s in r.lever_sensitivity}
    assert set(sens) == set(free)  # every lever of the default study has its entry
    # an active bound whose exact sensitivity moves the margin by less than MATERIAL_DB over
    # 1 % of the bound is not differenced: the re-optimized design's own tolerance (the
    # continuous peak's refinement, 1e-3 dB) and its neighbouring optima would be measured
    active = [s for s in sens.values() if s["at_bound"]
              and abs(s["db_per_unit"]) * 0.01 * abs(s[s["at_bound"]]) >= MATERIAL_DB]
    assert active, "no lever on a bound with a material sensitivity: nothing to difference"
    base = _from(st, r.values)
    for s in active:
        b = s[s["at_bound"]]
        h = STEP * abs(b)

        def moved(delta, s=s, b=b):
            res = optimize_table(_from(base, r.values, {s["name"]: {s["at_bound"]: b + delta}}),
                                 workers=1, analyze=False)
            # a re-optimization that misses its peak bound measures nothing
            assert res.feasible and res.success, (s["name"], delta, res.violations)
            return res.objective_value

        fd = (moved(h) - moved(-h)) / (2 * h)
        # the bound multiplier is exact; the difference is of the re-optimized design
        assert s["db_per_unit"] == pytest.approx(fd, rel=0.05, abs=1e-5 / h), (s, fd)


#: The step of the scaled lever's bound (z in [-1, 1]) in the same-NLP difference.
Z_STEP = 2e-3


@pytest.mark.slow
def test_every_active_bounds_sensitivity_against_the_same_nlp_re_solved_with_it_moved(
        monkeypatch):
    """What the reported number claims, checked where it is well posed: the multiplier of
    an active lever bound is the derivative of the NLP's optimal objective with respect to
    that bound (the envelope theorem, docs/table.md section 13). So the NLP the sensitivity
    was read from (its peak frequencies, frozen modes and distortion expansion as they
    were) is solved again with the scaled lever's bound moved by +-Z_STEP, warm from the
    optimum and its multipliers (so that IPOPT stays on that optimum: a cold re-solve from
    the optimum's point can leave it for another local optimum), and the central difference
    of its optimal worst margin, per unit of the lever's bound, must be the reported
    ``db_per_unit`` within 1 %.
    The test above differences the whole optimizer (its refinement included), whose
    optimum moves between neighbouring local optima by as much as the change it measures."""
    from isodesign.optimization.nlp import NLP
    from isodesign.optimization.table_problem import TableProblem

    seen = {}
    real = TableProblem.lever_sensitivities

    def spy(self, x, sol=None):
        out = real(self, x, sol)
        seen.update(prob=self, sol=sol, p=np.array(self.params(), float), out=out)
        return out

    monkeypatch.setattr(TableProblem, "lever_sensitivities", spy)
    st = _small()
    r = optimize_table(st, workers=1, analyze=False)
    assert r.success and r.feasible and seen["out"] == r.lever_sensitivity
    prob, sol = seen["prob"], seen["sol"]
    ls, nzs = prob.lever_scaling, len(prob.scaling.names)
    active = [s for s in r.lever_sensitivity if s["at_bound"] and abs(s["db_per_unit"]) > 0]
    assert active, "no lever on an active bound: nothing to difference"

    def margin(i, side, dz):
        name = "ubx" if side == "upper" else "lbx"
        kept = getattr(prob, name)
        moved = np.array(kept, float)
        moved[nzs + i] += dz
        setattr(prob, name, moved)
        try:  # the NLP alone (no outer round: its expansion stays the optimum's)
            res = NLP.solve(prob, sol.x, seen["p"], warm=sol)
        finally:
            setattr(prob, name, kept)
        worst = max((v for _, v in res.violations), default=0.0)  # (row, amount) pairs
        assert res.success and worst <= 1e-6, (ls.names[i], side, dz, res.status, worst)
        return -res.objective  # the worst margin, dB (J = -t)

    for s in active:
        i = list(ls.names).index(s["name"])
        # the same optimum: the re-solve at the bound itself returns it
        assert margin(i, s["at_bound"], 0.0) == pytest.approx(-sol.objective, abs=1e-6)
        dv_dz = ls.half[i] * (s["value"] if ls.is_log(i) else 1.0)
        fd = (margin(i, s["at_bound"], Z_STEP) - margin(i, s["at_bound"], -Z_STEP)) \
            / (2 * Z_STEP * dv_dz)
        assert s["db_per_unit"] == pytest.approx(fd, rel=0.01), (s, fd)
