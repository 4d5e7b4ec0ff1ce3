"""The prose under the default Pareto front in docs/optimization.md says what its listing
shows (the listing itself is checked against a run by tests/docs/test_listings.py)."""

from __future__ import annotations

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "optimization.md"
LISTING = "$ isodesign pareto --builtin vertical -o out/pareto"


def _front() -> list[dict]:
    text = DOC.read_text(encoding="utf-8")
    block = text.split(LISTING, 1)[1].split("```", 1)[0]
    rows = []
    for m in re.finditer(r"^\s+(\d+)\s+([+-]\d+\.\d+) dB\s+(\d+(?:\.\d+)?) L\s+(\S+)\s+(\S+)\s+"
                         r"(\S+)\s+(\S+)\s+(yes|no)$", block, re.M):
        rows.append({"i": int(m[1]), "margin": float(m[2]), "volume": float(m[3]),
                     "n": float(m[4]), "vt": float(m[5]), "lc": float(m[6]),
                     "dc": float(m[7])})
    return sorted(rows, key=lambda r: r["volume"])


def _prose() -> str:
    text = DOC.read_text(encoding="utf-8")
    return text.split(LISTING, 1)[1].split("## 11.", 1)[0]


def test_the_listing_is_parsed():
    front = _front()
    assert len(front) == 20 and front[-1]["volume"] == 6.0


def test_the_prose_quotes_the_front():
    front, prose = _front(), " ".join(_prose().split())
    # VC-C met from about 1 L: the first point with a positive margin
    first = next(r for r in front if r["margin"] > 0)
    m = re.search(r"VC-C is met \(margin > 0\) from about (\d+(?:\.\d+)?) L per spring", prose)
    assert m and abs(first["volume"] - float(m[1])) < 0.05, (first, m and m[0])
    # the last X L (from A to B L) buy Y dB
    m = re.search(r"the last (\d+\.\d) L \(from (\d+\.\d) to (\d+) L\) buy (\d+\.\d) dB", prose)
    assert m
    a = min(front, key=lambda r: abs(r["volume"] - float(m[2])))
    b = front[-1]
    assert round(b["volume"] - a["volume"], 1) == float(m[1])
    assert round(a["volume"], 1) == float(m[2]) and round(b["volume"]) == float(m[3])
    assert round(b["margin"] - a["margin"], 1) == float(m[4])
    # the tube: L_c at two volumes
    for lc, vol in re.findall(r"(\d+) mm at (\d+\.\d) L", prose):
        r = min(front, key=lambda r: abs(r["volume"] - float(vol)))
        assert round(r["volume"], 1) == float(vol) and round(r["lc"]) == float(lc), (lc, vol)
    # N reaches its upper bound 8 at X L: the smallest volume with N = 8
    m = re.search(r"N grows to its upper bound 8 \(reached at (\d+\.\d) L\)", prose)
    n8 = next(r for r in front if r["n"] == 8.0)
    assert m and round(n8["volume"], 1) == float(m[1])
    # below about 1 L: L_c at its 500 mm bound and V_t0 at 0.2 L
    small = [r for r in front if r["volume"] < first["volume"]]
    assert small and all(r["lc"] == 500 and r["vt"] == 0.2 for r in small)
    assert "at its 500 mm upper bound with V_t0 at its 0.2 L lower bound" in prose
