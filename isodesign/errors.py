"""Errors and input validation shared by the whole package.

Every bad input raises :class:`InputError` (a ``ValueError``) whose message names
the parameter and its valid range, so that the CLI can print it as one line.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "InputError",
    "ModelValidityWarning",
    "SolverError",
    "check_choice",
    "check_domain",
    "check_finite_array",
    "check_instance",
    "check_positive",
    "check_range",
    "did_you_mean",
]


class InputError(ValueError):
    """Bad user input: the message names the parameter and its valid range."""


class SolverError(RuntimeError):
    """A numerical solver failed; the message carries its status."""


class ModelValidityWarning(UserWarning):
    """Some evaluated points lie outside the validity range of a model."""


def did_you_mean(given: Any, valid) -> str:
    """``" (did you mean 'mass_kg'?)"`` for a key close to one of ``valid`` (else ``""``).

    Parameters
    ----------
    given : object
        The unknown key as the user typed it.
    valid : iterable of str
        The keys it could have meant.
    """
    import difflib

    if not isinstance(given, str):
        return ""
    keys = sorted(str(v) for v in valid)
    close = difflib.get_close_matches(given, keys, n=1, cutoff=0.6) or \
        difflib.get_close_matches(given.lower(), keys, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _is_symbolic(x: Any) -> bool:
    return type(x).__module__.startswith("casadi")


def _shown(value: Any) -> str:
    """``repr(value)``, shortened (a 400-digit integer is reported by its size)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**15:
        return f"an integer of {len(str(abs(value)))} digits"
    r = repr(value)
    return r if len(r) <= 60 else r[:57] + "..."


def check_positive(name: str, value: Any, *, unit: str = "", allow_array: bool = False):
    """Require a finite value > 0 (every entry for arrays); symbols pass through.

    Parameters
    ----------
    name : str
        The parameter's name as the user wrote it (it starts the error message).
    value : float, array_like or CasADi symbol
        The value given.
    unit : str
        Unit for the message.
    allow_array : bool
        Accept arrays (every entry is checked).
    """
    if _is_symbolic(value):
        return value
    u = f" {unit}" if unit else ""
    if allow_array:
        try:
            arr = np.asarray(value, dtype=float) if not isinstance(value, str) else None
        except (TypeError, ValueError):
            arr = None
        if arr is None or arr.size == 0:
            raise InputError(f"{name}: expected at least one finite value > 0{u}, got {value!r}")
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name}: every value must be finite and > 0{u} (got NaN or inf)")
        if np.any(arr <= 0):
            raise InputError(
                f"{name}: every value must be > 0{u}; got minimum {float(np.min(arr)):g}"
            )
        return arr
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a number > 0{u}, got {_shown(value)}") from None
    except OverflowError:
        raise InputError(f"{name}: must be finite and > 0{u}, got {_shown(value)}") from None
    if not math.isfinite(v) or v <= 0:
        raise InputError(f"{name}: must be finite and > 0{u}, got {_shown(value)}")
    return v


def check_domain(name: str, values, domain, *, unit: str = ""):
    """Require every entry of ``values`` in the closed range ``domain`` (symbols pass).

    For the models' numeric domain (:mod:`isodesign.domain`): a frequency of 1e-320 Hz is
    finite and positive but no solver can answer for it.

    Parameters
    ----------
    name : str
        The parameter's name as the user wrote it.
    values : float or array_like
        Already checked to be finite and positive.
    domain : tuple of float
        ``(lo, hi)``.
    unit : str
        Unit for the message.

    Returns
    -------
    values
        Unchanged.
    """
    if _is_symbolic(values):
        return values
    lo, hi = domain
    a = np.asarray(values, float)
    bad = (a < lo) | (a > hi)
    if np.any(bad):
        v = a[bad].flat[0]
        u = f" {unit}" if unit else ""
        raise InputError(f"{name}: every value must be in [{lo:g}, {hi:g}]{u} (the models' "
                         f"domain), got {v:g}")
    return values


def check_range(
    name: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
):
    """Require a finite scalar within [lo, hi] (open ends where asked).

    Parameters
    ----------
    name : str
        The parameter's name as the user wrote it (it starts the error message).
    value : float
        The value given.
    lo, hi : float or None
        Bounds (None: unbounded).
    lo_open, hi_open : bool
        Exclude the bound itself.
    unit : str
        Unit for the message.
    """
    if _is_symbolic(value):
        return value
    lb = "(" if lo_open else "["
    rb = ")" if hi_open else "]"
    rng = f"{lb}{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}{rb}"
    u = f" {unit}" if unit else ""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a number in {rng}{u}, got {_shown(value)}") from None
    except OverflowError:
        raise InputError(f"{name}: must be in {rng}{u}, got {_shown(value)}") from None
    bad = not math.isfinite(v)
    if lo is not None:
        bad |= v <= lo if lo_open else v < lo
    if hi is not None:
        bad |= v >= hi if hi_open else v > hi
    if bad:
        raise InputError(f"{name}: must be in {rng}{u}, got {_shown(value)}")
    return v


def check_finite_array(name: str, value: Any, *, positive: bool = True, unit: str = ""):
    """Convert to a float array; require finite (and > 0) entries.

    Parameters
    ----------
    name : str
        The parameter's name as the user wrote it (it starts the error message).
    value : array_like
        The values given.
    positive : bool
        Also require every entry > 0.
    unit : str
        Unit for the message.
    """
    if positive:
        return check_positive(name, value, unit=unit, allow_array=True)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected numbers, got {value!r}") from None
    if arr.size == 0 or not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: every value must be finite (got NaN, inf or nothing)")
    return arr


def check_choice(name: str, value: Any, choices) -> str:
    """Require one of the named choices (case-sensitive strings).

    Parameters
    ----------
    name : str
        The parameter's name as the user wrote it (it starts the error message).
    value : object
        The value given.
    choices : sequence of str
        The valid values.
    """
    choices = tuple(choices)
    if value not in choices:
        raise InputError(f"{name}: unknown value {value!r}; valid: {', '.join(map(str, choices))}")
    return value


def check_instance(name: str, value: Any, types, expected: str):
    """Require an instance of ``types`` (an object the public API passes on, not a number).

    Parameters
    ----------
    name : str
        The parameter's name as the user wrote it (it starts the error message).
    value : object
        The value given.
    types : type or tuple of types
        The accepted types.
    expected : str
        What to pass, for the message (``"a TableModel (table_model(design, table))"``).
    """
    if not isinstance(value, types):
        raise InputError(f"{name}: expected {expected}, got {type(value).__name__} "
                         f"{_shown(value)}")
    return value
