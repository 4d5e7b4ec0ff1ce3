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
    parsed = assert_report(text, BASE_SECTIONS, figures={**FIGS, "verdict": 4})
    body = " ".join(parsed.text)
    for needle in ("The table in six degrees of freedom", "every instrument point, axis and band",
                   "corner z", "rocking direction", "eig(A)/(W h)", "valve", "y+rx",
                   "the vertical floor 'VC-A floor' is applied to x and y",
                   "a rigid table in six degrees of freedom on 4 isolators"):
        assert needle in body, needle
    assert parsed.tables.get("verdict", 0) >= 6  # leveling, bands, modes, rocking, static, loop


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
    return (tmp / "r.html").read_text(encoding="utf-8"), design, run


def _section(html: str, sid: str) -> str:
    return html.split(f'<section id="{sid}">', 1)[1].split("</section>", 1)[0]


def _text(fragment: str) -> str:
    return " ".join(parse(fragment).text)


@pytest.mark.slow
def test_report_of_a_table_run_has_one_verdict_the_table_s(table_run_report):
    html, design, _ = table_run_report
    verdict = _section(html, "verdict")
    assert verdict.count('<div class="card') == 1  # one verdict: the table's
    word = "PASS" if design["verdict"].startswith("PASS") else "FAIL"
    assert f'<div class="word">{word}</div>' in verdict
    worst = design["derived"]["worst_band_margin_db"]
    assert f"margin <strong>{worst:+.2f} dB</strong>" in verdict
    assert "point-axis-bands" in _text(verdict)


@pytest.mark.slow
def test_report_of_a_table_run_shows_the_table_s_job_modes_and_constraints(table_run_report):
    html, design, _ = table_run_report
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


# -- the static verdict and the leveling loop: the words of ``isodesign stability`` -----------
def _stability_words(study, tmp_path) -> tuple[str, str, str]:
    """What ``isodesign stability STUDY`` prints: the quasi-static verdict's words, its
    critical CG height and the leveling loop's closed-loop verdict."""
    from .conftest import run_cli

    status, out, err = run_cli("stability", study, "-o", tmp_path / "stab")
    assert status == 0, err
    static = next(x for x in out.splitlines() if "quasi-static" in x)
    height = static.split("critical CG height ", 1)[1].split(" m -> ", 1)[0]
    loop = next(x for x in out.splitlines() if "leveling loop:" in x)
    return static.rsplit(" -> ", 1)[1], height, loop.split("; closed loop ", 1)[1]


def _table_study(tmp_path, cg_height_m=None, leveling=""):
    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    if cg_height_m is not None:
        src = src.replace("cg_m = [0.0, 0.0, 0.35]", f"cg_m = [0.0, 0.0, {cg_height_m}]")
        src = src.replace("cg_height_m = 0.35", f"cg_height_m = {cg_height_m}")
    src = src.replace("[table.horizontal]", leveling + "[table.horizontal]")
    p = tmp_path / "table.toml"
    p.write_text(src, encoding="utf-8")
    return p


def _plain(fragment: str) -> str:
    """The text of an HTML fragment as a reader sees it: tags dropped, spaces collapsed."""
    import html as _html
    import re

    return " ".join(_html.unescape(re.sub(r"<[^>]+>", "", fragment)).split())


def _stability_part(html: str) -> str:
    return _plain(html.split('id="table-stability"', 1)[1].split('<section id="job">', 1)[0])


def _assert_same_verdict(html: str, words: tuple[str, str, str]) -> None:
    static, height, loop = words
    card = _plain(_section(html, "verdict").split("<h3", 1)[0])
    part = _stability_part(html)
    assert f"Static stability: {static} (critical CG height {height} m" in card
    assert f"Static verdict: {static}; critical CG height {height} m" in part
    assert loop.split(";")[0] in card and loop.split(";")[0] in part
    # every verdict cell of the static table: one of the command's words for its time scale
    rows = _plain(html.split('id="table-stability"', 1)[1].split("</table></div>", 1)[0])
    quasi = rows.split("quasi-static (valves off) at 0.001 Hz", 1)[1]
    assert static in quasi.split("sealed springs at the leveling", 1)[0]


def test_report_shows_the_stability_command_s_verdict_and_loop(tmp_path):
    study = _table_study(tmp_path, leveling="[table.leveling]\ngain_kg_s_per_m = 0.03\n\n")
    words = _stability_words(study, tmp_path)
    assert words[0] == "stable" and words[2].startswith("stable")
    html = isodesign.report(study)
    _assert_same_verdict(html, words)
    part = _stability_part(html)
    assert "the study's [table.leveling]: valve gain 0.03 kg/s/m" in part
    for needle in ("gain margin (dB)", "phase margin (deg)", "delay margin (s)",
                   "Bode (magnitude, phase) and Nyquist", "self-consistent solutions",
                   "valves' limit cycle (describing function)"):
        assert needle in part, needle
    assert 'class="unstable"' not in html.split('id="table-stability"', 1)[1].split(
        '<section id="job">', 1)[0]


def test_report_of_a_high_cg_table_is_unstable_as_the_command_says(tmp_path):
    study = _table_study(tmp_path, cg_height_m=1.7)  # critical height 1.497 m
    words = _stability_words(study, tmp_path)
    assert words[0] == "UNSTABLE (margin < 1)" and words[2].startswith("UNSTABLE")
    html = isodesign.report(study)
    _assert_same_verdict(html, words)
    part = _stability_part(html)
    assert "Static verdict: stable" not in part and "the default valves" in part
    # no row says "stable" where the command says unstable
    head = part.split("Leveling loop", 1)[0]
    assert " stable " not in f" {head} ".replace("(", " ").replace(")", " ")
    assert "<= 1: tips" in head


@pytest.mark.slow
def test_a_mode_unstable_at_its_own_frequency_is_never_stable_in_the_report(tmp_path,
                                                                           monkeypatch):
    """Margins above 1 with a statically unstable mode: the report's rows used to say
    "stable" per direction while ``isodesign modes`` printed the mode "unstbl"."""
    import dataclasses

    import numpy as np

    import isodesign.table.modes as tm

    real = tm.table_modes

    def one_unstable(model, **kw):
        m = real(model, **kw)
        f = np.array(m.frequency_hz, float)
        f[0] = np.nan
        return dataclasses.replace(m, frequency_hz=f)

    monkeypatch.setattr(tm, "table_modes", one_unstable)
    study = _table_study(tmp_path)
    words = _stability_words(study, tmp_path)
    assert words[0] == "UNSTABLE: mode 1 statically unstable at its own frequency"
    html = isodesign.report(study)
    _assert_same_verdict(html, words)
    head = _stability_part(html).split("Leveling loop", 1)[0]
    assert "> 1" in head  # the margins alone would pass: the verdict does not
    assert " stable " not in f" {head} ".replace("(", " ").replace(")", " ").replace(";", " ")


@pytest.mark.slow
def test_report_of_a_table_run_shows_the_optimum_s_stability(table_run_report, tmp_path):
    """``isodesign report RUN``: the optimum's static verdict and loop, as ``isodesign
    stability RUN`` prints them for the same optimum."""
    html, _, run = table_run_report
    words = _stability_words(run, tmp_path)
    _assert_same_verdict(html, words)
    part = _stability_part(html)
    assert "the default valves (the study has no [table.leveling])" in part
    assert "Bode (magnitude, phase) and Nyquist" in part
