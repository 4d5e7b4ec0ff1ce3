"""Air-side calibration: minor-loss K, effective capillary diameter D_c and polytropic index n.

Nonlinear least squares on the self-consistent model (Eqs. 38, 42 with the harmonic-balance
flow amplitude of :mod:`isodesign.spring.stiffness`) against dual-chamber measurements::

    min_theta  sum_k |k_model(theta; f_k, X_k) + k_D*(f_k, X_k) - k_k|^2 / |k_k|^2

(real and imaginary parts; residuals relative to the measured magnitude, the rig's noise being
relative). The model is a CasADi expression of ``theta = (K, D_c, n)`` with the flow amplitude
from a Newton rootfinder, so the Jacobian is exact (implicit-function theorem). The solver is
Levenberg-Marquardt with the bounds (K in [0, 100], D_c in (0, L_c), n in [1, kappa]) enforced by
projection. Standard errors from the Gauss-Newton covariance ``s^2 (J^T J)^-1``,
``s^2 = SSR / (2 n_points - n_params)``, and the correlation matrix are reported: they assume
the model is right and the noise independent, so a systematic model error (the harmonic balance
is within about 3 % of the time-domain simulation, docs/simulation.md) is not in them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from isodesign.calibration.data import MeasuredStiffness
from isodesign.errors import InputError, SolverError
from isodesign.io.designfile import design_to_toml
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, amplitude_residual, kinematic_velocity
from isodesign.spring.flow_models import SMOOTH_FLOW_MODELS, resistance_function

__all__ = ["AIR_PARAMETERS", "AirFit", "fit_air_side"]

#: Parameters that can be calibrated: design field, label, scale (the solver works in
#: ``value / scale``).
AIR_PARAMETERS = {
    "minor_loss": ("K", 1.0),
    "capillary_diameter_m": ("D_c", 1e-3),
    "polytropic_index": ("n", 1.0),
}


@dataclass(frozen=True, eq=False)
class AirFit:
    """Result of :func:`fit_air_side`.

    Attributes
    ----------
    names : tuple of str
        Design fields calibrated.
    values, standard_errors : ndarray
        Estimates (SI) and their standard errors.
    correlation : ndarray, shape (p, p)
    design : SpringDesign
        The design with the estimates.
    relative_residual : ndarray of complex
        ``(k_fit - k) / |k|`` per point.
    iterations : int
    converged : bool
    at_bound : tuple of str
        Parameters that ended on a bound (their standard errors are not meaningful).
    measured : MeasuredStiffness
    diaphragm : str
    """

    names: tuple[str, ...]
    values: np.ndarray
    standard_errors: np.ndarray
    correlation: np.ndarray
    design: object
    relative_residual: np.ndarray
    iterations: int
    converged: bool
    at_bound: tuple[str, ...]
    measured: MeasuredStiffness
    diaphragm: str
    flow: str = "quasi_steady"
    solve_time_s: float = 0.0

    @property
    def rms_relative_residual(self) -> float:
        """RMS over points and real/imaginary parts of the relative residual."""
        r = self.relative_residual
        return float(np.sqrt(np.mean(np.r_[r.real, r.imag] ** 2)))

    def report(self) -> str:
        """Estimates with standard errors and the correlation matrix."""
        m = self.measured
        lines = [
            f"air-side fit: {m.source or 'data'} ({m.frequency_hz.size} points, "
            f"{m.frequency_hz.min():.3g}-{m.frequency_hz.max():.3g} Hz, "
            f"{m.amplitude_m.min() * 1e3:.3g}-{m.amplitude_m.max() * 1e3:.3g} mm); flow "
            f"{self.flow}, self-consistent amplitude; diaphragm {self.diaphragm}",
            f"Levenberg-Marquardt with CasADi exact Jacobian: {self.iterations} iterations, "
            f"{'converged' if self.converged else 'NOT converged'}; RMS residual "
            f"{self.rms_relative_residual:.2%} of |k|",
            "  parameter        estimate     std. error",
        ]
        for nm, v, se in zip(self.names, self.values, self.standard_errors, strict=True):
            label, scale = AIR_PARAMETERS[nm]
            unit = " mm" if nm == "capillary_diameter_m" else ""
            lines.append(f"  {label:<4} {nm:<22} {v / scale:10.5g}{unit}  {se / scale:10.3g}{unit}")
        lines.append("  correlation: " + "  ".join(AIR_PARAMETERS[n][0] for n in self.names))
        for nm, row in zip(self.names, self.correlation, strict=True):
            lines.append(f"    {AIR_PARAMETERS[nm][0]:<4}" + "".join(f"{c:8.3f}" for c in row))
        p = len(self.names)
        for i in range(p):
            for j in range(i + 1, p):
                if abs(self.correlation[i, j]) > 0.95:
                    a, b = AIR_PARAMETERS[self.names[i]][0], AIR_PARAMETERS[self.names[j]][0]
                    lines.append(
                        f"note: {a} and {b} are {abs(self.correlation[i, j]):.1%} correlated: "
                        "the data fix a combination of them; fix one (--parameters) or add "
                        "larger amplitudes (the minor loss grows as U^2, the laminar friction as U)"
                    )
        for b in self.at_bound:
            lines.append(f"note: {b} ended on its bound; its standard error is not meaningful")
        lines.append(
            "note: standard errors assume the model is exact and the noise independent; the "
            "harmonic-balance model itself is within about 3 % of the time-domain spring"
        )
        return "\n".join(lines)

    def to_toml(self) -> str:
        """The calibrated design as a design file, with the estimates in comments."""
        head = [
            "Air side calibrated by 'isodesign fit spring' (docs/calibration.md)",
            f"data: {self.measured.source}; RMS residual {self.rms_relative_residual:.3%}",
        ]
        for nm, v, se in zip(self.names, self.values, self.standard_errors, strict=True):
            head.append(f"{nm} = {v:.6g} +- {se:.2g} (1 standard error)")
        return design_to_toml(self.design, header="\n".join(head))


def _model_function(design, names, flow, dia):
    """CasADi function (theta, f, X) -> (Re k, Im k) of the self-consistent model."""
    import casadi as ca

    theta = ca.SX.sym("theta", len(names))
    f_hz, amp = ca.SX.sym("f"), ca.SX.sym("X")
    d = design.replace(**{nm: theta[i] * AIR_PARAMETERS[nm][1] for i, nm in enumerate(names)})
    w = 2.0 * math.pi * f_hz
    p = ca.vertcat(theta, f_hz, amp)
    xs = ca.SX.sym("x")
    g = ca.Function("F", [xs, p], [amplitude_residual(flow, d, w, amp, xs)])
    rf = ca.rootfinder(
        "flow_amplitude", "newton", g, {"abstol": 1e-13, "max_iter": 100, "error_on_fail": False}
    )
    lq = ca.log(d.volume_ratio * kinematic_velocity(d, w, amp))
    x_sol = rf(lq - amplitude_residual(flow, d, w, amp, lq), p)
    c = resistance_function(flow, d, w)(ca.exp(x_sol))
    k = air_stiffness(d, w, c, flow) + dia.stiffness(w, amp)
    return ca.Function("k_model", [theta, f_hz, amp], [k.re, k.im])


def fit_air_side(
    measured: MeasuredStiffness,
    design,
    *,
    parameters=("minor_loss", "capillary_diameter_m", "polytropic_index"),
    diaphragm="none",
    flow: str = "quasi_steady",
    max_iterations: int = 50,
    tolerance: float = 1e-9,
) -> AirFit:
    """Calibrate K, D_c and n (or a subset) from dual-chamber measurements.

    Parameters
    ----------
    measured : MeasuredStiffness
        ``dual_chamber`` data (the capillary carries the flow).
    design : SpringDesign
        The spring; its values of the calibrated fields are the starting point.
    parameters : sequence of str
        Design fields to calibrate, from :data:`AIR_PARAMETERS`.
    diaphragm : model spec
        The diaphragm in parallel (known, or fitted from single-chamber data with
        ``isodesign fit diaphragm``); ``"none"`` if the data are the air alone.
    flow : str
        A smooth flow model (:data:`~isodesign.spring.flow_models.SMOOTH_FLOW_MODELS`).
    max_iterations : int
        Levenberg-Marquardt iterations at most.
    tolerance : float
        Stop when an accepted step lowers the cost by less than this fraction.

    Returns
    -------
    AirFit
    """
    import casadi as ca

    t0 = time.perf_counter()
    if measured.configuration != "dual_chamber":
        raise InputError(
            "configuration: the air-side fit needs dual_chamber data (with the capillary "
            f"blocked K and D_c play no part); got {measured.configuration}"
        )
    names = tuple(parameters)
    bad = [p for p in names if p not in AIR_PARAMETERS]
    if bad or not names or len(set(names)) != len(names):
        raise InputError(
            f"parameters: unknown or repeated {', '.join(bad) or names}; valid: "
            f"{', '.join(AIR_PARAMETERS)}"
        )
    if flow not in SMOOTH_FLOW_MODELS:
        raise InputError(f"flow: {flow!r} is not smooth; valid: {', '.join(SMOOTH_FLOW_MODELS)}")
    n = measured.k.size
    if 2 * n <= 2 * len(names):
        raise InputError(f"measured stiffness: too sparse: {n} points for {len(names)} parameters")
    dia = diaphragm_model(diaphragm)
    kappa = design.gas.heat_capacity_ratio
    bounds = {
        "minor_loss": (0.0, 100.0),
        "capillary_diameter_m": (1e-6, 0.999 * design.capillary_length_m),
        "polytropic_index": (1.0, kappa),
    }
    lo = np.array([bounds[nm][0] / AIR_PARAMETERS[nm][1] for nm in names])
    hi = np.array([bounds[nm][1] / AIR_PARAMETERS[nm][1] for nm in names])
    x0 = []
    for nm in names:
        v = getattr(design, nm)
        if nm == "polytropic_index" and v is None:
            v = kappa
        x0.append(float(v) / AIR_PARAMETERS[nm][1])
    x = np.clip(np.array(x0), lo, hi)
    if "polytropic_index" in names:  # start inside: the bound kappa is a constraint
        i = names.index("polytropic_index")
        x[i] = min(x[i], 0.5 * (1.0 + kappa) + 0.25 * (kappa - 1.0))

    kf = _model_function(design, names, flow, dia)
    th = ca.MX.sym("theta", len(names))
    fm = kf.map(n, "serial")
    re, im = fm(ca.repmat(th, 1, n), measured.frequency_hz.reshape(1, -1),
                measured.amplitude_m.reshape(1, -1))  # fmt: skip
    scale = np.abs(measured.k)
    r = ca.vertcat(
        ((re - measured.k.real.reshape(1, -1)) / scale.reshape(1, -1)).T,
        ((im - measured.k.imag.reshape(1, -1)) / scale.reshape(1, -1)).T,
    )
    rj = ca.Function("rj", [th], [r, ca.jacobian(r, th)])

    def eval_rj(xv):
        rv, jv = rj(xv)
        return np.asarray(rv).ravel(), np.asarray(jv)

    rv, jv = eval_rj(x)
    if not np.all(np.isfinite(rv)):
        raise SolverError("air-side fit: the model cannot be evaluated at the starting point")
    cost = float(rv @ rv)
    mu = 1e-3 * float(np.max(np.diag(jv.T @ jv)))
    converged = False
    it = 0
    while it < max_iterations:
        it += 1
        jtj = jv.T @ jv
        g = jv.T @ rv
        step = np.linalg.solve(jtj + mu * np.diag(np.maximum(np.diag(jtj), 1e-12)), -g)
        xn = np.clip(x + step, lo, hi)
        rn, jn = eval_rj(xn)
        cn = float(rn @ rn) if np.all(np.isfinite(rn)) else np.inf
        if cn < cost:
            rel = (cost - cn) / max(cost, 1e-300)
            dx = np.max(np.abs(xn - x) / np.maximum(np.abs(x), 1e-3))
            x, rv, jv, cost = xn, rn, jn, cn
            mu = max(mu / 3.0, 1e-12)
            if rel < tolerance or dx < 1e-8:
                converged = True
                break
        else:
            mu *= 4.0
            if mu > 1e12:
                converged = bool(np.linalg.norm(g) < 1e-6 * max(1.0, cost))
                break
    dof = max(2 * n - len(names), 1)
    s2 = cost / dof
    jtj = jv.T @ jv
    try:
        cov = s2 * np.linalg.inv(jtj)
    except np.linalg.LinAlgError:
        cov = np.full((len(names), len(names)), np.nan)
    se_scaled = np.sqrt(np.abs(np.diag(cov)))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se_scaled, se_scaled)
    scales = np.array([AIR_PARAMETERS[nm][1] for nm in names])
    values = x * scales
    at_bound = tuple(
        nm for nm, v, a, b in zip(names, x, lo, hi, strict=True)
        if abs(v - a) < 1e-9 * max(1, abs(a)) or abs(v - b) < 1e-9 * max(1, abs(b))
    )  # fmt: skip
    fitted = design.replace(**{nm: float(v) for nm, v in zip(names, values, strict=True)})
    return AirFit(
        names=names,
        values=values,
        standard_errors=se_scaled * scales,
        correlation=corr,
        design=fitted,
        relative_residual=rv[:n] + 1j * rv[n:],
        iterations=it,
        converged=converged,
        at_bound=at_bound,
        measured=measured,
        diaphragm=dia.name,
        flow=flow,
        solve_time_s=time.perf_counter() - t0,
    )
