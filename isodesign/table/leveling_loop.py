"""The leveling loop, analysed with python-control (docs/table.md, section 12).

The valves close the loop ``u = -G y`` (mass flows from the sensor heights) around the
plant of :func:`~isodesign.table.leveling.leveling_plant`. This module gives:

* per valve ``g``: the loop broken at that valve with the other two closed,
  ``L_g(s) = G C_g (s I - A_o)^-1 B_g`` with ``A_o = A - G B_o C_o``: gain, phase and delay
  margins (``control.stability_margins``), Bode and Nyquist plots;
* the 3x3 MIMO loop: the closed-loop poles ``eig(A - G B C)`` and the critical gain
  ``G_c`` where a pole pair crosses the imaginary axis (every valve's gain scaled together):
  the onset of the leveling oscillation and its frequency;
* the load step (a mass placed on the table): settling time, overshoot, residual tilt
  (:func:`load_step`);
* the valve's describing function (dead band, linear region, saturation) and the limit
  cycle it predicts (:func:`limit_cycle`);
* the low-frequency transmissibility with the valves (:func:`leveling_transmissibility`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_instance, check_positive, check_range
from isodesign.results import ResultDisplay
from isodesign.spring.design import SpringDesign
from isodesign.table.leveling import (
    LevelingPlant,
    LevelingSystem,
    check_model_and_system,
    leveling_plant,
)
from isodesign.table.model import TableModel

__all__ = [
    "LevelingLoop",
    "LimitCycle",
    "LoadStep",
    "describing_function",
    "leveling_loop",
    "leveling_transmissibility",
    "limit_cycle",
    "load_step",
    "max_valve_gain",
    "study_valves",
]

#: Closed-loop poles with a real part above this (1/s) count as unstable.
_STABILITY_TOL = 1e-9


def _valve_loop(plant: LevelingPlant, g: int, gain: float):
    """``(A_o, B_g, C_g)`` of the loop broken at valve ``g`` (the other two closed)."""
    others = [k for k in range(3) if k != g]
    a_o = plant.a - gain * plant.b[:, others] @ plant.c[others]
    return a_o, plant.b[:, [g]], gain * plant.c[[g]]


def critical_gain(plant: LevelingPlant) -> tuple[float, float]:
    """``(G_c, f_c)``: the gain of every valve where the closed loop loses stability, and the
    frequency of the pole pair that crosses (Hz); ``(inf, nan)`` if none up to 1e6 G.

    Parameters
    ----------
    plant : LevelingPlant
    """
    g0 = plant.system.gain_kg_s_per_m

    def worst(k):
        ev = np.linalg.eigvals(plant.closed_loop(k))
        i = int(np.argmax(ev.real))
        return ev[i].real, ev[i]

    lo, hi = g0 * 1e-4, g0
    if worst(lo)[0] > _STABILITY_TOL:
        return 0.0, float("nan")
    while worst(hi)[0] <= _STABILITY_TOL:
        lo, hi = hi, hi * 4.0
        if hi > 1e6 * g0:
            return float("inf"), float("nan")
    for _ in range(80):
        mid = math.sqrt(lo * hi)
        if worst(mid)[0] > _STABILITY_TOL:
            hi = mid
        else:
            lo = mid
        if hi / lo < 1 + 1e-10:
            break
    return hi, abs(worst(hi)[1].imag) / (2 * math.pi)


@dataclass(frozen=True, eq=False, repr=False)
class LevelingLoop(ResultDisplay):
    """Margins, poles and critical gain of the leveling loop.

    Attributes
    ----------
    plant : LevelingPlant
    gain_kg_s_per_m : float
    gain_margin_db, phase_margin_deg, delay_margin_s : ndarray (3,)
        Per valve (the others closed); ``inf`` where the loop never crosses.
    gain_crossover_hz, phase_crossover_hz : ndarray (3,)
    closed_loop_poles : ndarray complex
        Of the 3x3 loop closed by ``control.feedback`` (``eig(A - G B C)``).
    stable : bool
        Every closed-loop pole has ``Re < 0`` (the gas masses' three integrators included).
    critical_gain_kg_s_per_m : float
        Every valve's gain at the onset of the leveling oscillation.
    oscillation_frequency_hz : float
        The frequency of the pole pair that crosses there.
    notes : tuple of str
        Diagnostics (a margin python-control found that the loop's own frequency response
        does not confirm).
    crossover_hz : float
        The slowest gain crossover (the loop's time scale, for the static verdict).
    """

    plant: LevelingPlant
    gain_kg_s_per_m: float
    gain_margin_db: np.ndarray
    phase_margin_deg: np.ndarray
    delay_margin_s: np.ndarray
    gain_crossover_hz: np.ndarray
    phase_crossover_hz: np.ndarray
    closed_loop_poles: np.ndarray
    stable: bool
    critical_gain_kg_s_per_m: float
    oscillation_frequency_hz: float
    notes: tuple = ()

    @property
    def crossover_hz(self) -> float:
        """The slowest finite gain crossover, Hz."""
        f = self.gain_crossover_hz[np.isfinite(self.gain_crossover_hz)]
        return float(f.min()) if f.size else float("nan")

    @property
    def mimo_gain_margin_db(self) -> float:
        """``20 log10(G_c / G)``: every valve's gain scaled together (``-inf``: the loop is
        unstable at the smallest gain, a statically unstable table)."""
        if not self.critical_gain_kg_s_per_m > 0:
            return float("-inf")
        return 20.0 * math.log10(self.critical_gain_kg_s_per_m / self.gain_kg_s_per_m)

    @property
    def worst_gain_margin_db(self) -> float:
        """The smallest gain margin, dB: the MIMO one (every valve's gain scaled together)
        and each valve's with the other two closed; negative for an unstable loop (the
        optimizer's ``leveling_gain_margin``)."""
        return float(min(self.mimo_gain_margin_db, float(np.min(self.gain_margin_db))))

    @property
    def worst_phase_margin_deg(self) -> float:
        """The smallest phase margin of the three valves' loops (the other two closed), deg
        (``inf`` when no loop crosses 0 dB; the optimizer's ``leveling_phase_margin``)."""
        return float(np.min(self.phase_margin_deg))

    def valve_loop(self, g: int):
        """Valve ``g``'s loop (the others closed) as a ``control.StateSpace``.

        Parameters
        ----------
        g : int
            Zero-based valve.
        """
        import control

        a, b, c = _valve_loop(self.plant, g, self.gain_kg_s_per_m)
        return control.ss(a, b, c, np.zeros((1, 1)))

    def to_frame(self):
        """One row per valve: margins and crossovers."""
        import pandas as pd

        return pd.DataFrame({"valve": [1, 2, 3], "gain_margin_db": self.gain_margin_db,
                             "phase_margin_deg": self.phase_margin_deg,
                             "delay_margin_s": self.delay_margin_s,
                             "gain_crossover_hz": self.gain_crossover_hz,
                             "phase_crossover_hz": self.phase_crossover_hz,
                             "critical_gain_kg_s_per_m": self.critical_gain_kg_s_per_m,
                             "oscillation_frequency_hz": self.oscillation_frequency_hz})

    def text(self) -> str:
        """Lines for the command line."""
        head = f"  leveling loop: valve gain {self.gain_kg_s_per_m:.4g} kg/s/m; closed loop "
        if not self.critical_gain_kg_s_per_m > 0:
            head += ("UNSTABLE from the smallest valve gain (the sealed table is statically "
                     "unstable: it tips)")
        elif math.isinf(self.critical_gain_kg_s_per_m):
            head += ("stable" if self.stable else "UNSTABLE") + " at every valve gain tried"
        else:
            head += (("stable" if self.stable else "UNSTABLE (leveling oscillation)")
                     + f"; onset at {self.critical_gain_kg_s_per_m:.4g} kg/s/m (MIMO gain "
                     f"margin {self.mimo_gain_margin_db:+.2f} dB), oscillating at "
                     f"{self.oscillation_frequency_hz:.3g} Hz")
        lines = [head]
        for g in range(3):
            lines.append(f"  valve {g + 1} (others closed): gain margin "
                         f"{self.gain_margin_db[g]:.3g} dB at {self.phase_crossover_hz[g]:.3g} Hz,"
                         f" phase margin {self.phase_margin_deg[g]:.3g} deg at "
                         f"{self.gain_crossover_hz[g]:.3g} Hz, delay margin "
                         f"{self.delay_margin_s[g]:.3g} s")
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("stable", str(self.stable)),
                ("critical gain", f"{self.critical_gain_kg_s_per_m:.4g} kg/s/m"),
                ("gain margins (dB)", ", ".join(f"{v:.3g}" for v in self.gain_margin_db)),
                ("phase margins (deg)", ", ".join(f"{v:.3g}" for v in self.phase_margin_deg))]

    def plot(self, ax=None, frequency_hz=None):
        """Bode (magnitude, phase) and Nyquist plots of the three valves' loops.

        Parameters
        ----------
        ax : sequence of 3 matplotlib Axes, optional
            Magnitude, phase, Nyquist; default a new figure.
        frequency_hz : ndarray, optional
            Default 1 mHz to 30 Hz.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.style import new_figure

        f = np.geomspace(1e-3, 30.0, 600) if frequency_hz is None else np.asarray(frequency_hz)
        if ax is None:
            fig = new_figure(11.0, 4.2)
            gs = fig.add_gridspec(2, 2)
            ax = [fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[1, 0]),
                  fig.add_subplot(gs[:, 1])]
        else:
            fig = ax[0].figure
        for g in range(3):
            lg = loop_response(self.plant, g, self.gain_kg_s_per_m, f)
            ax[0].loglog(f, np.abs(lg), label=f"valve {g + 1}")
            ax[1].semilogx(f, np.degrees(np.unwrap(np.angle(lg))))
            ax[2].plot(lg.real, lg.imag, label=f"valve {g + 1}")
        ax[0].axhline(1.0, color="0.5", lw=0.8)
        ax[0].set_ylabel("|L|")
        ax[0].legend(fontsize=8)
        ax[1].axhline(-180.0, color="0.5", lw=0.8)
        ax[1].set_ylabel("phase (deg)")
        ax[1].set_xlabel("frequency (Hz)")
        ax[2].plot([-1.0], [0.0], "r+", ms=12)
        ax[2].set_xlim(-3.0, 1.0)
        ax[2].set_ylim(-2.0, 2.0)
        ax[2].set_xlabel("Re L")
        ax[2].set_ylabel("Im L")
        ax[2].set_title("Nyquist (zoomed on -1)", fontsize=9)
        return fig


def loop_response(plant: LevelingPlant, g: int, gain: float, frequency_hz) -> np.ndarray:
    """``L_g(j w)`` of valve ``g``'s loop (the others closed), by complex solves.

    Parameters
    ----------
    plant : LevelingPlant
    g : int
        Zero-based valve.
    gain : float
        Every valve's gain, kg/s/m.
    frequency_hz : ndarray
    """
    a, b, c = _valve_loop(plant, g, gain)
    n = a.shape[0]
    out = []
    for f in np.atleast_1d(frequency_hz):
        x = np.linalg.solve(2j * math.pi * f * np.eye(n) - a, b[:, 0])
        out.append(c[0] @ x)
    return np.array(out)


def leveling_loop(model, system: LevelingSystem | None = None) -> LevelingLoop:
    """The leveling loop of a table: margins per valve, MIMO poles and critical gain.

    Parameters
    ----------
    model : TableModel
    system : LevelingSystem, optional

    Returns
    -------
    LevelingLoop
    """
    check_model_and_system(model, system)
    import control

    plant = leveling_plant(model, system)
    gain = plant.system.gain_kg_s_per_m
    gm, pm, dm, wg, wp = (np.full(3, np.inf) for _ in range(5))
    notes: list[str] = []
    for g in range(3):
        a, b, c = _valve_loop(plant, g, gain)
        sys = control.ss(a, b, c, np.zeros((1, 1)))
        with warnings.catch_warnings(), np.errstate(over="ignore", invalid="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)  # its polynomial far above
            m = control.stability_margins(sys)
        gm_, pm_, _, wpc, wgc, _ = m
        gm[g] = 20 * math.log10(gm_) if gm_ is not None and np.isfinite(gm_) and gm_ > 0 \
            else np.inf
        pm[g] = pm_ if np.isfinite(pm_) else np.inf
        wp[g] = wpc / (2 * math.pi) if np.isfinite(wpc) else np.nan
        wg[g] = wgc / (2 * math.pi) if np.isfinite(wgc) else np.nan
        dm[g] = math.radians(pm[g]) / wgc if np.isfinite(pm[g]) and np.isfinite(wgc) \
            and wgc > 0 else np.inf
        # python-control's polynomial method, checked on the loop's own frequency response
        if np.isfinite(wg[g]):
            err = abs(abs(loop_response(plant, g, gain, [wg[g]])[0]) - 1.0)
            if err > 1e-6:
                notes.append(f"valve {g + 1}: |L| = 1 +- {err:.2g} at the gain crossover "
                             "python-control found (margins inaccurate)")
    # the 3x3 MIMO loop closed by python-control: u = -G y around the plant
    closed = control.feedback(gain * plant.state_space(), np.eye(3))
    poles = np.asarray(closed.poles())
    g_c, f_c = critical_gain(plant)
    return LevelingLoop(plant=plant, gain_kg_s_per_m=gain, gain_margin_db=gm,
                        phase_margin_deg=pm, delay_margin_s=dm, gain_crossover_hz=wg,
                        phase_crossover_hz=wp, closed_loop_poles=poles,
                        stable=bool(np.max(poles.real) < _STABILITY_TOL),
                        critical_gain_kg_s_per_m=g_c, oscillation_frequency_hz=f_c,
                        notes=tuple(notes))


def max_valve_gain(model, system: LevelingSystem, gain_margin_db: float | None,
                   phase_margin_deg: float | None, *, lowest_fraction: float = 1e-3,
                   rtol: float = 1e-3) -> float | None:
    """The largest valve gain, at most the system's, whose loop meets both margin bounds.

    Lowering every valve's gain raises the MIMO gain margin ``20 log10(G_c / G)`` (``G_c``
    does not depend on ``G``) and, the valves' integrator dominating the slow crossover,
    the phase margins: the bounds hold below some gain, found by bisection in ``ln G``
    between ``lowest_fraction G`` and ``G`` (each step :func:`leveling_loop`, the margins
    :attr:`LevelingLoop.worst_gain_margin_db` and :attr:`~LevelingLoop.worst_phase_margin_deg`).

    Parameters
    ----------
    model : TableModel
    system : LevelingSystem
    gain_margin_db, phase_margin_deg : float or None
        The bounds (None: none).
    lowest_fraction : float
        The smallest gain tried, as a fraction of the system's.
    rtol : float
        Relative tolerance on the gain.

    Returns
    -------
    float or None
        The gain, kg/s/m (the system's own if it meets the bounds); None if even the
        smallest gain tried misses them.
    """
    check_instance("model", model, TableModel,
                   "a TableModel (isodesign.table.model.table_model(design, table))")
    check_instance("system", system, LevelingSystem,
                   "a LevelingSystem (leveling_of_study(study)) or None")
    if gain_margin_db is not None and gain_margin_db is not False:
        check_range("gain_margin_db", gain_margin_db, 0.0, None, unit="dB")
    if phase_margin_deg is not None and phase_margin_deg is not False:
        check_range("phase_margin_deg", phase_margin_deg, 0.0, None, unit="deg")
    def meets(g):
        lp = leveling_loop(model, system.replace(gain_kg_s_per_m=float(g)))
        return ((gain_margin_db is None or lp.worst_gain_margin_db >= gain_margin_db)
                and (phase_margin_deg is None or lp.worst_phase_margin_deg >= phase_margin_deg))

    hi = system.gain_kg_s_per_m
    if meets(hi):
        return hi
    lo = hi * lowest_fraction
    if not meets(lo):
        return None
    while hi / lo > 1.0 + rtol:
        mid = math.sqrt(lo * hi)
        if meets(mid):
            lo = mid
        else:
            hi = mid
    return lo


def study_valves(study, design) -> LevelingSystem:
    """The valves of a table study for a design of its springs.

    The study's ``[table.leveling]``; when it makes the valve gain a design variable
    (``gain_kg_s_per_m = {lower, upper}``), the largest gain within its bounds whose loop
    on the design's springs meets the study's margin bounds (:func:`max_valve_gain`; the
    lower bound when none does, the upper one without margin bounds). The gain enters
    nothing else the optimizer judges (the band response, the modes and the static verdict
    take the valves closed or off), so the choice is the optimizer's and every entry point
    that analyses the loop of a design (``isodesign stability``) makes the same one.

    Parameters
    ----------
    study : Study
        With a ``[table]``.
    design : SpringDesign

    Returns
    -------
    LevelingSystem
    """
    if not (hasattr(study, "raw") and hasattr(study, "table")):
        raise InputError(f"study: expected a Study (load_study(path)), got "
                         f"{type(study).__name__} {study!r:.40}")
    check_instance("design", design, SpringDesign, "a SpringDesign (study.start_design())")
    from isodesign.table.leveling import (
        leveling_margin_bounds,
        leveling_of_study,
        valve_gain_bounds,
    )
    from isodesign.table.model import study_table_model

    system = leveling_of_study(study)
    bounds = valve_gain_bounds(study)
    if bounds is None:
        return system
    lo, hi = bounds
    gm, pm = leveling_margin_bounds(study)
    if gm is None and pm is None:
        return system.replace(gain_kg_s_per_m=hi)
    model = study_table_model(study, design)
    g = max_valve_gain(model, system.replace(gain_kg_s_per_m=hi), gm, pm,
                       lowest_fraction=lo / hi)
    return system.replace(gain_kg_s_per_m=lo if g is None else g)


# ---------------------------------------------------------------------------
# load step
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class LoadStep(ResultDisplay):
    """The table's answer to a mass placed on it, with the valves leveling.

    Attributes
    ----------
    time_s : ndarray
    heights_m : ndarray (n_t, 3)
        The sensors' heights.
    peak_deviation_m : float
        The largest ``|height|`` of any sensor.
    settling_time_s : float
        When every sensor stays within ``settling_fraction`` of the peak deviation.
    overshoot_percent : float
        The largest excursion past the reference (opposite to the first sag) per peak
        deviation.
    residual_tilt_rad : float
        ``|(rx, ry)|`` at the end (zero for the linear loop; within the dead band's for the
        valves).
    settling_fraction : float
    """

    time_s: np.ndarray
    heights_m: np.ndarray
    peak_deviation_m: float
    settling_time_s: float
    overshoot_percent: float
    residual_tilt_rad: float
    settling_fraction: float

    def to_frame(self):
        """The sensors' heights against time (metrics in ``attrs``)."""
        import pandas as pd

        df = pd.DataFrame({"time_s": self.time_s} | {f"height_{g + 1}_m": self.heights_m[:, g]
                                                      for g in range(3)})
        df.attrs.update(peak_deviation_m=self.peak_deviation_m,
                        settling_time_s=self.settling_time_s,
                        overshoot_percent=self.overshoot_percent,
                        residual_tilt_rad=self.residual_tilt_rad)
        return df

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("peak deviation", f"{self.peak_deviation_m * 1e6:.4g} um"),
                ("settling time", f"{self.settling_time_s:.3g} s"),
                ("overshoot", f"{self.overshoot_percent:.3g} %"),
                ("residual tilt", f"{self.residual_tilt_rad * 1e6:.3g} urad")]


def step_load(table, mass_kg: float, position_m) -> np.ndarray:
    """The force and moment about the CG of a mass placed at ``position_m`` (x, y, z), N.

    Parameters
    ----------
    table : Table
    mass_kg : float
    position_m : sequence of 3 float
        Where it is placed, in the table frame, m.
    """
    r = np.asarray(position_m, dtype=float) - np.asarray(table.cg_m)
    f = np.array([0.0, 0.0, -float(mass_kg) * table.g_m_s2])
    return np.concatenate([f, np.cross(r, f)])


def step_metrics(time_s, heights_m, body, settling_fraction: float = 0.05) -> tuple:
    """``(peak, settling time, overshoot %, residual tilt)`` of a load-step response.

    Parameters
    ----------
    time_s : ndarray
    heights_m : ndarray (n_t, 3)
    body : ndarray (n_t, 6)
    settling_fraction : float
    """
    h = np.asarray(heights_m)
    k = int(np.argmax(np.max(np.abs(h), axis=1)))
    g = int(np.argmax(np.abs(h[k])))
    peak = float(abs(h[k, g]))
    sign = math.copysign(1.0, h[k, g])
    out = np.flatnonzero(np.max(np.abs(h), axis=1) > settling_fraction * peak)
    t_s = float(time_s[out[-1] + 1]) if out.size and out[-1] + 1 < len(time_s) else \
        float(time_s[-1]) if out.size else 0.0
    over = float(max(0.0, np.max(-sign * h[k:, g]))) / peak * 100.0
    tilt = float(np.hypot(body[-1, 3], body[-1, 4]))
    return peak, t_s, over, tilt


def load_step(loop: LevelingLoop, mass_kg: float, position_m, duration_s: float = 30.0, *,
              settling_fraction: float = 0.05, samples: int = 3000) -> LoadStep:
    """The linear closed loop's answer to a mass placed on the table (python-control).

    Parameters
    ----------
    loop : LevelingLoop
    mass_kg : float
        The mass, kg (> 0).
    position_m : sequence of 3 float
        Where it is placed, m.
    duration_s : float
    settling_fraction : float
        Settling band as a fraction of the peak deviation.
    samples : int

    Returns
    -------
    LoadStep
    """
    check_instance("loop", loop, LevelingLoop,
                   "a LevelingLoop (leveling_loop(model, system))")
    check_positive("mass_kg", mass_kg, unit="kg")
    check_positive("duration_s", duration_s, unit="s")
    pos = (np.asarray(position_m, dtype=float)
           if isinstance(position_m, list | tuple | np.ndarray)
           and all(isinstance(v, int | float | np.number) and not isinstance(v, bool)
                   for v in np.ravel(np.asarray(position_m, dtype=object))) else None)
    if pos is None or pos.shape != (3,) or not np.all(np.isfinite(pos)):
        raise InputError(f"position_m: expected (x, y, z), three finite numbers in m (the "
                         f"table frame), got {position_m!r:.60}")
    import control

    if not mass_kg > 0:
        raise InputError(f"mass_kg: must be > 0, got {mass_kg!r}")
    plant = loop.plant
    f = step_load(plant.model.table, mass_kg, position_m)
    a = plant.closed_loop(loop.gain_kg_s_per_m)
    c = np.concatenate([plant.c, np.eye(plant.n_states)[3:5]])
    sys = control.ss(a, (plant.e @ f)[:, None], c, np.zeros((5, 1)))
    t = np.linspace(0.0, float(duration_s), int(samples))
    resp = control.step_response(sys, T=t)
    y = np.asarray(resp.outputs).reshape(5, -1).T
    body = np.zeros((len(t), 6))
    body[:, 3:5] = y[:, 3:5]
    peak, t_s, over, tilt = step_metrics(t, y[:, :3], body, settling_fraction)
    return LoadStep(time_s=t, heights_m=y[:, :3], peak_deviation_m=peak, settling_time_s=t_s,
                    overshoot_percent=over, residual_tilt_rad=tilt,
                    settling_fraction=settling_fraction)


# ---------------------------------------------------------------------------
# describing function and limit cycle
# ---------------------------------------------------------------------------
def describing_function(amplitude_m, system: LevelingSystem, gain_kg_s_per_m=None):
    """The valve's describing function ``N(A)`` (kg/s per m): dead band, slope, saturation.

    With ``d`` the dead band, ``G`` the slope and ``e_s = d + q_sat/G`` full opening, and
    ``psi(x) = asin(x) + x sqrt(1 - x^2)``::

        N(A) = 0                                      A <= d
             = (2G/pi) (pi/2 - psi(d/A))              d < A <= e_s
             = (2G/pi) (psi(e_s/A) - psi(d/A))        A > e_s

    the fundamental of the flow for ``e = A sin(w t)`` (the orifice's pressure dependence
    set aside: at the leveled state both ports give ``G`` and ``q_sat``).

    Parameters
    ----------
    amplitude_m : float or ndarray
    system : LevelingSystem
    gain_kg_s_per_m : float, optional
        Default the system's.
    """
    check_positive("amplitude_m", amplitude_m, unit="m", allow_array=True)
    check_instance("system", system, LevelingSystem,
                   "a LevelingSystem (leveling_of_study(study)) or None")
    g = system.gain_kg_s_per_m if gain_kg_s_per_m is None else float(gain_kg_s_per_m)
    d = system.dead_band_m
    es = d + system.saturation_flow_kg_s / g
    a = np.atleast_1d(np.asarray(amplitude_m, dtype=float))

    def psi(x):
        x = np.clip(x, 0.0, 1.0)
        return np.arcsin(x) + x * np.sqrt(1.0 - x * x)

    with np.errstate(divide="ignore", invalid="ignore"):
        n = 2 * g / math.pi * (psi(np.minimum(es / a, 1.0)) - psi(np.minimum(d / a, 1.0)))
    return np.where(a <= d, 0.0, n)


@dataclass(frozen=True, eq=False, repr=False)
class LimitCycle(ResultDisplay):
    """The limit cycle the describing function predicts (``N(A) = G_c`` at ``f_c``).

    Attributes
    ----------
    amplitude_m : float or None
        The stable cycle's sensor amplitude (``N`` falling through ``G_c``); None: none
        (also when the loop has no finite, positive critical gain).
    threshold_m : float or None
        The unstable cycle's (``N`` rising through ``G_c``): smaller disturbances die out.
    frequency_hz : float
        ``f_c``, the frequency of the MIMO loop's crossing pole pair.
    critical_gain_kg_s_per_m : float
    amplitude_ratio : float
        Smallest over largest sensor amplitude in the crossing mode (the describing
        function applies the same ``A`` at every valve: reliable near 1).
    """

    amplitude_m: float | None
    threshold_m: float | None
    frequency_hz: float
    critical_gain_kg_s_per_m: float
    amplitude_ratio: float

    def to_frame(self):
        """One row."""
        import pandas as pd

        return pd.DataFrame([{"amplitude_m": self.amplitude_m, "threshold_m": self.threshold_m,
                              "frequency_hz": self.frequency_hz,
                              "critical_gain_kg_s_per_m": self.critical_gain_kg_s_per_m,
                              "amplitude_ratio": self.amplitude_ratio}])

    def _summary_items(self) -> list[tuple[str, str]]:
        a = "none" if self.amplitude_m is None else f"{self.amplitude_m * 1e6:.4g} um"
        return [("limit cycle", a), ("frequency", f"{self.frequency_hz:.3g} Hz")]


def limit_cycle(loop: LevelingLoop) -> LimitCycle:
    """The valves' limit cycle by the describing function (every valve at one amplitude).

    Parameters
    ----------
    loop : LevelingLoop

    Returns
    -------
    LimitCycle
    """
    check_instance("loop", loop, LevelingLoop,
                   "a LevelingLoop (leveling_loop(model, system))")
    from scipy.optimize import brentq

    plant, sysm = loop.plant, loop.plant.system
    g_c = loop.critical_gain_kg_s_per_m
    if not (math.isfinite(g_c) and g_c > 0):  # stable at every gain, or at none
        return LimitCycle(amplitude_m=None, threshold_m=None, frequency_hz=float("nan"),
                          critical_gain_kg_s_per_m=g_c, amplitude_ratio=float("nan"))
    ev, vec = np.linalg.eig(plant.closed_loop(g_c))
    i = int(np.argmax(ev.real))
    amp = np.abs(plant.c @ vec[:, i])
    ratio = float(amp.min() / amp.max())
    d = sysm.dead_band_m
    es = d + sysm.linear_range_m
    a_grid = np.geomspace(max(d, 1e-9) * (1 + 1e-9), 1e3 * es, 4000)
    n = describing_function(a_grid, sysm)
    r = n - g_c
    cross = np.flatnonzero(np.sign(r[:-1]) * np.sign(r[1:]) < 0)
    up = dn = None
    for k in cross:
        root = brentq(lambda aa: float(describing_function(aa, sysm)[0]) - g_c,
                      a_grid[k], a_grid[k + 1], xtol=1e-15)
        if r[k] < 0:
            up = root
        else:
            dn = root
    return LimitCycle(amplitude_m=dn, threshold_m=up, frequency_hz=loop.oscillation_frequency_hz,
                      critical_gain_kg_s_per_m=g_c, amplitude_ratio=ratio)


def leveling_transmissibility(loop: LevelingLoop, frequency_hz) -> tuple:
    """Vertical floor-to-table transmissibility at the CG with and without the valves.

    The floor's vertical motion ``u_f`` enters every spring's stroke, ``gz . q - u_f``, and
    its rate; the sensors read the table against the floor, ``y - u_f``. Returns
    ``(with_valves, sealed)``, complex arrays of ``z / u_f``: below the loop's crossover the
    valves make the table follow the floor (``|T| -> 1``) where the sealed table's springs
    alone would also give 1; around the crossover they change the low-frequency resonance.

    Parameters
    ----------
    loop : LevelingLoop
    frequency_hz : ndarray
    """
    check_instance("loop", loop, LevelingLoop,
                   "a LevelingLoop (leveling_loop(model, system))")
    check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    plant = loop.plant
    n = plant.n_states
    forced = plant.a.copy()
    forced[:6] = 0.0  # q' = v holds for the absolute body: only the forces see the floor
    e_q, e_v = np.zeros(n), np.zeros(n)
    e_q[2], e_v[8] = 1.0, 1.0
    g = loop.gain_kg_s_per_m
    a_v = plant.a - g * plant.b @ plant.c
    out_v, out_s = [], []
    for f in np.atleast_1d(frequency_hz):
        s = 2j * math.pi * f
        b_f = -forced @ (e_q + s * e_v)
        xv = np.linalg.solve(s * np.eye(n) - a_v, b_f + g * plant.b @ plant.c @ e_q)
        xs = np.linalg.solve(s * np.eye(n) - plant.a, b_f)
        out_v.append(xv[2])
        out_s.append(xs[2])
    return np.array(out_v), np.array(out_s)
