"""Complex numbers as (real, imag) pairs that work on NumPy and CasADi alike.

CasADi has no complex type, so the shared physics carries complex quantities as
:class:`Cx` pairs. Arithmetic is written with real operations only, so the same
expression builds a CasADi graph or evaluates on NumPy arrays. The NumPy face
of the package converts to ordinary complex arrays with :meth:`Cx.to_complex`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.numerics import backend as bk

__all__ = ["Cx", "as_cx"]


@dataclass(frozen=True, slots=True)
class Cx:
    """A complex value ``re + j im`` with real parts from either backend."""

    re: Any
    im: Any

    #: NumPy defers to Cx's reflected operators (``ndarray / Cx`` is ``Cx.__rtruediv__``)
    #: instead of building an object array element by element.
    __array_ufunc__ = None

    # -- construction ----------------------------------------------------
    @staticmethod
    def from_complex(z) -> Cx:
        """Split a NumPy complex array (or Python complex) into a pair (views, no copy)."""
        z = np.asarray(z)
        if np.iscomplexobj(z):
            return Cx(z.real, z.imag)
        return Cx(z.astype(float), np.zeros_like(z, dtype=float))

    def to_complex(self) -> np.ndarray:
        """Return a NumPy complex array (NumPy backend only)."""
        re, im = bk.as_numpy(self.re), bk.as_numpy(self.im)
        out = np.empty(np.broadcast_shapes(re.shape, im.shape), dtype=complex)
        out.real = re
        out.imag = im
        return out

    # -- arithmetic ------------------------------------------------------
    def __add__(self, other) -> Cx:
        o = as_cx(other)
        return Cx(self.re + o.re, self.im + o.im)

    __radd__ = __add__

    def __sub__(self, other) -> Cx:
        o = as_cx(other)
        return Cx(self.re - o.re, self.im - o.im)

    def __rsub__(self, other) -> Cx:
        return as_cx(other) - self

    def __neg__(self) -> Cx:
        return Cx(-self.re, -self.im)

    def __mul__(self, other) -> Cx:
        if _is_complex(other):
            o = as_cx(other)
            if _large_numpy(self, o):
                return Cx.from_complex(self.to_complex() * o.to_complex())
            return Cx(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
        return Cx(self.re * other, self.im * other)

    __rmul__ = __mul__

    def __truediv__(self, other) -> Cx:
        if _is_complex(other):
            o = as_cx(other)
            if _large_numpy(self, o):
                return Cx.from_complex(self.to_complex() / o.to_complex())
            d = o.re * o.re + o.im * o.im
            return Cx((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
        return Cx(self.re / other, self.im / other)

    def __rtruediv__(self, other) -> Cx:
        return as_cx(other) / self

    # -- functions ---------------------------------------------------------
    def conj(self) -> Cx:
        """Complex conjugate."""
        return Cx(self.re, -self.im)

    def abs2(self):
        """Squared modulus ``re^2 + im^2`` (smooth everywhere)."""
        return self.re * self.re + self.im * self.im

    def abs(self):
        """Modulus (not differentiable at 0: keep it away from zero on symbols)."""
        return bk.sqrt(self.abs2())

    def arg(self):
        """Argument (phase angle) in radians."""
        return bk.arctan2(self.im, self.re)

    def loss_factor(self):
        """Loss factor ``im / re`` of a complex stiffness."""
        return self.im / self.re


#: Above this many elements, NumPy pairs are multiplied and divided with NumPy's
#: complex ufuncs (one pass, fewer temporaries); the result is the same.
_NATIVE_MIN_SIZE = 4096


def _is_complex(x) -> bool:
    """True for a :class:`Cx`, a Python or NumPy complex scalar, or a complex NumPy array.

    Those are split into (real, imaginary) parts before multiplying or dividing;
    anything else (real numbers, real arrays, CasADi symbols) scales both parts.
    """
    if isinstance(x, Cx | complex | np.complexfloating):
        return True
    return isinstance(x, np.ndarray) and np.iscomplexobj(x)


def _large_numpy(a: Cx, b: Cx) -> bool:
    """True when both pairs hold NumPy data and one of them is large."""
    parts = (a.re, a.im, b.re, b.im)
    if any(bk.is_casadi(p) for p in parts):
        return False
    return max(np.size(p) for p in parts) >= _NATIVE_MIN_SIZE


def as_cx(x) -> Cx:
    """Promote a real value, a complex number or array, or a :class:`Cx` to a :class:`Cx`.

    Parameters
    ----------
    x : float, complex, ndarray, CasADi SX/MX/DM or Cx
        The value (a real one gets a zero imaginary part of the same backend).

    Returns
    -------
    Cx
    """
    if isinstance(x, Cx):
        return x
    if isinstance(x, complex | np.complexfloating):
        return Cx(float(x.real), float(x.imag))
    if isinstance(x, np.ndarray) and np.iscomplexobj(x):
        return Cx.from_complex(x)
    return Cx(
        x, 0.0 * x if bk.is_casadi(x) else np.zeros_like(x, dtype=float) if np.ndim(x) else 0.0
    )
