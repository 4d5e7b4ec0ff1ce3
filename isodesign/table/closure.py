"""The harmonic closures of the table's random response, per isolator, and the fixed point
both closures iterate.

:class:`TableDescribing` is each isolator's spring at its describing function at
``A* = 1.880 sigma_i`` of its own stroke RMS (``equivalent_amplitude``) or its Rayleigh
average (``rayleigh``), as the vertical model's harmonic closures
(docs/random-response.md); :func:`solve_describing_closure` solves the ``n`` stroke RMS
values together (docs/table.md, section 5). :func:`z_closure` is the exact reduction both
closures take on a z-reducible table under a vertical floor (docs/table.md, section 14).
The statistical closure per isolator is in :mod:`isodesign.table.response`.
"""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.numerics.cplx import Cx
from isodesign.response.linearization import (
    RAYLEIGH_NODES,
    equivalent_amplitude,
    rayleigh_rule,
)
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M
from isodesign.table.floor import TableGrid
from isodesign.table.model import TableModel

__all__ = ["TableDescribing", "anderson", "excited_axes", "solve_describing_closure",
           "z_closure", "z_only"]


def z_only(st) -> bool:
    """A closure whose table is z-reducible and whose floor moves in z alone (its state is
    one isolator's: docs/table.md, section 14).

    Parameters
    ----------
    st : TableStatistical or TableDescribing
    """
    return getattr(st, "axes", None) == (2,) and st.model.z_reducible


def z_closure(model: TableModel, grid: TableGrid, random_method: str, rtol: float,
              max_iter: int, *, with_info: bool = False):
    """The closure of a z-reducible table under a vertical floor: its z DOF alone, mass
    ``m`` on ``n`` equal springs, is the 1-DOF payload's closure
    (:func:`~isodesign.response.random_input.solve_stroke_rms`); every isolator has its
    state. Returns ``(sigma, sigma_u, evaluations)`` (``sigma_u`` NaN for a harmonic closure)
    and, ``with_info``, the 1-DOF closure's ``info`` (its slope ``closure_slope`` and its
    ``linearization``, :func:`~isodesign.response.random_input.solve_stroke_rms`).

    Parameters
    ----------
    model : TableModel
        A z-reducible table (:attr:`~isodesign.table.model.TableModel.z_reducible`).
    grid : TableGrid or ResponseGrid
        A floor moving in z alone (or the vertical floor's response grid).
    random_method : {'statistical', 'equivalent_amplitude'}
    rtol : float
    max_iter : int
    with_info : bool
    """
    from isodesign.response.isolator import Payload
    from isodesign.response.random_input import solve_stroke_rms

    n, t = model.n_isolators, model.table
    rg = grid.axis_grids[2] if isinstance(grid, TableGrid) else grid
    sigma, info = solve_stroke_rms(
        model.designs[0], Payload(t.mass_kg, n, g_m_s2=t.g_m_s2), rg,
        flow=model.flow, amplitude_mode=model.amplitude_mode, diaphragm=model.diaphragm,
        derive_pressure=False, rtol=rtol, max_iter=max_iter, random_method=random_method)
    su = info.get("tube_velocity_rms_m_s", np.nan)
    out = (np.full(n, sigma), np.full(n, su), int(info["iterations"]))
    return (*out, info) if with_info else out


def excited_axes(grid: TableGrid) -> tuple[int, ...]:
    """The floor axes of a grid that carry motion (a nonzero stroke weight; every axis for
    an object with frequencies alone).

    Parameters
    ----------
    grid : TableGrid
    """
    sw = getattr(grid, "stroke_weight", None)  # a grid of frequencies alone: every axis
    return (0, 1, 2) if sw is None else tuple(a for a in range(3) if np.any(sw[a] != 0))


class TableDescribing:
    """The harmonic closures per isolator on a :class:`TableGrid` (NumPy): each isolator's
    spring is its describing function at ``A* = 1.880 sigma_i`` of its own stroke RMS
    (``equivalent_amplitude``) or its Rayleigh average (``rayleigh``), as the vertical
    model's closures (docs/random-response.md); the tube velocity is not a state.

    Parameters
    ----------
    model : TableModel
    grid : TableGrid
    method : {'equivalent_amplitude', 'rayleigh'}
    nodes : int
        Nodes of the Rayleigh rule.
    """

    def __init__(self, model: TableModel, grid: TableGrid, method: str,
                 nodes: int = RAYLEIGH_NODES):
        self.model, self.grid, self.method = model, grid, method
        self.kh = model.horizontal_stiffness(grid.omega)
        self.axes = excited_axes(grid)
        self.rule = rayleigh_rule(nodes) if method == "rayleigh" else None

    def spring_result(self, i: int, sigma: float):
        """Isolator ``i``'s :class:`~isodesign.spring.stiffness.StiffnessResult` and ``k``
        (complex, on the grid) at the stroke RMS ``sigma``.

        Parameters
        ----------
        i : int
            Isolator index (zero-based).
        sigma : float
            Its stroke RMS, m.
        """
        f = self.grid.frequency_hz
        spring = self.model.spring(i)
        if self.rule is None:
            res = spring.stiffness(f, equivalent_amplitude(sigma), pairwise=True)
            return res, res.k
        a, wq = self.rule
        res = spring.stiffness(f, sigma * a, pairwise=False)
        return res, res.k @ wq

    def springs(self, sigma):
        """Per isolator ``k`` (Cx on the grid) at the stroke RMS values ``sigma``.

        Parameters
        ----------
        sigma : ndarray (n,)
        """
        first, inv = self.model.unique_isolators()
        cache: dict = {}
        ks = []
        for i in range(self.model.n_isolators):
            rep = int(first[inv[i]])
            key = (rep, float(sigma[i]))
            if key not in cache:
                cache[key] = Cx.from_complex(self.spring_result(rep, float(sigma[i]))[1])
            ks.append(cache[key])
        return ks

    def variances(self, sigma, sigma_u=None, *, strokes_only: bool = False):
        """``(sigma^2, zeros, outputs, k, None)`` produced at the stroke RMS ``sigma``.

        Parameters
        ----------
        sigma : ndarray (n,)
            Stroke RMS per isolator.
        sigma_u : ignored
            (The statistical closure's tube-velocity state; none here.)
        strokes_only : bool
            Outputs with the strokes only.
        """
        ks = self.springs(sigma)
        out = self.model.outputs(ks, self.grid.omega, self.kh, strokes_only=strokes_only,
                                 axes=self.axes if strokes_only else None)
        a2 = out.strokes.real ** 2 + out.strokes.imag ** 2
        s2 = np.einsum("fna,af->n", a2, self.grid.stroke_weight, optimize=True)
        return s2, np.zeros_like(s2), out, ks, None


def solve_describing_closure(st: TableDescribing, *, rtol: float = 1e-10,
                             max_iter: int = 100, reduce: bool = True):
    """Solve the harmonic closures per isolator; ``(sigma, evaluations)``.

    A fixed point in ``ln sigma`` (Anderson mixing, then hybrid Powell), from every spring
    at the linear reference amplitude, as the vertical model's secant.

    Parameters
    ----------
    st : TableDescribing
    rtol : float
        Tolerance on ``max |ln(sigma_new / sigma)|``.
    max_iter : int
        Iterations before the fallback.
    reduce : bool
        ``equivalent_amplitude`` on a z-reducible table under a vertical floor alone:
        its z DOF alone (default; exact, :func:`~isodesign.table.response.z_closure`).

    Raises
    ------
    SolverError
        No convergence.
    """
    if reduce and st.method == "equivalent_amplitude" and z_only(st):
        sigma, _, n_it = z_closure(st.model, st.grid, st.method, rtol, max_iter)
        return sigma, n_it
    model = st.model
    ks = [Cx.from_complex(k) for k in model.vertical_stiffness(st.grid.frequency_hz,
                                                                LINEAR_REFERENCE_AMPLITUDE_M)]
    out = model.outputs(ks, st.grid.omega, st.kh, strokes_only=True, axes=st.axes)
    s2 = np.einsum("fna,af->n", np.abs(out.strokes) ** 2, st.grid.stroke_weight)
    if not np.all(s2 > 0):
        raise InputError("floor: the spectrum carries no motion (PSD zero)")

    def g(x):
        return 0.5 * np.log(st.variances(np.exp(x), strokes_only=True)[0])

    x, n_eval, res = anderson(g, 0.5 * np.log(s2), rtol, max_iter)
    if not res <= rtol:
        from scipy.optimize import root

        sol = root(lambda z: g(z) - z, x if np.all(np.isfinite(x)) else 0.5 * np.log(s2),
                   method="hybr", options={"xtol": 1e-14})  # fmt: skip
        n_eval += int(sol.nfev)
        res = float(np.max(np.abs(g(sol.x) - sol.x)))
        if not res <= max(rtol, 1e-9):
            raise SolverError(f"table closure ({st.method}) did not converge: max "
                              f"|ln(sigma_new/sigma)| = {res:.3g} > rtol = {rtol:g} after "
                              f"{n_eval} evaluations")
        x = sol.x
    return np.exp(x), n_eval


def anderson(g, x0: np.ndarray, tol: float, max_iter: int, depth: int = 6, history=None):
    """Fixed point ``x = g(x)`` by Anderson mixing (steps clipped to +-2).

    Parameters
    ----------
    g : callable
        ``ndarray -> ndarray`` of the same shape.
    x0 : ndarray
        Start.
    tol : float
        Tolerance on ``max |g(x) - x|``.
    max_iter : int
        Iterations.
    depth : int
        History length of the mixing.
    history : list of (ndarray, ndarray), optional
        Pairs ``(x, g(x))`` already known (oldest first): the mixing starts from them, at
        the last one, without evaluating ``g`` there (``x0`` is then unused).

    Returns
    -------
    tuple
        ``(x, evaluations, residual)``.
    """
    if history:
        xs = [np.asarray(h[0], dtype=float) for h in history[-depth - 1:]]
        gs = [np.asarray(h[1], dtype=float) for h in history[-depth - 1:]]
        x, gx, n_eval = xs[-1].copy(), gs[-1], 0
    else:
        x = x0.copy()
        gx = g(x)
        n_eval = 1
        xs, gs = [x], [gx]
    for _ in range(max_iter):
        f = gx - x
        res = float(np.max(np.abs(f)))
        if res <= tol:
            return x, n_eval, res
        if len(xs) >= 2:
            hist = zip(xs[-depth - 1:], gs[-depth - 1:], strict=True)
            fs = np.array([gi - xi for xi, gi in hist])
            df = np.diff(fs, axis=0).T
            dg = np.diff(np.array(gs[-depth - 1:]), axis=0).T
            gamma = np.linalg.lstsq(df, f, rcond=None)[0]
            x_new = gx - dg @ gamma
        else:
            x_new = gx
        step = np.clip(x_new - x, -2.0, 2.0)
        x = x + step
        if not np.all(np.isfinite(x)):
            break
        gx = g(x)
        n_eval += 1
        xs.append(x)
        gs.append(gx)
    f = gx - x
    return x, n_eval, float(np.max(np.abs(f)))
