"""Figures of docs/acoustics.md that no script prints, recomputed.

(Section 5 is printed by ``studies/acoustics_check.py``; sections 2 and 5 are also asserted in
tests/spring/test_acoustics.py.) A quoted number must equal the computed one at the precision
it is printed with.
"""

from __future__ import annotations

import math
from pathlib import Path

from isodesign import SpringDesign, complex_stiffness

PAGE = (Path(__file__).parents[2] / "docs" / "acoustics.md").read_text(encoding="utf-8")
FLAT = " ".join(PAGE.split())
REF = SpringDesign.reference()


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in FLAT, text


def test_distributed_against_lumped_on_the_reference_spring():
    tube = 1.4 * REF.capillary_area_m2 * REF.capillary_length_m / REF.total_volume_m3
    quoted(f"(`1.4 V_c / V_total`, {tube:.0e} on the reference spring;".replace("e-0", "e-"))
    worst = 0.0
    for x in (1e-6, 5e-5, 5e-4):
        kd = complex_stiffness(REF, 80.0, x, diaphragm="none", warn=False).k.item()
        kl = complex_stiffness(REF.replace(acoustics="lumped"), 80.0, x, diaphragm="none",
                               warn=False).k.item()
        worst = max(worst, abs(kd / kl - 1))
    quoted(f"at 80 Hz the reference spring's stiffness\ndiffers from Eq. 38 by {worst:.1%}"
           .replace("%", " %"))


def test_plane_wave_limits():
    c = REF.gas.speed_of_sound(REF.temperature_k)
    khz = float(f"{1.8412 * c / (math.pi * 1e-3) / 1e3:.2g}")  # quoted to two digits
    quoted(f"`1.8412 c / (pi D_c)` ({khz:.0f} kHz for 1 mm")
    d_max = 0.98 * 1.8412 * c / (2 * math.pi * 89.0)
    quoted(f"a chamber diameter below {d_max:.1f} m at\n89 Hz")


def test_lumped_check_counts(study_script):
    """Section 4: the counts of ``studies/lumped_flag_check.py`` on its main grid (the wide
    grid's, 4 times as many points, are printed by the script and not re-run here)."""
    r = study_script("lumped_flag_check").lumped_flag_grid("main")
    assert r["passed_outside"] == 0
    n = r["points"]
    quoted(f"the check passes no point outside the 1 % (the largest error it passes: "
           f"{r['worst_passed']:.2%}".replace("%", " %") + f" on the\nmain grid, {n:,} points")
    quoted(f"it flags {r['flagged_within'] / n:.1%}".replace("%", " %") + " (main)")
    quoted(f"passed points {r['old_worst_passed']:.0%}".replace("%", " %") + " (main)")
    quoted(f"and flagged {r['old_flagged_within'] / n:.1%}".replace("%", " %") + " and")
