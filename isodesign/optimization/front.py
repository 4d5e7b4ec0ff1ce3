"""The measure of a two-objective front, shared by every Pareto front (vertical or table).

:func:`nondominated` filters the points, :func:`front_reference` places the ideal and the
reference point and :func:`hypervolume_2d` measures the dominated area in the normalized
space (ideal point 0, reference point 1), so a vertical and a table front report the same
figure (docs/optimization.md).
"""

from __future__ import annotations

import numpy as np

__all__ = ["REFERENCE_MARGIN", "front_reference", "hypervolume_2d", "nondominated"]

#: The hypervolume reference point is the front's nadir pushed out by this
#: fraction of the front's range in each (minimized) objective; the space is
#: normalized so that the ideal point is 0 and the reference point 1.
REFERENCE_MARGIN = 0.1


def nondominated(points: np.ndarray) -> np.ndarray:
    """Boolean mask of the non-dominated rows of an (n, 2) array (both minimized).

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Objective values to minimize (maximized objectives negated first).
        Rows with a non-finite value (failed sweep points, NaN) are never kept
        and dominate nothing.

    Returns
    -------
    ndarray of bool, shape (n,)
        True where no finite row is at least as good in both objectives and
        strictly better in one. Duplicate rows are all kept.
    """
    p = np.asarray(points, float)
    keep = np.ones(len(p), dtype=bool)
    for i in range(len(p)):
        if not np.all(np.isfinite(p[i])):
            keep[i] = False
            continue
        dom = np.all(p <= p[i], axis=1) & np.any(p < p[i], axis=1)
        keep[i] = not np.any(dom & np.all(np.isfinite(p), axis=1))
    return keep


def hypervolume_2d(points: np.ndarray, reference: np.ndarray) -> float:
    """Area dominated by a set of 2-D points (both minimized) up to a reference point.

    Exact sweep: sort the non-dominated points by the first objective and add
    the rectangles they dominate. Points not better than the reference in both
    objectives contribute nothing.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Objective values to minimize, in the same units as ``reference``
        (:func:`pareto_front` passes normalized values: ideal point 0).
    reference : array_like, shape (2,)
        The reference point bounding the area (normalized: ``(1, 1)``).

    Returns
    -------
    float
        The dominated area, in the product of the two objectives' units
        (dimensionless when normalized; 1 is the whole box from the ideal point).

    Notes
    -----
    With the non-dominated points sorted by increasing first objective ``x_i``
    (so decreasing second objective ``y_i``), the area is
    ``sum_i (r_x - x_i) (y_{i-1} - y_i)`` with ``y_0 = r_y``.
    """
    p = np.asarray(points, float)
    r = np.asarray(reference, float)
    p = p[np.all(p < r, axis=1)]
    if p.size == 0:
        return 0.0
    p = p[nondominated(p)]
    p = p[np.argsort(p[:, 0])]
    hv = 0.0
    prev_y = r[1]
    for x, y in p:
        if y < prev_y:
            hv += (r[0] - x) * (prev_y - y)
            prev_y = y
    return float(hv)


def front_reference(mins: np.ndarray, front: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                   float]:
    """Ideal point, reference point and normalized hypervolume of a front.

    Parameters
    ----------
    mins : ndarray, shape (n, 2)
        Both objectives minimized (margins negated), natural units.
    front : ndarray of bool, shape (n,)
        The non-dominated rows (:func:`nondominated`), at least one.

    Returns
    -------
    ideal, reference : ndarray, shape (2,)
        The front's best values, and its nadir pushed out by :data:`REFERENCE_MARGIN` of
        its range (minimized space).
    hypervolume : float
        The front's dominated area, normalized so that ideal -> 0 and reference -> 1.
    """
    ideal = np.nanmin(mins[front], axis=0)
    nadir = np.nanmax(mins[front], axis=0)
    span = np.where(nadir > ideal, nadir - ideal, 1.0)
    ref = nadir + REFERENCE_MARGIN * span
    hv = hypervolume_2d((mins[front] - ideal) / (ref - ideal), np.ones(2))
    return ideal, ref, hv
