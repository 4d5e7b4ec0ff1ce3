"""Fixtures shared by the whole suite (tests mirror the package: tests/<discipline>/)."""

from __future__ import annotations

import pytest

from isodesign.spring.design import SpringDesign


@pytest.fixture(scope="session")
def ref() -> SpringDesign:
    """The paper's Table 1 spring (SI units), the suite's common starting point."""
    return SpringDesign.reference()
