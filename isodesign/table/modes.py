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

Static stability (docs/table.md, section 7)
--------------------------------------------
The static forces stay vertical while the table turns: the gravity term ``-W h`` on ``rx``
and ``ry``. Condensing ``x, y, rz`` (the horizontal springs drop out) and the vertical
translation ``z`` leaves ``A - W h I`` on ``(rx, ry)`` with
``A = K_theta - s s^T / sum k_i`` (:func:`~isodesign.table.statics.condensed_rocking_stiffness`):
stable when positive definite, margins ``eig(A) / (W h)``, critical CG height
``lambda_min(A) / W``. Three-valve leveling does not put the vertical stiffness centre under
the CG (``s != 0``), so ``K_theta`` alone would be optimistic. Each sealed spring's
stiffness is taken on a stated time scale: the quasi-static 1 mHz by default (the
diaphragm keeps softening towards low frequency), or any frequency (the leveling loop's).
A mode that is statically unstable at its own frequency makes the verdict unstable too.

Near the limit the nonlinear eigenproblem of the lowest mode has several self-consistent
solutions (or none): :func:`mode_solutions` finds every root of
``Re mu_k(w) - w^2`` on a frequency scan, not only the one the fixed point reaches.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, SolverError, check_instance, check_positive
from isodesign.numerics.cplx import Cx
from isodesign.response.isolator import static_stiffness
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M, TWO_PI
from isodesign.results import ResultDisplay
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.table.assembly import DOFS, dynamic_stiffness, static_stiffness_matrix
from isodesign.table.model import TableModel
from isodesign.table.statics import QUASI_STATIC_FREQUENCY_HZ, condensed_rocking_stiffness

__all__ = ["ModeSolutions", "RockingStability", "TableModes", "mode_solutions",
           "rocking_stability", "table_modes"]


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
    """``w (array) -> (kv list Cx, kh list Cx)``: every isolator at each frequency."""

    def at(w):
        w = np.atleast_1d(np.asarray(w, dtype=float))
        if vertical is not None:
            kv = vertical(w)
        else:
            kv = [Cx.from_complex(k) for k in model.vertical_stiffness(w / TWO_PI, amplitude_m)]
        kh = model.horizontal_stiffness(w)
        return kv, kh

    return at


def _eigs(model: TableModel, stiffness_at, w) -> list:
    """``[(mu, vec)]``: the eigenproblem ``K(w_j) phi = mu M phi`` at each frequency
    ``w_j``, the springs evaluated at all of them at once (one vectorized evaluation)."""
    from scipy.linalg import eig

    w = np.atleast_1d(np.asarray(w, dtype=float))
    kv, kh = stiffness_at(w)
    d, _ = dynamic_stiffness(model.geometry, kv, kh, np.zeros(w.size))
    k = (np.asarray(d.re) + 1j * np.asarray(d.im)).reshape(w.size, 6, 6)
    return [eig(k[j], model.geometry.mass) for j in range(w.size)]


def _eig(model: TableModel, stiffness_at, w: float):
    return _eigs(model, stiffness_at, [w])[0]


def _energy(m: np.ndarray, phi: np.ndarray) -> np.ndarray:
    e = np.real(np.conj(phi) * (m @ phi))
    return e / np.sum(e)


def table_modes(model: TableModel, *, amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M,
                vertical=None, tol: float = 1e-10, max_iter: int = 60,
                side_by_side: bool = True) -> TableModes:
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
    side_by_side : bool
        Evaluate the springs once per step at every moving mode's frequency (default,
        vectorized: about 4x faster), or at each mode's frequency on its own (the
        evaluation the table optimizer freezes its NLP's modes with: the same iterates to
        rounding, 1e-15 Hz, but its re-optimizations are sensitive to rounding, docs/table.md
        section 6).

    Returns
    -------
    TableModes

    Raises
    ------
    SolverError
        A mode's iteration diverges (not raised for statically unstable modes: those get
        NaN frequency).
    """
    check_instance("model", model, TableModel,
                   "a TableModel (isodesign.table.model.table_model(design, table))")
    check_positive("amplitude_m", amplitude_m, unit="m")
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
    # each mode's fixed point w <- sqrt(Re mu(w)), the six iterated side by side: each step
    # evaluates the springs at the still-moving modes' frequencies in one call (the same
    # iterates as one mode at a time)
    phi = [vec0[:, idx] for idx in order]
    mu = [mu0[idx] for idx in order]
    w = [math.sqrt(x.real) if x.real > 0 else float("nan") for x in mu]
    ok = [False] * 6
    moving = [j for j in range(6) if math.isfinite(w[j])]
    while moving:
        eigs = _eigs(model, at, [w[j] for j in moving]) if side_by_side else \
            [_eigs(model, at, [w[j]])[0] for j in moving]
        for j, (mus, vecs) in zip(moving, eigs, strict=True):
            corr = np.abs(np.conj(phi[j]) @ m @ vecs) ** 2 / np.real(
                np.einsum("ij,ik,kj->j", np.conj(vecs), m, vecs))  # fmt: skip
            k = int(np.argmax(corr))
            phi[j], mu[j] = vecs[:, k], mus[k]
            its[j] += 1
            if not mu[j].real > 0:
                w[j] = float("nan")
                continue
            w_new = math.sqrt(mu[j].real)
            if abs(w_new - w[j]) <= tol * w[j]:
                w[j], ok[j] = w_new, True
                continue
            w[j] = w_new
        moving = [j for j in moving if math.isfinite(w[j]) and not ok[j] and its[j] < max_iter]
    for j in range(6):
        if math.isfinite(w[j]) and not ok[j]:
            raise SolverError(f"table modes: mode {j + 1} did not converge in {max_iter} "
                              f"iterations (last {w[j] / TWO_PI:.6g} Hz)")
        e = _energy(m, phi[j])
        ph = phi[j] / phi[j][int(np.argmax(e))]
        freq[j] = w[j] / TWO_PI if math.isfinite(w[j]) else np.nan
        zeta[j] = mu[j].imag / (2.0 * mu[j].real) if mu[j].real > 0 else np.nan
        shapes[:, j], energy[j], conv[j] = ph, e, ok[j] or not math.isfinite(w[j])
    srt = np.argsort(np.where(np.isnan(freq), -1.0, freq))
    return TableModes(frequency_hz=freq[srt], damping_ratio=zeta[srt], shapes=shapes[:, srt],
                      energy_fraction=energy[srt], iterations=its[srt], converged=conv[srt],
                      amplitude_m=float(amplitude_m))  # fmt: skip


@dataclass(frozen=True, eq=False, repr=False)
class RockingStability(ResultDisplay):
    """Static stability of the table with the gravity term, vertical translation condensed.

    Attributes
    ----------
    margin : ndarray (2,)
        ``eig(A) / (W h)`` per principal rocking direction, ascending (> 1 stable); equal to
        ``critical height / h`` for the weakest one.
    directions : ndarray (2, 2)
        Column ``j``: the rotation axis (rx, ry components) of margin ``j``.
    rocking_stiffness_n_m_per_rad : ndarray (2, 2)
        ``K_theta`` of the vertical springs about the CG (z held).
    condensed_stiffness_n_m_per_rad : ndarray (2, 2)
        ``A = K_theta - s s^T / sum k`` (z condensed out), N m/rad.
    overturning_n_m_per_rad : float
        ``W h``.
    critical_height_m : float
        ``lambda_min(A) / W``: the CG height above the support plane where the table tips.
    static_stiffness_n_per_m : ndarray (n,)
        Each isolator's vertical stiffness on the time scale (storage part), N/m.
    horizontal_static_n_per_m : ndarray (n,)
        Each isolator's horizontal storage stiffness at the same time scale.
    lowest_static_eigenvalue_rad2_s2 : float
        Smallest generalized eigenvalue of the full static 6x6 (springs + gravity) with
        the mass matrix, (rad/s)^2; > 0: statically stable in every direction.
    frequency_hz : float or None
        The time scale of the springs' stiffness (None: ``K0``, the 1-DOF definition).
    time_scale : str
        What that time scale is, for the output.
    unstable_modes : tuple of int
        Modes (one-based) found statically unstable at their own frequency (when the modes
        were given): the verdict is then unstable whatever the margins say.
    """

    margin: np.ndarray
    directions: np.ndarray
    rocking_stiffness_n_m_per_rad: np.ndarray
    condensed_stiffness_n_m_per_rad: np.ndarray
    overturning_n_m_per_rad: float
    critical_height_m: float
    static_stiffness_n_per_m: np.ndarray
    horizontal_static_n_per_m: np.ndarray
    lowest_static_eigenvalue_rad2_s2: float
    frequency_hz: float | None = QUASI_STATIC_FREQUENCY_HZ
    time_scale: str = ""
    unstable_modes: tuple = ()

    @property
    def stable(self) -> bool:
        """Every principal direction has margin > 1 and no mode is statically unstable."""
        return bool(np.all(self.margin > 1.0)) and not self.unstable_modes

    @property
    def weakest_direction(self) -> np.ndarray:
        """The rotation axis ``(rx, ry)`` of the smallest margin (unit vector)."""
        return self.directions[:, 0]

    def to_frame(self):
        """One row per principal rocking direction."""
        import pandas as pd

        df = pd.DataFrame({"direction": ["weakest", "strongest"],
                           "axis_rx": self.directions[0], "axis_ry": self.directions[1],
                           "margin": self.margin, "stable": self.margin > 1.0,
                           "critical_height_m": self.critical_height_m,
                           "frequency_hz": np.nan if self.frequency_hz is None
                           else self.frequency_hz})  # fmt: skip
        df.attrs.update(time_scale=self.time_scale, unstable_modes=list(self.unstable_modes))
        return df

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("margin", ", ".join(f"{m:.3g}" for m in self.margin)),
                ("critical CG height", f"{self.critical_height_m:.4g} m"),
                ("springs", self.time_scale),
                ("stable", str(self.stable))]


def _time_scale(frequency_hz) -> str:
    if frequency_hz is None:
        return "springs at K0 (the 1-DOF static stiffness, diaphragm at the air spring's " \
            "frequency)"
    if frequency_hz <= 0.01:
        return f"sealed springs, quasi-static (valves off) at {frequency_hz:g} Hz"
    return f"sealed springs at {frequency_hz:g} Hz"


def rocking_stability(model: TableModel, *, frequency_hz: float | None = QUASI_STATIC_FREQUENCY_HZ,
                      amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M,
                      modes: TableModes | None = None,
                      time_scale: str | None = None) -> RockingStability:
    """Static stability of a table: margins, critical CG height, weakest direction.

    Parameters
    ----------
    model : TableModel
    frequency_hz : float or None
        The time scale of the sealed springs' stiffness, Hz: the quasi-static 1 mHz by
        default (valves off), the leveling loop's crossover when the valves are modelled,
        or ``None`` for ``K0`` (the 1-DOF figure's definition, optimistic for a diaphragm
        that softens towards low frequency).
    amplitude_m : float
        Stroke amplitude of the springs (1 um, the linear regime).
    modes : TableModes, optional
        The modes: one statically unstable at its own frequency makes the verdict unstable.
    time_scale : str, optional
        How the output names the time scale (default from ``frequency_hz``).

    Returns
    -------
    RockingStability
    """
    check_instance("model", model, TableModel,
                   "a TableModel (isodesign.table.model.table_model(design, table))")
    if frequency_hz is not None:
        check_positive("frequency_hz", frequency_hz, unit="Hz")
    from scipy.linalg import eigh

    if frequency_hz is None:
        dia = diaphragm_model(model.diaphragm)
        lv = model.leveling
        k0 = np.array([float(np.asarray(static_stiffness(d, dia, float(mi), amplitude_m)))
                       for d, mi in zip(model.designs, lv.mass_per_isolator_kg, strict=True)])
        f_h = 0.1
    else:
        f = float(frequency_hz)
        if not (math.isfinite(f) and f > 0):
            raise InputError(f"frequency_hz: must be > 0 (or None for K0), got {frequency_hz!r}")
        k0 = np.array([float(np.real(k[0])) for k in
                       model.vertical_stiffness(np.array([f]), amplitude_m)])
        f_h = f
    r = model.table.vertical_points_m
    kt = np.array([[np.sum(k0 * r[:, 1] ** 2), -np.sum(k0 * r[:, 0] * r[:, 1])],
                   [-np.sum(k0 * r[:, 0] * r[:, 1]), np.sum(k0 * r[:, 0] ** 2)]])
    a11, a12, a22 = condensed_rocking_stiffness(k0, r)
    a = np.array([[a11, a12], [a12, a22]], dtype=float)
    w = model.table.weight_n
    wh = w * model.table.cg_height_m
    ev, vec = np.linalg.eigh(a)
    vec = vec * np.where(vec[np.argmax(np.abs(vec), axis=0), [0, 1]] < 0, -1.0, 1.0)
    margin = ev / wh if wh > 0 else np.full(2, np.inf)
    kh = np.array([float(np.asarray(k.re).ravel()[0]) for k in
                   model.horizontal_stiffness(np.array([TWO_PI * f_h]))])
    ks = static_stiffness_matrix(model.geometry, k0, kh, include_gravity=True)
    ev_full = eigh(0.5 * (ks + ks.T), model.geometry.mass, eigvals_only=True)
    bad = () if modes is None else tuple(int(j) + 1 for j in
                                        np.flatnonzero(np.isnan(modes.frequency_hz)))
    return RockingStability(margin=margin, directions=vec, rocking_stiffness_n_m_per_rad=kt,
                            condensed_stiffness_n_m_per_rad=a, overturning_n_m_per_rad=wh,
                            critical_height_m=float(ev[0] / w), static_stiffness_n_per_m=k0,
                            horizontal_static_n_per_m=kh,
                            lowest_static_eigenvalue_rad2_s2=float(ev_full[0]),
                            frequency_hz=None if frequency_hz is None else float(frequency_hz),
                            time_scale=time_scale or _time_scale(frequency_hz),
                            unstable_modes=bad)  # fmt: skip


@dataclass(frozen=True, eq=False, repr=False)
class ModeSolutions(ResultDisplay):
    """Every self-consistent solution of one mode of the nonlinear eigenproblem.

    The ``rank``-th lowest eigenvalue (by real part) of ``[K(w) - mu M] phi = 0`` is scanned
    over frequency; a self-consistent mode is a root of the fixed-point map's residual
    ``r(f) = Re mu(w) - w^2`` (``w = 2 pi f``). Near the static limit a softening spring
    gives two roots or none; where ``Re mu <= 0`` the table is statically unstable on that
    time scale.

    Attributes
    ----------
    rank : int
        Zero-based rank of the eigenvalue followed (0: the lowest mode).
    frequency_hz : ndarray
        The self-consistent frequencies, ascending (empty: no solution).
    damping_ratio : ndarray
        ``Im mu / (2 Re mu)`` at each.
    scan_frequency_hz, residual_rad2_s2, eigenvalue_rad2_s2 : ndarray
        The scan: ``f``, ``r(f)`` and ``Re mu(w)``.
    unstable_below_hz : float or None
        The top of the range with ``Re mu <= 0`` that starts at the scan's lowest frequency:
        statically unstable on every slower time scale (None: ``Re mu > 0`` there).
    negative_ranges_hz : tuple of (float, float)
        Other scanned ranges with ``Re mu <= 0`` (first and last scan point of each), above
        a positive one: the springs' storage stiffness is negative there (a capillary's
        air column above its resonance), a dynamic effect, not a static instability.
    """

    rank: int
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    scan_frequency_hz: np.ndarray
    residual_rad2_s2: np.ndarray
    eigenvalue_rad2_s2: np.ndarray
    unstable_below_hz: float | None
    negative_ranges_hz: tuple = ()

    def to_frame(self):
        """One row per self-consistent solution."""
        import pandas as pd

        return pd.DataFrame({"mode_rank": self.rank + 1, "frequency_hz": self.frequency_hz,
                             "damping_ratio": self.damping_ratio})  # fmt: skip

    def text(self) -> str:
        """One line: the solutions and where the mode is statically unstable."""
        sol = ", ".join(f"{f:.4g} Hz (zeta {z:.3g})" for f, z in
                        zip(self.frequency_hz, self.damping_ratio, strict=True)) or "none"
        line = f"  mode {self.rank + 1}: self-consistent solutions {sol}"
        if self.unstable_below_hz is not None:
            line += (f"; Re mu <= 0 (statically unstable) on time scales slower than "
                     f"{self.unstable_below_hz:.3g} Hz")
        if self.negative_ranges_hz:
            line += ("; Re mu <= 0 also from " + ", ".join(
                f"{a:.3g} to {b:.3g} Hz" for a, b in self.negative_ranges_hz)
                + " (the springs' storage stiffness there, not a static instability)")
        return line

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("solutions (Hz)", ", ".join(f"{f:.4g}" for f in self.frequency_hz) or "none")]

    def plot(self, ax=None):
        """``Re mu(w)`` and ``w^2`` against frequency, the solutions marked.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Default: a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.style import new_figure

        if ax is None:
            fig = new_figure(6.0, 4.0)
            ax = fig.add_subplot()
        else:
            fig = ax.figure
        f = self.scan_frequency_hz
        ax.plot(f, self.eigenvalue_rad2_s2, label="Re mu(w) of the mode")
        ax.plot(f, (TWO_PI * f) ** 2, "--", label="w^2")
        ax.plot(self.frequency_hz, (TWO_PI * self.frequency_hz) ** 2, "o",
                label="self-consistent")
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xscale("log")
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("(rad/s)^2")
        ax.legend()
        return fig


def mode_solutions(model: TableModel, *, rank: int = 0, frequency_range_hz=(1e-3, 20.0),
                   points: int = 241, amplitude_m: float = LINEAR_REFERENCE_AMPLITUDE_M,
                   vertical=None) -> ModeSolutions:
    """Every self-consistent solution of the ``rank``-th lowest mode (a scan of the residual).

    Parameters
    ----------
    model : TableModel
    rank : int
        Zero-based rank of the eigenvalue (by real part) to follow.
    frequency_range_hz : (float, float)
        The scan, log-spaced.
    points : int
        Scan points.
    amplitude_m : float
        Stroke amplitude of the springs (1 um).
    vertical : callable, optional
        As in :func:`table_modes`.

    Returns
    -------
    ModeSolutions
    """
    check_instance("model", model, TableModel,
                   "a TableModel (isodesign.table.model.table_model(design, table))")
    if isinstance(rank, bool) or not isinstance(rank, int | np.integer) or rank < 0:
        raise InputError(f"rank: expected an integer >= 0 (0: the lowest solution), "
                         f"got {rank!r:.40}")
    if (not isinstance(frequency_range_hz, list | tuple | np.ndarray)
            or len(frequency_range_hz) != 2):
        raise InputError(f"frequency_range_hz: expected (low, high) in Hz, 0 < low < high, got "
                         f"{frequency_range_hz!r:.40}")
    lo_hz, hi_hz = check_positive("frequency_range_hz", frequency_range_hz, unit="Hz",
                                  allow_array=True)
    if not lo_hz < hi_hz:
        raise InputError(f"frequency_range_hz: expected (low, high) with low < high, got "
                         f"{tuple(frequency_range_hz)}")
    from scipy.optimize import brentq

    if not 0 <= int(rank) < 6:
        raise InputError(f"rank: must be an integer in [0, 5], got {rank!r}")
    lo, hi = (float(v) for v in frequency_range_hz)
    if not 0 < lo < hi:
        raise InputError(f"frequency_range_hz: expected 0 < low < high, got {frequency_range_hz!r}")
    at = _stiffness_at(model, amplitude_m, vertical)

    def mu_at(f):
        mus, _ = _eig(model, at, TWO_PI * f)
        return mus[np.argsort(mus.real)[rank]]

    fs = np.geomspace(lo, hi, int(points))
    w = TWO_PI * fs
    if vertical is None:  # the whole scan in one evaluation of each distinct spring
        kv = [Cx.from_complex(k) for k in model.vertical_stiffness(fs, amplitude_m)]
    else:
        kv = vertical(w)
    d, _ = dynamic_stiffness(model.geometry, kv, model.horizontal_stiffness(w),
                             np.zeros_like(w))
    km = (np.asarray(d.re) + 1j * np.asarray(d.im)).reshape(-1, 6, 6)
    minv = np.linalg.inv(model.geometry.mass)
    ev = np.linalg.eigvals(minv @ km)  # (points, 6): [K - mu M] phi = 0
    mu = np.take_along_axis(ev, np.argsort(ev.real, axis=1)[:, [rank]], axis=1)[:, 0]
    res = mu.real - (TWO_PI * fs) ** 2
    roots, zetas = [], []
    for i in np.flatnonzero(np.sign(res[:-1]) * np.sign(res[1:]) < 0):
        f0 = brentq(lambda lf: mu_at(math.exp(lf)).real - (TWO_PI * math.exp(lf)) ** 2,
                    math.log(fs[i]), math.log(fs[i + 1]), xtol=1e-13)
        f0 = math.exp(f0)
        m0 = mu_at(f0)
        roots.append(f0)
        zetas.append(m0.imag / (2.0 * m0.real))
    # runs of Re mu <= 0: the one from the scan's bottom is a static instability (every
    # slower time scale); one above a positive range is the springs' dynamic stiffness
    neg = np.r_[False, mu.real <= 0, False]
    starts = np.flatnonzero(~neg[:-1] & neg[1:])
    ends = np.flatnonzero(neg[:-1] & ~neg[1:]) - 1
    below = None
    ranges = []
    for a, b in zip(starts, ends, strict=True):
        if a == 0:
            below = float(fs[b])
        else:
            ranges.append((float(fs[a]), float(fs[b])))
    return ModeSolutions(rank=int(rank), frequency_hz=np.array(roots),
                         damping_ratio=np.array(zetas), scan_frequency_hz=fs,
                         residual_rad2_s2=res, eigenvalue_rad2_s2=mu.real,
                         unstable_below_hz=below, negative_ranges_hz=tuple(ranges))  # fmt: skip
