"""Modes of the table and the static stability of its rocking directions.

Modes (docs/table.md, section 6)
--------------------------------
The isolators' stiffness depends on frequency, so the modes solve the *nonlinear*
eigenproblem ``[K(w) - mu M] phi = 0`` with ``Re mu = w^2``: the stiffness is evaluated at
the mode's own frequency. Each mode is followed by a fixed-point iteration on ``w``: solve
the linear complex eigenproblem at ``w_k``, pick the eigenvector that continues the mode
(largest mass-weighted correlation with the previous shape), set
``w_(k+1) = sqrt(Re mu)``, until ``|w_(k+1) - w_k| <= tol w_k``. The damping ratio is
``zeta = Im mu / (2 Re mu)`` (``eta / 2`` of the mode), exact for a viscous single
degree of freedom at its natural frequency. Kinetic-energy fractions per DOF are
``Re(conj(phi_j) (M phi)_j) / phi^H M phi``.

Rocking stability (docs/table.md, section 7)
--------------------------------------------
The static forces stay vertical while the table turns: the gravity term ``-W h`` on ``rx``
and ``ry``. The vertical springs' rocking stiffness ``K_theta`` (2x2 on ``rx, ry``,
``sum K0_i [[y_i^2, -x_i y_i], [-x_i y_i, x_i^2]]`` about the CG) must exceed ``W h``: the
margin of each principal rocking direction is ``eig(K_theta) / (W h)``. The horizontal
springs do not change this condition (the Schur complement of the coupled
translation-rocking block is ``K_theta - W h`` for a common elastic-centre height). For four
isolators on a rectangle with the CG over its centre this is ``n K0 (s/2)^2 / (m g h)`` per
spacing ``s``: the 1-DOF tilt margin is the smaller of the two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import SolverError
from isodesign.numerics.cplx import Cx
from isodesign.response.isolator import static_stiffness
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M, TWO_PI
from isodesign.results import ResultDisplay
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.table.assembly import DOFS, dynamic_stiffness, static_stiffness_matrix
from isodesign.table.model import TableModel

__all__ = ["RockingStability", "TableModes", "rocking_stability", "table_modes"]


@dataclass(frozen=True, eq=False, repr=False)
class TableModes(ResultDisplay):
    """The table's six modes from the nonlinear (frequency-dependent) eigenproblem.

    Attributes
    ----------
    frequency_hz : ndarray (6,)
        ``sqrt(Re mu) / (2 pi)``, ascending (NaN for a statically unstable mode).
    damping_ratio : ndarray (6,)
        ``Im mu / (2 Re mu)``.
    shapes : ndarray (6, 6) complex
        Column ``j`` is mode ``j`` over ``(x, y, z, rx, ry, rz)`` (m, rad), normalized so
        its largest kinetic-energy component is 1.
    energy_fraction : ndarray (6, 6)
        Row ``j``: kinetic-energy fraction of mode ``j`` per DOF (sums to 1).
    iterations : ndarray of int (6,)
        Fixed-point iterations per mode.
    converged : ndarray of bool (6,)
    amplitude_m : float
        Stroke amplitude of the springs (the linear regime, 1 um, unless a closure state).
    """

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    energy_fraction: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M

    @property
    def names(self) -> tuple[str, ...]:
        """Each mode's dominant DOFs (energy fraction >= 10 %), e.g. ``x+ry``."""
        out = []
        for e in self.energy_fraction:
            order = np.argsort(-e)
            dom = [DOFS[i] for i in order if e[i] >= 0.10] or [DOFS[order[0]]]
            out.append("+".join(dom))
        return tuple(out)

    def to_frame(self):
        """One row per mode: frequency, damping ratio, energy fractions, real shape."""
        import pandas as pd

        df = pd.DataFrame({"mode": np.arange(1, 7), "name": self.names,
                           "frequency_hz": self.frequency_hz,
                           "damping_ratio": self.damping_ratio})  # fmt: skip
        for i, d in enumerate(DOFS):
            df[f"energy_{d}"] = self.energy_fraction[:, i]
        for i, d in enumerate(DOFS):
            df[f"shape_{d}"] = self.shapes[i].real
        df["converged"] = self.converged
        return df

    def _summary_items(self) -> list[tuple[str, str]]:
        return [(f"mode {j + 1} {n}", f"{f:.3g} Hz, zeta {z:.3g}") for j, (n, f, z) in
                enumerate(zip(self.names, self.frequency_hz, self.damping_ratio, strict=True))]

    def _display_frame(self):
        return self.to_frame()[["mode", "name", "frequency_hz", "damping_ratio"]]

    def plot(self, ax=None):
        """Kinetic energy per degree of freedom of each mode, labelled with its frequency
        and damping ratio (:func:`isodesign.table.plots.table_modes_figure`).

        Parameters
        ----------
        ax : matplotlib Axes, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.table.plots import table_modes_figure

        return table_modes_figure(self, ax=ax)


def _stiffness_at(model: TableModel, amplitude_m, vertical=None):
    """``w -> (kv list Cx, kh list Cx)`` at one frequency."""

    def at(w: float):
        f = np.array([w / TWO_PI])
        if vertical is not None:
            kv = vertical(np.array([w]))
        else:
            kv = [Cx.from_complex(k) for k in model.vertical_stiffness(f, amplitude_m)]
        kh = model.horizontal_stiffness(np.array([w]))
        return kv, kh

    return at


def _eig(model: TableModel, stiffness_at, w: float):
    from scipy.linalg import eig

    kv, kh = stiffness_at(w)
    d, _ = dynamic_stiffness(model.geometry, kv, kh, np.array([0.0]))
    k = (np.asarray(d.re) + 1j * np.asarray(d.im)).reshape(6, 6)
    mu, vec = eig(k, model.geometry.mass)
    return mu, vec


def _energy(m: np.ndarray, phi: np.ndarray) -> np.ndarray:
    e = np.real(np.conj(phi) * (m @ phi))
    return e / np.sum(e)


def table_modes(model: TableModel, *, amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M,
                vertical=None, tol: float = 1e-10, max_iter: int = 60) -> TableModes:
    """The six modes of a table, its stiffness evaluated at each mode's own frequency.

    Parameters
    ----------
    model : TableModel
    amplitude_m : float
        Stroke amplitude of the vertical springs (default the linear regime, 1 um).
    vertical : callable, optional
        ``omega (array) -> list of Cx``: the vertical stiffnesses to use instead (e.g. the
        springs linearized at a band response's closure).
    tol : float
        Relative tolerance on each mode's frequency.
    max_iter : int
        Fixed-point iterations per mode.

    Returns
    -------
    TableModes

    Raises
    ------
    SolverError
        A mode's iteration diverges (not raised for statically unstable modes: those get
        NaN frequency).
    """
    at = _stiffness_at(model, amplitude_m, vertical)
    m = model.geometry.mass
    mu0, vec0 = _eig(model, at, TWO_PI * 1.0)
    order = np.argsort(mu0.real)
    freq = np.full(6, np.nan)
    zeta = np.full(6, np.nan)
    shapes = np.zeros((6, 6), complex)
    energy = np.zeros((6, 6))
    its = np.zeros(6, int)
    conv = np.zeros(6, bool)
    for j, idx in enumerate(order):
        phi, mu = vec0[:, idx], mu0[idx]
        w = math.sqrt(mu.real) if mu.real > 0 else float("nan")
        n_it = 0
        ok = False
        while math.isfinite(w) and n_it < max_iter:
            mus, vecs = _eig(model, at, w)
            corr = np.abs(np.conj(phi) @ m @ vecs) ** 2 / np.real(
                np.einsum("ij,ik,kj->j", np.conj(vecs), m, vecs))  # fmt: skip
            k = int(np.argmax(corr))
            phi, mu = vecs[:, k], mus[k]
            n_it += 1
            if not mu.real > 0:
                w = float("nan")
                break
            w_new = math.sqrt(mu.real)
            if abs(w_new - w) <= tol * w:
                w, ok = w_new, True
                break
            w = w_new
        if math.isfinite(w) and not ok:
            raise SolverError(f"table modes: mode {j + 1} did not converge in {max_iter} "
                              f"iterations (last {w / TWO_PI:.6g} Hz)")
        e = _energy(m, phi)
        phi = phi / phi[int(np.argmax(e))]
        freq[j] = w / TWO_PI if math.isfinite(w) else np.nan
        zeta[j] = mu.imag / (2.0 * mu.real) if mu.real > 0 else np.nan
        shapes[:, j], energy[j], its[j], conv[j] = phi, e, n_it, ok or not math.isfinite(w)
    srt = np.argsort(np.where(np.isnan(freq), -1.0, freq))
    return TableModes(frequency_hz=freq[srt], damping_ratio=zeta[srt], shapes=shapes[:, srt],
                      energy_fraction=energy[srt], iterations=its[srt], converged=conv[srt],
                      amplitude_m=float(amplitude_m))  # fmt: skip


@dataclass(frozen=True, eq=False, repr=False)
class RockingStability(ResultDisplay):
    """Static stability of the table's rocking directions, with the gravity term.

    Attributes
    ----------
    margin : ndarray (2,)
        ``eig(K_theta) / (W h)`` per principal rocking direction, ascending (> 1 stable).
    directions : ndarray (2, 2)
        Column ``j``: the rotation axis (rx, ry components) of margin ``j``.
    rocking_stiffness_n_m_per_rad : ndarray (2, 2)
        ``K_theta`` of the vertical springs about the CG.
    overturning_n_m_per_rad : float
        ``W h``.
    static_stiffness_n_per_m : ndarray (n,)
        Each isolator's static vertical stiffness K0 (the 1-DOF definition).
    horizontal_static_n_per_m : ndarray (n,)
        Each isolator's static horizontal stiffness (storage part at 0.1 Hz).
    lowest_static_eigenvalue_rad2_s2 : float
        Smallest generalized eigenvalue of the full static 6x6 (springs + gravity) with
        the mass matrix, (rad/s)^2; > 0: statically stable in every direction.
    """

    margin: np.ndarray
    directions: np.ndarray
    rocking_stiffness_n_m_per_rad: np.ndarray
    overturning_n_m_per_rad: float
    static_stiffness_n_per_m: np.ndarray
    horizontal_static_n_per_m: np.ndarray
    lowest_static_eigenvalue_rad2_s2: float

    @property
    def stable(self) -> bool:
        """Every rocking direction has margin > 1."""
        return bool(np.all(self.margin > 1.0))

    def to_frame(self):
        """One row per principal rocking direction."""
        import pandas as pd

        return pd.DataFrame({"direction": ["weakest", "strongest"],
                             "axis_rx": self.directions[0], "axis_ry": self.directions[1],
                             "margin": self.margin,
                             "stable": self.margin > 1.0})  # fmt: skip

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("margin", ", ".join(f"{m:.3g}" for m in self.margin)),
                ("stable", str(self.stable))]


def rocking_stability(model: TableModel, *,
                      amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M) -> RockingStability:
    """Static rocking margins of a table (gravity term included).

    Parameters
    ----------
    model : TableModel
    amplitude_m : float
        Reference amplitude of the static stiffness K0 (1 um, as the 1-DOF figures).

    Returns
    -------
    RockingStability
    """
    dia = diaphragm_model(model.diaphragm)
    lv = model.leveling
    k0 = np.array([float(np.asarray(static_stiffness(d, dia, float(mi), amplitude_m)))
                   for d, mi in zip(model.designs, lv.mass_per_isolator_kg, strict=True)])
    r = model.table.vertical_points_m
    kt = np.array([[np.sum(k0 * r[:, 1] ** 2), -np.sum(k0 * r[:, 0] * r[:, 1])],
                   [-np.sum(k0 * r[:, 0] * r[:, 1]), np.sum(k0 * r[:, 0] ** 2)]])
    wh = model.table.weight_n * model.table.cg_height_m
    ev, vec = np.linalg.eigh(kt)
    margin = ev / wh if wh > 0 else np.full(2, np.inf)
    kh = np.array([float(np.asarray(k.re).ravel()[0]) for k in
                   model.horizontal_stiffness(np.array([TWO_PI * 0.1]))])
    ks = static_stiffness_matrix(model.geometry, k0, kh, include_gravity=True)
    from scipy.linalg import eigh

    ev_full = eigh(0.5 * (ks + ks.T), model.geometry.mass, eigvals_only=True)
    return RockingStability(margin=margin, directions=vec, rocking_stiffness_n_m_per_rad=kt,
                            overturning_n_m_per_rad=wh, static_stiffness_n_per_m=k0,
                            horizontal_static_n_per_m=kh,
                            lowest_static_eigenvalue_rad2_s2=float(ev_full[0]))  # fmt: skip
