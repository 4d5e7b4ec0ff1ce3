"""Fixtures of the report tests: a fast study, one optimize run and one Pareto run."""

from __future__ import annotations

import contextlib
import io

import pytest

from isodesign.cli import main

FAST_STUDY = """\
name = "fast"
description = "the default study on a coarse grid, 2 starts (tests)"

[models]
points_per_band = 4
peak_points = 30

[solver]
starts = 2
workers = 1
"""


def run_cli(*argv: str) -> tuple[int, str, str]:
    """Run the CLI in-process, capturing its output: (status, stdout, stderr)."""
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        status = main([str(a) for a in argv])
    return status, o.getvalue(), e.getvalue()


@pytest.fixture(scope="session")
def fast_study(tmp_path_factory):
    p = tmp_path_factory.mktemp("study") / "fast.toml"
    p.write_text(FAST_STUDY, encoding="utf-8")
    return p


@pytest.fixture(scope="session")
def optimize_run(fast_study, tmp_path_factory):
    """An ``isodesign optimize`` run directory of the fast study."""
    out = tmp_path_factory.mktemp("opt") / "run"
    status, _, err = run_cli("optimize", fast_study, "-o", out, "--quiet", "--no-plots")
    assert status == 0, err
    return out


@pytest.fixture(scope="session")
def pareto_run(fast_study, tmp_path_factory):
    """An ``isodesign pareto`` run directory of the fast study (3 points)."""
    out = tmp_path_factory.mktemp("pareto") / "run"
    status, _, err = run_cli("pareto", fast_study, "--points", "3", "-o", out, "--quiet")
    assert status == 0, err
    return out


@pytest.fixture(scope="session")
def design_file(tmp_path_factory):
    """A design file of another spring, with a [models] table."""
    p = tmp_path_factory.mktemp("design") / "candidate_b.toml"
    p.write_text("""\
volume_ratio = 3.0
top_volume_m3 = 0.0012
capillary_length_m = 0.1
capillary_diameter_m = 0.0018
piston_area_m2 = 0.0053
pressure_pa = 400000.0

[models]
flow = "womersley"
amplitude_mode = "self_consistent"
diaphragm = "viscoelastic"
""", encoding="utf-8")
    return p
