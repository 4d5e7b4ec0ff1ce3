"""The assembly with the co-design levers' geometry as symbols (docs/table.md, section 15).

Every element vector of the assembly is affine in the geometric levers: raising the
elastic centres by ``delta`` and stretching the layout about the CG's plan position by
``(s_x, s_y)`` gives ``g = g_0 + sum_k t_k C_k`` with ``t = (delta, s_x - 1, s_y - 1)`` and
constant direction arrays ``C_k`` (:func:`lever_directions`), so

    g g^T = g_0 g_0^T + sum_k t_k (g_0 C_k^T + C_k g_0^T) + sum_k sum_l t_k t_l C_k C_l^T
    g e^T = g_0 e^T + sum_k t_k C_k e^T

and ``D(w)``, ``B(w)`` are exact polynomials in the levers (:func:`lever_stiffness`), on
NumPy numbers and CasADi symbols alike. The gravity term, the mass matrix and the instrument
points do not move: the static loads stay those of the start layout (the leveling's moment
equations are homogeneous in the offsets from the CG).
"""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.table.assembly import Geometry, dynamic_stiffness
from isodesign.table.layout import POSITION_LEVER, is_position_lever, position_lever_names

__all__ = ["POSITION_LEVER", "footprint_polygon", "is_position_lever", "layout_rows",
           "lever_directions", "lever_stiffness", "max_spacing_bound_m", "point_in_polygon",
           "polygon_area_perimeter", "polygon_edges", "position_directions",
           "position_lever_names", "position_rows", "vertical_vectors"]


def lever_directions(geo: Geometry, table) -> dict[str, np.ndarray]:
    """The direction arrays ``C_k`` (3n, 6) of the geometric levers, rows as ``geo.g``.

    ``elastic_centre_height_m``: ``e_ry`` on the x elements, ``-e_rx`` on the y elements
    (``r x e_x = (0, r_z, -r_y)``, ``r x e_y = (-r_z, 0, r_x)``). ``layout_length_m``
    (``s_x``, the offsets ``a_i`` from the CG scaled): ``-a_i e_ry`` on the vertical elements
    (``r x e_z = (r_y, -r_x, 0)``) and ``a_i e_rz`` on the y elements. ``layout_width_m``
    (``s_y``): ``b_i e_rx`` on the vertical elements and ``-b_i e_rz`` on the x elements.

    Parameters
    ----------
    geo : Geometry
        The start table's geometry.
    table : Table
        The start table (its vertical-force points from the CG).

    Returns
    -------
    dict
        By lever name.
    """
    n = geo.n_isolators
    r = table.vertical_points_m
    a, b = r[:, 0], r[:, 1]
    cd, cx, cy = np.zeros((3 * n, 6)), np.zeros((3 * n, 6)), np.zeros((3 * n, 6))
    cd[n: 2 * n, 4] = 1.0
    cd[2 * n:, 3] = -1.0
    cx[:n, 4] = -a
    cx[2 * n:, 5] = a
    cy[:n, 3] = b
    cy[n: 2 * n, 5] = -b
    return {"elastic_centre_height_m": cd, "layout_length_m": cx, "layout_width_m": cy}


def _stack(ks) -> Cx:
    if bk.is_casadi(*[k.re for k in ks], *[k.im for k in ks]):
        import casadi as ca

        return Cx(ca.horzcat(*[k.re for k in ks]), ca.horzcat(*[k.im for k in ks]))
    return Cx(np.stack([np.asarray(k.re, dtype=float) for k in ks], axis=-1),
              np.stack([np.asarray(k.im, dtype=float) for k in ks], axis=-1))


def _matmul(a, b: np.ndarray):
    if bk.is_casadi(a):
        import casadi as ca

        return ca.mtimes(a, ca.DM(b))
    return np.asarray(a) @ b


def lever_stiffness(geo: Geometry, terms, k_vertical, k_horizontal, omega) -> tuple[Cx, Cx]:
    """``D(w)`` and ``B(w)`` flattened, with the element vectors moved by the levers.

    Parameters
    ----------
    geo : Geometry
        The start table's geometry (``t = 0``).
    terms : sequence of (t_k, C_k)
        Each geometric lever's coordinate (float, NumPy array broadcasting over the
        frequencies, or CasADi symbol) and its direction array (:func:`lever_directions`).
    k_vertical, k_horizontal : list of Cx
        As in :func:`~isodesign.table.assembly.dynamic_stiffness`.
    omega : ndarray or CasADi column
        Angular frequency, rad/s.

    Returns
    -------
    (D, B) : Cx
        As :func:`~isodesign.table.assembly.dynamic_stiffness`.
    """
    d, b = dynamic_stiffness(geo, k_vertical, k_horizontal, omega)
    if not terms:
        return d, b
    n = geo.n_isolators
    k = _stack(list(k_vertical) + list(k_horizontal) * 2)
    axis = np.repeat([2, 0, 1], n)
    g0 = geo.g
    d_re, d_im, b_re, b_im = d.re, d.im, b.re, b.im
    for i, (ti, ci) in enumerate(terms):
        g1 = (np.einsum("ei,ej->eij", g0, ci) + np.einsum("ei,ej->eij", ci, g0)).reshape(
            3 * n, 36)
        gb1 = np.zeros((3 * n, 6, 3))
        gb1[np.arange(3 * n), :, axis] = ci
        gb1 = gb1.reshape(3 * n, 18)
        d_re = d_re + ti * _matmul(k.re, g1)
        d_im = d_im + ti * _matmul(k.im, g1)
        b_re = b_re + ti * _matmul(k.re, gb1)
        b_im = b_im + ti * _matmul(k.im, gb1)
        for tj, cj in terms[i:]:
            g2 = np.einsum("ei,ej->eij", ci, cj)
            if cj is not ci:
                g2 = g2 + np.einsum("ei,ej->eij", cj, ci)
            g2 = g2.reshape(3 * n, 36)
            if not np.any(g2):
                continue
            d_re = d_re + ti * tj * _matmul(k.re, g2)
            d_im = d_im + ti * tj * _matmul(k.im, g2)
    return Cx(d_re, d_im), Cx(b_re, b_im)


def vertical_vectors(geo: Geometry, terms) -> list[list]:
    """Each isolator's vertical element vector ``g_z,i`` with the levers (a stroke is
    ``g_z,i . q - u_fz``), as lists of six entries (floats or symbols).

    Parameters
    ----------
    geo : Geometry
    terms : sequence of (t_k, C_k)
    """
    n = geo.n_isolators
    out = []
    for i in range(n):
        row = []
        for r in range(6):
            v = float(geo.gz[i, r])
            for t, c in terms:
                if c[i, r] != 0:
                    v = v + t * float(c[i, r])
            row.append(v)
        out.append(row)
    return out


def layout_rows(table, constraints: dict, scale_xy, free: bool) -> list:
    """The layout's constraint rows: ``footprint_m`` and ``min_isolator_distance_m``.

    With the layout stretched by ``(s_x, s_y)`` about the CG, ``x_i = c_x + s_x (x_i0 -
    c_x)``: the footprint's rows ``x_i - x_min``, ``x_max - x_i``, ``y_i - y_min``, ``y_max -
    y_i >= 0`` (m, linear in the levers) and the distance rows ``ln d_ij >= ln d_min``,
    ``d_ij^2 = s_x^2 dx_ij0^2 + s_y^2 dy_ij0^2`` for every pair (smooth: no distance is 0).
    A fixed layout has no rows: it is checked here and refused naming the key when it breaks
    one.

    Parameters
    ----------
    table : Table
        The start table.
    constraints : dict
        The study's constraints.
    scale_xy : (float or symbol, float or symbol)
        The stretch ``(s_x, s_y)``.
    free : bool
        A layout lever is a design variable.

    Returns
    -------
    list of (name, expression, lower, upper)
    """
    fp, dmin = constraints.get("footprint_m"), constraints.get("min_isolator_distance_m")
    if not fp and not dmin:
        return []
    c = table.cg_m[:2]
    off = table.isolators_m - c
    n = off.shape[0]
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    if not free:
        xy = table.isolators_m
        if fp:
            x0, y0, x1, y1 = fp
            bad = [i for i in range(n) if not (x0 <= xy[i, 0] <= x1 and y0 <= xy[i, 1] <= y1)]
            if bad:
                i = bad[0]
                raise InputError(f"constraints.footprint_m: isolator {i + 1} (from 1) at "
                                 f"({xy[i, 0]:.4g}, {xy[i, 1]:.4g}) m lies outside the "
                                 f"footprint x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m, and the "
                                 "layout is fixed (free variables.layout_length_m or "
                                 "layout_width_m, or widen the footprint)")
        if dmin:
            d = [float(np.hypot(*(xy[i] - xy[j]))) for i, j in pairs]
            k = int(np.argmin(d))
            if d[k] < dmin:
                i, j = pairs[k]
                raise InputError(f"constraints.min_isolator_distance_m: isolators {i + 1} and "
                                 f"{j + 1} (from 1) are {d[k]:.4g} m apart, below {dmin:g} m, "
                                 "and the layout is fixed")
        return []
    import casadi as ca

    sx, sy = scale_xy
    out = []
    if fp:
        x0, y0, x1, y1 = fp
        rows = []
        for i in range(n):
            x = c[0] + sx * float(off[i, 0])
            y = c[1] + sy * float(off[i, 1])
            rows += [x - x0, x1 - x, y - y0, y1 - y]
        out.append(("footprint_m", ca.vertcat(*rows), 0.0, np.inf))
    if dmin:
        rows = []
        for i, j in pairs:
            dx, dy = (float(v) for v in off[i] - off[j])
            rows.append(0.5 * ca.log(sx * sx * dx * dx + sy * sy * dy * dy))
        out.append(("min_isolator_distance_m", ca.vertcat(*rows), float(np.log(dmin)), np.inf))
    return out


# -- free isolator positions inside a footprint polygon (docs/table.md, section 15) -------
def _cross(o, a, b) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _segments_cross(p1, p2, q1, q2) -> bool:
    """The closed segments p1-p2 and q1-q2 meet (touching counts)."""
    d1, d2 = _cross(q1, q2, p1), _cross(q1, q2, p2)
    d3, d4 = _cross(p1, p2, q1), _cross(p1, p2, q2)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and 0 not in (d1, d2, d3, d4):
        return True

    def on(a, b, c, d):  # c on segment a-b, collinear
        return d == 0 and min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and \
            min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    return on(q1, q2, p1, d1) or on(q1, q2, p2, d2) or on(p1, p2, q1, d3) or on(p1, p2, q2, d4)


def footprint_polygon(key: str, value, plausible_m: float = 20.0) -> np.ndarray:
    """A footprint polygon as the study gives it, checked: counter-clockwise vertices (m).

    The isolators' positions stay inside it by one linear row per edge and isolator
    (:func:`position_rows`), exact for a convex polygon; a non-convex one is refused (give
    its convex hull, or the convex part the isolators may use).

    Parameters
    ----------
    key : str
        The key as the user typed it, for errors.
    value : list of [x, y]
        The vertices in order (either orientation), m.
    plausible_m : float
        A coordinate beyond it is a unit slip (mm typed as m).

    Returns
    -------
    ndarray, shape (m, 2)
        The vertices, counter-clockwise.

    Raises
    ------
    InputError
        Fewer than 3 vertices, a non-number, a coordinate beyond ``plausible_m``, repeated
        vertices, a self-intersecting or non-convex polygon, no area.
    """
    bad = (isinstance(value, str | bytes | dict) or not isinstance(value, list | tuple)
           or any(not isinstance(p, list | tuple) or len(p) != 2 or any(
               isinstance(c, bool) or not isinstance(c, int | float) or not np.isfinite(c)
               for c in p) for p in value))
    if bad:
        raise InputError(f"{key}: expected a list of [x, y] vertices in m (at least 3, a convex "
                         f"polygon in order), got {value!r:.60}")
    p = np.array(value, dtype=float)
    if p.shape[0] < 3:
        raise InputError(f"{key}: a polygon needs at least 3 vertices, got {p.shape[0]}")
    big = float(np.max(np.abs(p)))
    if big > plausible_m:
        raise InputError(f"{key}: a coordinate of {big:g} m is outside the plausible range "
                         f"of a table's footprint (+-{plausible_m:g} m); a unit slip? it is in "
                         f"m, and {big:g} mm would be {big * 1e-3:g} m")
    m = p.shape[0]
    for i in range(m):
        if np.allclose(p[i], p[(i + 1) % m], rtol=0, atol=1e-9):
            raise InputError(f"{key}: vertices {i + 1} and {(i + 1) % m + 1} (from 1) coincide")
    for i in range(m):
        for j in range(i + 2, m):
            if i == 0 and j == m - 1:
                continue  # adjacent through the closing edge
            if _segments_cross(p[i], p[(i + 1) % m], p[j], p[(j + 1) % m]):
                raise InputError(f"{key}: the polygon intersects itself (edge {i + 1} meets "
                                 f"edge {j + 1}, from 1); give its vertices in order around it")
    area2 = float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
    scale = float(np.ptp(p, axis=0).max())
    if abs(area2) < 1e-9 * scale * scale:
        raise InputError(f"{key}: the polygon has no area (its vertices lie on one line)")
    if area2 < 0:
        p = p[::-1].copy()
    for i in range(m):
        if _cross(p[i - 1], p[i], p[(i + 1) % m]) < -1e-12 * scale * scale:
            raise InputError(f"{key}: the polygon is not convex (at the vertex "
                             f"({p[i, 0]:g}, {p[i, 1]:g}) m); the containment rows are exact "
                             "for a convex footprint only: give its convex hull, or the convex "
                             "part the isolators may stand in")
    p.flags.writeable = False
    return p


def polygon_edges(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit inward normals ``n_k`` and offsets ``c_k`` of a counter-clockwise convex polygon:
    a point ``q`` is inside when ``n_k . q - c_k >= 0`` for every edge ``k`` (its distance
    from the edge's line, m).

    Parameters
    ----------
    poly : ndarray, shape (m, 2)
        Counter-clockwise vertices (:func:`footprint_polygon`).
    """
    e = np.roll(poly, -1, axis=0) - poly
    nrm = np.column_stack([-e[:, 1], e[:, 0]]) / np.hypot(e[:, 0], e[:, 1])[:, None]
    return nrm, np.einsum("ij,ij->i", nrm, poly)


def polygon_area_perimeter(poly: np.ndarray) -> tuple[float, float]:
    """Area (m^2) and perimeter (m) of a simple polygon.

    Parameters
    ----------
    poly : ndarray, shape (m, 2)
    """
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * abs(float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
    per = float(np.sum(np.hypot(*(np.roll(poly, -1, axis=0) - poly).T)))
    return area, per


def max_spacing_bound_m(poly: np.ndarray, n: int) -> float:
    """An upper bound on the smallest distance ``n`` points in a convex polygon can keep
    (Oler's inequality: ``n <= 2 A / (sqrt(3) d^2) + P / (2 d) + 1`` for ``n`` points at
    least ``d`` apart in a convex region of area ``A`` and perimeter ``P``; also at most the
    polygon's diameter), m. A ``min_isolator_distance_m`` above it cannot be met.

    Parameters
    ----------
    poly : ndarray, shape (m, 2)
    n : int
        Points (isolators), >= 2.
    """
    area, per = polygon_area_perimeter(poly)
    diam = max(float(np.hypot(*(a - b))) for a in poly for b in poly)
    if n <= 2:
        return diam
    # (2 A / sqrt 3) u^2 + (P / 2) u - (n - 1) = 0 with u = 1 / d
    qa, qb, qc = 2.0 * area / np.sqrt(3.0), 0.5 * per, -(n - 1.0)
    u = (-qb + np.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa)
    return float(min(diam, 1.0 / u))


def point_in_polygon(poly: np.ndarray, xy) -> np.ndarray:
    """Each point's smallest clearance to the edges of a convex counter-clockwise polygon
    (negative: outside), m.

    Parameters
    ----------
    poly : ndarray, shape (m, 2)
    xy : ndarray, shape (n, 2)
    """
    nrm, c = polygon_edges(poly)
    return (np.asarray(xy, float) @ nrm.T - c).min(axis=1)


def position_directions(geo: Geometry) -> list[np.ndarray]:
    """The direction arrays ``C_k`` (3n, 6) of each isolator's x and y (in
    :func:`position_lever_names` order), rows as ``geo.g``: moving isolator ``i`` by ``dx``
    turns its vertical element's ``r x e_z = (r_y, -r_x, 0)`` by ``-dx e_ry`` and its y
    element's ``r x e_y = (-r_z, 0, r_x)`` by ``dx e_rz``; by ``dy``: ``dy e_rx`` on the
    vertical element and ``-dy e_rz`` on the x element (``r x e_x = (0, r_z, -r_y)``).

    Parameters
    ----------
    geo : Geometry
    """
    n = geo.n_isolators
    out = []
    for i in range(n):
        cx, cy = np.zeros((3 * n, 6)), np.zeros((3 * n, 6))
        cx[i, 4] = -1.0
        cx[2 * n + i, 5] = 1.0
        cy[i, 3] = 1.0
        cy[n + i, 5] = -1.0
        out += [cx, cy]
    return out


def position_rows(xy, poly: np.ndarray | None, dmin: float | None) -> list:
    """The free positions' layout rows, smooth (docs/table.md, section 15).

    ``footprint_polygon_m``: ``n_k . q_i - c_k >= 0`` for every edge ``k`` and isolator
    ``i`` (m, linear: :func:`polygon_edges`), isolator by isolator; ``isolator_distance_m2``:
    ``|q_i - q_j|^2 >= d_min^2`` for every pair (squared: no square root at 0).

    Parameters
    ----------
    xy : list of (x, y)
        Each isolator's position (floats or CasADi symbols), m.
    poly : ndarray or None
        The footprint (counter-clockwise, convex).
    dmin : float or None
        ``constraints.min_isolator_distance_m``.

    Returns
    -------
    list of (name, expression, lower, upper)
    """
    import casadi as ca

    out = []
    n = len(xy)
    if poly is not None:
        nrm, c = polygon_edges(poly)
        rows = [float(nrm[k, 0]) * x + float(nrm[k, 1]) * y - float(c[k])
                for x, y in xy for k in range(len(c))]
        out.append(("footprint_polygon_m", ca.vertcat(*rows), 0.0, np.inf))
    if dmin:
        rows = []
        for i in range(n):
            for j in range(i + 1, n):
                dx, dy = xy[i][0] - xy[j][0], xy[i][1] - xy[j][1]
                rows.append(dx * dx + dy * dy)
        out.append(("isolator_distance_m2", ca.vertcat(*rows), float(dmin) ** 2, np.inf))
    return out
