"""Fixtures of the table tests."""

from __future__ import annotations

import contextlib
import io

import pytest

#: A held-out-like table: 1,000 kg on 5 isolators, CG off-centre, VC-B floor, VC-D target,
#: a 15 dB peak bound (and a 20 L volume envelope, so that the peak bound binds).
HELD_OUT_TOML = """
name = "five"
[payload]
mass_kg = 1000.0
isolators = 5
spacing_m = 1.0
cg_height_m = 0.4
[table]
isolators_m = [[-0.8, -0.5], [0.8, -0.5], [0.8, 0.5], [-0.8, 0.5], [0.0, 0.55]]
cg_m = [0.12, -0.08, 0.4]
box_m = [1.8, 1.2, 0.8]
leveling_groups = [[1, 2], [3, 5], [4]]
instrument_points_m = [[0.0, 0.0, 0.8], [0.7, 0.45, 0.8]]
point_names = ["centre", "corner"]
supply_pressure_pa = 801325.0
[table.horizontal]
pendulum_length_m = 0.15
lateral_stiffness_n_per_m = 10000.0
lateral_loss_factor = 0.25
elastic_centre_height_m = 0.0
[floor]
criterion = "VC-B"
[target]
criterion = "VC-D"
band_min_hz = 4.0
band_max_hz = 80.0
[constraints]
max_peak_transmissibility_db = 15.0
max_total_volume_m3 = 0.02
[solver]
starts = 2
workers = 1
"""


@pytest.fixture(scope="session")
def held_out_toml() -> str:
    """The held-out-like table study, as TOML text."""
    return HELD_OUT_TOML


@pytest.fixture(scope="session")
def builtin_table_run(tmp_path_factory):
    """``isodesign optimize --builtin table --starts 1 --workers 1 -o DIR``, run once for the
    tests that read it (an xdist group, tests/conftest.py): (what it printed, DIR)."""
    from isodesign.cli import main

    out = tmp_path_factory.mktemp("builtin_table") / "o"
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        status = main(["optimize", "--builtin", "table", "--starts", "1", "--workers", "1",
                       "-o", str(out)])
    assert status == 0, e.getvalue()
    return o.getvalue(), out
