"""The chambers as acoustic volumes: a cylinder with plane waves along its axis.

Each chamber is a cylinder of volume ``V`` and aspect ratio ``a = l / D``
(:attr:`SpringDesign.chamber_aspect_ratio`): ``D = (4 V / (pi a))^(1/3)``, ``l = a D``,
section ``S = V / l``. Below the first transverse mode (``f < 1.8412 c / (pi D)``) the
pressure field is a sum of plane waves along the axis; the chamber is the lossless line::

    dp/dx = -(j w rho / S) Q,    dQ/dx = -(j w S / (n p0)) F p

of length ``l``, with ``F = 1`` for adiabatic (or polytropic ``n``) gas and, with wall
heat exchange (:attr:`SpringDesign.chamber_heat_exchange`), ``n = kappa`` and the
thermal boundary-layer factor ``F = 1 + (kappa - 1) tanh(x) / x``, ``x = (1 + j) h /
delta_t``, ``h = V / S_wall`` and ``delta_t = sqrt(2 chi / w)`` (the exact solution for a
gas layer of thickness ``2h`` between isothermal walls): the complex polytropic index
``n(w) = kappa / F`` runs from 1 (``w -> 0``) to kappa (``w -> inf``).

Its longitudinal modes are ``f_m = m c / (2 l)`` (closed at both ends); the top chamber
has the piston at one end and the tube at the other, the bottom chamber the tube at
one end and a closed end at the other. Derivation: ``docs/acoustics.md``.
"""

from __future__ import annotations

import math

from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.spring.transmission_line import TRANSVERSE_MODE_FACTOR, line_functions

__all__ = [
    "chamber_dimensions",
    "chamber_heat_exchange_factor",
    "chamber_line",
    "first_longitudinal_mode_hz",
    "first_transverse_mode_hz",
    "polytropic_index",
]


def chamber_dimensions(design, volume_m3):
    """``(length_m, diameter_m)`` of a cylindrical chamber of the design's aspect ratio.

    Parameters
    ----------
    design : SpringDesign
        Gives ``chamber_aspect_ratio`` (length / diameter).
    volume_m3 : float, ndarray or CasADi symbol
        Chamber volume, m^3.
    """
    a = design.chamber_aspect_ratio
    diameter = bk.power(4.0 * volume_m3 / (math.pi * a), 1.0 / 3.0)
    return a * diameter, diameter


def first_longitudinal_mode_hz(design, volume_m3):
    """First longitudinal mode ``c / (2 l)`` of a closed cylinder (adiabatic), Hz.

    Parameters
    ----------
    design : SpringDesign
        The spring (chamber shape, gas, temperature).
    volume_m3 : float, ndarray or CasADi symbol
        Chamber volume, m^3.
    """
    length, _ = chamber_dimensions(design, volume_m3)
    return design.speed_of_sound_m_s / (2.0 * length)


def first_transverse_mode_hz(design, volume_m3):
    """Cut-on of the first transverse mode ``1.8412 c / (pi D)``, Hz: plane waves below it.

    Parameters
    ----------
    design : SpringDesign
        The spring (chamber shape, gas, temperature).
    volume_m3 : float, ndarray or CasADi symbol
        Chamber volume, m^3.
    """
    _, diameter = chamber_dimensions(design, volume_m3)
    return TRANSVERSE_MODE_FACTOR * design.speed_of_sound_m_s / (math.pi * diameter)


def chamber_heat_exchange_factor(design, volume_m3, omega) -> Cx:
    """``F = 1 + (kappa - 1) tanh(x)/x``, ``x = (1 + j) h sqrt(w / (2 chi))`` (any backend).

    ``h = V / S_wall`` (volume over the whole wall area of the cylinder, ends included);
    ``chi`` the gas's thermal diffusivity. The chamber's compliance is ``V F / (kappa
    p0)``: ``F -> kappa`` (isothermal) as ``w -> 0``, ``F -> 1`` (adiabatic) as ``w -> inf``.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    volume_m3 : float, ndarray or CasADi symbol
        Chamber volume, m^3.
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    d = design
    length, diameter = chamber_dimensions(d, volume_m3)
    wall = math.pi * diameter * (length + 0.5 * diameter)
    h = volume_m3 / wall
    chi = d.gas.thermal_diffusivity(d.pressure_pa, d.temperature_k)
    p = h * bk.sqrt(omega / (2.0 * chi))
    # tanh((1+j) p) = ((1 - e^2) + 2 j e sin 2p) / ((1 + e^2) + 2 e cos 2p), e = exp(-2p)
    e = bk.exp(-2.0 * p)
    t = Cx(1.0 - e * e, 2.0 * e * bk.sin(2.0 * p)) / Cx(1.0 + e * e + 2.0 * e * bk.cos(2.0 * p),
                                                        0.0 * p)
    f = t / Cx(p, p)
    kappa = d.gas.heat_capacity_ratio
    return Cx(1.0 + (kappa - 1.0) * f.re, (kappa - 1.0) * f.im)


def polytropic_index(design, volume_m3, omega) -> Cx:
    """The chamber's complex polytropic index ``n(w)`` (``kappa / F`` with heat exchange).

    Without heat exchange it is the design's process index (kappa, or the polytropic
    index given), real.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    volume_m3 : float, ndarray or CasADi symbol
        Chamber volume, m^3.
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    """
    if not design.chamber_heat_exchange:
        return Cx(design.process_index + 0.0 * omega, 0.0 * omega)
    f = chamber_heat_exchange_factor(design, volume_m3, omega)
    return design.gas.heat_capacity_ratio / f


def chamber_line(design, volume_m3, omega) -> tuple[Cx, Cx, Cx]:
    """The chamber's two-port along its axis, ``(ch, B, C)`` as for the tube.

    ``B = (j w rho l / S) sh`` and ``C = (j w V F / (n p0)) sh`` with ``theta^2 = -w^2
    rho l^2 F / (n p0)``; lossless (real ``theta / j``) without heat exchange.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    volume_m3 : float, ndarray or CasADi symbol
        Chamber volume, m^3.
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.

    Returns
    -------
    tuple of Cx
    """
    d = design
    length, _ = chamber_dimensions(d, volume_m3)
    rho, p0 = d.density_kg_m3, d.pressure_pa
    # design factors apart from w (the NLP computes them once per design)
    inertance = rho * length * length / volume_m3  # rho l / S
    mass = omega * inertance  # w rho l / S
    if not d.chamber_heat_exchange:
        compliance = volume_m3 / (d.process_index * p0)  # V / (n p0)
        comp = omega * compliance  # w V / (n p0)
        kl = omega * bk.sqrt(inertance * compliance)  # w l / c_n
        ch = Cx(bk.cos(kl), 0.0 * kl)
        sinc = bk.sin(kl) / kl
        return ch, Cx(0.0 * kl, mass * sinc), Cx(0.0 * kl, comp * sinc)
    f = chamber_heat_exchange_factor(d, volume_m3, omega)
    comp = f * (omega * (volume_m3 / (d.gas.heat_capacity_ratio * p0)))  # w V F / (kappa p0)
    # (j mass)(j comp) = -mass comp
    ch, sh = line_functions(Cx(-mass * comp.re, -mass * comp.im))
    return ch, Cx(0.0 * mass, mass) * sh, Cx(-comp.im, comp.re) * sh
