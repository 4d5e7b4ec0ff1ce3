"""docs/equations.md points at functions and tests that exist."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
PAGE = (ROOT / "docs" / "equations.md").read_text(encoding="utf-8")
ROWS = [line for line in PAGE.splitlines() if line.startswith("| ") and "`" in line]
FUNCTIONS = sorted({m for row in ROWS for m in re.findall(r"`(isodesign\.[\w.]+)`", row)})
TESTS = sorted({m for row in ROWS for m in re.findall(r"`(tests/[\w/]+\.py::\w+)`", row)})


def _resolve(dotted: str):
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(dotted)


def test_the_index_is_not_empty():
    assert len(ROWS) >= 25 and len(FUNCTIONS) >= 25 and len(TESTS) >= 30
    for row in ROWS:  # every row names a function and a test
        assert "`isodesign." in row and "`tests/" in row, row


@pytest.mark.parametrize("dotted", FUNCTIONS)
def test_function_exists(dotted):
    assert _resolve(dotted) is not None


@pytest.mark.parametrize("ref", TESTS)
def test_test_exists(ref):
    path, name = ref.split("::")
    text = (ROOT / path).read_text(encoding="utf-8")
    assert re.search(rf"^def {name}\(", text, re.M), ref
