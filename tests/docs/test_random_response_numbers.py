"""The figures docs/random-response.md quotes outside its Monte Carlo table, recomputed.

The table of section 6 is printed by ``studies/random_closure_check.py`` (minutes of Monte
Carlo: not re-run here); the sentences that summarize it are checked against the table
itself. A quoted number must equal the computed one at the precision it is printed with. If
one of these fails, the page and the code disagree: fix the page (or the code), never the
tolerance.
"""

from __future__ import annotations

import re
import warnings
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path

import numpy as np

from isodesign import complex_stiffness
from isodesign.response import Payload, band_response
from isodesign.response.isolator import loaded_design
from isodesign.spring.capillary import (
    _gaussian_friction_rule,
    churchill_friction_re_product,
    gaussian_friction_excess,
)
from isodesign.spring.design import SpringDesign

PAGE = (Path(__file__).parents[2] / "docs" / "random-response.md").read_text(encoding="utf-8")
FLAT = " ".join(PAGE.split())
REF, PAYLOAD = SpringDesign.reference(), Payload(400.0, 4)


def quoted(text: str) -> None:
    """The page says ``text`` (whitespace-insensitive)."""
    assert " ".join(text.split()) in FLAT, text


def _band(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return band_response(REF, PAYLOAD, "VC-A", "VC-E", **kw)


def test_section_1_the_tube_velocity_the_stroke_closure_assumes():
    r = _band(random_method="equivalent_amplitude", diaphragm="none")
    d = loaded_design(REF, PAYLOAD)
    u = [complex_stiffness(d, f, r.equivalent_amplitude_m, diaphragm="none", warn=False)
         .diagnostics.velocity_amplitude_m_s.item() for f in (1.1, 4.0)]
    quoted(f"(for the reference spring on VC-A, no diaphragm: {u[0]:.1f} m/s at 1.1 Hz, "
           f"{u[1]:.1f} m/s at 4 Hz,")
    # ... while the tube velocity's RMS is the Monte Carlo's of the table's first row
    mc = re.search(r"\| reference spring, 100 kg, VC-A \|[^\n]*\| [0-9.]+ / ([0-9.]+) \|", PAGE)
    quoted(f"while\nthe tube velocity's RMS is {mc.group(1)} m/s)")


def test_section_2_gaussian_friction_rule():
    re_nodes, _ = _gaussian_friction_rule()
    quoted(f"{np.size(re_nodes)} nodes that do not move with `sigma_u`")
    res = np.geomspace(200.0, 1e5, 200)
    exact = np.array([float(gaussian_friction_excess(r)) for r in res])
    worst = {}
    for n in (64, 96):
        x, w = np.polynomial.hermite_e.hermegauss(n)
        w = w / np.sqrt(2.0 * np.pi)
        gh = np.array([np.sum(w * x**2 * (churchill_friction_re_product(r * np.abs(x)) - 64.0))
                       for r in res])
        worst[n] = float(np.max(np.abs(gh - exact) / (64.0 + exact)))
    quoted(f"({100 * worst[64]:.1f} % error with 64 nodes, {100 * worst[96]:.1f} % with 96)")


def test_section_3_closure_count():
    r = _band()
    quoted(f"it converges in a few\nouter and {r.iterations} inner evaluations")


def _table():
    rows = {}
    for line in PAGE.splitlines():
        m = re.match(r"\| ((?:reference spring|long capillary)[^|]*) \| ([+-][0-9.]+) \([^)]*\) "
                     r"\| ([+-][0-9.]+) % \| ([+-][0-9.]+) \([^)]*\) \| ([+-][0-9.]+) % \|", line)
        if m:
            rows[m.group(1)] = tuple(float(m.group(i)) for i in range(2, 6))
    assert len(rows) == 8, rows
    return rows


def test_section_6_sentences_summarize_the_table():
    rows = _table()
    plain = {k: v for k, v in rows.items() if "diaphragm" not in k}
    assert len(plain) == 5
    band = max(abs(v[2]) for v in plain.values())
    stroke = max(abs(v[3]) for v in plain.values())
    assert band <= 0.25
    quoted(f"within 0.25 dB in every band and {stroke:.1f} % in the stroke RMS on the\n  five "
           "cases without diaphragm")
    wom = rows["long capillary, 150 kg, 4x VC-A, Womersley flow"]
    quoted(f"Womersley flow included ({abs(wom[2]):.2f} dB)")
    old = [abs(v[0]) for v in plain.values()]

    def one_decimal(v):  # the table's two decimals, rounded half up as written
        return Decimal(str(v)).quantize(Decimal("0.1"), ROUND_HALF_UP)

    quoted(f"the harmonic closure on the\n  stroke erred by {one_decimal(min(old))} to "
           f"{one_decimal(max(old))} dB")
    ref4 = rows["reference spring, 100 kg, 4x VC-A"]
    quoted(f"stroke {ref4[3]:+.1f} %, 1 Hz band {ref4[2]:+.2f} dB")
