"""Backend dispatch: one physics source for NumPy arrays and CasADi symbols.

Every physics function in isodesign is written once against the small set of
functions below. Called with NumPy arrays (or Python floats) they evaluate with
NumPy; called with CasADi ``SX``/``MX``/``DM`` objects they build CasADi
expressions, so the optimizer gets exact derivatives through the same code that
the analysis path runs. The layer follows the spirit of AeroSandbox's
``aerosandbox.numpy``: a thin dispatch, not a NumPy clone.

CasADi is imported lazily, only when a CasADi object is actually met, so that
light commands (``isodesign --help``) never pay for it.

Rules for code written against this module
------------------------------------------
* No ``abs``, ``max``, ``min``, ``sqrt`` at 0 or Python ``if`` on values that may
  be symbolic. Use :func:`smooth_abs`, :func:`softplus`, :func:`smooth_max` or
  :func:`where` (CasADi ``if_else``) for switches that are continuous anyway.
* Complex numbers are carried as (real, imag) pairs, see :mod:`isodesign.numerics.cplx`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "arctan2",
    "as_numpy",
    "cos",
    "exp",
    "ipow",
    "is_casadi",
    "log",
    "log1p",
    "logistic",
    "power",
    "sin",
    "smooth_abs",
    "smooth_max",
    "softplus",
    "sqrt",
    "sum",
    "tanh",
    "where",
]


def _is_casadi_obj(x: Any) -> bool:
    return type(x).__module__.startswith("casadi")


def is_casadi(*xs: Any) -> bool:
    """Return True when any argument is a CasADi object (SX, MX or DM).

    Parameters
    ----------
    *xs : object
        Values to inspect (CasADi is not imported to answer).

    Returns
    -------
    bool
    """
    return any(_is_casadi_obj(x) for x in xs)


def _cs():
    import casadi

    return casadi


def exp(x):
    """Exponential.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().exp(x) if is_casadi(x) else np.exp(x)


def log(x):
    """Natural logarithm.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().log(x) if is_casadi(x) else np.log(x)


def log1p(x):
    """log(1 + x), accurate for small x.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().log1p(x) if is_casadi(x) else np.log1p(x)


def sqrt(x):
    """Square root (do not call at 0 on symbols: the derivative is infinite).

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().sqrt(x) if is_casadi(x) else np.sqrt(x)


def sin(x):
    """Sine.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().sin(x) if is_casadi(x) else np.sin(x)


def cos(x):
    """Cosine.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().cos(x) if is_casadi(x) else np.cos(x)


def tanh(x):
    """Hyperbolic tangent.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as the input
        NumPy array (or float) for NumPy input, a CasADi expression for CasADi input.
    """
    return _cs().tanh(x) if is_casadi(x) else np.tanh(x)


def arctan2(y, x):
    """Four-quadrant arctangent ``atan2(y, x)``.

    Parameters
    ----------
    y, x : float, ndarray or CasADi SX/MX/DM
        Ordinate and abscissa.

    Returns
    -------
    same type as the inputs
        The angle in radians, in ``(-pi, pi]``.
    """
    return _cs().atan2(y, x) if is_casadi(y, x) else np.arctan2(y, x)


def power(x, p):
    """``x ** p`` for ``x > 0`` and real ``p``.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Base (positive).
    p : float, ndarray or CasADi SX/MX/DM
        Exponent.

    Returns
    -------
    same type as the inputs
    """
    if is_casadi(x, p):
        return x**p
    return np.power(x, p)


def ipow(x, n: int):
    """x ** n for a non-negative integer ``n`` by repeated squaring.

    On NumPy arrays this is several times faster than ``np.power`` with a float
    exponent; on CasADi symbols it is ``x ** n`` (CasADi's ``constpow``).

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Base.
    n : int
        Exponent, a non-negative integer (``ValueError`` otherwise).

    Returns
    -------
    same type as ``x``
    """
    if n < 0 or int(n) != n:
        raise ValueError(f"ipow: n must be a non-negative integer, got {n!r}")
    if is_casadi(x):
        return x**n
    result = None
    base = x
    while n:
        if n & 1:
            result = base if result is None else result * base
        n >>= 1
        if n:
            base = base * base
    return np.ones_like(x) if result is None else result


def where(cond, a, b):
    """Elementwise switch; ``casadi.if_else`` on symbols.

    Only for switches whose two branches agree at the switching point (or for
    guards on parameters, not on decision variables): a jump breaks Newton-type
    solvers.

    Parameters
    ----------
    cond : bool ndarray or CasADi expression
        Where to take ``a``.
    a, b : float, ndarray or CasADi SX/MX/DM
        The two branches.

    Returns
    -------
    ndarray or CasADi expression
    """
    if is_casadi(cond, a, b):
        return _cs().if_else(cond, a, b)
    return np.where(cond, a, b)


def sum(x, axis=None):
    """Sum of the entries.

    Parameters
    ----------
    x : ndarray or CasADi SX/MX/DM
        The values (a matrix for CasADi).
    axis : {None, 0, 1}
        None: every entry; 0: down the rows (column sums); 1: along each row.

    Returns
    -------
    float, ndarray or CasADi expression
    """
    if is_casadi(x):
        return (
            _cs().sum1(_cs().sum2(x))
            if axis is None
            else (_cs().sum1(x) if axis == 0 else _cs().sum2(x))
        )
    return np.sum(x, axis=axis)


def softplus(x, hardness: float = 1.0):
    """Smooth ``max(x, 0)``: ``log(1 + exp(hardness x)) / hardness``.

    Overflow-safe on both backends: ``max(z, 0) + log1p(exp(-|z|))``, an
    expression that is analytic everywhere although it is written with max/abs.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.
    hardness : float
        Sharpness ``h``; the error against ``max(x, 0)`` is at most ``ln(2)/h``.

    Returns
    -------
    same type as ``x``
    """
    h = hardness
    if is_casadi(x):
        cs = _cs()
        z = h * x
        # log(1+exp(z)) = max(z,0) + log1p(exp(-|z|)); written with fmax/fabs
        # only in the value, the expression stays C-infinity.
        return (cs.fmax(z, 0) + cs.log1p(cs.exp(-cs.fabs(z)))) / h
    z = h * np.asarray(x, dtype=float)
    return (np.maximum(z, 0) + np.log1p(np.exp(-np.abs(z)))) / h


def smooth_max(a, b, hardness: float):
    """Smooth maximum of ``a`` and ``b``: ``b + softplus(a - b, hardness)``.

    Parameters
    ----------
    a, b : float, ndarray or CasADi SX/MX/DM
        The two values.
    hardness : float
        Sharpness of the corner (see :func:`softplus`).

    Returns
    -------
    same type as the inputs
    """
    return b + softplus(a - b, hardness)


def smooth_abs(x, eps: float):
    """Smooth ``|x|``: ``sqrt(x^2 + eps^2)``; differentiable at 0.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.
    eps : float
        Rounding of the corner (the value at 0).

    Returns
    -------
    same type as ``x``
    """
    return sqrt(x * x + eps * eps)


def logistic(x):
    """Logistic function ``1/(1 + exp(-x))``, overflow-safe on NumPy.

    Parameters
    ----------
    x : float, ndarray or CasADi SX/MX/DM
        Argument.

    Returns
    -------
    same type as ``x``
        Values in (0, 1).
    """
    if is_casadi(x):
        return 0.5 * (1 + _cs().tanh(0.5 * x))
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(x, dtype=float)))


def as_numpy(x) -> np.ndarray:
    """Convert a CasADi DM (or anything array-like) to a NumPy float array.

    Parameters
    ----------
    x : CasADi DM or array_like
        Numeric values (a symbolic SX/MX cannot be converted).

    Returns
    -------
    ndarray of float
    """
    if is_casadi(x):
        return np.asarray(_cs().DM(x).full(), dtype=float)
    return np.asarray(x, dtype=float)


PI = math.pi
