"""Fixtures of the optimizer's tests."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def held_out_toml() -> str:
    """The held-out-like table study (1,000 kg on 5 isolators, CG off-centre, VC-B floor,
    VC-D target, a 15 dB peak bound), as TOML text: tests/table/held_out_table.toml."""
    return (Path(__file__).parents[1] / "table" / "held_out_table.toml").read_text()
