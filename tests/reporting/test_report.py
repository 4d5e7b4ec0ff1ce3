"""The HTML report: parses, holds every section, figure and table, is self-contained."""

from __future__ import annotations

import re
from html.parser import HTMLParser

import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.reporting import SECTIONS

from .conftest import run_cli

BASE_SECTIONS = [s for s in SECTIONS if s not in ("optimization", "pareto")]


class ReportParser(HTMLParser):
    """Collects sections, figures, tables and anything that would load a resource."""

    def __init__(self):
        super().__init__()
        self.stack: list[str] = []
        self.sections: list[str] = []
        self.current: str | None = None
        self.svgs: dict[str, int] = {}
        self.tables: dict[str, int] = {}
        self.external: list[str] = []
        self.scripts = 0
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "section":
            self.current = a.get("id")
            self.sections.append(self.current)
        elif tag == "svg" and self.current:
            self.svgs[self.current] = self.svgs.get(self.current, 0) + 1
        elif tag == "table" and self.current:
            self.tables[self.current] = self.tables.get(self.current, 0) + 1
        elif tag in ("script", "iframe", "object", "embed", "link"):
            self.scripts += 1
        for key in ("src", "href", "xlink:href", "data"):
            v = a.get(key)
            if v and not v.startswith("#"):
                self.external.append(f"{tag} {key}={v}")

    def handle_data(self, data):
        self.text.append(data)


def parse(text: str) -> ReportParser:
    p = ReportParser()
    p.feed(text)
    p.close()
    return p


def assert_self_contained(text: str, p: ReportParser) -> None:
    assert p.scripts == 0
    assert p.external == []
    assert not re.search(r"url\(|@import|https?://", text.split("<body>", 1)[0])
    # svg markers and clip paths only point inside the document
    assert not re.search(r'(?:href|src)="(?!#)', text)


def assert_report(text: str, sections: list[str], *, figures: dict[str, int]) -> ReportParser:
    assert text.startswith("<!DOCTYPE html>")
    p = parse(text)
    assert p.sections == sections
    for sec, n in figures.items():
        assert p.svgs.get(sec, 0) >= n, (sec, p.svgs)
    for sec in ("design", "bands", "transmissibility", "stability"):
        assert p.tables.get(sec, 0) >= 1, (sec, p.tables)
    assert_self_contained(text, p)
    body = " ".join(p.text)
    assert re.search(r"\b(PASS|FAIL)\b", body)
    for needle in ("um/s", "uin/s", "p0 gauge", "static stiffness K0", "natural frequency",
                   "tilt margin", "damping ratio", "peak |T|", "models in force",
                   "ILLUSTRATIVE", "isodesign 0", "resolved study"):
        assert needle.lower() in body.lower(), needle
    assert "@media print" in text and "@page" in text
    return p


FIGS = {"bands": 1, "transmissibility": 1, "stiffness": 1}


@pytest.fixture(scope="module")
def optimize_report(optimize_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("rep") / "opt.html"
    status, stdout, err = run_cli("report", optimize_run, "-o", out)
    assert status == 0, err
    assert f"wrote {out}" in stdout
    return out.read_text(encoding="utf-8")


def test_report_of_an_optimize_run(optimize_report, optimize_run):
    import json

    p = assert_report(optimize_report, [*BASE_SECTIONS[:7], "optimization",
                                        *BASE_SECTIONS[7:]], figures=FIGS)
    assert p.tables["optimization"] >= 2  # start vs optimum, constraints
    assert p.svgs["optimization"] == 1  # start vs optimum, bands and |T|
    body = " ".join(p.text)
    rec = json.loads((optimize_run / "record.json").read_text())
    for c in rec["constraints"]:
        assert c["name"] in body
    assert "binding" in body
    assert "D_c spans" in body and "L_c" in body  # the flat-direction band
    design = json.loads((optimize_run / "design.json").read_text())
    assert design["verdict"].split(";")[0].split(":")[0] in body  # PASS/FAIL as the run's
    assert "no (shown)" in body  # bands outside the judged range are in the table
    # the models table names the acoustic model the analysis used (distributed by default)
    assert "transmission line" in body


def test_models_table_names_the_acoustics_the_design_uses():
    from isodesign.reporting.analysis import model_caveats

    base = {"amplitude_mode": "self_consistent", "diaphragm": "viscoelastic",
            "random_method": "statistical"}
    rows = {r[0]: r for r in model_caveats({**base, "flow": "womersley"}, "distributed")}
    assert rows["acoustics"][1] == "distributed"
    rows = {r[0]: r for r in model_caveats({**base, "flow": "womersley"}, "lumped")}
    assert rows["acoustics"][1] == "lumped"
    # the paper's flow models are lumped whatever the design says
    rows = {r[0]: r for r in model_caveats({**base, "flow": "zhao"}, "distributed")}
    assert rows["acoustics"][1] == "lumped" and "paper" in rows["acoustics"][2]
    assert "acoustics" not in {r[0] for r in model_caveats({**base, "flow": "womersley"})}


def test_report_of_a_design_file_and_of_a_study(design_file, fast_study, tmp_path):
    text = isodesign.report(design_file)
    p = assert_report(text, BASE_SECTIONS, figures=FIGS)
    assert "built-in vertical study" in " ".join(p.text)
    out = isodesign.report(fast_study, tmp_path / "study.html")
    assert out.stat().st_size > 50_000
    p = assert_report(out.read_text(encoding="utf-8"), BASE_SECTIONS, figures=FIGS)
    assert "start design" in " ".join(p.text)


def test_comparison_report_puts_candidates_side_by_side(optimize_run, design_file,
                                                        fast_study, tmp_path):
    out = tmp_path / "cmp.html"
    status, _, err = run_cli("report", optimize_run, design_file, fast_study, "-o", out,
                                  "--label", "optimum", "--label", "candidate B",
                                  "--label", "start")
    assert status == 0, err
    text = out.read_text(encoding="utf-8")
    p = assert_report(text, [*BASE_SECTIONS[:7], "optimization", *BASE_SECTIONS[7:]],
                      figures=FIGS)
    # one band plot, one transmissibility plot: all candidates in the same figure
    assert p.svgs["bands"] == 1 and p.svgs["transmissibility"] == 1
    for name in ("optimum", "candidate B", "start"):
        assert text.count(name) >= 5, name
    assert "optimum: margin (dB)" in text and "candidate B: margin (dB)" in text


@pytest.mark.slow
def test_report_of_a_pareto_run(pareto_run, tmp_path):
    out = isodesign.report(pareto_run, tmp_path / "pareto.html")
    text = out.read_text(encoding="utf-8")
    p = assert_report(text, [*BASE_SECTIONS[:7], "pareto", *BASE_SECTIONS[7:]],
                      figures={**FIGS, "pareto": 1})
    assert "pass/fail: margin 0 dB" in text
    assert p.tables["pareto"] == 1


def test_report_bad_inputs(tmp_path):
    status, _, err = run_cli("report", tmp_path, "-o", tmp_path / "r.html")
    assert status == 2 and err.startswith("isodesign: error:") and "record.json" in err
    status, _, err = run_cli("report", tmp_path / "missing.toml", "-o", tmp_path / "r.html")
    assert status == 2 and "no such file" in err
    status, _, err = run_cli("report", tmp_path / "x.toml", "-o", tmp_path / "no" / "r.html")
    assert status == 2 and "--output" in err
    with pytest.raises(InputError):
        isodesign.report([])


def test_report_is_a_top_level_function():
    assert callable(isodesign.report)
    assert "report" in isodesign.__all__
