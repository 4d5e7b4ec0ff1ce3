"""Fixtures of the table tests."""

from __future__ import annotations

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
