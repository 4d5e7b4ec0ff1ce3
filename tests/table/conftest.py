"""Fixtures of the table tests."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

#: A held-out-like table: 1,000 kg on 5 isolators, CG off-centre, VC-B floor, VC-D target,
#: a 15 dB peak bound (and a 20 L volume envelope, so that the peak bound binds); the
#: optimizer's tests read the same file (tests/optimization/conftest.py).
HELD_OUT_TOML = (Path(__file__).parent / "held_out_table.toml").read_text()


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
