"""Display of optimization results: optimize's figure shows every band, PASS/FAIL, dB."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.optimization.driver import optimize
from isodesign.optimization.study import vertical_study
from isodesign.plotting.optimization import optimization_figure


@pytest.fixture(scope="module")
def result():
    st = vertical_study().with_changes(solver={"starts": 1, "workers": 1},
                                      models={"points_per_band": 4, "peak_points": 30})
    return optimize(st)


def test_optimization_figure_shows_every_band_verdict_and_limits(result):
    fig = optimization_figure(result)
    ax_b = fig.axes[0]
    # every band of the floor and criterion (1-80 Hz: 20), not only the 14 judged ones
    ticks = np.concatenate([ax_b.xaxis.get_majorticklocs(), ax_b.xaxis.get_minorticklocs()])
    assert len(np.unique(np.round(ticks, 6))) == 20
    labels = [t.get_text() for t in ax_b.get_legend().get_texts()]
    assert any(t.startswith("judged bands 4-80 Hz") for t in labels)
    assert any(t.startswith("payload, start design") for t in labels)
    assert any(t.startswith("payload, optimum") for t in labels)
    assert ax_b.get_title().split()[1] in ("PASS:", "FAIL:")
    ax_m = next(a for a in fig.axes if "dB" in a.get_ylabel())
    names = [ln.get_label() for ln in ax_m.get_lines()]
    assert "|T| = 1 (0 dB)" in names and "peak limit 15 dB" in names
    assert any("phase" in a.get_ylabel() for a in fig.axes)
    # the start design's worst band at 1 Hz (amplification) is visible: below the judged range
    start_line = next(ln for ln in ax_b.get_lines()
                      if ln.get_label().startswith("payload, start design"))
    x = np.asarray(start_line.get_xdata(), float)
    assert x.min() < 1.1


def test_optimization_result_display_and_plot(result):
    from isodesign.plotting.style import new_figure

    text = repr(result)
    assert text.startswith("<OptimizationResult: study vertical") and len(text) <= 240
    assert ("PASS" in text) or ("FAIL" in text)
    s = str(result)
    assert "binding" in s and "volume_ratio" in s  # key figures and the to_frame table
    assert "<table" in result._repr_html_()
    fig = result.plot()
    assert type(fig).__name__ == "Figure" and len(fig.axes) >= 3
    fig2 = new_figure(6, 4)
    ax = fig2.add_subplot()
    assert result.plot(ax) is fig2
    assert any(ln.get_label() == "payload, start design" for ln in ax.get_lines())


def test_pareto_result_display_and_plot():
    from isodesign.optimization.pareto import ParetoResult

    values = np.array([[-4.0, 1e-3], [-1.0, 2e-3], [2.0, 4e-3]])
    designs = tuple({"volume_ratio": n, "top_volume_m3": 1e-3, "capillary_length_m": 0.1,
                     "capillary_diameter_m": 1e-3} for n in (0.8, 0.9, 1.0))
    res = ParetoResult(objectives=("worst_band_margin", "total_volume"), values=values,
                       designs=designs, statuses=("Solve_Succeeded",) * 3,
                       front=np.array([True, True, True]),
                       reference_point=np.array([4.6, 4.3e-3]),
                       ideal_point=np.array([-2.0, 1e-3]), hypervolume=0.7, wall_s=1.0)
    assert repr(res).startswith("<ParetoResult: objectives worst_band_margin")
    assert "nondominated" in str(res)
    fig = res.plot()
    ax = fig.axes[0]
    assert "per isolator" in ax.get_xlabel()
    assert any(ln.get_label().startswith("pass/fail") for ln in ax.get_lines())
