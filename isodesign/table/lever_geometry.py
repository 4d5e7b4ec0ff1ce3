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

__all__ = ["layout_rows", "lever_directions", "lever_stiffness", "vertical_vectors"]


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
