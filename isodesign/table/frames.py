"""Labelled frames of a table's transmissibility arrays (one row per frequency, point and
axis pair), shared by the band response and the harmonic response.

A table's transmissibility is ``T[f, point, axis out, axis in]``: the motion of an
instrument point along ``axis out`` per unit floor motion along ``axis in`` (docs/table.md,
section 5). :func:`transmissibility_frame` names every index and adds ``|T|`` in dB and
the phase, so no caller handles the bare ``(n_freq, k, 3, 3)`` array.
"""

from __future__ import annotations

import numpy as np

from isodesign.table.assembly import AXES

__all__ = ["transmissibility_frame"]

#: The columns of :func:`transmissibility_frame` (``linear`` adds ``transmissibility_linear_db``).
COLUMNS = ("frequency_hz", "point", "axis_in", "axis_out", "transmissibility_abs",
           "transmissibility_db", "phase_deg")


def transmissibility_frame(frequency_hz, transmissibility, point_names, *, axes_in=AXES,
                           linear=None):
    """One row per frequency, instrument point, floor axis and point axis.

    Parameters
    ----------
    frequency_hz : array_like (n_freq,)
    transmissibility : ndarray (n_freq, k, 3, n_in) complex
        ``T[f, point, axis out, axis in]``.
    point_names : sequence of str (k,)
    axes_in : sequence of str (n_in,)
        Names of the floor motions (default ``x, y, z``; a harmonic response along another
        direction names it).
    linear : ndarray like ``transmissibility``, optional
        The linear-regime transmissibility: adds ``transmissibility_linear_db``.

    Returns
    -------
    pandas.DataFrame
        Columns ``frequency_hz``, ``point``, ``axis_in`` (the floor's motion), ``axis_out``
        (the point's motion), ``transmissibility_abs`` (``|T|``), ``transmissibility_db``
        (``20 log10 |T|``), ``phase_deg`` (of ``T``, in (-180, 180]) and, with ``linear``,
        ``transmissibility_linear_db``; ordered by frequency, point, axis in, axis out.
    """
    import pandas as pd

    f = np.asarray(frequency_hz, float)
    t = np.asarray(transmissibility, complex)
    n_f, k, n_out, n_in = t.shape
    if f.shape != (n_f,) or len(point_names) != k or len(axes_in) != n_in or n_out != 3:
        raise ValueError(f"transmissibility_frame: shape {t.shape} does not match "
                         f"{f.size} frequencies, {len(point_names)} points, "
                         f"{len(axes_in)} floor axes")
    order = (0, 1, 3, 2)  # rows by frequency, point, axis in, axis out
    tt = t.transpose(order).ravel()
    idx = np.indices((n_f, k, n_in, n_out)).reshape(4, -1)
    mag = np.abs(tt)
    with np.errstate(divide="ignore"):
        db = 20.0 * np.log10(mag)
    df = pd.DataFrame({
        "frequency_hz": f[idx[0]],
        "point": np.asarray(point_names, dtype=object)[idx[1]],
        "axis_in": np.asarray(axes_in, dtype=object)[idx[2]],
        "axis_out": np.asarray(AXES, dtype=object)[idx[3]],
        "transmissibility_abs": mag,
        "transmissibility_db": db,
        "phase_deg": np.degrees(np.angle(tt)),
    })
    if linear is not None:
        lin = np.abs(np.asarray(linear, complex).transpose(order).ravel())
        with np.errstate(divide="ignore"):
            df["transmissibility_linear_db"] = 20.0 * np.log10(lin)
    return df
