"""Every function of :mod:`isodesign.numerics.backend` on every input type.

The model is AeroSandbox's numpy-dispatch test: each operation runs on a Python float, a
NumPy scalar, a NumPy array, and CasADi ``SX`` and ``MX`` symbols (evaluated through a
``casadi.Function`` at the same numbers), and all of them must agree with a reference
written here directly in NumPy (not through the backend).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from isodesign.numerics import backend as bk

KINDS = ("float", "numpy_scalar", "numpy_array", "SX", "MX")

#: Test points (positive where the function needs it).
X = np.array([0.3, 1.7, 4.2])
Y = np.array([-1.1, 0.4, 2.5])
SIGNED = np.array([-30.0, -0.5, 0.0, 0.7, 40.0])


def run(kind: str, fn, *args: np.ndarray) -> np.ndarray:
    """``fn(*args)`` on one input type, returned as a NumPy array of the points."""
    args = [np.asarray(a, dtype=float) for a in args]
    if kind == "numpy_array":
        out = fn(*args)
        assert isinstance(out, np.ndarray | np.floating | float)
        return np.asarray(out, dtype=float)
    if kind in ("float", "numpy_scalar"):
        conv = float if kind == "float" else np.float64
        outs = [fn(*[conv(a[i]) for a in args]) for i in range(args[0].size)]
        for o in outs:
            assert not bk.is_casadi(o)
        return np.asarray(outs, dtype=float)
    sym = ca.SX if kind == "SX" else ca.MX
    syms = [sym.sym(f"a{j}", a.size) for j, a in enumerate(args)]
    expr = fn(*syms)
    assert bk.is_casadi(expr)
    f = ca.Function("f", syms, [expr])
    return np.asarray(f(*args)).ravel()


#: name -> (function under test, NumPy reference, arguments)
ELEMENTWISE = {
    "exp": (bk.exp, np.exp, (Y,)),
    "log": (bk.log, np.log, (X,)),
    "log1p": (bk.log1p, lambda x: np.log(1.0 + x), (np.array([1e-3, 0.5, 3.0]),)),
    "sqrt": (bk.sqrt, lambda x: x**0.5, (X,)),
    "sin": (bk.sin, np.sin, (Y,)),
    "cos": (bk.cos, np.cos, (Y,)),
    "tanh": (bk.tanh, lambda x: (np.exp(2 * x) - 1) / (np.exp(2 * x) + 1), (Y,)),
    "arctan2": (bk.arctan2, lambda y, x: np.angle(x + 1j * y), (Y, np.array([-2.0, 0.5, -0.1]))),
    "power": (bk.power, lambda x, p: np.exp(p * np.log(x)), (X, np.array([0.5, -1.3, 2.0]))),
    "ipow": (lambda x: bk.ipow(x, 5), lambda x: x * x * x * x * x, (Y,)),
    "where": (lambda a, b: bk.where(a < b, a, b), np.minimum, (Y, X - 1.0)),
    "softplus": (lambda x: bk.softplus(x, 2.0), lambda x: np.log(1 + np.exp(2 * x)) / 2, (SIGNED,)),
    "smooth_max": (
        lambda a, b: bk.smooth_max(a, b, 3.0),
        lambda a, b: b + np.log(1 + np.exp(3 * (a - b))) / 3,
        (SIGNED / 10, np.array([0.1, -0.2, 0.0, 0.5, 1.0])),
    ),
    "smooth_abs": (lambda x: bk.smooth_abs(x, 0.1), lambda x: np.hypot(x, 0.1), (SIGNED,)),
    "logistic": (bk.logistic, lambda x: 1 / (1 + np.exp(-x)), (SIGNED,)),
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(ELEMENTWISE))
def test_elementwise_on_every_input_type(name, kind):
    fn, reference, args = ELEMENTWISE[name]
    assert np.allclose(run(kind, fn, *args), reference(*args), rtol=1e-12, atol=1e-14)


def test_softplus_does_not_overflow():
    x = np.array([-800.0, 800.0])
    assert np.allclose(bk.softplus(x), [0.0, 800.0])
    s = ca.SX.sym("s")
    f = ca.Function("f", [s], [bk.softplus(s)])
    assert float(f(800.0)) == pytest.approx(800.0)
    assert float(f(-800.0)) == pytest.approx(0.0, abs=1e-300)


def test_softplus_is_smooth_on_symbols():
    """The value is written with fmax/fabs, the derivative is still the logistic."""
    s = ca.SX.sym("s")
    df = ca.Function("df", [s], [ca.jacobian(bk.softplus(s, 2.0), s)])
    for x in (-3.0, 0.0, 1e-9, 2.0):
        assert float(df(x)) == pytest.approx(1 / (1 + math.exp(-2 * x)), rel=1e-12)


def test_logistic_does_not_overflow():
    assert np.allclose(bk.logistic(np.array([-1e4, 1e4])), [0.0, 1.0])


@pytest.mark.parametrize("n", [0, 1, 2, 3, 8, 13])
@pytest.mark.parametrize("kind", KINDS)
def test_ipow_every_exponent(n, kind):
    assert np.allclose(run(kind, lambda x: bk.ipow(x, n), Y), Y**n, rtol=1e-13)


@pytest.mark.parametrize("n", [-1, 1.5])
def test_ipow_rejects_non_natural_exponents(n):
    with pytest.raises(ValueError, match="ipow"):
        bk.ipow(2.0, n)


@pytest.mark.parametrize("axis", [None, 0, 1])
@pytest.mark.parametrize("sym", [ca.SX, ca.MX])
def test_sum_on_numpy_and_casadi(axis, sym):
    m = np.arange(6.0).reshape(2, 3) + 0.5
    ref = np.sum(m, axis=axis)
    assert np.allclose(bk.sum(m, axis=axis), ref)
    s = sym.sym("m", 2, 3)
    out = np.asarray(ca.Function("f", [s], [bk.sum(s, axis=axis)])(m))
    assert np.allclose(out.ravel(), np.ravel(ref))


def test_is_casadi():
    assert bk.is_casadi(ca.SX.sym("x"))
    assert bk.is_casadi(ca.MX.sym("x"))
    assert bk.is_casadi(ca.DM(1.0))
    assert bk.is_casadi(1.0, np.ones(2), ca.SX.sym("x"))
    assert not bk.is_casadi(1.0, np.float64(2.0), np.ones(3), [1.0], None)
    assert not bk.is_casadi()


def test_as_numpy():
    assert bk.as_numpy(ca.DM([[1.0, 2.0], [3.0, 4.0]])).tolist() == [[1.0, 2.0], [3.0, 4.0]]
    out = bk.as_numpy([1, 2])
    assert out.dtype == float and out.tolist() == [1.0, 2.0]
    assert bk.as_numpy(np.float64(2.5)).shape == ()


def test_numpy_inputs_do_not_import_casadi():
    """NumPy calls never touch CasADi (the lazy import is only for CasADi objects)."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np\n"
        "from isodesign.numerics import backend as bk\n"
        "x = np.linspace(0.1, 2, 5)\n"
        "[f(x) for f in (bk.exp, bk.log, bk.log1p, bk.sqrt, bk.sin, bk.cos, bk.tanh, "
        "bk.softplus, bk.logistic, bk.sum, bk.as_numpy)]\n"
        "bk.power(x, 0.5); bk.ipow(x, 3); bk.where(x > 1, x, -x); bk.arctan2(x, x)\n"
        "bk.smooth_max(x, 1.0, 5.0); bk.smooth_abs(x, 1e-3)\n"
        "print('casadi' in sys.modules)\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "False"


def test_every_backend_function_is_tested():
    tested = set(ELEMENTWISE) | {"sum", "is_casadi", "as_numpy"}
    assert set(bk.__all__) == tested
