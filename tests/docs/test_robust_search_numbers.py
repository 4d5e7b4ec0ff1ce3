"""The numbers docs/robust.md quotes about the robust table's search of the box (section 3,
step 3, and the comparison table), recomputed from the code and the tests that check them.
If one of these fails, the page and the code disagree: fix the page (or the code), never
the tolerance. (The timings it quotes come from ``studies/robust_table_search_cost.py``, the
command the page names.)"""

from __future__ import annotations

import sys
from pathlib import Path

from isodesign.optimization import robust_table, table_search
from isodesign.optimization.uncertainty import SCENARIO_SETTINGS

ROOT = Path(__file__).parents[2]
PAGE = " ".join((ROOT / "docs" / "robust.md").read_text(encoding="utf-8").split())
WORDS = {2: "two", 3: "three", 4: "four", 5: "five"}


def sci(x: float) -> str:
    """``1e-4`` as the page writes it."""
    m, e = f"{x:e}".split("e")
    return f"{float(m):g}e{int(e)}"


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in PAGE, text


def test_the_search_settings_and_the_refinement():
    quoted(f"| `search_samples` | {SCENARIO_SETTINGS['search_samples']} | 0..4096 |")
    quoted(f"scores the corners (at most {robust_table.MAX_CORNERS}) and the centre")
    quoted(f"The {WORDS[table_search.REFINE]} best candidates (by the score;")
    quoted(f"finite differences of the scorer (step {sci(table_search.REFINE_STEP)} of the box's "
           f"width), at most {table_search.REFINE_EVALUATIONS} evaluations each")
    quoted(f"the {WORDS[table_search.REFINE]} maximizations (L-BFGS-B, at most "
           f"{table_search.REFINE_EVALUATIONS} evaluations each)")
    assert SCENARIO_SETTINGS["search_samples"] == 16  # "the default 16" in the cost run
    quoted("with the default 16")


def test_the_tolerances_and_the_interior_case_of_the_search_tests():
    sys.path.insert(0, str(ROOT / "tests" / "optimization"))
    try:
        import test_robust_table_search as t
    finally:
        sys.path.pop(0)
    quoted(f"equal to {sci(t.SAME_J_DB)} dB in the objective and {sci(t.SAME_ROW)} in every row")
    src = (ROOT / "tests" / "optimization" / "test_robust_table_search.py").read_text()
    assert "max_peak_transmissibility_db=13.94" in src
    assert '"payload_mass_kg": {"min": 740.0, "max": 900.0}' in src
    assert "np.linspace(740.0, 900.0, 81)" in src
    quoted("the payload in 740-900 kg and the peak bound at 13.94 dB")
    quoted("the largest of 81 scenarios 2 kg apart")
