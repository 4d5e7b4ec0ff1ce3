"""The branch the distortion closure's optimizer misses, reached from the plain closure's.

The co-design script's case ``all_and_inertia_base`` (``studies/table_codesign.py``: the
built-in table with its four horizontal-element levers and the inertia base free) ends at
+9.55 dB with the default closure (its tubes' distortion power on), while the plain closure
(``models.distortion = false``) reaches +12.4 dB. The distortion optimizer finds that branch
among its starts but its first peak-refinement round does not converge there (docs/table.md
section 13, "What the distortion closure's optimizer misses there"). This script shows the
branch is real for the distortion closure: it optimizes the case with the plain closure, then
with the default closure from that optimum (one start), and prints both (NLP grid and fine-grid
analysis, whether the continuous peak meets its bound, the design) and, for comparison, the
default closure's own multi-start answer (``--no-default`` skips it: about 2 minutes).

``--case NAME`` runs another case of the co-design script instead (``default``: the default
study, whose figures docs/table.md section 13 quotes beside this case's).

Usage::

    python studies/table_distortion_homotopy.py [--case all_and_inertia_base] [--workers 2]
        [--no-default]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from isodesign.optimization.table_driver import optimize_table

sys.path.insert(0, str(Path(__file__).resolve().parent))
from table_codesign import CASES, case_study


def _line(label: str, r, wall: float) -> str:
    met = (r.peak or {}).get("met")
    return (f"{label}: NLP {r.objective_value:+.2f} dB, analysis "
            f"{r.analysis.worst_margin_db:+.2f} dB, success {r.success}, peak bound met "
            f"{met}, {wall:.0f} s\n    " + ", ".join(f"{k} {v:.4g}" for k, v in
                                                   r.values.items()))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default="all_and_inertia_base",
                   help=f"a case of studies/table_codesign.py: {', '.join(CASES)}")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--no-default", action="store_true",
                   help="skip the default closure's own multi-start")
    a = p.parse_args(argv)
    if a.case not in CASES:
        p.error(f"--case: unknown {a.case!r}; valid: {', '.join(CASES)}")
    st = case_study(CASES[a.case])
    t = time.perf_counter()
    plain = optimize_table(st.with_changes(models={"distortion": False}), workers=a.workers)
    print(_line("plain closure, multi-start", plain, time.perf_counter() - t))
    free = {v.name for v in (*st.variables, *st.levers) if v.free}
    from_plain = st.with_changes(
        variables={k: {"start": float(v)} for k, v in plain.values.items() if k in free},
        solver={"starts": 1})
    t = time.perf_counter()
    r = optimize_table(from_plain, workers=1)
    print(_line("default closure, from the plain optimum", r, time.perf_counter() - t))
    if not a.no_default:
        t = time.perf_counter()
        d = optimize_table(st, workers=a.workers)
        print(_line("default closure, its own multi-start", d, time.perf_counter() - t))
    return 0


if __name__ == "__main__":
    sys.exit(main())
