"""The lumped model's validity flag against the distributed model: docs/acoustics.md, section 4.

Usage (from the repository root)::

    python studies/lumped_flag_check.py

Evaluates the air stiffness of the lumped model (Eq. 38) and of the distributed network
(``isodesign.spring.acoustics``) for the same flow resistance on two grids of geometries
(top volume, volume ratio, tube length and bore, chamber aspect ratio) and frequencies, and
counts, against the ``lumped`` check of :func:`isodesign.spring.diagnostics.
evaluate_diagnostics` (the first-order error estimate of :mod:`isodesign.spring.compactness`):

* points the check passes where the lumped ``k`` is more than the tolerance from the line's
  (must be none), and the largest error it passes;
* points it flags although within the tolerance (its conservatism);
* the same counts for the former check ``w l / c <= 0.3`` (``l`` the largest of the tube length
  and ``V^(1/3)``).

Grid ``main``: the ``womersley`` (linear) flow, 51,840 points; grid ``wide``: larger and
taller chambers, thinner and longer tubes, ``quasi_steady`` at 0.5 and 5 m/s and
``womersley``, 209,520 points.
"""

from __future__ import annotations

import itertools

import numpy as np

from isodesign.spring.acoustics import acoustic_network
from isodesign.spring.compactness import LUMPED_TOLERANCE
from isodesign.spring.design import SpringDesign
from isodesign.spring.diagnostics import (
    LUMPED_ESTIMATE_FRACTION,
    LUMPED_LIMIT,
    lumped_error_bound,
)
from isodesign.spring.equations import air_stiffness
from isodesign.spring.flow_models import resistance_function

#: name -> (frequencies Hz, (flow, tube velocity m/s) cases, geometry axes: V_t0 m^3, N,
#: L_c m, D_c m, aspect ratio)
GRIDS = {
    "main": (np.geomspace(0.1, 200.0, 60), [("womersley", 1.0)],
             ([0.3e-3, 1e-3, 3e-3, 10e-3], [1.0, 2.0, 4.0, 8.0],
              [0.02, 0.05, 0.2, 0.5, 1.0, 2.0], [1e-3, 2e-3, 4e-3], [0.5, 1.0, 3.0])),
    "wide": (np.geomspace(0.1, 200.0, 97),
             [("quasi_steady", 0.5), ("quasi_steady", 5.0), ("womersley", 1.0)],
             ([0.15e-3, 0.7e-3, 5e-3, 20e-3], [0.5, 3.0, 6.0], [0.01, 0.1, 0.35, 1.5, 3.0],
              [0.7e-3, 1.5e-3, 3e-3, 5e-3], [0.3, 2.0, 6.0])),
}


def lumped_flag_grid(name: str = "main", tolerance: float = LUMPED_TOLERANCE) -> dict:
    """Counts of the ``lumped`` check against the distributed model on one grid.

    Parameters
    ----------
    name : {'main', 'wide'}
        The grid (:data:`GRIDS`).
    tolerance : float
        The stated tolerance on ``|k_lumped / k_line - 1|``.

    Returns
    -------
    dict
        ``points``; ``passed_outside`` (flag true, error above the tolerance: must be 0),
        ``worst_passed`` (largest error among the passed points), ``flagged``,
        ``flagged_within`` (flagged although within the tolerance); and ``old_*`` the same
        for ``w l / c <= 0.3``.
    """
    f_hz, cases, axes = GRIDS[name]
    w = 2.0 * np.pi * f_hz
    ref = SpringDesign.reference()
    err, ok, old = [], [], []
    for (flow, u), (vt, n, lc, dc, ar) in itertools.product(cases, itertools.product(*axes)):
        d = ref.replace(top_volume_m3=vt, volume_ratio=n, capillary_length_m=lc,
                        capillary_diameter_m=dc, chamber_aspect_ratio=ar, acoustics="distributed")
        c = resistance_function(flow, d, w)(np.full_like(w, u))
        k_line = acoustic_network(d, w, flow).stiffness(c).to_complex()
        lumped = d.replace(acoustics="lumped")
        k_lumped = air_stiffness(lumped, w, c, flow).to_complex()
        err.append(np.abs(k_lumped / k_line - 1.0))
        bound = lumped_error_bound(lumped, w, c, flow, w.shape)
        ok.append(bound <= LUMPED_ESTIMATE_FRACTION * tolerance)
        size = max(lc, vt ** (1 / 3), (n * vt) ** (1 / 3))
        old.append(w * size / d.speed_of_sound_m_s <= LUMPED_LIMIT)
    err, ok, old = (np.concatenate(v) for v in (err, ok, old))
    out = {"points": err.size}
    for key, flag in (("", ok), ("old_", old)):
        out.update({
            f"{key}passed_outside": int(np.sum(flag & (err > tolerance))),
            f"{key}worst_passed": float(np.max(err[flag])),
            f"{key}flagged": int(np.sum(~flag)),
            f"{key}flagged_within": int(np.sum(~flag & (err <= tolerance))),
        })
    return out


def main() -> None:
    """Print the counts of both grids."""
    for name in GRIDS:
        r = lumped_flag_grid(name)
        print(f"grid {name}, {r['points']:,} points, tolerance {LUMPED_TOLERANCE:.0%}:")
        for key, label in (("", "lumped check (estimate)"), ("old_", "w l / c <= 0.3")):
            print(f"  {label}: passes {r[key + 'passed_outside']:,} points outside the tolerance "
                  f"(worst passed {r[key + 'worst_passed']:.2%}); flags {r[key + 'flagged']:,}, "
                  f"of which {r[key + 'flagged_within']:,} "
                  f"({r[key + 'flagged_within'] / r['points']:.1%} of the grid) are within it")


if __name__ == "__main__":
    main()
