"""The 6x6 assembly: Harris' coupled pair, an independent assembly, the gravity term, CasADi."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.spatial.transform import Rotation

from isodesign.numerics.cplx import Cx
from isodesign.table.assembly import (
    dynamic_stiffness,
    geometry,
    solve_complex,
    static_stiffness_matrix,
)
from isodesign.table.layout import HorizontalElement, Table
from isodesign.table.model import table_model
from isodesign.table.statics import level


def _harris(kappa, a, c):
    b = kappa * (1.0 + c * c) + a * a
    disc = math.sqrt(b * b - 4.0 * kappa * a * a)
    return (b - disc) / 2.0, (b + disc) / 2.0


@pytest.mark.parametrize("kx, h, e", [(4.0e4, 0.35, 0.0), (1.5e5, 0.6, 0.0), (8.0e3, 0.2, 0.0)])
def test_harris_coupled_translation_rocking_pair(kx, h, e):
    """Harris (Shock and Vibration Handbook, Ch. 3): kappa = k_x/k_z, A = half-spacing / rho,
    C = support height below the CG / rho, B = kappa (1 + C^2) + A^2, (f/f_z)^2 =
    (B -+ sqrt(B^2 - 4 kappa A^2)) / 2; real constant stiffnesses, no gravity term."""
    m, kz, sx, sy = 600.0, 2.0e5, 1.2, 0.8
    t = Table.symmetric(m, sx, sy, h, size_m=(1.3, 0.9, 0.5),
                        horizontal=HorizontalElement(None, kx, 0.0, elastic_centre_height_m=e))
    geo = geometry(t, level(t, 5.3e-3).load_n, include_gravity=False)
    k = static_stiffness_matrix(geo, [kz] * 4, [kx] * 4, include_gravity=False)
    lam = eigh(k, t.mass_matrix, eigvals_only=True)
    wz2 = 4 * kz / m
    kappa = kx / kz
    for axis, half, inertia in (("ry", sx / 2, t.inertia_kg_m2[1, 1]),
                                ("rx", sy / 2, t.inertia_kg_m2[0, 0])):
        rho = math.sqrt(inertia / m)
        lo, hi = _harris(kappa, half / rho, (h - e) / rho)
        for r in (lo, hi):
            assert np.min(np.abs(lam / wz2 - r)) / r < 1e-6, (axis, r, lam / wz2)
    assert np.min(np.abs(lam / wz2 - 1.0)) < 1e-12  # the vertical mode


def _independent(table, loads, kz, kh, omega):
    """Textbook assembly, written here from finite rotations: each spring's Jacobian and the
    gravity moment come from scipy's rotation matrices by central differences."""
    cg = table.cg_m
    rv = np.column_stack([table.isolators_m - cg[:2], np.full(table.n_isolators, -cg[2])])
    rh = rv + np.array([0.0, 0.0, table.horizontal.elastic_centre_height_m])

    def disp(q, r):
        return q[:3] + Rotation.from_rotvec(q[3:]).apply(r) - r

    def jac(r):
        j = np.zeros((3, 6))
        for d in range(6):
            dq = np.zeros(6)
            dq[d] = 1e-6
            j[:, d] = (disp(dq, r) - disp(-dq, r)) / 2e-6
        return j

    n = table.n_isolators
    kmat = np.zeros((len(omega), 6, 6), complex)
    bmat = np.zeros((len(omega), 6, 3), complex)
    for i in range(n):
        for r, axis, k in ((rv[i], 2, kz[i]), (rh[i], 0, kh[i]), (rh[i], 1, kh[i])):
            row = jac(r)[axis]
            kmat += k[:, None, None] * np.outer(row, row)[None]
            e = np.zeros(3)
            e[axis] = 1.0
            bmat += k[:, None, None] * np.outer(row, e)[None]
    # gravity: moment about the CG of the static forces W_i e_z at the turned points
    kg = np.zeros((6, 6))
    for d in range(3, 6):
        mom = np.zeros(3)
        for sgn in (1, -1):
            th = np.zeros(3)
            th[d - 3] = sgn * 1e-6
            pts = Rotation.from_rotvec(th).apply(rv)
            mom += sgn * sum(np.cross(p, [0.0, 0.0, w]) for p, w in zip(pts, loads, strict=True))
        kg[3:, d] = -mom / 2e-6
    d = kmat + kg - omega[:, None, None] ** 2 * table.mass_matrix
    q = np.linalg.solve(d, bmat)
    rp = table.instrument_points_m - cg
    out = []
    for r in rp:
        out.append(np.einsum("ij,fja->fia", jac(r), q))
    strokes = np.stack([np.einsum("j,fja->fa", jac(r)[2], q) - [0.0, 0.0, 1.0] for r in rv],
                       axis=1)
    return np.stack(out, axis=1), kg, strokes


def test_general_layout_against_an_independent_assembly(ref):
    t = Table(750.0, [(0.0, 0.0), (1.4, 0.1), (1.3, 0.9), (0.2, 1.0), (0.7, 1.3)],
              (0.65, 0.55, 0.42), [[90.0, 6.0, -4.0], [6.0, 120.0, 3.0], [-4.0, 3.0, 170.0]],
              leveling_groups=[[0, 4], [1], [2, 3]],
              instrument_points_m=[(0.6, 0.5, 0.9), (1.2, 0.2, 0.8)],
              horizontal=HorizontalElement(0.12, 2.0e4, 0.15, elastic_centre_height_m=0.05))
    model = table_model(ref, t)
    f = np.geomspace(0.3, 40.0, 60)
    w = 2 * np.pi * f
    kv = model.vertical_stiffness(f, 5e-6)
    kh = [k.to_complex() * np.ones_like(f) for k in model.horizontal_stiffness(w)]
    out = model.outputs(kv, w)
    ind, kg, strokes = _independent(t, model.leveling.load_n, kv, kh, w)
    np.testing.assert_allclose(out.points, ind, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(model.geometry.gravity, kg, atol=1e-6 * t.weight_n)
    # the gravity term at equilibrium is -W h on rx and ry, nothing else
    expect = np.zeros((6, 6))
    expect[3, 3] = expect[4, 4] = -t.weight_n * t.cg_height_m
    np.testing.assert_allclose(model.geometry.gravity, expect, atol=1e-9 * t.weight_n)
    # strokes: the relative motion at each isolator's vertical-force point
    np.testing.assert_allclose(out.strokes, strokes, rtol=1e-7, atol=1e-9)


def test_casadi_assembly_and_solve_match_numpy(ref):
    ca = pytest.importorskip("casadi")
    t = Table(500.0, [(0, 0), (1.0, 0), (0.9, 0.8), (0.1, 0.7)], (0.45, 0.4, 0.3),
              [40.0, 50.0, 70.0])
    model = table_model(ref, t)
    f = np.array([0.7, 1.9, 6.0])
    w = 2 * np.pi * f
    kv = [Cx.from_complex(k) for k in model.vertical_stiffness(f, 1e-5)]
    kh = model.horizontal_stiffness(w)
    d, b = dynamic_stiffness(model.geometry, kv, kh, w)
    q_np = solve_complex(d, b)
    sym = [ca.SX.sym(f"k{i}", 3, 2) for i in range(4)]
    kv_s = [Cx(s[:, 0], s[:, 1]) for s in sym]
    kh_s = [Cx(ca.DM(np.broadcast_to(k.re, f.shape)), ca.DM(np.broadcast_to(k.im, f.shape)))
            for k in kh]
    ds, bs = dynamic_stiffness(model.geometry, kv_s, kh_s, ca.DM(w))
    qs = solve_complex(ds, bs)
    fn = ca.Function("q", sym, [qs.re, qs.im])
    args = [np.column_stack([k.re, k.im]) for k in kv]
    re, im = (np.asarray(v) for v in fn(*args))
    np.testing.assert_allclose((re + 1j * im).reshape(3, 6, 3), q_np, rtol=1e-9, atol=1e-12)
