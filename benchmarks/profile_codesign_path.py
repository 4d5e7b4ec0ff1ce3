"""How the co-designed table's limited-memory path depends on a row inactive at every
iterate (docs/table.md, section 13, "Speed"): the reproducer.

``python benchmarks/profile_codesign_path.py [BOUND ...]`` optimizes the default study
(``default_study()``, the co-designed built-in table) once per bound of the tube's length
row ``tube_end_length`` (``D_c / L_c <= BOUND`` x the validity margin 0.98; the product's
BOUND is 0.5, the end correction's four bore radii; default bounds 0.5 0.45 0.3 0.2 1.0)
and prints,
per bound, the whole call's wall time, the worst margin of the fine-grid analysis and each
solve's status and IPOPT iterations (the tied starts, then the full NLP's solve from the
best tied optimum). The row is inactive at every iterate (the optimum's ``D_c / L_c`` is
near 0.01), so the bounds only change the barrier term of a far constraint: the iterations
it prints measure how sensitive the quasi-Newton path is to it.
"""

from __future__ import annotations

import dataclasses
import sys
import time
import warnings

DEFAULT_BOUNDS = (0.5, 0.45, 0.3, 0.2, 1.0)


def run(bounds) -> list[dict]:
    """One optimize of the default study per bound of the tube's length row.

    Parameters
    ----------
    bounds : sequence of float
        Upper bounds of ``D_c / L_c``.

    Returns
    -------
    list of dict
        ``bound``, ``wall_s``, ``worst_margin_db`` and ``solves`` (``(status,
        iterations)`` per solve, the starts' order).
    """
    from isodesign.optimization import constraint_registry as cr
    from isodesign.optimization.study import default_study
    from isodesign.optimization.table_driver import optimize_table

    kind = cr.CONSTRAINTS["tube_end_length"]
    rows = []
    try:
        for bound in bounds:
            cr.CONSTRAINTS["tube_end_length"] = dataclasses.replace(
                kind, bounds=lambda c, b=float(bound): (None, b))
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = optimize_table(default_study())
            rows.append({"bound": float(bound), "wall_s": time.perf_counter() - t0,
                         "worst_margin_db": r.analysis.worst_margin_db,
                         "solves": [(s[1], s[3]) for s in r.starts]})
    finally:
        cr.CONSTRAINTS["tube_end_length"] = kind
    return rows


if __name__ == "__main__":
    for row in run([float(a) for a in sys.argv[1:]] or DEFAULT_BOUNDS):
        solves = ", ".join(f"{st} {it}" for st, it in row["solves"])
        print(f"D_c/L_c <= {row['bound']:g}: {row['wall_s']:.1f} s, worst margin "
              f"{row['worst_margin_db']:+.3f} dB; {solves}")
