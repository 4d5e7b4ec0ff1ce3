"""The figures the comments of isodesign/data/reference.toml quote, recomputed.

(The default study's comment is checked by tests/optimization/test_docs_numbers.py.)
"""

from __future__ import annotations

from pathlib import Path

from isodesign import SpringDesign
from isodesign.io.designfile import load_design
from isodesign.spring.gas import Gas

PATH = Path(__file__).parents[2] / "isodesign" / "data" / "reference.toml"
TEXT = " ".join(line.lstrip("# ") for line in PATH.read_text(encoding="utf-8").splitlines())


def test_reference_file_comments():
    d = SpringDesign.reference()
    assert load_design(PATH) == d
    assert f"1.5e-3 / 8.1e-4 = {d.volume_ratio:.3f} exactly" in TEXT
    assert f"A_p (p0 - p_atm) = {d.load_n:.0f} N, about {d.load_n / 9.80665:.0f} kg" in TEXT
    mu = Gas().viscosity(288.1)
    assert f"{mu:.2e}" == "1.79e-05"
    assert "Fixed at Table 1's 1.79e-5 Pa s (Sutherland's law gives this value at 288.1 K)" in TEXT
