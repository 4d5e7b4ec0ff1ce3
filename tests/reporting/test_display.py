"""Result objects: short repr, table str, notebook HTML; plot methods return a Figure."""

from __future__ import annotations

import sys
from html.parser import HTMLParser

import numpy as np
import pytest

from isodesign.floor import FloorSpectrum
from isodesign.floor.bands import third_octave_bands
from isodesign.floor.compliance import compliance
from isodesign.plotting.style import save_figure, with_breaks
from isodesign.response import Payload, band_response, harmonic_response
from isodesign.spring.design import SpringDesign
from isodesign.spring.stiffness import complex_stiffness


@pytest.fixture(scope="module")
def results():
    d = SpringDesign.reference()
    p = Payload(400.0, 4, spacing_m=0.8, cg_height_m=0.3)
    br = band_response(d, p, "VC-A", "VC-E", points_per_band=8, warn=False)
    hr = harmonic_response(d, p, np.geomspace(0.5, 20, 30), [1e-6, 1e-5], warn=False)
    sr = complex_stiffness(d, [1.0, 5.0, 10.0], [[1e-5], [1e-4]], warn=False)
    fl = FloorSpectrum.from_criterion("VC-A")
    bands = third_octave_bands(4, 80)
    co = compliance(np.full(len(bands), 1e-6), bands, "VC-C")
    return {"band": br, "harmonic": hr, "stiffness": sr, "stability": br.stability,
            "floor": fl, "compliance": co}


class _Tags(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)


@pytest.mark.parametrize("name", ["band", "harmonic", "stiffness", "stability", "floor",
                                  "compliance"])
def test_repr_is_short_and_str_is_a_table(results, name):
    r = results[name]
    text = repr(r)
    assert text.startswith(f"<{type(r).__name__}") and text.endswith(">")
    assert len(text) <= 240 and "\n" not in text and "array(" not in text
    s = str(r)
    assert s.splitlines()[0] == type(r).__name__
    assert "rows x" in s  # the table, cut to MAX_ROWS rows
    assert len(s) < 20_000
    h = r._repr_html_()
    parser = _Tags()
    parser.feed(h)
    assert "table" in parser.tags and len(h) < 60_000


def test_band_response_repr_names_the_verdict(results):
    r = results["band"]
    assert ("PASS" if r.passes else "FAIL") in repr(r)
    assert f"{r.worst_margin_db:+.2f} dB" in repr(r)


def test_plot_methods_return_figures_without_touching_the_backend(results, tmp_path):
    import matplotlib

    backend = matplotlib.get_backend()
    pyplot_loaded = "matplotlib.pyplot" in sys.modules
    figs = [results["band"].plot(), results["harmonic"].plot(), results["stiffness"].plot()]
    for i, fig in enumerate(figs):
        assert type(fig).__name__ == "Figure"
        assert save_figure(fig, tmp_path / f"f{i}.png").stat().st_size > 5000
    assert matplotlib.get_backend() == backend
    assert ("matplotlib.pyplot" in sys.modules) == pyplot_loaded


def test_plot_into_given_axes(results):
    from isodesign.plotting.style import new_figure

    fig = new_figure(6, 4)
    ax = fig.add_subplot()
    assert results["band"].plot(ax) is fig
    assert ax.get_yscale() == "log" and "um/s" in ax.get_ylabel()
    fig2 = new_figure(6, 6)
    axes = fig2.subplots(2, 1)
    assert results["stiffness"].plot(axes) is fig2
    fig3 = new_figure(6, 4)
    ax3 = fig3.add_subplot()
    assert results["harmonic"].plot(ax3) is fig3
    assert "dB" in ax3.get_ylabel()


def test_band_axis_labels_band_centres_without_overlap(results):
    fig = results["band"].plot()
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_xticklabels()]
    r = results["band"]
    assert len(r.bands) > 12
    # octave centres only, each one a band's nominal label
    assert set(labels) <= set(r.bands.labels)
    assert {"1", "2", "4", "8", "16", "31.5", "63"} <= set(labels)
    assert ax.xaxis.get_minor_formatter().__class__.__name__ == "NullFormatter"


def test_transmissibility_panel_is_in_db_with_unity_line(results):
    fig = results["band"].plot()
    ax_m = next(a for a in fig.axes if "dB" in a.get_ylabel())
    assert any(line.get_label() == "|T| = 1 (0 dB)" for line in ax_m.get_lines())
    assert any("phase" in a.get_ylabel() for a in fig.axes)


def test_with_breaks_never_joins_gaps_or_branch_changes():
    x, y = with_breaks([1, 2, 3, 4], [1.0, np.nan, 3.0, 4.0], [False, False, False, True])
    assert np.isnan(y[1])
    # a NaN before index 3 (the branch change)
    assert np.isnan(y[3]) and x.size == 5


def test_pareto_figure_breaks_the_line_at_gaps_and_branch_changes():
    from types import SimpleNamespace

    from isodesign.plotting.optimization import pareto_figure

    def d(n):
        return {"volume_ratio": n, "top_volume_m3": 1e-3, "capillary_length_m": 0.1,
                "capillary_diameter_m": 1e-3}

    # points sorted by volume: 0.8, 1.0 (same branch), unsolved, 1.6, then N jumps 2 -> 8
    values = np.array([[-4.0, 1e-3], [-2.0, 2e-3], [np.nan, np.nan], [0.5, 3e-3],
                       [1.0, 4e-3], [2.0, 5e-3]])
    res = SimpleNamespace(objectives=("worst_band_margin", "total_volume"), values=values,
                          designs=tuple(d(n) for n in (0.8, 1.0, 1.2, 1.6, 2.0, 8.0)),
                          front=np.array([True, True, False, True, True, True]),
                          hypervolume=0.5)
    fig = pareto_figure(res)
    ax = fig.axes[0]
    front_line = next(ln for ln in ax.get_lines() if ln.get_label().startswith("non-dominated"))
    y = np.asarray(front_line.get_ydata(), float)
    assert np.isnan(y).sum() >= 2  # one break at the unsolved point, one at N 2 -> 8
    pf = next(ln for ln in ax.get_lines() if ln.get_label().startswith("pass/fail"))
    assert np.allclose(pf.get_ydata(), 0.0)
    assert "per isolator" in ax.get_xlabel() and "(L;" in ax.get_xlabel()
