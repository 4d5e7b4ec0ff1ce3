"""How far the lumped acoustic model is from the distributed one: a first-order estimate.

The lumped model (Eq. 38: uniform chamber pressures, an incompressible slug in the tube) is
the distributed network of :mod:`isodesign.spring.acoustics` with every two-port replaced by
its limit at zero length. Expanding each line's two-port in its propagation constant
(``docs/acoustics.md``, section 4) gives the lumped model's error to first order:

* a chamber of length ``l`` (from its volume and ``chamber_aspect_ratio``,
  :func:`isodesign.spring.chamber.chamber_dimensions`), ``x = w l / c_n``:
  ``ch = 1 - x^2/2``, ``B = j w M (1 - x^2/6)``, ``C = j w C_V (1 - x^2/6)`` (``M = rho l/S``,
  ``C_V = V/(n p0)``, ``w^2 M C_V = x^2``); for the piston-driven top chamber in front of
  the admittance ``Y_in`` this changes the piston admittance by
  ``dY_top = x^2 (j w C_V / 3 + Y_in) - j w M Y_in^2``, and the closed bottom chamber's
  admittance by ``dy_b = j w C_V x^2 / 3``;
* the tube (series ``Z = rho C_lin``, shunt ``Y_t = y L_c``, ``theta^2 = Z Y_t``, the end terms
  ``r`` outside): ``ch = 1 + theta^2/2``, ``B = Z (1 + theta^2/6)``, ``C = Y_t``; the lumped
  slug has ``ch = 1``, ``B = Z``, ``C = 0`` (no gas volume in the tube: at low frequency this
  term alone is ``n V_c / V_total``).

Each change reaches the piston through the lumped network's own sensitivities
(``dY_in = (dC + dD y_b - Y_in (dA + dB y_b)) / (1 + Z_s y_b)``), so the estimate grows near
the tube's resonance where the lumped model is sensitive, and the relative error of ``k`` is
``|dY_p / Y_p|``. NumPy only (a diagnostic).
"""

from __future__ import annotations

import numpy as np

from isodesign.spring.acoustics import acoustic_network
from isodesign.spring.chamber import chamber_dimensions
from isodesign.spring.transmission_line import tube_shunt_admittance

__all__ = ["LUMPED_TOLERANCE", "lumped_error_estimate"]

#: The tolerance the ``lumped`` check states: the lumped model's air stiffness within this
#: fraction of the distributed model's (first-order estimate, docs/acoustics.md section 4).
LUMPED_TOLERANCE = 0.01


def _cx(v) -> np.ndarray:
    return v.to_complex() if hasattr(v, "to_complex") else np.asarray(v, dtype=complex)


def lumped_error_estimate(design, omega, c, flow: str | None = None) -> dict[str, np.ndarray]:
    """First-order relative error of the lumped air stiffness against the distributed one.

    Parameters
    ----------
    design : SpringDesign
        The spring (NumPy fields).
    omega : ndarray
        Angular frequency, rad/s (broadcastable with ``c``).
    c : Cx or complex ndarray
        The flow resistance ``C`` at the points, Pa s/kg.
    flow : str, optional
        The flow model that gave ``c`` (its linear part is what the line distributes).

    Returns
    -------
    dict of str to ndarray
        ``total`` (``|dk/k|``, the estimate the ``lumped`` check compares with
        :data:`LUMPED_TOLERANCE`) and the parts ``top_chamber``, ``bottom_chamber`` and
        ``tube`` (each alone), and ``tube_theta2``, the tube's ``|theta^2|`` (the
        expansion's parameter).
    """
    d = design
    w = np.asarray(omega, dtype=float)
    c = _cx(c)
    rho, p0, n = d.density_kg_m3, d.pressure_pa, d.process_index
    cn = np.sqrt(n * p0 / rho)
    jw = 1j * w
    # the lumped network (Eq. 38)
    cv_t = d.top_volume_m3 / (n * p0)
    cv_b = d.bottom_volume_m3 / (n * p0)
    z_s = rho * c
    y_b = jw * cv_b
    den = 1.0 + z_s * y_b
    y_in = y_b / den
    y_p = jw * cv_t + y_in
    # top chamber
    l_t, _ = chamber_dimensions(d, d.top_volume_m3)
    x2_t = (w * l_t / cn) ** 2
    m_t = rho * l_t * l_t / d.top_volume_m3
    dy_top = x2_t * (jw * cv_t / 3.0 + y_in) - jw * m_t * y_in * y_in
    # bottom chamber
    l_b, _ = chamber_dimensions(d, d.bottom_volume_m3)
    dy_b = jw * cv_b * (w * l_b / cn) ** 2 / 3.0
    dy_bottom = dy_b / (den * den)
    # tube: its linear part distributed, the rest r at each end
    net = acoustic_network(d.replace(acoustics="distributed"), w, flow)
    z_lin = rho * _cx(net.c_womersley)
    y_t = _cx(tube_shunt_admittance(d, w)) * d.capillary_length_m
    r = 0.5 * (z_s - z_lin)
    th2 = z_lin * y_t
    da = th2 / 2.0 + r * y_t
    db = th2 * r + z_lin * th2 / 6.0 + r * r * y_t
    dc = y_t
    dy_tube = (dc + da * y_b - y_in * (da + db * y_b)) / den
    scale = 1.0 / np.abs(y_p)
    parts = {
        "top_chamber": np.abs(dy_top) * scale,
        "bottom_chamber": np.abs(dy_bottom) * scale,
        "tube": np.abs(dy_tube) * scale,
    }
    parts["total"] = np.abs(dy_top + dy_bottom + dy_tube) * scale
    parts["tube_theta2"] = np.abs(th2) + 0.0 * scale
    return parts
