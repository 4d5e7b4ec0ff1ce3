"""Complex stiffness k*(X_p, w) of the dual-chamber pneumatic spring.

Paper references:

* Eq. 38: ``k_d* = k_s (1 + j w tau) / (N + 1 + j w tau)``, ``tau = V_b0 C / (n R T0)``,
  the air spring for a flow resistance ``C`` (:func:`air_stiffness`). Written here
  for a complex ``C`` (inertance) and a polytropic index ``n`` (kappa if adiabatic).
* Eq. 37: the kinematic flow amplitude ``u_max = (A_p/A_c) X_p w``
  (:func:`kinematic_velocity`): all displaced air goes through the tube.
* Eq. 42: ``k*_{d+D} = k_d* + k_D*`` (diaphragm in parallel).

The self-consistent flow amplitude
----------------------------------
Solving Eqs. 32-35 for the tube's mass flow gives, for any complex ``C``,
``m_dot = rho A_p X jw N / (1 + N + j w tau)``, so the velocity amplitude that
the chamber pressures actually drive through the tube is::

    U = (A_p/A_c) X w N / |1 + N + j w s C(U)|,      s = V_b0 / (n R T0)

Eq. 37 replaces this by ``U = (A_p/A_c) X w`` (the tube never blocks), which is
wrong by the factor ``N/|1 + N + j w tau|``: 0.65 at low frequency for N = 1.85
and far smaller once the tube blocks (docs/physics.md, section 3). The
``self_consistent`` mode solves the harmonic-balance equation above, written as
the residual in ``x = ln U`` (:func:`amplitude_residual`)::

    F(x) = x + ln|1 + N + j w s C(e^x)| - ln(N (A_p/A_c) X w) = 0

``F`` is strictly increasing with ``F' >= 1`` for every passive model whose
resistance does not fall with ``U`` and whose inertance does not depend on
``U``, so the root is unique; :func:`solve_velocity_amplitude` brackets it and
converges with the Illinois method, vectorized over all points.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.domain import FREQUENCY_DOMAIN_HZ, MODEL_AMPLITUDE_DOMAIN_M
from isodesign.errors import (
    InputError,
    ModelValidityWarning,
    SolverError,
    check_choice,
    check_domain,
    check_positive,
)
from isodesign.plotting.stiffness import stiffness_figure
from isodesign.results import ResultDisplay
from isodesign.spring.amplitude import solve_velocity_amplitude
from isodesign.spring.design import SpringDesign
from isodesign.spring.diagnostics import Diagnostics, evaluate_diagnostics
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import (
    air_stiffness,
    amplitude_residual,
    kinematic_velocity,
    spring_stiffness,
)
from isodesign.spring.flow_models import (
    FLOW_MODELS,
    SMOOTH_FLOW_MODELS,
    flow_model,
    model_design,
    resistance_function,
)

__all__ = [
    "AMPLITUDE_MODES",
    "StiffnessResult",
    "check_models",
    "complex_stiffness",
    "stiffness_function",
]

AMPLITUDE_MODES = ("self_consistent", "kinematic")


# ---------------------------------------------------------------------------
# result and public API
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class StiffnessResult(ResultDisplay):
    """Complex stiffness over frequency x amplitude, with diagnostics.

    Attributes
    ----------
    frequency_hz, amplitude_m : ndarray
        The evaluated points (broadcast to a common shape).
    k : ndarray of complex
        Total complex stiffness k*_{d+D} (Eq. 42), N/m.
    k_air, k_diaphragm : ndarray of complex
        The air spring k_d* (Eq. 38) and the diaphragm k_D*.
    diagnostics : Diagnostics
        Flow quantities and validity checks for every point.
    flow, amplitude_mode, diaphragm : str
        The models used.
    """

    frequency_hz: np.ndarray
    amplitude_m: np.ndarray
    k: np.ndarray
    k_air: np.ndarray
    k_diaphragm: np.ndarray
    diagnostics: Diagnostics
    flow: str
    amplitude_mode: str
    diaphragm: str
    design: Any = field(repr=False, default=None)

    @property
    def loss_factor(self) -> np.ndarray:
        """Loss factor Im k / Re k."""
        return self.k.imag / self.k.real

    @property
    def storage_n_per_m(self) -> np.ndarray:
        """Real part (storage stiffness), N/m."""
        return self.k.real

    @property
    def loss_n_per_m(self) -> np.ndarray:
        """Imaginary part (loss stiffness), N/m."""
        return self.k.imag

    @property
    def valid(self) -> np.ndarray:
        """True where every validity check passes."""
        return self.diagnostics.valid

    @property
    def warnings(self) -> tuple[str, ...]:
        """One line per failed validity check, with the count of points."""
        return self.diagnostics.summary()

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the evaluated grid."""
        return self.k.shape

    def _summary_items(self) -> list[tuple[str, str]]:
        """Grid, stiffness range, models and validity (for repr and notebooks)."""
        f = np.asarray(self.frequency_hz, float)
        x = np.asarray(self.amplitude_m, float)
        kr = np.asarray(self.k.real, float) / 1e3
        return [
            ("points", f"{self.k.size} ({f.min():.3g}-{f.max():.3g} Hz, "
                       f"{x.min() * 1e3:.3g}-{x.max() * 1e3:.3g} mm)"),
            ("Re k*", f"{kr.min():.4g}-{kr.max():.4g} kN/m"),
            ("loss factor", f"{np.nanmin(self.loss_factor):.3g}-{np.nanmax(self.loss_factor):.3g}"),
            ("models", f"{self.flow} flow, {self.amplitude_mode}, {self.diaphragm} diaphragm"),
            ("outside validity", f"{int(np.sum(~np.asarray(self.valid, bool)))} points"),
        ]

    def plot(self, ax=None, *, title=None):
        """Real part of k* and loss factor against frequency, one curve per amplitude.

        Parameters
        ----------
        ax : pair of matplotlib Axes, optional
            (real part, loss factor) to draw into; default a new figure.
        title : str, optional

        Returns
        -------
        matplotlib.figure.Figure
            Made with an Agg canvas; the global Matplotlib backend is not touched.
        """
        return stiffness_figure([self], title=title, axes=ax)

    def to_frame(self):
        """One row per point: stiffness, loss factor and every diagnostic."""
        import pandas as pd

        cols = {
            "frequency_hz": self.frequency_hz.ravel(),
            "amplitude_m": self.amplitude_m.ravel(),
            "k_real_n_per_m": self.k.real.ravel(),
            "k_imag_n_per_m": self.k.imag.ravel(),
            "loss_factor": self.loss_factor.ravel(),
            "k_air_real_n_per_m": self.k_air.real.ravel(),
            "k_air_imag_n_per_m": self.k_air.imag.ravel(),
            "k_diaphragm_real_n_per_m": self.k_diaphragm.real.ravel(),
            "k_diaphragm_imag_n_per_m": self.k_diaphragm.imag.ravel(),
        }
        cols.update(self.diagnostics.columns())
        df = pd.DataFrame(cols)
        df.attrs.update(
            flow=self.flow, amplitude_mode=self.amplitude_mode, diaphragm=self.diaphragm
        )
        return df


def _grid(frequency_hz, amplitude_m, pairwise: bool):
    f = check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    x = check_positive("amplitude_m", amplitude_m, unit="m", allow_array=True)
    check_domain("frequency_hz", f, FREQUENCY_DOMAIN_HZ, unit="Hz")
    check_domain("amplitude_m", x, MODEL_AMPLITUDE_DOMAIN_M, unit="m")
    if pairwise:
        try:
            np.broadcast_shapes(f.shape, x.shape)
            return f, x
        except ValueError:
            raise InputError(
                f"frequency_hz, amplitude_m: shapes {f.shape} and {x.shape} do not broadcast"
            ) from None
    return f.reshape(f.shape + (1,) * x.ndim), x.reshape((1,) * f.ndim + x.shape)


def check_models(flow: str, amplitude_mode: str) -> None:
    """Validate a flow-model / amplitude-mode pair (names and compatibility).

    Parameters
    ----------
    flow : str
        A flow model (:data:`isodesign.spring.flow_models.FLOW_MODELS`).
    amplitude_mode : str
        ``self_consistent`` or ``kinematic``.
    """
    check_choice("flow", flow, FLOW_MODELS)
    check_choice("amplitude_mode", amplitude_mode, AMPLITUDE_MODES)
    if amplitude_mode == "self_consistent" and not flow_model(flow).self_consistent:
        raise InputError(
            f"amplitude_mode: 'self_consistent' is not defined for flow={flow!r}: the paper's "
            "friction is independent of the amplitude and negative below Re_w = 3.673, so the "
            "harmonic balance has no unique root. Use amplitude_mode='kinematic' to reproduce "
            f"the paper, or a passive model ({', '.join(SMOOTH_FLOW_MODELS)})"
        )


def complex_stiffness(
    design,
    frequency_hz,
    amplitude_m,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    pairwise: bool = False,
    warn: bool = True,
) -> StiffnessResult:
    """Complex stiffness k*(X_p, w) of a dual-chamber spring with diaphragm.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    frequency_hz : float or array
        Excitation frequencies, Hz (> 0).
    amplitude_m : float or array
        Piston displacement amplitudes X_p, m (> 0).
    flow : str
        Capillary model (:data:`isodesign.spring.flow_models.FLOW_MODELS`). Default
        ``quasi_steady``: all-regime (laminar to turbulent) and passive for any
        input, which is what the amplitudes of real tables need (the tube flow of
        the reference spring reaches Re ~ 7000 at 0.5 mm).
    amplitude_mode : str
        ``self_consistent`` (default: the velocity the chamber pressures really
        drive, harmonic balance) or ``kinematic`` (Eq. 37, the paper's, which
        overestimates the tube velocity as soon as the tube blocks).
    diaphragm : str or model
        ``viscoelastic`` (default, illustrative parameters), ``none``,
        ``table:PATH.csv`` or a model object (:mod:`isodesign.spring.diaphragm`).
    pairwise : bool
        ``False`` (default): the result has shape ``frequency.shape +
        amplitude.shape`` (every frequency with every amplitude). ``True``:
        frequency and amplitude broadcast elementwise.
    warn : bool
        Emit one :class:`~isodesign.errors.ModelValidityWarning` summarizing the
        points outside the models' validity (they are always flagged in the
        result's diagnostics).

    Returns
    -------
    StiffnessResult

    Notes
    -----
    Reproduce the paper (Fig. 11, solid lines) with ``flow="zhao",
    amplitude_mode="kinematic"`` and its comparison model (dashed) with
    ``flow="poiseuille"``.
    """
    if not isinstance(design, SpringDesign):
        raise InputError(f"design: expected a SpringDesign, got {type(design).__name__} "
                         f"{design!r:.40}")
    check_models(flow, amplitude_mode)
    design = model_design(flow, design)
    dia = diaphragm_model(diaphragm)
    f, x = _grid(frequency_hz, amplitude_m, pairwise)  # un-broadcast, broadcastable
    shape = np.broadcast_shapes(f.shape, x.shape)
    w = 2.0 * math.pi * f
    solve = None
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        if amplitude_mode == "kinematic":
            u = np.broadcast_to(kinematic_velocity(design, w, x), shape)
            c = resistance_function(flow, design, w)(u)
        else:
            solve = solve_velocity_amplitude(
                flow, design, np.broadcast_to(w, shape), np.broadcast_to(x, shape)
            )
            if not np.all(solve.converged):
                nbad = int(np.sum(~solve.converged))
                raise SolverError(
                    f"self-consistent flow amplitude did not converge at {nbad} of "
                    f"{solve.velocity.size} points (max |residual| "
                    f"{np.max(np.abs(solve.residual)):.3g})"
                )
            u = solve.velocity
            c = solve.resistance
        k_air = air_stiffness(design, w, c, flow)
        k_air_c = k_air.re + 1j * k_air.im
        k_d = dia.stiffness(w, x)
        k_d_c = np.broadcast_to(k_d.re + 1j * np.asarray(k_d.im), shape)
        k_tot = spring_stiffness(k_air_c, k_d_c)
    diag = evaluate_diagnostics(
        flow,
        design,
        w,
        x,
        u,
        c,
        k_air_c,
        k_tot,
        dia,
        amplitude_mode,
        converged=None if solve is None else solve.converged,
        iterations=None if solve is None else solve.iterations,
    )
    res = StiffnessResult(
        frequency_hz=np.broadcast_to(f, shape),
        amplitude_m=np.broadcast_to(x, shape),
        k=k_tot,
        k_air=k_air_c,
        k_diaphragm=k_d_c,
        diagnostics=diag,
        flow=flow,
        amplitude_mode=amplitude_mode,
        diaphragm=dia.name,
        design=design,
    )
    if warn and res.warnings:
        warnings.warn(
            f"complex_stiffness(flow={flow!r}, amplitude_mode={amplitude_mode!r}): "
            + "; ".join(res.warnings),
            ModelValidityWarning,
            stacklevel=2,
        )
    return res


# ---------------------------------------------------------------------------
# CasADi face
# ---------------------------------------------------------------------------
def stiffness_function(
    design,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
):
    """CasADi function of the complex stiffness, differentiable in the design.

    Returns a ``casadi.Function`` named ``k_star`` with inputs ``(N, V_t0, L_c,
    D_c, frequency_hz, amplitude_m)`` (scalars) and outputs ``(k_real, k_imag,
    U)``; the other design fields are taken from ``design``. In
    ``self_consistent`` mode the flow amplitude comes from a CasADi Newton
    rootfinder on :func:`amplitude_residual`, so derivatives follow from the
    implicit function theorem. The expressions are the same functions the NumPy
    path evaluates.

    Parameters
    ----------
    design : SpringDesign
        The spring; N, V_t0, L_c and D_c become the function's inputs.
    flow : str
        A smooth flow model (:data:`isodesign.spring.flow_models.SMOOTH_FLOW_MODELS`).
    amplitude_mode : str
        ``self_consistent`` (default) or ``kinematic``.
    diaphragm : str or model
        As in :func:`complex_stiffness`.
    """
    import casadi as ca

    check_models(flow, amplitude_mode)
    if not flow_model(flow).smooth:
        raise InputError(
            f"flow: {flow!r} is not available on CasADi symbols; valid: "
            f"{', '.join(SMOOTH_FLOW_MODELS)}"
        )
    design = model_design(flow, design)
    dia = diaphragm_model(diaphragm)
    syms = ca.SX.sym("N"), ca.SX.sym("V_t0"), ca.SX.sym("L_c"), ca.SX.sym("D_c")
    f_hz, amp = ca.SX.sym("frequency_hz"), ca.SX.sym("amplitude_m")
    d = design.replace(
        volume_ratio=syms[0],
        top_volume_m3=syms[1],
        capillary_length_m=syms[2],
        capillary_diameter_m=syms[3],
    )
    w = 2.0 * math.pi * f_hz
    p = ca.vertcat(*syms, f_hz, amp)
    if amplitude_mode == "kinematic":
        u = kinematic_velocity(d, w, amp)
    else:
        xs = ca.SX.sym("x")
        g = ca.Function("F", [xs, p], [amplitude_residual(flow, d, w, amp, xs)])
        rf = ca.rootfinder(
            "flow_amplitude", "newton", g, {"abstol": 1e-14, "max_iter": 100, "error_on_fail": True}
        )
        # start one unit-slope Newton step below x = ln(N Q): a lower bound (F' >= 1)
        lq = ca.log(d.volume_ratio * kinematic_velocity(d, w, amp))
        x_sol = rf(lq - amplitude_residual(flow, d, w, amp, lq), p)
        u = ca.exp(x_sol)
    c = resistance_function(flow, d, w)(u)
    k = spring_stiffness(air_stiffness(d, w, c, flow), dia.stiffness(w, amp))
    return ca.Function(
        "k_star",
        [*syms, f_hz, amp],
        [k.re, k.im, u],
        ["N", "V_t0", "L_c", "D_c", "frequency_hz", "amplitude_m"],
        ["k_real", "k_imag", "U"],
    )
