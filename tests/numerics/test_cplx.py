"""Every :class:`~isodesign.numerics.cplx.Cx` operation on every input type.

Each operation runs with the pair's parts as Python floats, NumPy scalars, NumPy arrays,
CasADi ``SX`` and ``MX`` symbols (evaluated through a ``casadi.Function``), and must agree
with NumPy's own complex arithmetic on the same numbers.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx, as_cx

KINDS = ("float", "numpy_scalar", "numpy_array", "SX", "MX")

A = np.array([1.5 - 0.25j, -0.7 + 2.0j, 3.0 + 0.0j])
B = np.array([0.4 + 1.1j, -2.0 - 0.3j, 0.8 - 1.6j])
R = np.array([2.0, -0.5, 1.25])  # a real operand


def evaluate(kind: str, fn, *zs: np.ndarray):
    """``fn`` applied to Cx pairs built from ``zs``; returns a complex (or real) array."""
    if kind == "numpy_array":
        return _collect(fn(*[Cx(z.real.copy(), z.imag.copy()) for z in zs]))
    if kind in ("float", "numpy_scalar"):
        conv = float if kind == "float" else np.float64
        outs = []
        for i in range(zs[0].size):
            o = fn(*[Cx(conv(z.real[i]), conv(z.imag[i])) for z in zs])
            assert not bk.is_casadi(*((o.re, o.im) if isinstance(o, Cx) else (o,)))
            outs.append(_collect(o))
        return np.array(outs).ravel()
    sym = ca.SX if kind == "SX" else ca.MX
    parts = [(sym.sym(f"r{j}", z.size), sym.sym(f"i{j}", z.size)) for j, z in enumerate(zs)]
    out = fn(*[Cx(r, i) for r, i in parts])
    flat = [p for pair in parts for p in pair]
    vals = [v for z in zs for v in (z.real, z.imag)]
    if isinstance(out, Cx):
        assert bk.is_casadi(out.re) and bk.is_casadi(out.im)
        f = ca.Function("f", flat, [out.re, out.im])
        re, im = f(*vals)
        return np.asarray(re).ravel() + 1j * np.asarray(im).ravel()
    f = ca.Function("f", flat, [out])
    return np.asarray(f(*vals)).ravel()


def _collect(o):
    if isinstance(o, Cx):
        re, im = np.asarray(o.re, dtype=float), np.asarray(o.im, dtype=float)
        assert not np.iscomplexobj(o.re) and not np.iscomplexobj(o.im)
        return re + 1j * im
    return np.asarray(o, dtype=float)


#: name -> (operation on Cx pairs, the same on NumPy complex numbers, operands)
BINARY = {
    "add": (lambda a, b: a + b, np.add),
    "sub": (lambda a, b: a - b, np.subtract),
    "mul": (lambda a, b: a * b, np.multiply),
    "truediv": (lambda a, b: a / b, np.divide),
}
UNARY = {
    "neg": (lambda a: -a, np.negative),
    "conj": (lambda a: a.conj(), np.conj),
    "abs2": (lambda a: a.abs2(), lambda z: np.abs(z) ** 2),
    "abs": (lambda a: a.abs(), np.abs),
    "arg": (lambda a: a.arg(), np.angle),
    "loss_factor": (lambda a: a.loss_factor(), lambda z: z.imag / z.real),
}
#: operations with a plain real number or real array on either side
WITH_REAL = {
    "add_real": (lambda a, r: a + r, lambda z, r: z + r),
    "radd_real": (lambda a, r: r + a, lambda z, r: r + z),
    "sub_real": (lambda a, r: a - r, lambda z, r: z - r),
    "rsub_real": (lambda a, r: r - a, lambda z, r: r - z),
    "mul_real": (lambda a, r: a * r, lambda z, r: z * r),
    "rmul_real": (lambda a, r: r * a, lambda z, r: r * z),
    "truediv_real": (lambda a, r: a / r, lambda z, r: z / r),
    "rtruediv_real": (lambda a, r: r / a, lambda z, r: r / z),
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(BINARY))
def test_binary_on_every_input_type(name, kind):
    op, ref = BINARY[name]
    assert np.allclose(evaluate(kind, op, A, B), ref(A, B), rtol=1e-13)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(UNARY))
def test_unary_on_every_input_type(name, kind):
    op, ref = UNARY[name]
    assert np.allclose(evaluate(kind, op, A), ref(A), rtol=1e-13)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(WITH_REAL))
def test_real_operand_on_every_input_type(name, kind):
    op, ref = WITH_REAL[name]
    if kind in ("SX", "MX"):
        # the real operand is a symbol too
        got = evaluate(kind, lambda a, r: op(a, r.re), A, R + 0j)
    elif kind == "numpy_array":
        got = evaluate(kind, lambda a: op(a, R), A)
    else:
        conv = float if kind == "float" else np.float64
        pairs = zip(A, R, strict=True)
        got = np.array([_collect(op(Cx(conv(a.real), conv(a.imag)), conv(r))) for a, r in pairs])
    assert np.allclose(got, ref(A, R), rtol=1e-13)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(BINARY))
def test_python_complex_operand(name, kind):
    """A Python complex on either side of a pair (constant in a CasADi graph)."""
    op, ref = BINARY[name]
    c = 0.6 - 1.3j
    assert np.allclose(evaluate(kind, lambda a: op(a, c), A), ref(A, c), rtol=1e-13)
    assert np.allclose(evaluate(kind, lambda a: op(c, a), A), ref(c, A), rtol=1e-13)


@pytest.mark.parametrize("name", sorted(BINARY))
@pytest.mark.parametrize(
    "other", [B, B[0], np.complex64(0.5 + 0.25j)], ids=["array", "complex128", "complex64"]
)
def test_numpy_complex_operand_gives_real_parts(name, other):
    """``Cx op complex_ndarray`` splits the complex operand: both parts stay real.

    (A complex array used to be taken for a real factor, leaving complex numbers in
    ``re`` and ``im``.)
    """
    op, ref = BINARY[name]
    out = op(Cx(A.real.copy(), A.imag.copy()), other)
    assert isinstance(out, Cx)
    assert not np.iscomplexobj(out.re) and not np.iscomplexobj(out.im)
    assert np.allclose(out.to_complex(), ref(A, np.asarray(other, dtype=complex)), rtol=1e-6)
    # reflected: ndarray.__array_ufunc__ is disabled for Cx, so this is Cx's own operator
    back = op(other, Cx(A.real.copy(), A.imag.copy()))
    assert isinstance(back, Cx) and not np.iscomplexobj(back.re)
    assert np.allclose(back.to_complex(), ref(np.asarray(other, dtype=complex), A), rtol=1e-6)


@pytest.mark.parametrize("name", ["mul", "truediv"])
def test_large_arrays_take_the_native_path_with_the_same_result(name):
    op, ref = BINARY[name]
    rng = np.random.default_rng(1)
    n = 5000  # above the native-path threshold
    a = rng.normal(size=n) + 1j * rng.normal(size=n)
    b = rng.normal(size=n) + 1j * rng.normal(size=n)
    big = op(Cx.from_complex(a), Cx.from_complex(b)).to_complex()
    small = np.concatenate(
        [op(Cx.from_complex(a[i : i + 100]), Cx.from_complex(b[i : i + 100])).to_complex()
         for i in range(0, n, 100)]
    )
    assert np.allclose(big, ref(a, b), rtol=1e-13)
    assert np.allclose(big, small, rtol=1e-13)


def test_from_complex_and_to_complex_round_trip():
    c = Cx.from_complex(A)
    assert np.array_equal(c.to_complex(), A)
    real = Cx.from_complex(R)
    assert np.array_equal(real.im, np.zeros(3)) and real.re.dtype == float
    assert Cx.from_complex(2.0 + 1.0j).to_complex() == 2.0 + 1.0j
    dm = Cx(ca.DM([1.0, 2.0]), ca.DM([3.0, 4.0])).to_complex()
    assert np.array_equal(dm.ravel(), [1 + 3j, 2 + 4j])


def test_as_cx():
    c = Cx(1.0, 2.0)
    assert as_cx(c) is c
    assert as_cx(1.0 - 2.0j) == Cx(1.0, -2.0)
    assert as_cx(np.complex128(1.0 - 2.0j)) == Cx(1.0, -2.0)
    assert as_cx(3.0) == Cx(3.0, 0.0)
    arr = as_cx(R)
    assert np.array_equal(arr.re, R) and np.array_equal(arr.im, np.zeros(3))
    z = as_cx(A)
    assert np.array_equal(z.re, A.real) and np.array_equal(z.im, A.imag)
    s = ca.SX.sym("s")
    sc = as_cx(s)
    assert bk.is_casadi(sc.im) and float(ca.Function("f", [s], [sc.im])(2.0)) == 0.0


def test_every_cx_operation_is_tested():
    ops = {n for n in vars(Cx) if not n.startswith("_") and callable(getattr(Cx, n))}
    assert ops == set(UNARY) - {"neg"} | {"from_complex", "to_complex"}
