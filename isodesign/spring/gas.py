"""Gas state of the chambers: density, viscosity, thermal process, pressure.

Paper references (Sections 3.1.1-3.1.2):

* Eq. 1 ``f_p = A_p (p0 - p_atm)``: static equilibrium, used by
  :func:`pressure_from_load` to derive the chamber pressure from the payload.
* Eq. 4 ideal gas ``p0 V = m R T0``: :meth:`Gas.density`.
* Eqs. 12-15: adiabatic chambers; a polytropic process replaces ``kappa`` by
  an index ``n`` in [1, kappa] (isothermal 1, adiabatic kappa).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from isodesign.domain import DESIGN_DOMAIN, GAS_DOMAIN
from isodesign.errors import InputError, check_positive, check_range
from isodesign.numerics import backend as bk

__all__ = ["AIR", "G_STANDARD", "P_ATM", "Gas", "pressure_from_load"]

#: Standard atmospheric pressure, Pa (paper: p_atm = 101.325 kPa).
P_ATM = 101_325.0
#: Standard gravity, m/s^2.
G_STANDARD = 9.80665


@dataclass(frozen=True)
class Gas:
    """An ideal gas with Sutherland viscosity.

    Parameters
    ----------
    name : str
        Label.
    gas_constant_j_per_kg_k : float
        Specific gas constant R (paper Table 1: 286.9 J/(kg K) for air).
    heat_capacity_ratio : float
        kappa = c_p / c_v (1.4 for air).
    viscosity_pa_s : float or None
        Fixed dynamic viscosity. ``None`` (default) uses Sutherland's law.
        Table 1 passes 1.79e-5 Pa s, which Sutherland gives at 288.1 K.
    sutherland_mu_ref_pa_s, sutherland_t_ref_k, sutherland_s_k : float
        Sutherland constants (air: 1.716e-5 Pa s at 273.15 K, S = 110.4 K).
    prandtl_number : float
        Prandtl number ``mu c_p / lambda`` (air: 0.71, nearly independent of p and T): the
        thermal boundary layers of the tube and the chambers (``docs/acoustics.md``).
    """

    name: str = "air"
    gas_constant_j_per_kg_k: float = 286.9
    heat_capacity_ratio: float = 1.4
    viscosity_pa_s: float | None = None
    sutherland_mu_ref_pa_s: float = 1.716e-5
    sutherland_t_ref_k: float = 273.15
    sutherland_s_k: float = 110.4
    prandtl_number: float = 0.71

    def __post_init__(self):
        check_positive("gas.gas_constant_j_per_kg_k", self.gas_constant_j_per_kg_k)
        check_range("gas.heat_capacity_ratio", self.heat_capacity_ratio, 1.0, 1.7, lo_open=True)
        if self.viscosity_pa_s is not None:
            check_positive("gas.viscosity_pa_s", self.viscosity_pa_s, unit="Pa s")
        for name, (lo, hi, unit) in GAS_DOMAIN.items():  # the models' numeric domain
            v = getattr(self, name)
            if v is not None:
                check_range(f"gas.{name}", v, lo, hi, unit=unit)
        check_positive("gas.sutherland_mu_ref_pa_s", self.sutherland_mu_ref_pa_s)
        check_positive("gas.sutherland_t_ref_k", self.sutherland_t_ref_k)
        check_positive("gas.sutherland_s_k", self.sutherland_s_k)
        check_range("gas.prandtl_number", self.prandtl_number, 0.1, 10.0)

    def viscosity(self, temperature_k):
        """Dynamic viscosity mu(T) in Pa s (Sutherland, or the fixed value)."""
        if self.viscosity_pa_s is not None:
            return self.viscosity_pa_s
        t_ref, s = self.sutherland_t_ref_k, self.sutherland_s_k
        return (
            self.sutherland_mu_ref_pa_s
            * bk.power(temperature_k / t_ref, 1.5)
            * (t_ref + s)
            / (temperature_k + s)
        )

    def density(self, pressure_pa, temperature_k):
        """Density rho = p / (R T) in kg/m^3 (paper Eq. 4)."""
        return pressure_pa / (self.gas_constant_j_per_kg_k * temperature_k)

    def thermal_diffusivity(self, pressure_pa, temperature_k):
        """Thermal diffusivity ``chi = lambda/(rho c_p) = mu/(rho Pr)`` in m^2/s."""
        return self.viscosity(temperature_k) / (
            self.density(pressure_pa, temperature_k) * self.prandtl_number
        )

    def speed_of_sound(self, temperature_k):
        """Adiabatic speed of sound sqrt(kappa R T) in m/s."""
        return bk.sqrt(self.heat_capacity_ratio * self.gas_constant_j_per_kg_k * temperature_k)


#: Air as in the paper's Table 1 (R = 286.9, kappa = 1.4, Sutherland viscosity).
AIR = Gas()


def pressure_from_load(
    mass_kg: float,
    n_isolators: int,
    piston_area_m2: float,
    *,
    p_atm_pa: float = P_ATM,
    g_m_s2: float = G_STANDARD,
) -> float:
    """Absolute chamber pressure that carries a payload, from Eq. 1.

    ``p0 = p_atm + m g / (n A_p)``: each of ``n_isolators`` identical springs
    carries an equal share of the weight.

    Parameters
    ----------
    mass_kg : float
        Supported mass (> 0).
    n_isolators : int
        Number of identical isolators sharing the load (>= 1).
    piston_area_m2 : float
        Effective piston area A_p of one isolator.
    p_atm_pa : float
        Ambient (gauge reference) pressure, Pa.
    g_m_s2 : float
        Gravitational acceleration, m/s^2.

    Returns
    -------
    float
        p0 in Pa (absolute).
    """
    m = check_positive("mass_kg", mass_kg, unit="kg")
    a = check_positive("piston_area_m2", piston_area_m2, unit="m^2")
    if (isinstance(n_isolators, bool) or not isinstance(n_isolators, int | float)
            or int(n_isolators) != n_isolators or not 1 <= n_isolators <= 10**6):
        raise InputError(f"n_isolators: must be an integer in [1, 1000000], got "
                         f"{n_isolators!r:.40}")
    g = check_range("g_m_s2", g_m_s2, 0.0, 100.0, lo_open=True, unit="m/s^2")
    pa = check_range("p_atm_pa", p_atm_pa, 0.0, 1e7, unit="Pa")
    p0 = pa + m * g / (int(n_isolators) * a)
    if not math.isfinite(p0):
        raise InputError(
            f"mass_kg: {m:g} kg on {int(n_isolators)} isolators of {a:g} m^2 needs a chamber "
            "pressure beyond floating point; give a physical payload"
        )
    if not p0 > pa:
        raise InputError(
            f"mass_kg: {m:g} kg on {int(n_isolators)} isolators of {a:g} m^2 adds nothing to "
            f"the atmosphere's {pa:g} Pa in floating point; give a physical payload"
        )
    p_hi = DESIGN_DOMAIN["pressure_pa"][1]
    if p0 > p_hi:
        raise InputError(
            f"mass_kg: {m:g} kg on {int(n_isolators)} isolators of {a:g} m^2 needs p0 = "
            f"{p0:.3g} Pa, beyond the models' domain ({p_hi:g} Pa); give a physical payload"
        )
    return p0
