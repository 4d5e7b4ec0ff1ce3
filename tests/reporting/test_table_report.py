"""The report of a study with a [table]: layout, verdict over points and axes, bands, |T|,
modes and rocking stability (docs/table.md)."""

from __future__ import annotations

import shutil
from importlib import resources

import isodesign

from .test_report import BASE_SECTIONS, FIGS, assert_report


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
