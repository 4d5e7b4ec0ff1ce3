"""The distributed acoustic model of the spring: chambers and tube as one network.

The piston drives the volume velocity ``Q_p = j w A_p X`` into the top chamber's
piston end. The top chamber (a line, :func:`isodesign.spring.chamber.chamber_line`)
carries it to the tube's inlet; the tube (:func:`isodesign.spring.transmission_line.
tube_two_port`) to the bottom chamber, closed at its far end. The flow model's
resistance ``C`` (Pa s/kg) enters as its linear part ``C_lin`` (the Womersley impedance
``C_u zeta(alpha)`` for ``womersley``, Poiseuille plus the 4/3 inertance for
``quasi_steady``), which the line carries distributed along the tube as its series
impedance ``rho C_lin / L_c`` per length, plus the rest ``dC = C - C_lin`` (the minor
loss and the turbulent friction excess): half of ``rho dC`` at each end of the tube as a
series impedance. With ``r = rho dC / 2``::

    Z2 = Z_b + r                         (Z_b = ch_b / C_b, the bottom chamber, closed end)
    Z3 = (ch Z2 + B) / (C Z2 + ch) + r   (the tube and its inlet term)
    k  = j w A_p^2 (ch_t Z3 + B_t) / (C_t Z3 + ch_t)
    Q1 = Q_p / (C_t Z3 + ch_t),   Q2 = Q1 / (C Z2 + ch)

and the tube's representative velocity ``U^2 = (|Q1|^2 + |Q2|^2) / (2 A_c^2)`` (the mean
of the squared end velocities), which the harmonic and random closures use as the
lumped model uses ``|m_dot| / (rho A_c)``. With lumped chambers and tube this is
exactly Eq. 38 (``docs/acoustics.md``).

Every function evaluates on NumPy arrays and on CasADi symbols.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.spring.capillary import (
    STATISTICAL_FLOW_MODELS,
    linear_resistance,
    poiseuille_resistance,
    tube_end_reactance,
    womersley_number,
    womersley_zeta,
)
from isodesign.spring.chamber import chamber_line
from isodesign.spring.transmission_line import tube_two_port

__all__ = ["AcousticNetwork", "acoustic_network"]


@dataclass(frozen=True, eq=False)
class AcousticNetwork:
    """Frequency-only parts of the distributed model at given frequencies (any backend).

    Attributes
    ----------
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    top : tuple of Cx
        The top chamber's two-port ``(ch_t, B_t, C_t)``.
    tube : tuple of Cx
        The tube's two-port ``(ch, B, C)``.
    z_bottom : Cx
        The bottom chamber's input impedance ``ch_b / C_b``, Pa s/m^3.
    c_womersley : Cx
        The flow model's linear part of ``C``, which the line replaces (``C_u zeta(alpha)``
        for ``womersley``), Pa s/kg.
    rho, piston_area, tube_area : float or CasADi symbol
        Density, piston area and tube section.
    """

    omega: Any
    top: tuple
    tube: tuple
    z_bottom: Cx
    c_womersley: Cx
    rho: Any
    piston_area: Any
    tube_area: Any
    _cache: dict = field(default_factory=dict, repr=False)

    def take(self, idx) -> AcousticNetwork:
        """The network at a subset of flat NumPy points (``idx`` indexes every array)."""

        def t(x):
            if isinstance(x, Cx):
                return Cx(_t(x.re, idx), _t(x.im, idx))
            return _t(x, idx)

        return AcousticNetwork(
            omega=t(self.omega), top=tuple(t(c) for c in self.top),
            tube=tuple(t(c) for c in self.tube), z_bottom=t(self.z_bottom),
            c_womersley=t(self.c_womersley), rho=self.rho, piston_area=self.piston_area,
            tube_area=self.tube_area,
        )

    def _numpy(self) -> tuple | None:
        """The parts as NumPy complex arrays (built once), or None on CasADi symbols."""
        got = self._cache.get("np")
        if got is None:
            parts = (*self.top, *self.tube, self.z_bottom, self.c_womersley)
            if any(bk.is_casadi(p.re, p.im) for p in parts) or bk.is_casadi(self.omega):
                return None
            got = tuple(p.to_complex() for p in parts)
            self._cache["np"] = got
        return got

    def _solve_numpy(self, parts, c: Cx):
        """:meth:`_solve` with NumPy's complex arithmetic (one pass per operation)."""
        ch_t, _, c_t, ch, b, cc, zb, c_lin = parts
        re, im = np.asarray(c.re, float), np.asarray(c.im, float)
        r = ((re - c_lin.real) + 1j * (im - c_lin.imag)) * (0.5 * self.rho)
        z2 = zb + r
        den2 = cc * z2 + ch
        z3 = (ch * z2 + b) / den2 + r
        return z3, c_t * z3 + ch_t, den2

    def _solve(self, c: Cx):
        """``(N1, D1, den2)`` for the resistance ``c``, free of divisions (symbolic path).

        With ``N3 = ch Z2 + B + r den2`` (so that ``Z3 = N3 / den2``):
        ``N1 = ch_t N3 + B_t den2`` and ``D1 = C_t N3 + ch_t den2 = den1 den2``, so that
        ``Z_piston = N1 / D1`` and ``|Q1|^2 / |Q_p|^2 = |den2|^2 / |D1|^2``: one complex
        division for the stiffness, none for the gain (smaller derivatives in the NLP).
        """
        dc = c - self.c_womersley
        r = dc * (0.5 * self.rho)
        ch, b, cc = self.tube
        z2 = self.z_bottom + r
        den2 = cc * z2 + ch
        n3 = ch * z2 + b + r * den2
        ch_t, b_t, c_t = self.top
        return ch_t * n3 + b_t * den2, c_t * n3 + ch_t * den2, den2

    def stiffness(self, c: Cx) -> Cx:
        """Air stiffness ``k = j w A_p^2 (ch_t Z3 + B_t) / (C_t Z3 + ch_t)``, N/m.

        Parameters
        ----------
        c : Cx
            The flow model's resistance ``C``, Pa s/kg.
        """
        parts = self._numpy()
        if parts is not None:
            z3, den1, _ = self._solve_numpy(parts, c)
            zp = (parts[0] * z3 + parts[1]) / den1
            return Cx.from_complex(1j * (self.omega * self.piston_area**2) * zp)
        n1, d1, _ = self._solve(c)
        zp = n1 / d1
        s = self.omega * self.piston_area * self.piston_area
        return Cx(-s * zp.im, s * zp.re)

    def velocity_gain2(self, c: Cx):
        """``|U/X|^2 = w^2 A_p^2 (1 + 1/|den2|^2) / (2 A_c^2 |den1|^2)``, 1/s^2.

        Parameters
        ----------
        c : Cx
            The flow model's resistance ``C``, Pa s/kg.
        """
        g = self.omega * self.piston_area / self.tube_area
        parts = self._numpy()
        if parts is not None:
            _, den1, den2 = self._solve_numpy(parts, c)
            a1 = den1.real * den1.real + den1.imag * den1.imag
            a2 = den2.real * den2.real + den2.imag * den2.imag
            return 0.5 * g * g * (1.0 + 1.0 / a2) / a1
        _, d1, den2 = self._solve(c)
        return 0.5 * g * g * (den2.abs2() + 1.0) / d1.abs2()


def _t(x, idx):
    if np.ndim(x) == 0:
        return x
    return np.asarray(x)[idx]


def acoustic_network(design, omega, flow: str | None = None) -> AcousticNetwork:
    """The frequency-only parts of the distributed model (any backend).

    Parameters
    ----------
    design : SpringDesign
        The spring (fields may be CasADi symbols).
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s (> 0).
    flow : str, optional
        The flow model whose resistance the network will receive. Its linear part
        (:func:`isodesign.spring.capillary.linear_resistance`: Poiseuille plus the 4/3
        inertance for ``quasi_steady``, ``C_u zeta`` for ``womersley``), per unit length,
        is the line's series impedance, so the end terms are exactly the model's nonlinear
        part (minor loss, turbulent friction excess: passive) and the distributed model
        tends to the same flow model's lumped one at low frequency. ``None``: the exact
        laminar impedance ``C_u zeta``.

    Returns
    -------
    AcousticNetwork
    """
    if not bk.is_casadi(omega) and isinstance(omega, np.ndarray) and omega.size > 1:
        try:  # the closures evaluate the same design at the same frequencies many times
            return _cached_network(design, flow, omega.shape, omega.tobytes())
        except TypeError:  # a field that cannot be hashed (a symbol, an array): no cache
            pass
    return _network(design, omega, flow)


@lru_cache(maxsize=16)
def _cached_network(design, flow, shape, omega_bytes) -> AcousticNetwork:
    """:func:`_network` memoized on NumPy frequencies (the arrays are read-only)."""
    omega = np.frombuffer(omega_bytes, dtype=float).reshape(shape)
    net = _network(design, omega, flow)
    for part in (*net.top, *net.tube, net.z_bottom, net.c_womersley):
        for a in (part.re, part.im):
            if isinstance(a, np.ndarray):
                a.flags.writeable = False
    return net


def _network(design, omega, flow) -> AcousticNetwork:
    """The network's frequency-only parts (any backend), uncached."""
    d = design
    top = chamber_line(d, d.top_volume_m3, omega)
    ch_b, _, c_b = chamber_line(d, d.bottom_volume_m3, omega)
    if flow in STATISTICAL_FLOW_MODELS:
        # the line carries the tube's own linear law; the ends' mass (part of the flow
        # model's C) stays outside it, half at each end with the other end terms
        c_lin = linear_resistance(flow, d, omega) - tube_end_reactance(d, omega)
    else:
        zeta = womersley_zeta(womersley_number(d, omega))
        c_u = poiseuille_resistance(d)
        c_lin = Cx(c_u * zeta.re, c_u * zeta.im)
    tube = tube_two_port(d, omega, c_lin)
    return AcousticNetwork(
        omega=omega,
        top=top,
        tube=tube,
        z_bottom=ch_b / c_b,
        c_womersley=c_lin,
        rho=d.density_kg_m3,
        piston_area=d.piston_area_m2,
        tube_area=d.capillary_area_m2,
    )
