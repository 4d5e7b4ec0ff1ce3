"""Capillary flow laws: the dimensionless groups, friction laws and impedances.

The flow resistance between the two chambers is
``C = (P_t - P_b) / m_dot_tb`` in Pa s/kg (paper Eq. 35); it may be complex (an
imaginary part is the inertance of the air slug). This module holds the physics
the flow models are built from (Reynolds and Womersley numbers, the describing
velocity, the Churchill, Poiseuille and Zhao friction laws, the Womersley
impedance). The models themselves (name, resistance ``C(U, w)``, validity checks,
whether they may enter the NLP) are registered in :mod:`isodesign.spring.flow_models`.

The Gaussian-equivalent resistance (random input)
-------------------------------------------------
Under a random floor the tube velocity ``u(t)`` is one Gaussian process of RMS
``sigma_u``. :func:`statistical_resistance_function` splits the pressure drop into
its linear part (Poiseuille friction or the Womersley impedance, and the
inertance: frequency dependent, :func:`linear_resistance`) and its nonlinear part
``dp_nl(u)`` (the minor loss ``K rho |u| u / 2`` and, for ``quasi_steady``, the
excess of Churchill's friction over the laminar law), replaced by the
frequency-independent resistance ``E[u dp_nl(u)] / sigma_u^2``
(:func:`gaussian_equivalent_resistance`): ``K rho sqrt(8/pi) sigma_u / 2`` in
closed form for the minor loss, and :func:`gaussian_friction_excess` (a fixed
quadrature in ``ln Re``) for the friction. Derivation: ``docs/random-response.md``.

The describing function used by ``quasi_steady``
------------------------------------------------
Eq. 22 replaces ``|u| u`` by ``(8 U / 3 pi) u`` for ``u = U sin wt``. For a
general friction law ``dp = (L/D f(Re) + K) rho/2 |u| u`` the quasi-steady model
evaluates the steady friction factor at the describing-function velocity
``U_eq = 8 U / (3 pi)``::

    C = [ (L/D) f(Re_eq) + K ] U_eq / (2 A_c),   Re_eq = rho U_eq D / mu

This is exact for laminar friction (``f = 64/Re`` makes the law linear, and
``C`` becomes Eq. 41's ``C_u``) and for the quadratic minor loss (Eq. 22
itself), and within 0.5 % of the exact first harmonic for Blasius friction
(``U^1.75``: 0.884 against 0.880; docs/physics.md, section 7). In the
laminar-turbulent transition (peak Re 2,400 to 3,000) the friction term differs
from the exact describing function of Churchill's law by up to 9 %; the effect on
k is at most 1.2 % on the reference spring, and the time-domain check
(:mod:`isodesign.simulation.harmonic_rig`, ``docs/simulation.md``) bounds the
whole harmonic-balance error at 2.3 % in |k| over 0.2-24 Hz and 0.05-0.5 mm.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx

__all__ = [
    "FLANGED_END_CORRECTION",
    "LAMINAR_REYNOLDS_LIMIT",
    "QUASI_STEADY_INERTANCE_COEFFICIENT",
    "QUASI_STEADY_WOMERSLEY_LIMIT",
    "STATISTICAL_FLOW_MODELS",
    "TURBULENT_REYNOLDS_LIMIT",
    "UNFLANGED_END_CORRECTION",
    "ZHAO_RANGES",
    "churchill_friction_factor",
    "churchill_friction_re_product",
    "describing_velocity",
    "flow_regime",
    "gaussian_equivalent_resistance",
    "gaussian_friction_excess",
    "kinetic_reynolds",
    "linear_resistance",
    "poiseuille_resistance",
    "quasi_steady_reactance",
    "statistical_resistance_function",
    "tube_boundary_layer_functions",
    "tube_end_length_m",
    "tube_end_reactance",
    "womersley_number",
    "womersley_zeta",
    "zhao_friction",
]

#: Upper Reynolds number of laminar pipe flow (Eq. 26).
LAMINAR_REYNOLDS_LIMIT = 2300.0
#: Start of fully turbulent pipe flow used for the regime label.
TURBULENT_REYNOLDS_LIMIT = 4000.0
#: Womersley number above which the quasi-steady model is flagged: there the exact
#: laminar oscillating-flow impedance differs from the quasi-steady one
#: (Poiseuille resistance plus 4/3 of the plug inertance) by more than 5 % in
#: modulus (3.7 % at alpha = 3, 6.8 % at 4, 19 % at 10).
QUASI_STEADY_WOMERSLEY_LIMIT = 3.4
#: Inertance coefficient of the quasi-steady model: 4/3 of the plug-flow value
#: ``L/A_c``, the exact low-frequency limit of developed laminar flow. Turbulent
#: profiles are flatter (coefficient near 1), but at turbulent speeds the
#: resistance dominates the impedance, so the difference is small there.
QUASI_STEADY_INERTANCE_COEFFICIENT = 4.0 / 3.0
#: End correction of a tube opening flush into a wall much wider than its bore (a flanged
#: end), in bore radii: the entrained gas outside each end moves like ``0.8216 a`` more of
#: plug (``docs/acoustics.md``, section 1). The capillary ends in the chamber walls.
FLANGED_END_CORRECTION = 0.8216
#: The same for an end protruding into a large volume (an unflanged pipe end), in radii:
#: the other limit, which bounds the end correction's uncertainty.
UNFLANGED_END_CORRECTION = 0.6133
#: Stated ranges of the Zhao correlations, Eqs. 24 and 25: (Re_w lo, hi, A0 lo, hi).
ZHAO_RANGES = {
    "laminar": (23.0, 395.0, 0.0, 26.4),
    "turbulent": (81.0, 540.0, 53.4, 113.5),
}


# ---------------------------------------------------------------------------
# dimensionless groups
# ---------------------------------------------------------------------------
def describing_velocity(velocity_amplitude):
    """``U_eq = 8 U / (3 pi)``, the describing-function velocity of Eq. 22.

    Parameters
    ----------
    velocity_amplitude : float, ndarray or CasADi symbol
        Velocity amplitude U, m/s.
    """
    return 8.0 * velocity_amplitude / (3.0 * math.pi)


def kinetic_reynolds(design, omega):
    """Kinetic Reynolds number ``Re_w = rho w D_c^2 / mu`` (paper, after Eq. 23).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    return design.density_kg_m3 * omega * design.capillary_diameter_m**2 / design.viscosity_pa_s


def womersley_number(design, omega):
    """Womersley number ``alpha = (D_c/2) sqrt(w rho / mu) = sqrt(Re_w)/2``.

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    # the design's factor apart from sqrt(w): the NLP computes it once per design
    d = design
    return bk.sqrt(omega) * (0.5 * d.capillary_diameter_m
                             * bk.sqrt(d.density_kg_m3 / d.viscosity_pa_s))


def flow_regime(reynolds) -> np.ndarray:
    """Label each Reynolds number 'laminar', 'transitional' or 'turbulent'.

    Parameters
    ----------
    reynolds : array_like
        Reynolds numbers (NumPy).
    """
    re = np.asarray(reynolds, dtype=float)
    out = np.full(re.shape, "transitional", dtype=object)
    out[re <= LAMINAR_REYNOLDS_LIMIT] = "laminar"
    out[re >= TURBULENT_REYNOLDS_LIMIT] = "turbulent"
    return out


# ---------------------------------------------------------------------------
# friction laws
# ---------------------------------------------------------------------------
def poiseuille_resistance(design):
    """Unidirectional laminar flow constant, Eq. 41: ``128 mu L_c / (pi rho D_c^4)``.

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    """
    d = design.capillary_diameter_m
    return (
        128.0
        * design.viscosity_pa_s
        * design.capillary_length_m
        / (math.pi * design.density_kg_m3 * bk.ipow(d, 4))
    )


def churchill_friction_re_product(reynolds, relative_roughness=0.0, *, with_slope=False):
    """``Phi = f Re`` for the Churchill (1977) all-regime Darcy friction factor.

    Churchill, S. W. (1977), "Friction-factor equation spans all fluid-flow
    regimes", Chem. Eng. 84(24), 91-92::

        f = 8 [ (8/Re)^12 + (A + B)^(-3/2) ]^(1/12)
        A = [ -2.457 ln( (7/Re)^0.9 + 0.27 eps/D ) ]^16,  B = (37530/Re)^16

    Written as ``f Re = 8 [ 8^12 + Re^12 (A+B)^(-3/2) ]^(1/12)``, which is finite
    at Re -> 0 (``64``, Poiseuille) and smooth everywhere. Valid for all Re.

    With ``with_slope=True`` also returns ``dPhi/dRe`` (NumPy only; used by the
    self-consistent solver). On NumPy the points with ``Re <= 1000`` skip the
    turbulent terms: there ``Phi = 64`` to better than 1e-13 relative.

    Parameters
    ----------
    reynolds : float, ndarray or CasADi symbol
        Reynolds number (> 0).
    relative_roughness : float, ndarray or CasADi symbol
        Roughness over diameter, ``eps / D``.
    with_slope : bool
        Also return ``dPhi/dRe`` (NumPy only).
    """
    if bk.is_casadi(reynolds, relative_roughness):
        return _churchill(reynolds, relative_roughness, False)[0]
    re = np.asarray(reynolds, dtype=float)
    phi = np.full(re.shape, 64.0)
    slope = np.zeros(re.shape)
    m = re > _CHURCHILL_LAMINAR_RE
    if np.any(m):
        r = relative_roughness if np.ndim(relative_roughness) == 0 else relative_roughness[m]
        phi_m, slope_m = _churchill(re[m], r, with_slope)
        phi[m] = phi_m
        if with_slope:
            slope[m] = slope_m
    if with_slope:
        return phi, slope
    return phi


#: Below this Reynolds number Churchill's Phi equals 64 to better than 1e-13.
_CHURCHILL_LAMINAR_RE = 1000.0


def _churchill(re, rel_rough, with_slope):
    """Churchill's Phi (and dPhi/dRe) on any backend.

    For a smooth tube (``rel_rough == 0``, a plain number, never a decision
    variable) ``ln((7/Re)^0.9) = 0.9 (ln 7 - ln Re)`` saves two transcendental
    functions per point; the value is the same formula.
    """
    lr = bk.log(re)
    if isinstance(rel_rough, int | float) and rel_rough == 0.0:
        a = 2.457 * 0.9 * (lr - math.log(7.0))
        vfrac = 1.0  # v / (v + 0.27 eps/D)
    else:
        v = bk.exp(0.9 * (math.log(7.0) - lr))
        vr = v + 0.27 * rel_rough
        a = -2.457 * bk.log(vr)
        vfrac = v / vr
    big_a = bk.ipow(a * a, 8)
    big_b = bk.ipow(37530.0 / re, 16)
    s = big_a + big_b
    term = bk.ipow(re, 12) / (s * bk.sqrt(s))
    inner = 8.0**12 + term
    phi = 8.0 * bk.power(inner, 1.0 / 12.0)
    if not with_slope:
        return phi, None
    # d/dRe: a' = 2.2113 (v/(v + r)) / Re; A' = 16 A a'/a; B' = -16 B / Re
    da = 2.457 * 0.9 * vfrac / re
    ds = 16.0 * big_a * da / a - 16.0 * big_b / re
    dterm = term * (12.0 / re - 1.5 * ds / s)
    return phi, phi * dterm / (12.0 * inner)


def churchill_friction_factor(reynolds, relative_roughness=0.0):
    """Churchill (1977) Darcy friction factor ``f(Re)``; see
    :func:`churchill_friction_re_product`.

    Parameters
    ----------
    reynolds : float, ndarray or CasADi symbol
        Reynolds number (> 0).
    relative_roughness : float, ndarray or CasADi symbol
        Roughness over diameter, ``eps / D``.
    """
    return churchill_friction_re_product(reynolds, relative_roughness) / reynolds


def zhao_friction(kinetic_re, dimensionless_amplitude, correlation: str = "laminar"):
    """Zhao's oscillating-flow friction coefficient, Eqs. 24-25 as printed.

    ``fr_o = 4/A0 * 3.27 / (Re_w^0.548 - 2.04)`` (Eq. 24, laminar, stated for
    23 <= Re_w <= 395, A0 <= 26.4) or ``fr_o = 4/A0 * (76.6/Re_w^1.2 + 0.41)``
    (Eq. 25, turbulent, 81 <= Re_w <= 540, 53.4 <= A0 <= 113.5).

    Eq. 24 has a pole at ``Re_w = 2.04^(1/0.548) = 3.673`` and is negative
    below it: the model is not passive there (docs/physics.md, section 2).

    Parameters
    ----------
    kinetic_re : ndarray
        Kinetic Reynolds number ``Re_w``.
    dimensionless_amplitude : ndarray
        ``A0 = x_max / D_c``.
    correlation : {'laminar', 'turbulent'}
        Eq. 24 or Eq. 25.
    """
    if correlation == "laminar":
        return 4.0 / dimensionless_amplitude * (3.27 / (np.power(kinetic_re, 0.548) - 2.04))
    if correlation == "turbulent":
        return 4.0 / dimensionless_amplitude * (76.6 / np.power(kinetic_re, 1.2) + 0.41)
    raise InputError(f"correlation: unknown value {correlation!r}; valid: laminar, turbulent")


# ---------------------------------------------------------------------------
# Womersley impedance
# ---------------------------------------------------------------------------
def _womersley_zeta_exact(alpha):
    """Exact normalized impedance on NumPy, via scipy's Bessel functions."""
    from scipy import special

    alpha = np.asarray(alpha, dtype=float)
    tiny = alpha < 1e-6
    a = np.where(tiny, 1.0, alpha)
    z = np.exp(0.75j * np.pi) * a  # i^(3/2) alpha
    # F = 1 - 2 J1/(z J0) = -J2/J0 (from J0 + J2 = 2 J1/z): no cancellation at
    # small alpha. Exponentially scaled Bessel functions: the scaling cancels.
    f = -special.jve(2, z) / special.jve(0, z)
    zeta = 1j * a * a / (8.0 * f)
    # alpha -> 0: zeta = 1 + j alpha^2/6 + O(alpha^4)
    zeta_small = 1.0 + 1j * alpha**2 / 6.0
    return np.where(tiny, zeta_small, zeta)


_ZETA_T_MIN = math.log(1e-3)
_ZETA_T_MAX = math.log(1e3)


#: Prandtl number of air: the thermal wave number of the tube is ``alpha sqrt(Pr)``.
AIR_PRANDTL = 0.71


@lru_cache(maxsize=4)
def _tube_spline(prandtl: float = AIR_PRANDTL):
    """One CasADi B-spline of the tube's boundary-layer functions in ``t = ln(alpha)``, built once.

    Four outputs, smooth and O(1), so that a cubic spline on a uniform grid of step 0.004
    matches scipy's Bessel evaluation to better than 1e-8 (checked in the tests):
    ``ln(zeta_r(alpha))``, ``zeta_i(alpha) / alpha^2`` (the Womersley impedance) and the
    real and imaginary parts of the thermal function ``G(alpha sqrt(Pr))``
    (:func:`isodesign.spring.transmission_line.thermal_function`). One call evaluates the
    flow model's impedance and the transmission line's elements (one interpolant call per
    frequency in the NLP).
    """
    import casadi as ca

    t = np.linspace(_ZETA_T_MIN, _ZETA_T_MAX, 3455)
    alpha = np.exp(t)
    zeta = _womersley_zeta_exact(alpha)
    zt = _womersley_zeta_exact(alpha * math.sqrt(prandtl))
    a2t = prandtl * alpha**2
    g = 1.0 - 1j * a2t / (8.0 * zt)  # G = 1 - j s^2 / (8 zeta(s))
    values = np.stack([np.log(zeta.real), zeta.imag / alpha**2, g.real, g.imag], axis=0)
    # multi-output values are flattened with the output index fastest
    return ca.interpolant("womersley_tube", "bspline", [t.tolist()],
                          values.T.ravel().tolist(), {})


def tube_boundary_layer_functions(alpha, prandtl: float = AIR_PRANDTL) -> tuple[Cx, Cx]:
    """``(zeta(alpha), G(alpha sqrt(Pr)))``: the Womersley impedance and thermal function.

    NumPy: scipy's Bessel functions (exact). CasADi: one four-output B-spline call
    (:func:`_tube_spline`), valid for 1e-3 <= alpha <= 1e3.

    Parameters
    ----------
    alpha : float, ndarray or CasADi symbol
        Womersley (shear wave) number (> 0).
    prandtl : float
        Prandtl number of the gas (a plain number).

    Returns
    -------
    tuple of Cx
    """
    if bk.is_casadi(alpha):
        out = _tube_spline(float(prandtl))(bk.log(alpha))
        return (Cx(bk.exp(out[0]), out[1] * alpha * alpha), Cx(out[2], out[3]))
    alpha = np.asarray(alpha, dtype=float)
    if alpha.size > 64:  # many points share few frequencies: the Bessel functions once each
        uniq, inv = np.unique(alpha, return_inverse=True)
        if uniq.size < alpha.size:
            zeta, g = _tube_functions_exact(uniq, prandtl)
            return (Cx.from_complex(zeta[inv].reshape(alpha.shape)),
                    Cx.from_complex(g[inv].reshape(alpha.shape)))
    zeta, g = _tube_functions_exact(alpha, prandtl)
    return Cx.from_complex(zeta), Cx.from_complex(g)


def _tube_functions_exact(alpha: np.ndarray, prandtl: float):
    """``(zeta(alpha), G(alpha sqrt(Pr)))`` as complex NumPy arrays (scipy's Bessel)."""
    s = alpha * math.sqrt(prandtl)
    zt = _womersley_zeta_exact(s)
    return _womersley_zeta_exact(alpha), 1.0 - 1j * s * s / (8.0 * zt)


def womersley_zeta(alpha) -> Cx:
    """Impedance of laminar oscillating tube flow, normalized by Poiseuille.

    ``zeta(alpha) = Z'(w) / (128 mu / (pi D^4))`` with the exact solution
    ``Z' = i w rho / (A F)``, ``F = 1 - 2 J1(z)/(z J0(z))``, ``z = i^(3/2) alpha``
    (docs/physics.md, section 4). Limits: ``zeta -> 1 + j alpha^2/6`` (Poiseuille
    plus 4/3 of the plug inertance) as alpha -> 0, ``zeta -> j alpha^2/8 +
    alpha/(4 sqrt 2) (1 + j)`` as alpha -> inf.

    NumPy: scipy's Bessel functions (exact). CasADi: a cubic B-spline of the
    exact function in ln(alpha), valid for 1e-3 <= alpha <= 1e3 (the first two outputs
    of :func:`tube_boundary_layer_functions`' spline).

    Parameters
    ----------
    alpha : float, ndarray or CasADi symbol
        Womersley number (> 0).
    """
    if bk.is_casadi(alpha):
        return tube_boundary_layer_functions(alpha)[0]
    return Cx.from_complex(_womersley_zeta_exact(alpha))


# ---------------------------------------------------------------------------
# Gaussian (random-input) equivalent resistance
# ---------------------------------------------------------------------------
#: Flow models with a time-domain law whose nonlinear part the random-input (statistical)
#: linearization replaces: the smooth models.
STATISTICAL_FLOW_MODELS = ("quasi_steady", "womersley", "poiseuille")
#: ``E|x|^3 = sqrt(8/pi)`` for a standard Gaussian ``x``: the Gaussian-equivalent gain of
#: ``|u| u`` is ``sqrt(8/pi) sigma_u`` (against ``8 U/(3 pi)`` for a sine of amplitude U).
GAUSSIAN_QUADRATIC_FACTOR = math.sqrt(8.0 / math.pi)
#: Range in Re of the friction quadrature: Churchill's Phi equals 64 below the lower end
#: (to 1e-13), and a Gaussian of ``Re_sigma <= 1e6`` has no mass above the upper end.
_GAUSS_RE_RANGE = (1.0e3, 1.0e7)
#: Panel width in ln Re and Gauss-Legendre nodes per panel of that quadrature.
_GAUSS_PANEL, _GAUSS_NODES = 0.2, 8


@lru_cache(maxsize=1)
def _gaussian_friction_rule() -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``Re_j`` and weights (in ``ln Re``) of the friction-excess quadrature."""
    lo, hi = (math.log(v) for v in _GAUSS_RE_RANGE)
    n_panels = math.ceil((hi - lo) / _GAUSS_PANEL - 1e-9)
    edges = lo + _GAUSS_PANEL * np.arange(n_panels + 1)
    t, w = np.polynomial.legendre.leggauss(_GAUSS_NODES)
    h = 0.5 * _GAUSS_PANEL
    ln_re = (0.5 * (edges[:-1, None] + edges[1:, None]) + h * t).ravel()
    weights = np.tile(h * w, n_panels)
    re = np.exp(ln_re)
    re.flags.writeable = False
    weights.flags.writeable = False
    return re, weights


@lru_cache(maxsize=1)
def _smooth_excess() -> np.ndarray:
    """``Phi(Re_j) - 64`` on the quadrature nodes for a smooth tube (built once)."""
    re, _ = _gaussian_friction_rule()
    out = churchill_friction_re_product(re) - 64.0
    out.flags.writeable = False
    return out


def gaussian_friction_excess(reynolds_rms, relative_roughness=0.0):
    """``E[x^2 (Phi(Re_sigma |x|) - 64)]`` for a standard Gaussian ``x`` (any backend).

    The Gaussian-equivalent gain of the turbulent part of Churchill's friction
    (:func:`churchill_friction_re_product`), ``Phi = f Re``: for a tube velocity of RMS
    ``sigma_u`` and ``Re_sigma = rho sigma_u D_c / mu`` the friction drop
    ``L mu Phi(Re) u / (2 D^2)`` has the equivalent linear gain
    ``L mu (64 + gaussian_friction_excess(Re_sigma)) / (2 D^2)``.

    With ``r = Re_sigma x`` the expectation is ``2 integral (Phi(r) - 64) x^3 phi(x) d ln r``
    (``phi`` the standard normal density, ``x = r / Re_sigma``), evaluated by a composite
    8-point Gauss-Legendre rule on panels of 0.2 in ``ln r`` from ``Re = 10^3`` (below it
    ``Phi - 64 < 1e-13``) to ``10^7``: the nodes do not move with ``sigma_u``, so the sharp
    laminar-turbulent transition of the law is resolved once (relative error below 1e-9
    of ``64 + excess`` for ``Re_sigma <= 10^6``; a 64-node Gauss-Hermite rule in ``x`` errs
    by 0.6 % there). Smooth in ``Re_sigma``; zero (to 1e-13) for ``Re_sigma < 1000/9``.

    Parameters
    ----------
    reynolds_rms : float, array or CasADi scalar
        ``Re_sigma`` (> 0). NumPy arrays broadcast over a new trailing axis.
    relative_roughness : float or CasADi scalar
        ``eps / D_c``.
    """
    re, w = _gaussian_friction_rule()
    if bk.is_casadi(reynolds_rms, relative_roughness):
        import casadi as ca

        if isinstance(relative_roughness, int | float) and relative_roughness == 0.0:
            g = ca.DM(_smooth_excess())
        else:
            g = _churchill(ca.DM(re), relative_roughness, False)[0] - 64.0
        x = ca.DM(re) / reynolds_rms
        return ca.sum1(ca.DM(w) * g * x * x * x * ca.exp(-0.5 * x * x)) * (2.0 / _SQRT_2PI)
    if np.ndim(relative_roughness) == 0 and float(relative_roughness) == 0.0:
        g = _smooth_excess()
    else:
        g = churchill_friction_re_product(re, float(relative_roughness)) - 64.0
    x = re / np.asarray(reynolds_rms, dtype=float)[..., None]
    return (2.0 / _SQRT_2PI) * np.sum(w * g * x**3 * np.exp(-0.5 * x * x), axis=-1)


_SQRT_2PI = math.sqrt(2.0 * math.pi)


def gaussian_equivalent_resistance(flow: str, design, velocity_rms):
    """Gaussian-equivalent resistance of the tube's nonlinear pressure drop, Pa s/kg.

    ``C_nl = E[u dp_nl(u)] / (rho A_c sigma_u^2)`` for a Gaussian tube velocity of RMS
    ``sigma_u`` (statistical linearization; ``docs/random-response.md``), with ``dp_nl``
    the part of the pressure drop that is not linear in ``u``:

    * the minor loss ``K rho |u| u / 2`` (every model but ``poiseuille``):
      ``K sqrt(8/pi) sigma_u / (2 A_c)`` (closed form);
    * ``quasi_steady`` also the excess of Churchill's all-regime friction over the laminar
      law: ``L mu E[u^2 (Phi - 64)] / (2 D^2 rho A_c sigma_u^2)``
      (:func:`gaussian_friction_excess`).

    Frequency independent: one number for the whole spectrum. Any backend.

    Parameters
    ----------
    flow : {'quasi_steady', 'womersley', 'poiseuille'}
        The flow model (``poiseuille`` has no nonlinear part: 0).
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    velocity_rms : float, array or CasADi scalar
        ``sigma_u``, RMS of the tube's mean velocity, m/s (> 0).

    Returns
    -------
    float, array or CasADi scalar
        ``C_nl`` in Pa s/kg.
    """
    d = design
    area = d.capillary_area_m2
    if flow == "poiseuille":
        return 0.0 * velocity_rms
    if flow == "womersley":
        return d.minor_loss * GAUSSIAN_QUADRATIC_FACTOR * velocity_rms / (2.0 * area)
    if flow == "quasi_steady":
        rho, mu, dc = d.density_kg_m3, d.viscosity_pa_s, d.capillary_diameter_m
        friction_scale = d.capillary_length_m * mu / (rho * dc * dc)
        excess = gaussian_friction_excess(rho * velocity_rms * dc / mu, d.roughness_m / dc)
        return (
            friction_scale * excess + d.minor_loss * GAUSSIAN_QUADRATIC_FACTOR * velocity_rms
        ) / (2.0 * area)
    raise InputError(
        f"flow: the random-input (statistical) linearization needs a flow law with a "
        f"time-domain form; valid: {', '.join(STATISTICAL_FLOW_MODELS)}; got {flow!r}"
    )


def tube_end_length_m(design):
    """The extra plug length of the tube's two ends, ``2 x 0.8216 a`` (0 if switched off).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).

    Returns
    -------
    float or CasADi symbol
        m.
    """
    if not getattr(design, "tube_end_correction", False):
        return 0.0
    return FLANGED_END_CORRECTION * design.capillary_diameter_m  # 2 ends x 0.8216 (D/2)


def tube_end_reactance(design, omega) -> Cx:
    """The two ends' mass as a resistance: ``j w L_end / A_c`` (Pa s/kg, any backend).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.

    Returns
    -------
    Cx
    """
    x = omega * (tube_end_length_m(design) / design.capillary_area_m2)
    return Cx(0.0 * x, x)


def quasi_steady_reactance(design, omega):
    """``w`` times the quasi-steady tube's inertance: ``w ((4/3) L_c + L_end) / A_c``.

    Eq. 17's ``rho du/dt`` with the developed laminar profile (the 4/3 coefficient), plus
    the mass at the tube's two ends (:func:`tube_end_length_m`). Pa s/kg, any backend.

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.

    Returns
    -------
    float, ndarray or CasADi symbol
    """
    return ((QUASI_STEADY_INERTANCE_COEFFICIENT * design.capillary_length_m
             + tube_end_length_m(design)) * omega / design.capillary_area_m2)


def linear_resistance(flow: str, design, omega) -> Cx:
    """The part of ``C`` linear in the tube velocity, frequency dependent (any backend).

    ``quasi_steady``: Poiseuille's ``C_u`` plus the inertance ``j w (4/3) L / A_c``;
    ``womersley``: ``C_u zeta(alpha)`` (exact laminar oscillating flow); ``poiseuille``:
    ``C_u``. The limit of :func:`resistance` as the velocity amplitude goes to zero.

    Parameters
    ----------
    flow : {'quasi_steady', 'womersley', 'poiseuille'}
        The flow model.
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : array or CasADi symbol
        Angular frequency, rad/s.

    Returns
    -------
    Cx
        Resistance (real) and ``w`` times the inertance (imaginary), Pa s/kg.
    """
    d = design
    c_u = poiseuille_resistance(d)
    if flow == "quasi_steady":
        c_i = quasi_steady_reactance(d, omega)
        return Cx(c_u + 0.0 * c_i, c_i)
    if flow == "womersley":
        alpha = womersley_number(d, omega)
        zeta = womersley_zeta(alpha)
        return Cx(c_u * zeta.re, c_u * zeta.im) + tube_end_reactance(d, omega)
    if flow == "poiseuille":
        z = 0.0 * omega
        return Cx(c_u + z, z)
    raise InputError(
        f"flow: the random-input (statistical) linearization needs a flow law with a "
        f"time-domain form; valid: {', '.join(STATISTICAL_FLOW_MODELS)}; got {flow!r}"
    )


def statistical_resistance_function(flow: str, design, omega):
    """Return ``sigma_u -> C(w; sigma_u)``: linear part plus Gaussian-equivalent part.

    ``C = linear_resistance(w) + gaussian_equivalent_resistance(sigma_u)``: the
    frequency-dependent linear parts are computed once; each call adds the one
    frequency-independent equivalent resistance of the nonlinear drop at the tube
    velocity's RMS ``sigma_u`` (m/s). Any backend.

    Parameters
    ----------
    flow : {'quasi_steady', 'womersley', 'poiseuille'}
        The flow model.
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : array or CasADi symbol
        Angular frequency, rad/s.

    Returns
    -------
    callable
        ``sigma_u -> Cx``.
    """
    lin = linear_resistance(flow, design, omega)

    def c_statistical(velocity_rms):
        c_nl = gaussian_equivalent_resistance(flow, design, velocity_rms)
        return Cx(lin.re + c_nl, lin.im)

    return c_statistical
