"""Design charts of a sweep and the sweep's HTML report (also in headless Chromium)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import isodesign
from isodesign.plotting.sweep import chart_breaks, chart_objectives, design_chart


def _table() -> pd.DataFrame:
    """Eight masses on two floors; the binding set changes at 700 kg, N jumps at 1100 kg."""
    rows = []
    for floor in ("VC-A", "VC-B"):
        for i, m in enumerate(range(400, 1200, 100)):
            n = 8.0 if m < 1100 else 2.0
            rows.append({"payload.mass_kg": m, "floor.criterion": floor, "task": "optimize",
                         "status": "complete" if m != 500 else "infeasible",
                         "feasible": m != 500, "objective": "worst_band_margin",
                         "objective_value": 0.01 * m, "worst_band_margin_db": 0.01 * m,
                         "natural_frequency_hz": 1.5 - 1e-4 * m, "volume_ratio": n,
                         "top_volume_m3": 6e-3 / (1 + n), "capillary_length_m": 0.1 + 0.01 * i,
                         "capillary_diameter_m": 2e-3,
                         "binding": "total_volume" if m < 700 else "total_volume;peak"})
    return pd.DataFrame(rows)


def test_lines_break_where_the_binding_set_or_the_branch_changes():
    br = chart_breaks(["a", "a", "a;b", "a;b", "a;b"], [8.0, 8.0, 8.0, 7.9, 2.0])
    assert list(br) == [False, False, True, False, True]
    assert list(chart_breaks(["a", "a"], [np.nan, 3.0])) == [False, False]


def test_the_design_chart_draws_each_series_with_its_breaks():
    df = _table()
    assert chart_objectives(df) == ["worst_band_margin"]
    fig = design_chart(df, ["payload.mass_kg", "floor.criterion"])
    axes = [ax for ax in fig.get_axes() if ax.get_visible()]
    assert len(axes) == 7  # objective, natural frequency, N, V_t0, L_c, D_c, binding strip
    lines = [ln for ln in axes[0].get_lines() if ln.get_linestyle() not in ("None", "")]
    solid = [ln for ln in lines if np.isnan(ln.get_ydata()).any() or len(ln.get_ydata()) > 2]
    assert len(solid) == 2  # one line per floor
    for ln in solid:
        y = np.asarray(ln.get_ydata(), float)
        # 500 kg has no feasible design (a gap), the set changes at 700, N jumps at 1100
        assert np.isnan(y).sum() >= 3
    assert {t.get_text() for t in axes[-1].get_yticklabels()} == {
        "total_volume", "total_volume, peak", "no feasible design"}
    legend = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert "floor.criterion=VC-A" in legend and "floor.criterion=VC-B" in legend


@pytest.fixture(scope="module")
def response_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "sweep"
    return isodesign.sweep(isodesign.vertical_study(),
                           vary=["payload.mass_kg=300:1500:7", "floor.criterion=VC-A,VC-B"],
                           task="response", output=out, scheduler="serial")


def test_report_of_a_sweep_directory_holds_the_charts_and_the_table(response_sweep, tmp_path):
    from isodesign.cli import main

    out = tmp_path / "r.html"
    assert main(["report", str(response_sweep.directory), "-o", str(out)]) == 0
    html = out.read_text(encoding="utf-8")
    assert html.count("<svg") == 1 and "<script" not in html and "<link" not in html
    assert "src=\"http" not in html and "url(http" not in html
    assert "Design charts" in html and "worst_band_margin" in html
    for p in response_sweep.table["point"]:
        assert f"points/{p}" in html
    assert html.count("<tr class=\"complete\">") == 14
    rec = json.loads((response_sweep.directory / "record.json").read_text())
    assert rec["charts"] == ["charts/worst_band_margin.png"]
    with pytest.raises(isodesign.InputError, match="on its own"):
        isodesign.report([response_sweep.directory, response_sweep.directory], tmp_path / "x.html")


@pytest.mark.browser
def test_sweep_report_opens_cleanly_in_chromium(response_sweep, tmp_path):
    import os
    from pathlib import Path

    from tests.reporting.cdp import Browser, chromium_path

    chromium = chromium_path()
    if chromium is None:
        pytest.skip("chromium not installed (make test-browser installs it)")
    html = isodesign.report(response_sweep.directory, tmp_path / "sweep.html")
    shots = Path(os.environ.get("ISODESIGN_SCREENSHOT_DIR") or tmp_path)
    shots.mkdir(parents=True, exist_ok=True)
    url = Path(html).resolve().as_uri()
    with Browser(chromium) as b:
        session = b.open(url)
        res = b.call("Runtime.evaluate", {
            "expression": "JSON.stringify([...document.querySelectorAll('svg')].map("
                          "s => Math.round(s.getBoundingClientRect().width)))",
            "returnByValue": True}, session=session)
        widths = json.loads(res["result"]["value"])
        png = b.screenshot(session, shots / "report_sweep.png")
        problems = b.problems(url)
    assert problems == [] and widths and min(widths) > 600
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
