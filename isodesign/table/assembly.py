"""The 6x6 rigid-body assembly: dynamic stiffness, floor input, outputs (any backend).

Body coordinates about the CG, ``q = (x, y, z, rx, ry, rz)`` (m, rad), small rotations. A
one-dimensional spring of complex stiffness ``k`` along the unit vector ``e`` at ``r`` (from
the CG) stretches by ``e . (t + theta x r) - e . u_f = g . q - e . u_f`` with
``g = (e, r x e)``, so (docs/table.md, section 2)::

    D(w) = sum_e k_e(w) g_e g_e^T + K_g - w^2 M          (6x6, complex symmetric)
    B(w) = sum_e k_e(w) g_e e_e^T                          (6x3, floor translations)
    D q = B u_f

Each isolator contributes three elements: vertical (``e_z`` at its vertical-force point)
and horizontal in x and y (at its elastic centre). ``K_g`` is the gravity (overturning)
term: the isolators' static forces ``W_i e_z`` stay vertical while their points turn with
the table, giving the moment ``sum_i W_i (theta x r_i) x e_z``; at equilibrium
(``sum W_i (x_i, y_i) = 0`` about the CG) it is ``-W h`` on ``rx`` and ``ry``.

The element stiffnesses enter as a matrix product with constant geometry matrices, so
the same :func:`dynamic_stiffness` evaluates NumPy arrays (``(n_freq, n_elements)``) and
CasADi columns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.table.layout import Table

__all__ = [
    "AXES",
    "DOFS",
    "Geometry",
    "dynamic_stiffness",
    "elastic_centre_terms",
    "element_vectors",
    "floor_input",
    "geometry",
    "gravity_stiffness",
    "ldlt_solve",
    "point_matrix",
    "solve_complex",
    "static_stiffness_matrix",
]

#: Body degrees of freedom, in order.
DOFS = ("x", "y", "z", "rx", "ry", "rz")
#: Floor and output translation axes.
AXES = ("x", "y", "z")


def _skew(r) -> np.ndarray:
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def element_vectors(points_m: np.ndarray, direction: int) -> np.ndarray:
    """``g = (e, r x e)`` of springs along axis ``direction`` at ``points_m``, shape (n, 6).

    Parameters
    ----------
    points_m : ndarray, shape (n, 3)
        Spring points relative to the CG, m.
    direction : int
        0, 1, 2 for x, y, z.
    """
    e = np.zeros(3)
    e[direction] = 1.0
    p = np.asarray(points_m, dtype=float)
    return np.concatenate([np.broadcast_to(e, p.shape), np.cross(p, e)], axis=1)


def point_matrix(r) -> np.ndarray:
    """``G_r = [I, -[r]x]`` (3x6): translation of the body point ``r`` (from the CG).

    Parameters
    ----------
    r : sequence of 3 float
        The point relative to the CG, m.
    """
    return np.concatenate([np.eye(3), -_skew(np.asarray(r, dtype=float))], axis=1)


def gravity_stiffness(table: Table, load_n) -> np.ndarray:
    """The gravity (overturning) stiffness ``K_g`` (6x6, real), N m/rad.

    ``K_g[3:, 3:] = sum_i W_i P [r_i]x`` with ``P (a, b, c) = (b, -a, 0)`` (the moment of
    the vertical static forces about the CG under a small rotation, with the sign of a
    stiffness). At equilibrium it is ``diag(-W h, -W h, 0)`` on ``(rx, ry, rz)``.

    Parameters
    ----------
    table : Table
    load_n : ndarray, shape (n,)
        The isolators' static loads (:class:`~isodesign.table.statics.Leveling`), N.
    """
    kg = np.zeros((6, 6))
    p = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    for w, r in zip(np.asarray(load_n, dtype=float), table.vertical_points_m, strict=True):
        kg[3:, 3:] += w * (p @ _skew(r))
    return kg


@dataclass(frozen=True, eq=False)
class Geometry:
    """Constant matrices of a table's assembly (NumPy, built once).

    Attributes
    ----------
    n_isolators : int
    g : ndarray, shape (3n, 6)
        Element vectors, rows ``[z_1..z_n, x_1..x_n, y_1..y_n]``.
    gg : ndarray, shape (3n, 36)
        ``g g^T`` per element, flattened row-major: ``D_flat = k @ gg``.
    gb : ndarray, shape (3n, 18)
        ``g e^T`` per element, flattened (6x3 row-major): ``B_flat = k @ gb``.
    mass : ndarray, shape (6, 6)
    gravity : ndarray, shape (6, 6)
        :func:`gravity_stiffness`.
    points : ndarray, shape (k, 3, 6)
        :func:`point_matrix` of each instrument point.
    gz : ndarray, shape (n, 6)
        Vertical element vectors (a stroke is ``gz_i . q - u_fz``).
    gh : ndarray, shape (2, n, 6)
        Horizontal element vectors (x, y).
    """

    n_isolators: int
    g: np.ndarray
    gg: np.ndarray
    gb: np.ndarray
    mass: np.ndarray
    gravity: np.ndarray
    points: np.ndarray
    gz: np.ndarray
    gh: np.ndarray


def geometry(table: Table, load_n, *, include_gravity: bool = True) -> Geometry:
    """The constant matrices of :func:`dynamic_stiffness` for a table.

    Parameters
    ----------
    table : Table
    load_n : ndarray, shape (n,)
        Static loads, N (for the gravity term).
    include_gravity : bool
        Add the overturning term (default; switch off only for comparisons with
        spring-only formulas such as Harris').
    """
    gz = element_vectors(table.vertical_points_m, 2)
    gx = element_vectors(table.horizontal_points_m, 0)
    gy = element_vectors(table.horizontal_points_m, 1)
    g = np.concatenate([gz, gx, gy], axis=0)
    n = table.n_isolators
    axis = np.repeat([2, 0, 1], n)
    gg = np.einsum("ei,ej->eij", g, g).reshape(3 * n, 36)
    gb = np.zeros((3 * n, 6, 3))
    gb[np.arange(3 * n), :, axis] = g
    kg = gravity_stiffness(table, load_n) if include_gravity else np.zeros((6, 6))
    pts = np.stack([point_matrix(r) for r in table.instrument_points_from_cg_m])
    arrays = (g, gg, gb, kg, pts, gz)
    for a in arrays:
        a.flags.writeable = False
    return Geometry(n_isolators=n, g=g, gg=gg, gb=gb.reshape(3 * n, 18), mass=table.mass_matrix,
                    gravity=kg, points=pts, gz=gz, gh=np.stack([gx, gy]))  # fmt: skip


def _matmul(a, b: np.ndarray):
    """``a @ b`` for a NumPy array or a CasADi matrix ``a`` and a constant NumPy ``b``."""
    if bk.is_casadi(a):
        import casadi as ca

        return ca.mtimes(a, ca.DM(b))
    return np.asarray(a) @ b


def _stack(ks) -> Cx:
    """Element stiffnesses (a list of Cx, each (n_freq,) or a CasADi column) side by side."""
    if bk.is_casadi(*[k.re for k in ks], *[k.im for k in ks]):
        import casadi as ca

        return Cx(ca.horzcat(*[k.re for k in ks]), ca.horzcat(*[k.im for k in ks]))
    re = np.stack([np.asarray(k.re, dtype=float) for k in ks], axis=-1)
    im = np.stack([np.asarray(k.im, dtype=float) for k in ks], axis=-1)
    return Cx(re, im)


def elastic_centre_terms(geo: Geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The terms of the assembly in a shift ``delta`` of every elastic centre's height.

    A horizontal element's vector is linear in its height, ``g = g_0 + delta c`` (x: ``c =
    e_ry``; y: ``c = -e_rx``), so ``g g^T = g_0 g_0^T + delta (g_0 c^T + c g_0^T) + delta^2
    c c^T`` and ``g e^T = g_0 e^T + delta c e^T``: exact and polynomial (docs/table.md,
    section "Co-design levers").

    Parameters
    ----------
    geo : Geometry

    Returns
    -------
    (gg1, gg2, gb1) : ndarray
        Shapes ``(3n, 36)``, ``(3n, 36)``, ``(3n, 18)`` (zero rows for the vertical
        elements): ``gg = gg0 + delta gg1 + delta^2 gg2`` and ``gb = gb0 + delta gb1``.
    """
    n = geo.n_isolators
    c = np.zeros((3 * n, 6))
    c[n: 2 * n, 4] = 1.0    # x elements: r x e_x = (0, r_z, -r_y)
    c[2 * n:, 3] = -1.0     # y elements: r x e_y = (-r_z, 0, r_x)
    g = geo.g
    gg1 = (np.einsum("ei,ej->eij", g, c) + np.einsum("ei,ej->eij", c, g)).reshape(3 * n, 36)
    gg2 = np.einsum("ei,ej->eij", c, c).reshape(3 * n, 36)
    axis = np.repeat([2, 0, 1], n)
    gb1 = np.zeros((3 * n, 6, 3))
    gb1[np.arange(3 * n), :, axis] = c
    return gg1, gg2, gb1.reshape(3 * n, 18)


def dynamic_stiffness(geo: Geometry, k_vertical, k_horizontal, omega,
                      centre_shift_m=None) -> tuple[Cx, Cx]:
    """``D(w)`` and ``B(w)`` flattened, any backend.

    Parameters
    ----------
    geo : Geometry
    k_vertical : list of Cx
        Vertical complex stiffness of each isolator at ``omega`` (N/m): NumPy arrays
        ``(n_freq,)`` or CasADi columns.
    k_horizontal : list of Cx
        Horizontal complex stiffness of each isolator (the same in x and y).
    omega : ndarray (n_freq,) or CasADi column
        Angular frequency, rad/s.
    centre_shift_m : float or CasADi symbol, optional
        Raise every elastic centre by this much above ``geo``'s (the co-design lever,
        :func:`elastic_centre_terms`); None: ``geo`` as built.

    Returns
    -------
    D : Cx
        ``(n_freq, 36)``: ``D[f].reshape(6, 6)`` is the dynamic stiffness at ``omega[f]``.
    B : Cx
        ``(n_freq, 18)``: ``B[f].reshape(6, 3)`` the floor-input matrix.
    """
    n = geo.n_isolators
    if len(k_vertical) != n or len(k_horizontal) != n:
        raise InputError(f"k_vertical, k_horizontal: expected {n} isolators each")
    k = _stack(list(k_vertical) + list(k_horizontal) * 2)
    d_re = _matmul(k.re, geo.gg)
    d_im = _matmul(k.im, geo.gg)
    b_re, b_im = _matmul(k.re, geo.gb), _matmul(k.im, geo.gb)
    if centre_shift_m is not None:
        gg1, gg2, gb1 = elastic_centre_terms(geo)
        dl = centre_shift_m
        d_re = d_re + dl * _matmul(k.re, gg1) + dl * dl * _matmul(k.re, gg2)
        d_im = d_im + dl * _matmul(k.im, gg1) + dl * dl * _matmul(k.im, gg2)
        b_re, b_im = b_re + dl * _matmul(k.re, gb1), b_im + dl * _matmul(k.im, gb1)
    const = geo.gravity.reshape(1, 36)
    mass = geo.mass.reshape(1, 36)
    if bk.is_casadi(d_re):
        import casadi as ca

        w2 = omega * omega
        d_re = d_re + ca.repmat(ca.DM(const), d_re.shape[0], 1) - ca.mtimes(w2, ca.DM(mass))
    else:
        w2 = np.asarray(omega, dtype=float) ** 2
        d_re = d_re + const - w2[:, None] * mass
    return Cx(d_re, d_im), Cx(b_re, b_im)


def floor_input(geo: Geometry, k_vertical, k_horizontal) -> Cx:
    """``B`` alone (see :func:`dynamic_stiffness`), flattened ``(n_freq, 18)``.

    Parameters
    ----------
    geo : Geometry
    k_vertical, k_horizontal : list of Cx
        As in :func:`dynamic_stiffness`.
    """
    k = _stack(list(k_vertical) + list(k_horizontal) * 2)
    return Cx(_matmul(k.re, geo.gb), _matmul(k.im, geo.gb))


def solve_complex(d: Cx, b: Cx, n_rhs: int = 3):
    """Solve ``D X = B`` frequency by frequency (NumPy: complex LU; CasADi: real 12x12).

    Parameters
    ----------
    d : Cx
        ``(n_freq, 36)`` flattened 6x6 matrices.
    b : Cx
        ``(n_freq, 6 n_rhs)`` flattened 6 x n_rhs right-hand sides.
    n_rhs : int
        Columns of the right-hand side.

    Returns
    -------
    ndarray (n_freq, 6, n_rhs) of complex, or Cx of CasADi ``(n_freq, 6 n_rhs)``
    """
    if bk.is_casadi(d.re, d.im, b.re, b.im):
        return _solve_casadi(d, b, n_rhs)
    dm = (np.asarray(d.re) + 1j * np.asarray(d.im)).reshape(-1, 6, 6)
    bm = (np.asarray(b.re) + 1j * np.asarray(b.im)).reshape(-1, 6, n_rhs)
    return np.linalg.solve(dm, bm)


def _solve_casadi(d: Cx, b: Cx, n_rhs: int) -> Cx:
    if d.re.shape[0] == 1:  # one frequency (the NLP's point function): inline LDL^T
        import casadi as ca

        dd = [[Cx(d.re[0, 6 * i + j], d.im[0, 6 * i + j]) for j in range(6)] for i in range(6)]
        bb = [[Cx(b.re[0, n_rhs * i + a], b.im[0, n_rhs * i + a]) for a in range(n_rhs)]
              for i in range(6)]
        x = ldlt_solve(dd, bb)
        return Cx(ca.horzcat(*[x[i][a].re for i in range(6) for a in range(n_rhs)]),
                  ca.horzcat(*[x[i][a].im for i in range(6) for a in range(n_rhs)]))
    fn = _casadi_solver(n_rhs)
    nf = d.re.shape[0]
    out = fn.map(nf)(d.re.T, d.im.T, b.re.T, b.im.T)
    return Cx(out[0].T, out[1].T)


def _is_zero(c: Cx) -> bool:
    def z(v):
        if isinstance(v, int | float):
            return v == 0
        try:
            return bool(v.is_zero())
        except AttributeError:
            return False
    return z(c.re) and z(c.im)


def ldlt_solve(a, b):
    """Solve ``A X = B`` for a complex *symmetric* ``A`` (``A = A^T``) by ``LDL^T``, any backend.

    No pivoting: the pivots of the table's dynamic stiffness are its translational and
    rotational diagonal terms and their Schur complements, complex with the isolators'
    losses. Structural zeros (a symmetric layout's decoupled blocks) are skipped, so a
    symbolic solve stays small.

    Parameters
    ----------
    a : list of list of Cx
        The ``m x m`` matrix (entries scalars or arrays of one shape, or CasADi scalars).
    b : list of list of Cx
        The ``m x r`` right-hand sides.

    Returns
    -------
    list of list of Cx
        ``X``, ``m x r``.
    """
    m = len(a)
    lo = [[None] * m for _ in range(m)]
    dg = [None] * m
    for j in range(m):
        s = a[j][j]
        for k in range(j):
            if lo[j][k] is not None:
                s = s - lo[j][k] * lo[j][k] * dg[k]
        dg[j] = s
        for i in range(j + 1, m):
            t = a[i][j]
            for k in range(j):
                if lo[i][k] is not None and lo[j][k] is not None:
                    t = t - lo[i][k] * lo[j][k] * dg[k]
            lo[i][j] = None if _is_zero(t) else t / dg[j]
    r = len(b[0])
    x = [[None] * r for _ in range(m)]
    for c in range(r):
        y = [None] * m
        for i in range(m):
            t = b[i][c]
            for k in range(i):
                if lo[i][k] is not None:
                    t = t - lo[i][k] * y[k]
            y[i] = t
        for i in reversed(range(m)):
            t = y[i] / dg[i]
            for k in range(i + 1, m):
                if lo[k][i] is not None:
                    t = t - lo[k][i] * x[k][c]
            x[i][c] = t
    return x


_SOLVERS: dict = {}


def _casadi_solver(n_rhs: int):
    """A CasADi Function: one frequency's real 12x12 solve of ``(D_re + j D_im) X = B``."""
    import casadi as ca

    if n_rhs in _SOLVERS:
        return _SOLVERS[n_rhs]
    dr, di = ca.SX.sym("dr", 36), ca.SX.sym("di", 36)
    br, bi = ca.SX.sym("br", 6 * n_rhs), ca.SX.sym("bi", 6 * n_rhs)
    a_re, a_im = ca.reshape(dr, 6, 6).T, ca.reshape(di, 6, 6).T
    b_re, b_im = ca.reshape(br, n_rhs, 6).T, ca.reshape(bi, n_rhs, 6).T
    big = ca.vertcat(ca.horzcat(a_re, -a_im), ca.horzcat(a_im, a_re))
    x = ca.solve(big, ca.vertcat(b_re, b_im))
    xr, xi = x[:6, :], x[6:, :]
    fn = ca.Function("table_solve", [dr, di, br, bi],
                     [ca.reshape(xr.T, 6 * n_rhs, 1), ca.reshape(xi.T, 6 * n_rhs, 1)])
    _SOLVERS[n_rhs] = fn
    return fn


def static_stiffness_matrix(geo: Geometry, k_vertical, k_horizontal,
                            *, include_gravity: bool = True) -> np.ndarray:
    """Real 6x6 static stiffness ``sum_e k_e g_e g_e^T (+ K_g)`` (NumPy).

    Parameters
    ----------
    geo : Geometry
    k_vertical, k_horizontal : array_like, shape (n,)
        Real static stiffnesses of each isolator, N/m.
    include_gravity : bool
        Add ``K_g``.
    """
    k = np.concatenate([np.asarray(k_vertical, float), np.asarray(k_horizontal, float),
                        np.asarray(k_horizontal, float)])  # fmt: skip
    out = (k @ geo.gg).reshape(6, 6)
    return out + geo.gravity if include_gravity else out
