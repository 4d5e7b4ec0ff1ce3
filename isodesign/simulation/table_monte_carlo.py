"""Monte Carlo verifier of the rigid table's response to a three-axis random floor.

The table is a rigid body in six degrees of freedom (translations of the CG and small
rotations about it) on ``n`` isolators; the floor translates in x, y and z, three
independent stationary Gaussian processes, the same under every isolator (a rigid floor).
Per isolator, the NONLINEAR lumped equations of the vertical spring at that isolator's own
static pressure are integrated (the same compiled function as the 1-DOF verifier,
:func:`isodesign.simulation._mc_kernel.spring_rhs`: adiabatic chambers with mass flow, the
tube with Churchill friction and the minor loss, or Womersley modes); the horizontal element
is the pendulum ``W_i / L_p`` in parallel with the lateral stiffness, realized causally as a
Prony (generalized Maxwell) series. The velocity of every instrument point is analysed in
one-third-octave bands per axis; each isolator's stroke and tube velocity RMS are returned.
Nothing in the spring is linearized: this is the independent check of the table's
frequency-domain closure (``docs/table-monte-carlo.md``).

Kinematics (linearized, small rotations ``theta``): a point ``r`` of the body (relative to
the CG) moves by ``t + theta x r``. The vertical force of isolator ``i`` acts at its
vertical-force point ``r_v,i``, its horizontal force at its elastic centre ``r_h,i``; their
generalized forces are ``J(r)^T F`` with ``J(r) = [I, -[r]x]``
(:func:`isodesign.table.assembly.point_matrix`). The static loads ``W_i`` stay vertical
while their points turn with the body: the gravity (overturning) term ``-K_g q``, the same
matrix as the frequency-domain model's (:func:`isodesign.table.assembly.gravity_stiffness`,
``-W h`` on the rocking diagonal at equilibrium). The equations are written relative to the
floor: ``M r'' = Q(r, states) - K_g r - M e a_floor``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.errors import InputError, SolverError, check_choice
from isodesign.floor.bands import Bands
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR, default_bands
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M, resolve_floor, resolve_target
from isodesign.results import ResultDisplay
from isodesign.simulation.monte_carlo import (
    _AMPLITUDES,
    _FLOW_CODE,
    MONTE_CARLO_FLOW_MODELS,
    _band_mean_square,
    _check_seeds,
    _diaphragm_branches,
    _floor_half_steps,
    _kurtosis,
    _norm_bands,
    _parameters,
    _rms_se,
    _timing,
    fit_prony,
)
from isodesign.spring.diaphragm import NoDiaphragm, PronyDiaphragm, diaphragm_model
from isodesign.table.assembly import gravity_stiffness, point_matrix

__all__ = [
    "AXES",
    "TableMonteCarloResult",
    "TableRig",
    "lateral_prony",
    "simulate_table_response",
    "table_rig",
]

#: Axes of the floor and of the instrument points' velocities.
AXES = ("x", "y", "z")
#: Default warm-up: at least this long (s), and this many times the slowest decay time of
#: the linearized table, at most this many record lengths.
_MIN_WARMUP_S = 20.0
_WARMUP_DECAYS = 14.0
_MAX_WARMUP_PERIODS = 5.0
#: Largest ``rate x step`` of a Prony branch: RK4's stability limit on a real decay (2.785).
_MAX_RATE_STEP = 2.78


# ---------------------------------------------------------------------------
# the lateral element, realized causally
# ---------------------------------------------------------------------------
def lateral_prony(lateral, frequency_hz) -> tuple[PronyDiaphragm, float]:
    """The lateral (horizontal) stiffness as a causal Prony series, and its fit error.

    A loss-factor stiffness ``k (1 + j eta)`` is not causal (no time-domain element has a
    frequency-independent loss factor), so it is fitted over ``frequency_hz`` with
    :func:`~isodesign.simulation.monte_carlo.fit_prony`, the storage and the loss stiffness
    each relative to itself (``weighting='parts'``: the loss stiffness sets the damping of
    the horizontal and rocking modes; for ``eta = 0.15`` over 0.9-89 Hz the storage is
    within about 18 % and the loss within about 10 %, the compromise Kramers-Kronig allows).
    The closure to compare with must be evaluated with the returned element.

    Parameters
    ----------
    lateral : PronyDiaphragm, complex, (k, eta), or model with ``stiffness(omega, amplitude)``
        A :class:`PronyDiaphragm` is returned as it is (error 0); a complex number or a pair
        ``(k_n_per_m, loss_factor)`` is the constant ``k (1 + j eta)``.
    frequency_hz : array_like
        Frequencies of the fit, Hz.

    Returns
    -------
    PronyDiaphragm, float
    """
    if isinstance(lateral, PronyDiaphragm):
        return lateral, 0.0
    w = 2.0 * math.pi * np.asarray(frequency_hz, dtype=float)
    if hasattr(lateral, "stiffness"):
        k = lateral.stiffness(w, LINEAR_REFERENCE_AMPLITUDE_M)
        kt = np.asarray(k.re, dtype=float) + 1j * np.asarray(k.im, dtype=float)
    else:
        if isinstance(lateral, tuple | list) and len(lateral) == 2:
            k0, eta = (float(v) for v in lateral)
            value = complex(k0, k0 * eta)
        else:
            try:
                value = complex(lateral)
            except (TypeError, ValueError):
                raise InputError(
                    "lateral: expected a PronyDiaphragm, a complex stiffness, (k, loss "
                    f"factor) or a model with stiffness(omega, amplitude), got {lateral!r:.60}"
                ) from None
        if not (value.real >= 0 and value.imag >= 0 and abs(value) > 0):
            raise InputError(f"lateral: the stiffness must be passive (Re, Im >= 0), got {value}")
        kt = np.full(w.shape, value)
    parts = bool(np.all(kt.real > 0) and np.all(kt.imag > 0))
    k_inf, k_i, rate_i, err = fit_prony(w, kt, weighting="parts" if parts else "complex")
    return PronyDiaphragm(k_inf, tuple(k_i.tolist()), tuple(rate_i.tolist())), err


@dataclass(frozen=True, eq=False)
class TableRig:
    """Everything the time-domain table needs, in SI, relative to the CG.

    Built from a table model by :func:`simulate_table_response`; it can also be given
    directly (the tests build independent cases this way).

    Parameters
    ----------
    mass_kg : float
    inertia_kg_m2 : array_like (3, 3)
        Inertia tensor about the CG.
    designs : tuple of SpringDesign
        Each isolator's spring at its own static pressure (leveling).
    loads_n : array_like (n,)
        Each isolator's static vertical load, N.
    r_vertical_m, r_horizontal_m : array_like (n, 3)
        Vertical-force point and elastic centre of each isolator, relative to the CG.
    pendulum_n_per_m : array_like (n,)
        Pendulum stiffness ``W_i / L_p`` of each isolator (0 without pendulum).
    lateral : tuple of PronyDiaphragm
        Lateral stiffness of each isolator (the same in x and y), causal.
    points_m : array_like (n_points, 3)
        Instrument points relative to the CG.
    gravity_n_per_m : array_like (6, 6)
        The gravity (overturning) stiffness ``K_g``
        (:func:`isodesign.table.assembly.gravity_stiffness`).
    point_names : tuple of str
    lateral_fit_error : float
        Largest relative error of the lateral elements' Prony fits (reported).
    """

    mass_kg: float
    inertia_kg_m2: Any
    designs: tuple
    loads_n: Any
    r_vertical_m: Any
    r_horizontal_m: Any
    pendulum_n_per_m: Any
    lateral: tuple
    points_m: Any
    gravity_n_per_m: Any
    point_names: tuple = ()
    lateral_fit_error: float = 0.0

    def __post_init__(self):
        n = len(self.designs)
        if n < 1:
            raise InputError("table: at least one isolator")
        arr = {
            "inertia_kg_m2": (3, 3), "loads_n": (n,), "r_vertical_m": (n, 3),
            "r_horizontal_m": (n, 3), "pendulum_n_per_m": (n,),
        }  # fmt: skip
        for name, shape in arr.items():
            a = np.array(getattr(self, name), dtype=float)
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise InputError(f"table.{name}: expected finite values of shape {shape}, got "
                                 f"shape {a.shape}")  # fmt: skip
            a.flags.writeable = False
            object.__setattr__(self, name, a)
        pts = np.array(self.points_m, dtype=float).reshape(-1, 3)
        pts.flags.writeable = False
        object.__setattr__(self, "points_m", pts)
        if len(self.lateral) != n or not all(isinstance(x, PronyDiaphragm) for x in self.lateral):
            raise InputError(f"table.lateral: expected {n} PronyDiaphragm elements")
        names = tuple(self.point_names) or tuple(f"P{i + 1}" for i in range(len(pts)))
        if len(names) != len(pts):
            raise InputError("table.point_names: one name per instrument point")
        object.__setattr__(self, "point_names", names)
        kg = np.array(self.gravity_n_per_m, dtype=float)
        if kg.shape != (6, 6) or not np.all(np.isfinite(kg)):
            raise InputError("table.gravity_n_per_m: expected a 6 x 6 matrix")
        object.__setattr__(self, "gravity_n_per_m", kg)
        if not float(self.mass_kg) > 0:
            raise InputError(f"table.mass_kg: must be > 0 kg, got {self.mass_kg}")

    @property
    def isolators(self) -> int:
        """Number of isolators."""
        return len(self.designs)

    @property
    def mass_matrix(self) -> np.ndarray:
        """``diag(m, m, m, I)`` (6 x 6) about the CG."""
        m = np.zeros((6, 6))
        m[:3, :3] = float(self.mass_kg) * np.eye(3)
        m[3:, 3:] = self.inertia_kg_m2
        return m


# ---------------------------------------------------------------------------
# the result
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class TableMonteCarloResult(ResultDisplay):
    """Band RMS velocities of the table's instrument points from time-domain simulations.

    Attributes
    ----------
    bands : Bands
    point_names : tuple of str
    velocity_rms_m_s, velocity_rms_se_m_s : ndarray (n_points, 3, n_bands)
        Band RMS absolute velocity of each point in x, y, z (root of the mean over seeds of
        the band mean squares) and its standard error across seeds (NaN with one seed).
    floor_velocity_rms_m_s : ndarray (3, n_bands)
        The synthesized floor's band RMS per axis (mean over seeds).
    stroke_rms_m, stroke_rms_se_m : ndarray (n_isolators,)
        Each isolator's vertical stroke RMS and its standard error.
    horizontal_stroke_rms_m : ndarray (n_isolators, 2)
        RMS of each isolator's horizontal deflection in x and y at its elastic centre.
    tube_velocity_rms_m_s, tube_velocity_rms_se_m_s : ndarray (n_isolators,)
    stroke_kurtosis, tube_velocity_kurtosis : ndarray (n_isolators,)
    seeds : tuple of int
    duration_s, warmup_s, time_step_s : float
    transient_left : float
        ``exp(-lambda_min warmup_s)``: what is left of the start-up transient of the slowest
        mode of the linearized table when the record starts.
    flow, diaphragm, amplitudes : str
    floor_names : tuple of str
        Per axis.
    diaphragm_amplitude_m : ndarray (n_isolators,) or None
        Amplitudes at which each vertical diaphragm was frozen.
    diaphragm_fit_error, lateral_fit_error : float
        Largest relative errors of the Prony fits (vertical diaphragm; lateral element).
    seconds_per_realization : float
    per_seed_band_ms : ndarray (n_seeds, n_points, 3, n_bands)
    rig : TableRig
    """

    bands: Bands
    point_names: tuple
    velocity_rms_m_s: np.ndarray
    velocity_rms_se_m_s: np.ndarray
    floor_velocity_rms_m_s: np.ndarray
    stroke_rms_m: np.ndarray
    stroke_rms_se_m: np.ndarray
    horizontal_stroke_rms_m: np.ndarray
    tube_velocity_rms_m_s: np.ndarray
    tube_velocity_rms_se_m_s: np.ndarray
    stroke_kurtosis: np.ndarray
    tube_velocity_kurtosis: np.ndarray
    seeds: tuple
    duration_s: float
    warmup_s: float
    transient_left: float
    time_step_s: float
    flow: str
    diaphragm: str
    amplitudes: str
    floor_names: tuple
    diaphragm_amplitude_m: Any
    diaphragm_fit_error: float
    lateral_fit_error: float
    seconds_per_realization: float
    per_seed_band_ms: np.ndarray = field(repr=False)
    rig: Any = field(repr=False, default=None)

    def _summary_items(self) -> list[tuple[str, str]]:
        se = np.nanmax(self.standard_error_db()) if len(self.seeds) > 1 else float("nan")
        lo = self.stroke_rms_m
        return [
            ("seeds", f"{len(self.seeds)} x {self.duration_s:g} s"),
            ("dt", f"{self.time_step_s * 1e3:.3g} ms"),
            ("isolators", str(len(self.stroke_rms_m))),
            ("points", str(len(self.point_names))),
            ("bands", f"{len(self.bands)} ({self.bands.labels[0]}-{self.bands.labels[-1]} Hz)"),
            ("stroke RMS", f"{np.min(lo) * 1e6:.3g}-{np.max(lo) * 1e6:.3g} um"),
            ("max se", f"{se:.3f} dB"),
            ("models", f"{self.flow} flow, {self.diaphragm} diaphragm"),
        ]

    def standard_error_db(self) -> np.ndarray:
        """Standard error of the band RMS in dB, shape ``(n_points, 3, n_bands)``."""
        return 20.0 * np.log10(1.0 + self.velocity_rms_se_m_s / self.velocity_rms_m_s)

    def error_db(self, closure_velocity_rms_m_s, closure_bands: Bands | None = None):
        """``20 log10(closure / Monte Carlo)`` per point, axis and band.

        Parameters
        ----------
        closure_velocity_rms_m_s : array_like (n_points, 3, n_closure_bands)
            The frequency-domain band RMS in the same point and axis order.
        closure_bands : Bands, optional
            Its bands, if they are not this result's (they must include them).

        Returns
        -------
        ndarray (n_points, 3, n_bands)
        """
        v = np.asarray(closure_velocity_rms_m_s, dtype=float)
        if closure_bands is not None:
            pos = {int(b): i for i, b in enumerate(closure_bands.index)}
            try:
                idx = np.array([pos[int(b)] for b in self.bands.index])
            except KeyError:
                raise InputError("closure_bands: they do not include the Monte Carlo bands") \
                    from None
            v = v[..., idx]
        if v.shape != self.velocity_rms_m_s.shape:
            raise InputError(f"closure_velocity_rms_m_s: expected shape "
                             f"{self.velocity_rms_m_s.shape}, got {v.shape}")  # fmt: skip
        return 20.0 * np.log10(v / self.velocity_rms_m_s)

    def to_frame(self):
        """One row per point, axis and band: floor and point band RMS, standard error (SI)."""
        import pandas as pd

        bf = self.bands.to_frame()
        rows = []
        for ip, name in enumerate(self.point_names):
            for ia, ax in enumerate(AXES):
                df = bf.copy()
                df.insert(0, "axis", ax)
                df.insert(0, "point", name)
                df["floor_velocity_rms_m_s"] = self.floor_velocity_rms_m_s[ia]
                df["velocity_rms_m_s"] = self.velocity_rms_m_s[ip, ia]
                df["velocity_rms_se_m_s"] = self.velocity_rms_se_m_s[ip, ia]
                rows.append(df)
        out = pd.concat(rows, ignore_index=True)
        out.attrs.update(
            seeds=list(self.seeds), duration_s=self.duration_s, time_step_s=self.time_step_s,
            stroke_rms_m=self.stroke_rms_m.tolist(),
            stroke_rms_se_m=self.stroke_rms_se_m.tolist(),
            tube_velocity_rms_m_s=self.tube_velocity_rms_m_s.tolist(),
            flow=self.flow, diaphragm=self.diaphragm, amplitudes=self.amplitudes,
            floor=list(self.floor_names),
        )  # fmt: skip
        return out

    def isolator_frame(self):
        """One row per isolator: stroke, horizontal deflection and tube velocity RMS (SI)."""
        import pandas as pd

        return pd.DataFrame({
            "isolator": np.arange(1, len(self.stroke_rms_m) + 1),
            "stroke_rms_m": self.stroke_rms_m,
            "stroke_rms_se_m": self.stroke_rms_se_m,
            "horizontal_x_rms_m": self.horizontal_stroke_rms_m[:, 0],
            "horizontal_y_rms_m": self.horizontal_stroke_rms_m[:, 1],
            "tube_velocity_rms_m_s": self.tube_velocity_rms_m_s,
            "tube_velocity_rms_se_m_s": self.tube_velocity_rms_se_m_s,
            "tube_velocity_kurtosis": self.tube_velocity_kurtosis,
        })  # fmt: skip

    def plot(self, ax=None, *, point: int = 0):
        """Band RMS velocity of one instrument point in x, y and z, with the floor.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw into this axes; default a new figure.
        point : int
            Index of the instrument point.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.style import FLOOR, band_axis, new_figure

        if ax is None:
            fig = new_figure(6.4, 3.8)
            ax = fig.add_subplot(1, 1, 1)
        c = np.asarray(self.bands.centre_hz, float)
        styles = {"x": ("C0", "-"), "y": ("C2", "--"), "z": ("C3", "-.")}
        for ia, axis in enumerate(AXES):
            col, ls = styles[axis]
            ax.plot(c, self.floor_velocity_rms_m_s[ia], **{**FLOOR, "ls": ls, "ms": 2.5},
                    label=f"floor {axis}")
            v = self.velocity_rms_m_s[point, ia]
            ax.errorbar(c, v, yerr=self.velocity_rms_se_m_s[point, ia], color=col, ls=ls,
                        marker="s", ms=3, lw=1.5, label=f"{self.point_names[point]} {axis}")
        ax.set_yscale("log")
        band_axis(ax, self.bands)
        ax.set_ylabel("band RMS velocity (m/s)")
        ax.set_title(f"Monte Carlo, {len(self.seeds)} seeds x {self.duration_s:g} s",
                     fontsize=10)  # fmt: skip
        ax.legend(fontsize=7, ncol=2)
        return ax.figure


# ---------------------------------------------------------------------------
# the simulation
# ---------------------------------------------------------------------------
def _floors(floor) -> tuple:
    """Three floors (x, y, z; ``None``: no motion) from one floor, a mapping or a sequence.

    A :class:`~isodesign.table.floor.TableFloor` gives its own three spectra.
    """
    if hasattr(floor, "spectra") and hasattr(floor, "names"):  # a TableFloor
        out = tuple(floor.spectra)
    elif isinstance(floor, dict):
        missing = [a for a in AXES if a not in floor]
        if missing:
            raise InputError(f"floor: the axes {', '.join(missing)} are missing "
                             "(give x, y and z)")  # fmt: skip
        out = tuple(None if floor[a] is None else resolve_floor(floor[a]) for a in AXES)
    elif isinstance(floor, tuple | list):
        if len(floor) != 3:
            raise InputError(f"floor: expected 3 floors (x, y, z), got {len(floor)}")
        out = tuple(None if f is None else resolve_floor(f) for f in floor)
    else:
        f = resolve_floor(floor)
        out = (f, f, f)
    if all(f is None for f in out):
        raise InputError("floor: no axis has a floor spectrum")
    return out


def _pack(rig: TableRig, flow: str, k_dia: list, rate_hz: float):
    """Per-isolator parameter rows, Womersley modes, diaphragm and lateral branches, offsets."""
    n = rig.isolators
    rows, gains, rates = [], [], []
    for i in range(n):
        p, g, r = _parameters(rig.designs[i], flow, rig.loads_n[i] / 9.80665, k_dia[i][0],
                              rate_hz)  # fmt: skip
        rows.append(p)
        gains.append(g)
        rates.append(r)

    def pad(seqs):
        m = max([len(s) for s in seqs] + [1])
        out = np.zeros((n, m))
        for i, s in enumerate(seqs):
            out[i, : len(s)] = s
        return out

    n_modes = np.array([len(g) for g in gains], dtype=np.int64)
    n_br = np.array([len(k[1]) for k in k_dia], dtype=np.int64)
    lat = rig.lateral
    n_hb = np.array([len(x.branch_stiffness_n_per_m) for x in lat], dtype=np.int64)
    n_tube = n_modes if flow == "womersley" else np.full(n, 1 if flow == "quasi_steady" else 0)
    off = np.zeros(n, dtype=np.int64)
    hoff = np.zeros(n, dtype=np.int64)
    pos = 12
    for i in range(n):
        off[i] = pos
        pos += 3 + int(n_tube[i]) + int(n_br[i])
        hoff[i] = pos
        pos += 2 * int(n_hb[i])
    kh0 = np.array([rig.pendulum_n_per_m[i] + lat[i].k_inf_n_per_m for i in range(n)])
    return {
        "P": np.ascontiguousarray(np.array(rows)),
        "n_modes": n_modes, "mode_gain": pad(gains), "mode_rate": pad(rates),
        "n_branch": n_br, "br_k": pad([k[1] for k in k_dia]),
        "br_rate": pad([k[2] for k in k_dia]),
        "kh0": kh0, "n_hb": n_hb,
        "hk": pad([x.branch_stiffness_n_per_m for x in lat]),
        "hrate": pad([x.branch_rate_1_per_s for x in lat]),
        "off": off, "hoff": hoff, "n_states": pos,
    }  # fmt: skip


def _packed(ctx, dia_amp):
    """The kernel's arrays for one diaphragm amplitude per isolator (and the fit errors)."""
    rig = ctx["rig"]
    k_dia = [_diaphragm_branches(ctx["dia"], None if dia_amp is None else dia_amp[i],
                                 ctx["f_fit"]) for i in range(rig.isolators)]  # fmt: skip
    return _pack(rig, ctx["flow"], k_dia, 1.0 / ctx["dt"]), k_dia


def _slowest_decay_rate(ctx, dia_amp) -> float:
    """Slowest decay rate (1/s) of the table's linearized equations about the static state.

    The Jacobian of the compiled right-hand side by central differences (steps sized per
    kind of state), its eigenvalues ``lambda``; the slowest ``-Re lambda`` over the modes
    with ``|lambda| > 1e-3 1/s`` (the gas's neutral energy mode excluded). A mode with
    ``Re lambda > 0`` means the table is unstable (``SolverError``).
    """
    from isodesign.simulation import _table_kernel as kern

    rig = ctx["rig"]
    pk, _ = _packed(ctx, dia_amp)
    n = pk["n_states"]
    step = np.full(n, 1e-9)  # body (m, rad, m/s, rad/s), tube velocities, Womersley modes
    for i in range(rig.isolators):
        o = int(pk["off"][i])
        step[o:o + 2] = 1e-3  # chamber pressures, Pa
        step[o + 2] = 1e-12  # top chamber's gas mass, kg
        n_tube = {"quasi_steady": 1, "poiseuille": 0}.get(ctx["flow"], int(pk["n_modes"][i]))
        step[o + 3 + n_tube:int(pk["hoff"][i])] = 1e-6  # diaphragm branch forces, N
        step[int(pk["hoff"][i]):int(pk["hoff"][i]) + 2 * int(pk["n_hb"][i])] = 1e-6
    jac = np.empty((n, n))
    args = (np.linalg.inv(rig.mass_matrix), np.ascontiguousarray(rig.gravity_n_per_m),
            pk["P"], _FLOW_CODE[ctx["flow"]], pk["n_modes"], pk["mode_gain"], pk["mode_rate"],
            pk["n_branch"], pk["br_k"], pk["br_rate"], np.ascontiguousarray(rig.r_vertical_m),
            np.ascontiguousarray(rig.r_horizontal_m), pk["kh0"], pk["n_hb"], pk["hk"],
            pk["hrate"], pk["off"], pk["hoff"], np.zeros(rig.isolators), np.zeros(6))
    for j in range(n):
        yp, ym, fp, fm = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
        yp[j], ym[j] = step[j], -step[j]
        kern._table_rhs(yp, fp, 0.0, 0.0, 0.0, *args)
        kern._table_rhs(ym, fm, 0.0, 0.0, 0.0, *args)
        jac[:, j] = (fp - fm) / (2.0 * step[j])
    lam = np.linalg.eigvals(jac)
    lam = lam[np.abs(lam) > 1e-3]
    if np.any(lam.real > 1e-6 * np.abs(lam)):
        worst = lam[int(np.argmax(lam.real))]
        raise SolverError(
            f"Monte Carlo: the linearized table is unstable (eigenvalue {worst:.4g} 1/s): "
            "check the rocking stability with the gravity term (isodesign modes)"
        )
    return float(np.min(-lam.real))


def _run(ctx, seed: int, dia_amp):
    """One realization: band mean squares (points, axes, bands), floor ms, records, seconds."""
    from isodesign.simulation import _table_kernel as kern

    t0 = time.perf_counter()
    rig, n, n_skip = ctx["rig"], ctx["n"], ctx["n_skip"]
    pk, k_dia = _packed(ctx, dia_amp)
    fastest = float(max(np.max(pk["br_rate"]), np.max(pk["hrate"])))
    if fastest * ctx["dt"] > _MAX_RATE_STEP:
        raise InputError(
            f"time_step_s: {ctx['dt']:.4g} s is too long for the fastest relaxation rate of "
            f"the Prony elements, {fastest:.4g} 1/s (RK4 needs rate x step <= "
            f"{_MAX_RATE_STEP:g}); use at most {_MAX_RATE_STEP / fastest:.3g} s"
        )
    rng = np.random.default_rng(seed)
    halves, vels = [], []
    for ia, fl in enumerate(ctx["floors"]):  # x, y, z: interleaved bins, one stream
        if fl is None:  # no motion in this axis
            halves.append(np.zeros(2 * (n_skip + n - 1) + 1))
            vels.append(np.zeros(n))
            continue
        a_half, vel = _floor_half_steps(fl, {**ctx, "norm_bands": _norm_bands(
            fl, ctx["amplitudes"])}, rng, 3, ia)  # fmt: skip
        halves.append(a_half)
        vels.append(vel)
    a_half = np.ascontiguousarray(np.array(halves))
    y0 = np.zeros(pk["n_states"])
    rec_q, rec_qd = np.empty((n, 6)), np.empty((n, 6))
    rec_u = np.empty((n, rig.isolators))
    minv = np.linalg.inv(rig.mass_matrix)
    kern.integrate_table(
        y0, a_half, ctx["dt"], n_skip, minv, np.ascontiguousarray(rig.gravity_n_per_m),
        pk["P"], _FLOW_CODE[ctx["flow"]], pk["n_modes"], pk["mode_gain"], pk["mode_rate"],
        pk["n_branch"], pk["br_k"], pk["br_rate"], np.ascontiguousarray(rig.r_vertical_m),
        np.ascontiguousarray(rig.r_horizontal_m), pk["kh0"], pk["n_hb"], pk["hk"],
        pk["hrate"], pk["off"], pk["hoff"], rec_q, rec_qd, rec_u,
    )
    if not (np.all(np.isfinite(rec_q)) and np.all(np.isfinite(rec_u))):
        raise SolverError(
            f"Monte Carlo: the table's integration diverged (seed {seed}, dt = "
            f"{ctx['dt']:.3g} s); reduce time_step_s, or check the rocking stability"
        )
    bands, dur = ctx["bands"], ctx["duration"]
    ms = np.empty((len(rig.points_m), 3, len(bands)))
    for ip, r in enumerate(rig.points_m):
        v_rel = rec_qd @ point_matrix(r).T  # (n, 3)
        for ia in range(3):
            ms[ip, ia] = _band_mean_square(v_rel[:, ia] + vels[ia], dur, bands)
    ms_floor = np.array([_band_mean_square(v, dur, bands) for v in vels])
    strokes = np.array([rec_q @ point_matrix(r)[2] for r in rig.r_vertical_m])  # (n_iso, n)
    horiz = np.array([rec_q @ point_matrix(r)[:2].T for r in rig.r_horizontal_m])
    fit_err = max([k[3] for k in k_dia] + [0.0])
    return ms, ms_floor, strokes, rec_u.T.copy(), horiz, time.perf_counter() - t0, fit_err


def simulate_table_response(
    design,
    table,
    floor,
    *,
    target=None,
    bands=None,
    seeds=4,
    duration_s: float = 320.0,
    warmup_s: float | None = None,
    time_step_s: float | None = None,
    flow: str = "quasi_steady",
    diaphragm="viscoelastic",
    diaphragm_amplitude_m=None,
    amplitudes: str = "random_phase",
) -> TableMonteCarloResult:
    """Monte Carlo simulation of the rigid table on its isolators under a three-axis floor.

    Parameters
    ----------
    design : SpringDesign or None
        The isolators' spring (each gets its own p0 from the leveling); ``None`` when
        ``table`` is a :class:`TableRig` (which carries its designs).
    table : Table or TableRig
        The table model (:class:`~isodesign.table.Table`, realized by :func:`table_rig`) or
        a realization.
    floor : FloorSpectrum, str, path, TableFloor, or mapping/sequence of three
        One floor for x, y and z (independent realizations), or one per axis (a
        :class:`~isodesign.table.floor.TableFloor`, ``{"x": ..., "y": ..., "z": ...}`` or
        ``(fx, fy, fz)``; ``None`` for an axis without motion).
    target : str or CriterionCurve, optional
        Only to choose the default bands.
    bands : Bands, optional
        Default: the target's bands inside the vertical floor's range.
    seeds : int or sequence of int
    duration_s : float
        Analysed period of each realization, s.
    warmup_s : float, optional
        Simulated time before the record, s. Default: ``max(20 s, 14 / lambda_min)`` with
        ``lambda_min`` the slowest decay rate of the linearized table (eigenvalues of its
        Jacobian about the static state), at most ``5 duration_s``: the start-up transient
        of a lightly damped horizontal, yaw or rocking mode must have decayed to ``e^-14`` before
        the record, or its leakage spreads over every band (it would dominate bands where
        the response is 80-90 dB below the floor). The transient left, ``exp(-lambda_min
        warmup)``, is reported.
    time_step_s : float, optional
        RK4 step; default ``1/2048`` s (``1/8192`` s for ``womersley``).
    flow : {'quasi_steady', 'poiseuille', 'womersley'}
    diaphragm : str or model
        The vertical diaphragm of every isolator: ``none``, a :class:`PronyDiaphragm`
        (integrated as it is), or a describing-function model frozen per isolator at
        ``1.880 sigma_i`` of its own stroke RMS from a pilot run (or at
        ``diaphragm_amplitude_m``).
    diaphragm_amplitude_m : float or array_like (n_isolators,), optional
    amplitudes : {'random_phase', 'gaussian'}

    Returns
    -------
    TableMonteCarloResult
    """
    check_choice("flow", flow, MONTE_CARLO_FLOW_MODELS)
    check_choice("amplitudes", amplitudes, _AMPLITUDES)
    rig = table if isinstance(table, TableRig) else table_rig(design, table)
    seed_list = _check_seeds(seeds)
    floors = _floors(floor)
    given = [f for f in floors if f is not None]
    tg = None if target is None else resolve_target(target)
    b = default_bands(floors[2] or given[0], tg) if bands is None else bands
    duration, warm, n, dt = _timing(duration_s, 0.0 if warmup_s is None else warmup_s,
                                    time_step_s, b, max(f.f_max_hz for f in given),
                                    flow)  # fmt: skip
    if duration * float(np.min(b.upper_hz - b.lower_hz)) < 12.0:
        raise InputError(
            f"duration_s: {duration:g} s leaves fewer than 4 frequency bins per axis in the "
            f"narrowest band ({b.labels[0]} Hz; the three axes take every third bin); use a "
            "longer record"
        )
    dia = diaphragm_model(diaphragm)
    ctx = {
        "rig": rig, "flow": flow, "floors": floors, "duration": duration,
        "amplitudes": amplitudes, "bands": b, "n": n, "n_skip": round(warm / dt), "dt": dt,
        "dia": dia,
        "f_fit": np.geomspace(min(f.f_min_hz for f in given),
                              max(f.f_max_hz for f in given), 60),
    }  # fmt: skip
    lin_amp = None if isinstance(dia, NoDiaphragm | PronyDiaphragm) else np.full(
        rig.isolators, LINEAR_REFERENCE_AMPLITUDE_M)  # fmt: skip
    decay = _slowest_decay_rate(ctx, lin_amp)
    if warmup_s is None:
        warm = min(max(_MIN_WARMUP_S, _WARMUP_DECAYS / decay), _MAX_WARMUP_PERIODS * duration)
        ctx["n_skip"] = round(warm / dt)
    dia_amp = None
    if lin_amp is not None:
        if diaphragm_amplitude_m is not None:
            a = np.broadcast_to(np.asarray(diaphragm_amplitude_m, dtype=float),
                                (rig.isolators,))  # fmt: skip
            if not np.all(np.isfinite(a) & (a > 0)):
                raise InputError("diaphragm_amplitude_m: must be > 0 m")
            dia_amp = a.copy()
        else:  # pilot run of the first seed at the linear-regime amplitude
            pilot = _run(ctx, seed_list[0], lin_amp)
            dia_amp = EQUIVALENT_AMPLITUDE_FACTOR * np.sqrt(np.mean(pilot[2] ** 2, axis=1))
    runs = [_run(ctx, s, dia_amp) for s in seed_list]
    ms = np.array([r[0] for r in runs])
    v_rms, v_se = _rms_se(ms)
    z_rms, z_se = _rms_se([np.mean(r[2] ** 2, axis=1) for r in runs])
    u_rms, u_se = _rms_se([np.mean(r[3] ** 2, axis=1) for r in runs])
    h_rms, _ = _rms_se([np.mean(r[4] ** 2, axis=1) for r in runs])
    z_all = np.concatenate([r[2] for r in runs], axis=1)
    u_all = np.concatenate([r[3] for r in runs], axis=1)
    return TableMonteCarloResult(
        bands=b,
        point_names=rig.point_names,
        velocity_rms_m_s=v_rms,
        velocity_rms_se_m_s=v_se,
        floor_velocity_rms_m_s=np.sqrt(np.mean([r[1] for r in runs], axis=0)),
        stroke_rms_m=z_rms,
        stroke_rms_se_m=z_se,
        horizontal_stroke_rms_m=h_rms,
        tube_velocity_rms_m_s=u_rms,
        tube_velocity_rms_se_m_s=u_se,
        stroke_kurtosis=np.array([_kurtosis(z) for z in z_all]),
        tube_velocity_kurtosis=np.array([_kurtosis(u) for u in u_all]),
        seeds=seed_list,
        duration_s=duration,
        warmup_s=warm,
        transient_left=float(math.exp(-decay * warm)),
        time_step_s=dt,
        flow=flow,
        diaphragm=dia.name,
        amplitudes=amplitudes,
        floor_names=tuple("none" if f is None else f.name for f in floors),
        diaphragm_amplitude_m=dia_amp,
        diaphragm_fit_error=float(max(r[6] for r in runs)),
        lateral_fit_error=float(rig.lateral_fit_error),
        seconds_per_realization=float(np.mean([r[5] for r in runs])),
        per_seed_band_ms=ms,
        rig=rig,
    )


def table_rig(design, table, *, frequency_hz=None) -> TableRig:
    """The :class:`TableRig` of a :class:`~isodesign.table.Table` on ``design``'s isolators.

    Leveling (:func:`isodesign.table.statics.level`) gives each isolator its load and p0;
    the horizontal element's pendulum is ``W_i / L_p``; its lateral stiffness is taken as it
    is when it is a :class:`PronyDiaphragm`, otherwise fitted as one over ``frequency_hz``
    (:func:`lateral_prony`; the fit error is kept in ``lateral_fit_error``).

    Parameters
    ----------
    design : SpringDesign
        The (identical) isolators' spring; its p0 is replaced by each isolator's.
    table : Table
    frequency_hz : array_like, optional
        Frequencies of the lateral fit; default 60 points from 0.89 to 89.1 Hz (the
        one-third-octave bands 1-80 Hz).

    Returns
    -------
    TableRig
    """
    from isodesign.table.layout import Table
    from isodesign.table.statics import level

    if not isinstance(table, Table):
        raise InputError(f"table: expected an isodesign Table or a TableRig, got "
                         f"{type(table).__name__}")  # fmt: skip
    lev = level(table, design.piston_area_m2)
    hz = table.horizontal
    f_fit = np.geomspace(0.89, 89.1, 60) if frequency_hz is None else frequency_hz
    lateral = hz.lateral_model if hz.lateral_model is not None else (
        hz.lateral_stiffness_n_per_m, hz.lateral_loss_factor)
    lat, err = lateral_prony(lateral, f_fit)
    n = table.n_isolators
    return TableRig(
        mass_kg=table.mass_kg,
        inertia_kg_m2=table.inertia_kg_m2,
        designs=lev.designs(design),
        loads_n=lev.load_n,
        r_vertical_m=table.vertical_points_m,
        r_horizontal_m=table.horizontal_points_m,
        pendulum_n_per_m=np.broadcast_to(hz.pendulum_stiffness(lev.load_n), (n,)),
        lateral=(lat,) * n,
        points_m=table.instrument_points_from_cg_m,
        gravity_n_per_m=gravity_stiffness(table, lev.load_n),
        point_names=table.point_names,
        lateral_fit_error=err,
    )
