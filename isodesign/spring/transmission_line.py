"""The capillary as a lossy acoustic transmission line (low-reduced-frequency solution).

Plane waves in a rigid circular tube with viscous and thermal boundary layers
(Zwikker and Kosten; Tijdeman; Stinson): for pressure ``p(x)`` and volume velocity
``Q(x)`` at angular frequency ``w``::

    dp/dx = -z Q,   dQ/dx = -y p
    z = j w rho / (A_c (1 - G(s)))                 series impedance per length
    y = j w A_c / (kappa p0) (1 + (kappa-1) G(s sqrt(Pr)))   shunt admittance per length
    G(s) = 2 J1(i^(3/2) s) / (i^(3/2) s J0(i^(3/2) s))

with the shear wave number ``s`` (the Womersley number ``alpha = (D_c/2) sqrt(w rho/mu)``)
and the thermal one ``s sqrt(Pr)``. ``z`` is exactly the Womersley impedance of the lumped
models per unit length: ``z L_c = rho C_u zeta(alpha)``
(:func:`isodesign.spring.capillary.womersley_zeta`), and ``G`` follows from the same
function, ``G(s) = 1 - j s^2 / (8 zeta(s))``, so both backends evaluate the Bessel
functions the way ``womersley_zeta`` does (scipy on NumPy, the B-spline to 1e-8 on CasADi).

The line of length ``L`` is the two-port ``[p1, Q1] = [[ch, z L sh], [y L sh, ch]] [p2, Q2]``
with ``theta^2 = z y L^2``, ``ch = cosh theta`` and ``sh = sinh theta / theta``
(:func:`line_functions`). Derivation: ``docs/acoustics.md``.
"""

from __future__ import annotations

import math

from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.spring.capillary import (
    tube_boundary_layer_functions,
    womersley_number,
    womersley_zeta,
)

__all__ = [
    "TRANSVERSE_MODE_FACTOR",
    "line_functions",
    "thermal_function",
    "tube_series_impedance",
    "tube_shunt_admittance",
    "tube_two_port",
]

#: First zero of J1': the first transverse (1,1) mode of a circular duct of diameter D
#: cuts on at ``f = 1.8412 c / (pi D)``; plane waves only below it.
TRANSVERSE_MODE_FACTOR = 1.8412


def thermal_function(s) -> Cx:
    """``G(s) = 2 J1(z) / (z J0(z))``, ``z = i^(3/2) s``: the boundary-layer function.

    From the Womersley impedance ``zeta(s) = j s^2 / (8 (1 - G(s)))``:
    ``G = 1 - j s^2 / (8 zeta(s))``. Limits: ``1 - j s^2/8 - s^4/48`` as s -> 0 (no
    boundary layer: isothermal, viscous-dominated), ``(1 - j) sqrt(2) / s`` as s -> inf.

    Parameters
    ----------
    s : float, ndarray or CasADi symbol
        Shear or thermal wave number (> 0; the CasADi form covers 1e-3 to 1e3).

    Returns
    -------
    Cx
    """
    zeta = womersley_zeta(s)
    m = s * s / (8.0 * zeta.abs2())
    # j s^2 / (8 zeta) = j conj(zeta) m = (zeta_i + j zeta_r) m
    return Cx(1.0 - m * zeta.im, -m * zeta.re)


def tube_series_impedance(design, omega) -> Cx:
    """Series impedance per unit length ``z = 128 mu zeta(alpha) / (pi D_c^4)``, Pa s/m^4.

    For the volume velocity (``dp/dx = -z Q``); ``z L_c = rho C_u zeta``, the lumped
    Womersley tube.

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    d = design
    zeta, _ = tube_boundary_layer_functions(womersley_number(d, omega), d.gas.prandtl_number)
    scale = 128.0 * d.viscosity_pa_s / (math.pi * bk.ipow(d.capillary_diameter_m, 4))
    return Cx(scale * zeta.re, scale * zeta.im)


def tube_shunt_admittance(design, omega) -> Cx:
    """Shunt admittance per length ``y = j w A_c (1 + (kappa-1) G(alpha sqrt Pr))/(kappa p0)``.

    In m^3/(Pa s m). The tube's gas is isothermal at low frequency (``G -> 1``, ``y -> j w
    A_c / p0``) and adiabatic at high frequency, whatever the chambers' process.

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    return _shunt_admittance(design, omega, design.capillary_area_m2)


def _shunt_admittance(design, omega, area) -> Cx:
    """``j w area (1 + (kappa-1) G) / (kappa p0)``: ``y`` for the section, ``y L_c`` for
    the tube's volume (the design factor apart from ``w`` is computed once in the NLP)."""
    d = design
    kappa = d.gas.heat_capacity_ratio
    _, g = tube_boundary_layer_functions(womersley_number(d, omega), d.gas.prandtl_number)
    scale = omega * (area / (kappa * d.pressure_pa))
    # j scale (1 + (kappa-1) G)
    return Cx(-scale * (kappa - 1.0) * g.im, scale * (1.0 + (kappa - 1.0) * g.re))


def _sqrt_upper(w: Cx) -> Cx:
    """Square root with a positive imaginary part of ``w`` in the upper half plane.

    ``q = sqrt((|w| - Re w)/2)``, ``p = Im w / (2 q)``: no cancellation for ``Re w <= 0``
    (every lossy line here: ``z`` and ``y`` lie in the first quadrant), smooth for
    ``w != 0``.
    """
    r = bk.sqrt(w.abs2())
    q = bk.sqrt(0.5 * (r - w.re))
    return Cx(0.5 * w.im / q, q)


def line_functions(zyl2: Cx) -> tuple[Cx, Cx]:
    """``(cosh theta, sinh theta / theta)`` for ``theta^2 = zyl2`` (any backend).

    ``theta = p + j q`` is the root in the upper half plane (:func:`_sqrt_upper`);
    ``cosh theta = cosh p cos q + j sinh p sin q`` and ``sinh theta = sinh p cos q + j
    cosh p sin q``. Both results are even in ``theta``, so the root chosen does not matter.

    Parameters
    ----------
    zyl2 : Cx
        ``z y L^2`` with ``Im >= 0`` or ``Re < 0`` (and not 0).

    Returns
    -------
    tuple of Cx
    """
    th = _sqrt_upper(zyl2)
    ep, em = bk.exp(th.re), bk.exp(-th.re)
    chp, shp = 0.5 * (ep + em), 0.5 * (ep - em)
    cq, sq = bk.cos(th.im), bk.sin(th.im)
    ch = Cx(chp * cq, shp * sq)
    sh = Cx(shp * cq, chp * sq) / th
    return ch, sh


def tube_two_port(design, omega, series_resistance: Cx | None = None) -> tuple[Cx, Cx, Cx]:
    """The tube's two-port ``(ch, B, C)``: ``p1 = ch p2 + B Q2``, ``Q1 = C p2 + ch Q2``.

    ``B = z L sh`` and ``C = y L sh`` (:func:`line_functions`); ``Q`` flows from end 1 (top
    chamber) to end 2 (bottom chamber). As ``w -> 0``: ``B -> rho C_u zeta`` (the lumped
    Womersley tube with its inertance), ``C -> j w V_c / p0`` (the tube's own volume).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    series_resistance : Cx, optional
        The flow model's linear resistance ``C_lin`` of the whole tube (Pa s/kg), whose
        ``rho C_lin / L_c`` becomes the series impedance per length; default the exact
        laminar one, ``C_u zeta`` (:func:`tube_series_impedance`).

    Returns
    -------
    tuple of Cx
        ``(ch, B, C)``.
    """
    d = design
    if series_resistance is None:
        zl = tube_series_impedance(d, omega) * d.capillary_length_m
    else:  # rho C_lin / L_c per length: z L = rho C_lin
        zl = series_resistance * d.density_kg_m3
    yl = _shunt_admittance(d, omega, d.capillary_area_m2 * d.capillary_length_m)  # y L
    ch, sh = line_functions(zl * yl)
    return ch, zl * sh, yl * sh
