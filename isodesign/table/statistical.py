"""The table's statistical closure: each isolator's spring linearized at its own stroke and
tube-velocity RMS, the ``2n`` RMS values solved together (docs/table.md, section 5; split
from :mod:`isodesign.table.response`, which re-exports these names)."""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.numerics.cplx import Cx
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    equivalent_amplitude,
)
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M
from isodesign.spring.capillary import statistical_resistance_function
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness, tube_velocity_gain2
from isodesign.table.closure import anderson as _anderson
from isodesign.table.closure import (
    excited_axes,
    z_closure,
    z_only,
)
from isodesign.table.floor import TableGrid
from isodesign.table.model import TableModel

__all__ = ["TableStatistical", "solve_table_closure"]


class TableStatistical:
    """The statistical linearization of every isolator on a :class:`TableGrid` (NumPy).

    Parameters
    ----------
    model : TableModel
    grid : TableGrid
    """

    def __init__(self, model: TableModel, grid: TableGrid):
        self.model, self.grid = model, grid
        self.dia = diaphragm_model(model.diaphragm)
        w = grid.omega
        self.first, self.inv = model.unique_isolators()
        self.c_of = {int(i): statistical_resistance_function(model.flow, model.designs[i], w)
                     for i in self.first}  # fmt: skip
        self.kh = model.horizontal_stiffness(w)
        #: the floor axes that move (the closure's strokes need no other)
        self.axes = excited_axes(grid)
        #: per isolator, the minor loss's equivalent gain over the Gaussian (the distortion's
        #: non-Gaussian correction, docs/random-response.md 3c; ones: Gaussian)
        self.gain_ratio = np.ones(model.n_isolators)

    def resistance(self, c_of, i: int, sigma_u: float):
        """Isolator ``i``'s ``C(sigma_u)`` from ``c_of``, its gain scaled by
        :attr:`gain_ratio`."""
        c = c_of(sigma_u)
        g = float(self.gain_ratio[i])
        if g == 1.0 or self.model.flow == "poiseuille":
            return c
        from isodesign.response.distortion import minor_loss_gain_shift

        return Cx(c.re + minor_loss_gain_shift(self.model.designs[i], sigma_u, g), c.im)

    def springs(self, sigma, sigma_u):
        """Per isolator ``(k, C)`` (Cx on the grid) at the RMS values ``sigma``, ``sigma_u``.

        Parameters
        ----------
        sigma, sigma_u : ndarray (n,)
            Stroke and tube-velocity RMS per isolator (m, m/s).
        """
        w = self.grid.omega
        cache: dict = {}
        ks, cs = [], []
        for i in range(self.model.n_isolators):
            rep = int(self.first[self.inv[i]])
            key = (rep, float(sigma[i]), float(sigma_u[i]), float(self.gain_ratio[i]))
            if key not in cache:
                c = self.resistance(self.c_of[rep], i, float(sigma_u[i]))
                k_air = air_stiffness(self.model.designs[rep], w, c, self.model.flow)
                k_d = self.dia.stiffness(w, equivalent_amplitude(float(sigma[i])))
                cache[key] = (spring_stiffness(k_air, k_d), c, k_air, k_d)
            k, c, _, _ = cache[key]
            ks.append(k)
            cs.append(c)
        return ks, cs

    def variances(self, sigma, sigma_u, *, strokes_only: bool = False):
        """``(sigma^2, sigma_u^2, outputs, k, C)`` produced at ``(sigma, sigma_u)``.

        Parameters
        ----------
        sigma, sigma_u : ndarray (n,)
            Stroke and tube-velocity RMS per isolator.
        strokes_only : bool
            Outputs with the strokes only (the closure's iterations).
        """
        ks, cs = self.springs(sigma, sigma_u)
        out = self.model.outputs(ks, self.grid.omega, self.kh, strokes_only=strokes_only,
                                 axes=self.axes if strokes_only else None)
        a2 = out.strokes.real ** 2 + out.strokes.imag ** 2  # (f, n, 3)
        sw = self.grid.stroke_weight  # (3, f)
        s2 = np.einsum("fna,af->n", a2, sw, optimize=True)
        su2 = np.empty_like(s2)
        gains: dict = {}
        for i in range(self.model.n_isolators):
            rep = int(self.first[self.inv[i]])
            key = (rep, float(sigma[i]), float(sigma_u[i]), float(self.gain_ratio[i]))
            if key not in gains:  # the isolators sharing a spring share its tube's gain
                gains[key] = np.asarray(tube_velocity_gain2(self.model.designs[rep],
                                                            self.grid.omega, cs[i],
                                                            self.model.flow))
            su2[i] = float(np.sum(sw.T * a2[:, i, :] * gains[key][:, None]))
        #: the last state's outputs (the distortion at the closure's solution reuses them)
        self._last = (_state_key(sigma, sigma_u), out, ks, cs)
        return s2, su2, out, ks, cs


def _state_key(sigma, sigma_u) -> bytes:
    """An exact key of a closure state (two RMS vectors)."""
    return np.asarray(sigma, float).tobytes() + np.asarray(sigma_u, float).tobytes()


def solve_table_closure(st: TableStatistical, *, rtol: float = 1e-10, max_iter: int = 100,
                        start=None, reduce: bool = True, record=None, history=None):
    """Solve the per-isolator statistical closure; ``(sigma, sigma_u, evaluations)``.

    Parameters
    ----------
    st : TableStatistical
        The linearization on its grid.
    rtol : float
        Tolerance on ``max |ln(sigma_new / sigma)|`` over the ``2n`` RMS values.
    max_iter : int
        Iterations of the fixed point before the Newton (hybrid Powell) fallback.
    start : tuple of ndarray, optional
        ``(sigma, sigma_u)`` to start from (default: the linear regime).
    reduce : bool
        A z-reducible table under a vertical floor alone solves its z DOF alone (default;
        exact, :func:`z_closure`); False: the ``2n`` RMS values together, always.
    record : list, optional
        Appended with each evaluation's ``(x, g(x))`` (``x`` the log RMS values, ``2n``).
    history : list, optional
        Such pairs of this closure's map to start the mixing from
        (:func:`~isodesign.table.closure.anderson`).

    Raises
    ------
    SolverError
        No convergence.
    """
    if reduce and start is None and z_only(st):
        return z_closure(st.model, st.grid, "statistical", rtol, max_iter)
    n = st.model.n_isolators
    sigma0 = np.full(n, LINEAR_REFERENCE_AMPLITUDE_M / EQUIVALENT_AMPLITUDE_FACTOR)
    s2, su2, _, _, _ = st.variances(sigma0, np.full(n, 1e-9), strokes_only=True)
    if not np.all(s2 > 0):
        raise InputError("floor: the spectrum carries no motion (PSD zero)")
    x0 = 0.5 * np.log(np.concatenate([s2, np.maximum(su2, 1e-300)]))
    if start is not None:
        x0 = np.log(np.concatenate([np.asarray(start[0], float), np.asarray(start[1], float)]))

    def g(x):
        e = np.exp(x)
        a, b, _, _, _ = st.variances(e[:n], e[n:], strokes_only=True)
        gx = 0.5 * np.log(np.concatenate([a, np.maximum(b, 1e-300)]))
        if record is not None:
            record.append((x, gx))
        return gx

    x, n_eval, res = _anderson(g, x0, rtol, max_iter, history=history)
    if not res <= rtol:
        from scipy.optimize import root

        sol = root(lambda z: g(z) - z, x if np.all(np.isfinite(x)) else x0, method="hybr",
                   options={"xtol": 1e-14})  # fmt: skip
        n_eval += int(sol.nfev)
        res = float(np.max(np.abs(g(sol.x) - sol.x)))
        if not res <= max(rtol, 1e-9):
            raise SolverError(f"table closure did not converge: max |ln(sigma_new/sigma)| = "
                              f"{res:.3g} > rtol = {rtol:g} after {n_eval} evaluations")
        x = sol.x
    e = np.exp(x)
    return e[:n], e[n:], n_eval
