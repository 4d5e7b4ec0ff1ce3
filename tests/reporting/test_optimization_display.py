"""Display of optimization results: optimize's figure shows every band, PASS/FAIL, dB."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.optimization.driver import optimize
from isodesign.optimization.study import default_study
from isodesign.plotting.optimization import optimization_figure


@pytest.fixture(scope="module")
def result():
    st = default_study().with_changes(solver={"starts": 1, "workers": 1},
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
