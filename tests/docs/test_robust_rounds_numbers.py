"""The numbers docs/robust.md quotes about the robust table's rounds (section 3, "The
table's rounds"), recomputed from the code and the tests that check them. If one of these
fails, the page and the code disagree: fix the page (or the code), never the tolerance."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from isodesign.optimization import robust_table
from isodesign.optimization.table_problem import PEAK_SLOTS_PER_ROUND, TABLE_PEAK_ROUNDS

ROOT = Path(__file__).parents[2]
PAGE = " ".join((ROOT / "docs" / "robust.md").read_text(encoding="utf-8").split())


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in PAGE, text


def test_the_movable_frequencies_and_the_drift_comb():
    n = PEAK_SLOTS_PER_ROUND * TABLE_PEAK_ROUNDS
    quoted(f"the scenario NLP's {n} movable frequencies are spent")
    quoted(f"with its {n} movable peak frequencies present from the start")
    comb = np.asarray(robust_table.DRIFT_COMB)
    step = float(np.diff(comb).mean())
    assert np.allclose(np.diff(comb), step)
    half = float(comb.max() - 1.0)
    assert float(1.0 - comb.min()) == pytest.approx(half)
    quoted(f"a peak within {100 * robust_table.DRIFT_RANGE:g} % of a frequency placed before")
    words = {3: "three", 5: "five", 7: "seven", 9: "nine", 11: "eleven"}
    quoted(f"gets a comb of {words[comb.size]}, {100 * step:g} % apart over "
           f"+-{100 * half:g} %")


def test_the_tolerances_of_the_rebuilt_answer_test():
    sys.path.insert(0, str(ROOT / "tests" / "optimization"))
    try:
        import test_robust_table_rounds as t
    finally:
        sys.path.pop(0)
    quoted(f"(worst case within {t.SAME_WORST_CASE_DB:g} dB, design within "
           f"{100 * t.SAME_VALUES_REL:g} % relative)")
