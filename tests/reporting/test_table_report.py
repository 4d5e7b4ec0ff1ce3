"""The report of a study with a [table]: layout, verdict over points and axes, bands, |T|,
modes and rocking stability (docs/table.md)."""

from __future__ import annotations

import json
import shutil
from importlib import resources

import pytest

import isodesign

from .test_report import BASE_SECTIONS, FIGS, assert_report, parse


def test_report_of_a_table_study(tmp_path):
    study = tmp_path / "table.toml"
    with resources.as_file(resources.files("isodesign") / "data" / "table_study.toml") as p:
        shutil.copy(p, study)
    text = isodesign.report(study)
    parsed = assert_report(text, BASE_SECTIONS, figures={**FIGS, "verdict": 3})
    body = " ".join(parsed.text)
    for needle in ("The table in six degrees of freedom", "every instrument point, axis and band",
                   "corner z", "rocking direction", "K_theta/(W h)", "valve", "y+rx",
                   "the vertical floor 'VC-A floor' is applied to x and y",
                   "a rigid table in six degrees of freedom on 4 isolators"):
        assert needle in body, needle
    assert parsed.tables.get("verdict", 0) >= 4  # leveling, bands, modes, rocking


TABLE_FAST = """
[models]
points_per_band = 4
[solver]
starts = 1
workers = 1
"""


@pytest.fixture(scope="module")
def table_run_report(tmp_path_factory):
    """An ``isodesign optimize`` run of the built-in table (1 start, coarse grid), its
    design.json and the HTML of ``isodesign report RUN``."""
    from .conftest import run_cli

    tmp = tmp_path_factory.mktemp("table_run")
    study = tmp / "table.toml"
    with resources.as_file(resources.files("isodesign") / "data" / "table_study.toml") as p:
        text = p.read_text(encoding="utf-8").replace("[solver]\nstarts = 4\n", "")
    study.write_text(text + TABLE_FAST, encoding="utf-8")
    run = tmp / "run"
    status, _, err = run_cli("optimize", study, "-o", run, "--quiet", "--no-plots")
    assert status == 0, err
    status, _, err = run_cli("report", run, "-o", tmp / "r.html")
    assert status == 0, err
    design = json.loads((run / "design.json").read_text())
    return (tmp / "r.html").read_text(encoding="utf-8"), design


def _section(html: str, sid: str) -> str:
    return html.split(f'<section id="{sid}">', 1)[1].split("</section>", 1)[0]


def _text(fragment: str) -> str:
    return " ".join(parse(fragment).text)


@pytest.mark.slow
def test_report_of_a_table_run_has_one_verdict_the_table_s(table_run_report):
    html, design = table_run_report
    verdict = _section(html, "verdict")
    assert verdict.count('<div class="card') == 1  # one verdict: the table's
    word = "PASS" if design["verdict"].startswith("PASS") else "FAIL"
    assert f'<div class="word">{word}</div>' in verdict
    worst = design["derived"]["worst_band_margin_db"]
    assert f"margin <strong>{worst:+.2f} dB</strong>" in verdict
    assert "point-axis-bands" in _text(verdict)


@pytest.mark.slow
def test_report_of_a_table_run_shows_the_table_s_job_modes_and_constraints(table_run_report):
    html, design = table_run_report
    job = _text(_section(html, "job"))
    for needle in ("600 kg on 4 isolators", "(0, 0, 0.35) m", "Ixx", "valve 1: isolator(s) 1, 2",
                   "bar abs", "1: (-0.6, -0.4)", "centre (0, 0, 0.7) m"):
        assert needle in job, needle
    assert "150 kg per isolator" not in job and "spacing 0.8 m" not in job
    # the design table: the six modes' frequencies, p0 per valve
    dsg = _text(_section(html, "design"))
    assert "natural frequency f_n (Hz)" in dsg and "(y+rx)" in dsg and "(per valve)" in dsg
    row = dsg.split("natural frequency f_n (Hz)", 1)[1][:200]
    assert "n/a" not in row
    f_y = design["derived"]["natural_frequencies_hz"]["y+rx"]
    assert f"{f_y:.3g} (y+rx)" in dsg
    # the constraint table, filled from the run, with the binding sentence
    opt = _section(html, "optimization")
    text = _text(opt)
    for c in design["constraints"]:
        assert c["name"] in text, c["name"]
    assert 'class="binding"' in opt and "What stopped the design" in text
    assert any("constraints.max_total_volume_m3" in s for s in design["limited_by"])
    # the start-vs-optimum titles give the table's worst margin per axis
    per_axis = design["worst_margin_per_axis_db"]
    for ax, m in per_axis.items():
        assert f"{ax} axis: start" in opt and f"optimum {m:+.1f} dB" in opt, ax
    # the continuous peak from below the lowest mode (the grid starts above it)
    tab = _text(_section(html, "verdict"))
    assert "continuous from 0.3" in tab or "continuous from 0.4" in tab
