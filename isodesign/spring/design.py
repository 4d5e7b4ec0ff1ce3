"""The spring design: validated, immutable parameters of one dual-chamber spring.

A :class:`SpringDesign` holds SI values. Its fields may also be CasADi symbols
(the optimizer replaces N, V_t0, L_c, D_c by decision variables with
:func:`dataclasses.replace`); validation applies to numeric values only, and
every derived quantity is computed through :mod:`isodesign.numerics.backend` so it works
on both.

Paper references: Table 1 (:meth:`SpringDesign.reference`), Eq. 39 (N), Eq. 40
(k_s), Eq. 43 (:func:`piston_area_from_diaphragm`).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.domain import DESIGN_DOMAIN
from isodesign.errors import InputError, check_positive, check_range
from isodesign.numerics import backend as bk
from isodesign.spring.gas import AIR, P_ATM, Gas, pressure_from_load

__all__ = ["ACOUSTIC_MODELS", "SpringDesign", "piston_area_from_diaphragm"]

#: The acoustic models of tube and chambers (:attr:`SpringDesign.acoustics`); the first is
#: the default.
ACOUSTIC_MODELS = ("distributed", "lumped")


def piston_area_from_diaphragm(r1_m, r2_m):
    """Equivalent piston area of a rolling diaphragm, paper Eq. 43.

    ``A_p = dV_t/dx_p = pi (r2^2 + 2 r2 r1 + 4 r1^2 / 3)``, from the conical
    deformation of Fig. 10.

    Parameters
    ----------
    r1_m : float
        Radial width of the free (rolling) part of the diaphragm, m.
    r2_m : float
        Radius of the rigid piston, m.
    """
    r1 = check_positive("diaphragm_r1_m", r1_m, unit="m")
    r2 = check_positive("diaphragm_r2_m", r2_m, unit="m")
    return math.pi * (r2 * r2 + 2.0 * r2 * r1 + 4.0 * r1 * r1 / 3.0)


def _sym(x: Any) -> bool:
    return bk.is_casadi(x)


def _check_real(name: str, value: Any) -> None:
    """Strict types at the API's edge, as in design files: a real number, not a bool/str."""
    if _sym(value):
        return
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
    if isinstance(value, np.ndarray):
        ok = value.ndim == 0 and value.dtype.kind in "fiu"
    if not ok:
        shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
        raise InputError(f"{name}: expected a number, got {type(value).__name__} {shown}")


@dataclass(frozen=True)
class SpringDesign:
    """Parameters of one dual-chamber pneumatic spring (SI units).

    Parameters
    ----------
    volume_ratio : float
        N = V_b0 / V_t0 (Eq. 39), > 0.
    top_volume_m3 : float
        Top-chamber volume V_t0, m^3.
    capillary_length_m : float
        Capillary length L_c, m.
    capillary_diameter_m : float
        Capillary diameter D_c, m.
    piston_area_m2 : float
        Equivalent piston area A_p, m^2 (see :func:`piston_area_from_diaphragm`).
    pressure_pa : float
        Absolute static chamber pressure p0, Pa; must exceed atmospheric.
        :meth:`with_load` derives it from the payload (Eq. 1).
    temperature_k : float
        Static gas temperature T0, K.
    minor_loss : float
        Minor-loss coefficient K of the capillary inlet plus outlet (paper: 1.5).
    gas : Gas
        Gas properties (default air with Sutherland viscosity).
    polytropic_index : float or None
        Thermal process of the chambers: ``None`` = adiabatic (n = kappa, the
        paper's choice), otherwise n in [1, kappa] replacing kappa in Eqs. 12-15.
    roughness_m : float
        Absolute wall roughness of the capillary for the all-regime friction law.
    acoustics : {'distributed', 'lumped'}
        Acoustic model of tube and chambers. ``distributed`` (default): the tube as a
        lossy transmission line (viscous and thermal boundary layers) between chambers
        with plane-wave (longitudinal) modes (:mod:`isodesign.spring.acoustics`,
        ``docs/acoustics.md``). ``lumped``: the paper's uniform chamber pressures and
        incompressible tube slug (Eq. 38), valid while ``w l / c <= 0.3``.
    chamber_aspect_ratio : float
        Length over diameter of each (cylindrical) chamber, in (0.05, 20]; default 1. The
        plane waves run along the axis: the top chamber has the piston at one end and the
        tube at the other, the bottom chamber the tube at one end.
    chamber_heat_exchange : bool
        Heat exchange of the chamber gas with the walls (thermal boundary layer, a complex
        polytropic index between 1 and kappa with frequency). Off by default (adiabatic
        chambers, the paper's choice); exclusive with ``polytropic_index``.
    tube_end_correction : bool
        The mass of the gas entrained at each end of the capillary, where it opens flush
        into the chamber wall (a flanged end: ``0.8216 a`` of extra plug length per end,
        ``a = D_c/2``), added to the tube's inertance in both acoustic models for the
        ``quasi_steady`` and ``womersley`` flows (``docs/acoustics.md``, section 1). On by
        default; ``False`` gives the tube without ends (the model before the correction).
    """

    volume_ratio: Any
    top_volume_m3: Any
    capillary_length_m: Any
    capillary_diameter_m: Any
    piston_area_m2: float
    pressure_pa: float
    temperature_k: float = 288.15
    minor_loss: float = 1.5
    gas: Gas = field(default=AIR)
    polytropic_index: float | None = None
    roughness_m: float = 0.0
    acoustics: str = "distributed"
    chamber_aspect_ratio: float = 1.0
    chamber_heat_exchange: bool = False
    tube_end_correction: bool = True

    def __post_init__(self):
        for name in ("volume_ratio", "top_volume_m3", "capillary_length_m",
                     "capillary_diameter_m", "piston_area_m2", "pressure_pa", "temperature_k",
                     "minor_loss", "roughness_m"):
            _check_real(name, getattr(self, name))
        if self.polytropic_index is not None:
            _check_real("polytropic_index", self.polytropic_index)
        for name, unit in (
            ("volume_ratio", ""),
            ("top_volume_m3", "m^3"),
            ("capillary_length_m", "m"),
            ("capillary_diameter_m", "m"),
            ("piston_area_m2", "m^2"),
            ("temperature_k", "K"),
        ):
            v = getattr(self, name)
            if not _sym(v):
                object.__setattr__(self, name, check_positive(name, v, unit=unit))
        if not isinstance(self.gas, Gas):
            raise InputError(f"gas: expected an isodesign.Gas, got {type(self.gas).__name__}")
        p = check_range("pressure_pa", self.pressure_pa, P_ATM, None, lo_open=True, unit="Pa")
        object.__setattr__(self, "pressure_pa", p)
        for name, (lo, hi, unit) in DESIGN_DOMAIN.items():  # the models' numeric domain
            v = getattr(self, name)
            if not _sym(v) and not lo <= v <= hi:
                raise InputError(f"{name}: must be in [{lo:g}, {hi:g}]{' ' + unit if unit else ''}"
                                 f" (the models' domain), got {v:g}")
        object.__setattr__(
            self, "minor_loss", check_range("minor_loss", self.minor_loss, 0.0, 100.0)
        )
        object.__setattr__(
            self, "roughness_m", check_range("roughness_m", self.roughness_m, 0.0, None, unit="m")
        )
        if self.polytropic_index is not None:
            n = check_range(
                "polytropic_index", self.polytropic_index, 1.0, self.gas.heat_capacity_ratio
            )
            object.__setattr__(self, "polytropic_index", n)
        if self.acoustics not in ACOUSTIC_MODELS:
            raise InputError(f"acoustics: unknown value {self.acoustics!r}; valid: "
                             f"{', '.join(ACOUSTIC_MODELS)}")
        _check_real("chamber_aspect_ratio", self.chamber_aspect_ratio)
        object.__setattr__(self, "chamber_aspect_ratio", check_range(
            "chamber_aspect_ratio", self.chamber_aspect_ratio, 0.05, 20.0, lo_open=True))
        if not isinstance(self.chamber_heat_exchange, bool | np.bool_):
            raise InputError("chamber_heat_exchange: expected true or false, got "
                             f"{type(self.chamber_heat_exchange).__name__} "
                             f"{self.chamber_heat_exchange!r:.40}")
        object.__setattr__(self, "chamber_heat_exchange", bool(self.chamber_heat_exchange))
        if not isinstance(self.tube_end_correction, bool | np.bool_):
            raise InputError("tube_end_correction: expected true or false, got "
                             f"{type(self.tube_end_correction).__name__} "
                             f"{self.tube_end_correction!r:.40}")
        object.__setattr__(self, "tube_end_correction", bool(self.tube_end_correction))
        if self.chamber_heat_exchange and self.polytropic_index is not None:
            raise InputError("chamber_heat_exchange: exclusive with polytropic_index (the wall "
                             "heat exchange sets the polytropic index at each frequency)")
        if not _sym(self.capillary_diameter_m) and not _sym(self.capillary_length_m):
            if self.capillary_diameter_m >= self.capillary_length_m:
                raise InputError(
                    "capillary_diameter_m: must be smaller than capillary_length_m "
                    f"({self.capillary_diameter_m:g} >= {self.capillary_length_m:g} m): "
                    "the models assume a tube, not an orifice"
                )

    # -- constructors -----------------------------------------------------
    @classmethod
    def reference(cls) -> SpringDesign:
        """The paper's Table 1 spring.

        N is 1.5e-3 / 8.1e-4 = 1.852 from the volumes (the table rounds it to
        1.9); the viscosity is Table 1's fixed 1.79e-5 Pa s and the temperature
        288.1 K. Note that Table 1's p0 = 4.93e5 Pa with A_p = 5.3e-3 m^2 carries
        about 212 kg, not the 100 kg named in the text (docs/physics.md, section 1);
        :meth:`with_load` derives p0 from a payload instead.
        """
        return cls(
            volume_ratio=1.5e-3 / 8.1e-4,
            top_volume_m3=8.1e-4,
            capillary_length_m=1.2e-2,
            capillary_diameter_m=0.9e-3,
            piston_area_m2=5.3e-3,
            pressure_pa=4.93e5,
            temperature_k=288.1,
            minor_loss=1.5,
            gas=Gas(viscosity_pa_s=1.79e-5),
        )

    def with_load(self, mass_kg: float, n_isolators: int = 1, *, g_m_s2: float = 9.80665):
        """Copy with p0 derived from a payload shared by ``n_isolators`` springs (Eq. 1)."""
        p0 = pressure_from_load(mass_kg, n_isolators, self.piston_area_m2, g_m_s2=g_m_s2)
        return dataclasses.replace(self, pressure_pa=p0)

    def replace(self, **changes) -> SpringDesign:
        """Copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # -- derived quantities (backend-agnostic) ------------------------------
    @property
    def bottom_volume_m3(self):
        """V_b0 = N V_t0 (Eq. 39)."""
        return self.volume_ratio * self.top_volume_m3

    @property
    def total_volume_m3(self):
        """V_t0 (1 + N)."""
        return self.top_volume_m3 * (1 + self.volume_ratio)

    @property
    def process_index(self) -> float:
        """The thermal-process index n (kappa when adiabatic)."""
        if self.polytropic_index is None:
            return self.gas.heat_capacity_ratio
        return self.polytropic_index

    @property
    def density_kg_m3(self):
        """Static gas density rho = p0/(R T0)."""
        return self.gas.density(self.pressure_pa, self.temperature_k)

    @property
    def viscosity_pa_s(self):
        """Dynamic viscosity at T0."""
        return self.gas.viscosity(self.temperature_k)

    @property
    def speed_of_sound_m_s(self):
        """Speed of sound at T0."""
        return self.gas.speed_of_sound(self.temperature_k)

    @property
    def capillary_area_m2(self):
        """Capillary cross-section A_c = pi D_c^2 / 4."""
        return math.pi * self.capillary_diameter_m**2 / 4.0

    @property
    def single_chamber_stiffness_n_per_m(self):
        """k_s = n p0 A_p^2 / V_t0 (Eq. 40, with n = kappa when adiabatic)."""
        return self.process_index * self.pressure_pa * self.piston_area_m2**2 / self.top_volume_m3

    @property
    def static_stiffness_n_per_m(self):
        """Low-frequency limit of the air stiffness, k_s / (N + 1)."""
        return self.single_chamber_stiffness_n_per_m / (1 + self.volume_ratio)

    @property
    def compliance_factor_kg_per_pa(self):
        """Bottom-chamber mass compliance ``s = V_b0 / (n R T0)``, kg/Pa (= m s^2).

        The mass of gas the bottom chamber takes up per pascal of pressure rise
        (``dm = s dp``), so that ``tau = s C`` in Eq. 38 with C in Pa s/kg.
        """
        return self.bottom_volume_m3 / (
            self.process_index * self.gas.gas_constant_j_per_kg_k * self.temperature_k
        )

    @property
    def area_ratio(self):
        """A_p / A_c, the kinematic velocity gain of Eq. 37."""
        return self.piston_area_m2 / self.capillary_area_m2

    @property
    def load_n(self):
        """Load carried by the spring, A_p (p0 - p_atm) (Eq. 1)."""
        return self.piston_area_m2 * (self.pressure_pa - P_ATM)

    # -- serialization --------------------------------------------------------
    def to_dict(self) -> dict:
        """Plain dictionary of SI values (the TOML design-file schema)."""
        d = {
            "volume_ratio": float(self.volume_ratio),
            "top_volume_m3": float(self.top_volume_m3),
            "capillary_length_m": float(self.capillary_length_m),
            "capillary_diameter_m": float(self.capillary_diameter_m),
            "piston_area_m2": float(self.piston_area_m2),
            "pressure_pa": float(self.pressure_pa),
            "temperature_k": float(self.temperature_k),
            "minor_loss": float(self.minor_loss),
            "roughness_m": float(self.roughness_m),
        }
        if self.polytropic_index is not None:
            d["polytropic_index"] = float(self.polytropic_index)
        if self.acoustics != ACOUSTIC_MODELS[0]:
            d["acoustics"] = self.acoustics
        if self.chamber_aspect_ratio != 1.0:
            d["chamber_aspect_ratio"] = float(self.chamber_aspect_ratio)
        if self.chamber_heat_exchange:
            d["chamber_heat_exchange"] = True
        if not self.tube_end_correction:
            d["tube_end_correction"] = False
        g = self.gas
        gd = {
            "name": g.name,
            "gas_constant_j_per_kg_k": g.gas_constant_j_per_kg_k,
            "heat_capacity_ratio": g.heat_capacity_ratio,
        }
        if g.viscosity_pa_s is not None:
            gd["viscosity_pa_s"] = g.viscosity_pa_s
        if g.prandtl_number != 0.71:
            gd["prandtl_number"] = g.prandtl_number
        d["gas"] = gd
        return d
