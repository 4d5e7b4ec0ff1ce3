"""The report in a real browser: headless Chromium, no console error, no network request.

Needs Debian's ``chromium`` (``make test-browser`` installs it); skipped without it.
Screenshots go to ``$ISODESIGN_SCREENSHOT_DIR`` when set (else the test's tmp dir).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import isodesign

from .cdp import Browser, chromium_path

CHROMIUM = chromium_path()

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (Debian package "
                       "'chromium'; run 'make test-browser' to install it and run these tests)"),
]


def _shot_dir(tmp_path) -> Path:
    d = os.environ.get("ISODESIGN_SCREENSHOT_DIR")
    if not d:
        return tmp_path
    p = Path(d)
    p.mkdir(parents=True, exist_ok=True)
    return p


def _ink_fraction(png: bytes) -> tuple[int, int, float]:
    """(width, height, fraction of non-white pixels) of a PNG."""
    import io

    from PIL import Image

    im = Image.open(io.BytesIO(png)).convert("L")
    hist = im.histogram()
    return im.width, im.height, sum(hist[:240]) / (im.width * im.height)


def _check_in_browser(html_path: Path, shot: Path) -> None:
    url = html_path.resolve().as_uri()
    with Browser(CHROMIUM) as b:
        session = b.open(url)
        # the figures are drawn: every inline SVG has a size
        res = b.call("Runtime.evaluate", {
            "expression": "JSON.stringify([...document.querySelectorAll('svg')].map("
                          "s => Math.round(s.getBoundingClientRect().width)))",
            "returnByValue": True}, session=session)
        widths = [int(w) for w in __import__("json").loads(res["result"]["value"])]
        assert widths and min(widths) > 300, widths
        png = b.screenshot(session, shot)
        pdf = b.print_pdf(session)
        problems = b.problems(url)
    assert problems == []
    w, h, ink = _ink_fraction(png)
    assert w == 1280 and h > 4000  # the whole page
    assert 0.03 < ink < 0.6  # text and figures, not a blank or black page
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page") >= 4


def test_the_check_sees_console_errors_and_requests(tmp_path):
    """The browser check is not vacuous: a page with an error and a request fails it."""
    page = tmp_path / "bad.html"
    page.write_text("<!DOCTYPE html><html><body><p>x</p>"
                    "<img src='http://192.0.2.1/x.png'>"
                    "<script>console.error('boom')</script></body></html>", encoding="utf-8")
    url = page.resolve().as_uri()
    with Browser(CHROMIUM) as b:
        b.open(url)
        problems = b.problems(url)
    assert any("console error" in p for p in problems), problems
    assert any("192.0.2.1" in p for p in problems), problems


@pytest.fixture(scope="module")
def reports(optimize_run, design_file, fast_study, tmp_path_factory):
    d = tmp_path_factory.mktemp("browser")
    return {
        "optimize": isodesign.report(optimize_run, d / "optimize.html"),
        "comparison": isodesign.report([optimize_run, design_file, fast_study],
                                       d / "comparison.html",
                                       labels=["optimum", "candidate B", "start"]),
    }


@pytest.mark.parametrize("kind", ["optimize", "comparison"])
def test_report_opens_cleanly_in_chromium(reports, kind, tmp_path):
    _check_in_browser(reports[kind], _shot_dir(tmp_path) / f"report_{kind}.png")


@pytest.mark.slow
def test_pareto_report_opens_cleanly_in_chromium(pareto_run, tmp_path):
    html = isodesign.report(pareto_run, tmp_path / "pareto.html")
    _check_in_browser(html, _shot_dir(tmp_path) / "report_pareto.png")


def test_table_report_with_its_stability_opens_cleanly_in_chromium(tmp_path):
    """A table study whose CG is above its critical height: the stability subsection, its
    loop's Bode and Nyquist figure and the unstable verdicts render without errors."""
    from importlib import resources

    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    src = src.replace("cg_m = [0.0, 0.0, 0.35]", "cg_m = [0.0, 0.0, 1.7]")
    study = tmp_path / "high.toml"
    study.write_text(src.replace("cg_height_m = 0.35", "cg_height_m = 1.7"), encoding="utf-8")
    html = isodesign.report(study, tmp_path / "table.html")
    assert 'id="table-stability"' in html.read_text(encoding="utf-8")
    _check_in_browser(html, _shot_dir(tmp_path) / "report_table.png")
