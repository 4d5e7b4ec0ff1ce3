"""The outer fixed point's proximal term (docs/random-response.md section 3d, docs/table.md
section 13): with the co-designed table's per-group springs and its horizontal element free
(a flat set of optima), the distortion power's outer loop converges and the optimum
re-checks against the NumPy closure with the distortion."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from isodesign.optimization.distortion_rows import (
    DISTORTION_MAX_ROUNDS,
    DISTORTION_PROXIMAL_WEIGHT,
)
from isodesign.optimization.study import default_study, study_from_dict, vertical_study


def _small_default():
    """default_study() with the distortion (its default), on a coarse grid (3 points per
    band, bands 4-20 Hz), one start, one worker."""
    raw = copy.deepcopy(default_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    return study_from_dict(raw, source="small_default.toml", fill_defaults=False)


def test_the_default_study_carries_the_distortion():
    assert default_study().models["distortion"] is True


def test_the_proximal_term_vanishes_with_its_gradient_at_the_expansion_point():
    """The table NLP's objective with a sloped round's expansion is the problem's plus
    (w / 2) |z - z_0|^2: the same J at z_0, exactly the quadratic away from it."""
    from isodesign.optimization.table_problem import TableProblem

    st = _small_default()
    prob = TableProblem(st)
    assert prob.distortion and prob._n_prox == 1
    vals = {v.name: v.start for v in (*st.variables, *st.levers)}
    x0 = prob.initial_guess(vals)
    z0 = x0[:prob.nz]
    v0 = prob._terms_at_z(z0)
    sloped = prob.expansion(z0, v0)
    assert sloped[-1] == DISTORTION_PROXIMAL_WEIGHT
    assert sloped.size == prob._n_dist == prob.nz + v0.size * (1 + prob.nz) + 1
    plain = sloped.copy()
    plain[-1] = 0.0  # the same expansion without the proximal term

    def j(x, p_dist):
        prob._dist_p = p_dist
        return float(prob.eval_fn(x, prob.params())[0])

    assert j(x0, sloped) == pytest.approx(j(x0, plain), abs=1e-14)
    rng = np.random.default_rng(26)
    for h in (1e-4, 1e-2):
        x = x0.copy()
        dz = h * rng.standard_normal(prob.nz)
        x[:prob.nz] = z0 + dz
        assert j(x, sloped) - j(x, plain) == pytest.approx(
            0.5 * DISTORTION_PROXIMAL_WEIGHT * float(dz @ dz), rel=1e-6, abs=1e-15)
    # the values alone (a start's first round): no proximal pull
    assert prob._values_only(vals)[-1] == 0.0


def test_the_vertical_expansion_carries_no_proximal_weight():
    from isodesign.optimization.problem import Problem

    st = vertical_study()
    prob = Problem(st)
    assert prob.distortion and prob._n_prox == 0
    p = prob._values_only({})
    assert p.size == prob._n_dist == prob.nz + prob._n_terms * (1 + prob.nz)


@pytest.mark.slow
def test_the_co_designed_table_with_group_springs_rechecks_with_the_distortion():
    """The reproducer of the defect: before the proximal term the pendulum, the lateral
    stiffness and its loss factor (on a flat set of the worst margin's optima) moved by up
    to 0.8 of their scaled box in an outer round; on the default study's own grid (one
    start) the loop ended after its 8 rounds with the terms 13-24 % from the NumPy terms at
    its answer and the re-check refused the design (tube velocity 8e-6 relative); here it
    refused it at 2.2e-6. About 55 s on one core."""
    import isodesign

    st = _small_default()
    assert st.models["distortion"]
    res = isodesign.optimize(st, analyze=False)
    assert res.feasible
    # converged before the cap (the last solve goes on from the peak refinement's last
    # round, whose expansion at its answer it starts from: 1 round when that one confirms)
    assert 1 <= res.distortion_outer_rounds < DISTORTION_MAX_ROUNDS
    assert res.recheck_sigma_rel < 1e-7 and res.recheck_margin_db < 1e-7
