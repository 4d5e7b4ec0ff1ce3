"""The capillary flow models, registered once each.

A flow model gives the complex resistance ``C(U, w) = (P_t - P_b) / m_dot`` (Pa s/kg,
paper Eq. 35) of the capillary as a function of the tube's velocity amplitude ``U`` and
the angular frequency ``w``. Everything the package knows about a model is in its
:class:`FlowModel` entry of :data:`FLOW_MODEL_REGISTRY`:

* its name and a one-line description (the CLI's ``--flow`` choices come from here);
* its resistance function (:attr:`FlowModel.resistance_function`);
* whether it is smooth and written for CasADi symbols, so that it may enter the NLP
  (:attr:`FlowModel.smooth`);
* whether its small-amplitude resistance is affine in ``s`` (a python-control transfer
  function, :attr:`FlowModel.rational`);
* whether the time-domain simulator has it (:attr:`FlowModel.time_domain`);
* whether the self-consistent amplitude (harmonic balance) is defined for it;
* its validity checks (:class:`FlowCheck`), evaluated by
  :func:`isodesign.spring.diagnostics.evaluate_diagnostics`.

Adding a model is one :func:`_register` call below (and its tests). The name tuples
:data:`FLOW_MODELS`, :data:`SMOOTH_FLOW_MODELS`, :data:`RATIONAL_FLOW_MODELS` and
:data:`SIMULATION_FLOW_MODELS` are derived from the registry.

Models, by name:

``quasi_steady``
    All-regime steady friction (Churchill 1977, laminar to turbulent joined smoothly)
    plus the minor loss K, linearized by the describing function of Eq. 22, plus the
    inertance of the air in the tube (Eq. 17's ``rho du/dt``, kept, with the
    developed-laminar coefficient 4/3). Passive for every input. The default.
``womersley``
    Exact laminar oscillating flow in a rigid tube (Womersley; ``docs/physics.md``,
    section 4) plus the minor loss K. Passive. Frequency-dependent resistance and
    inertance (4/3 of the plug value at low frequency).
``poiseuille``
    Unidirectional laminar flow, Eq. 41: ``C_u = 128 mu L_c / (pi rho D_c^4)``; the
    linear model of earlier work (Harris, DeBra, Erin & Wilson). No minor loss, no
    inertia.
``zhao``
    The paper's oscillating-flow friction, Eq. 24 (laminar correlation) in Eq. 36 with
    the minor loss K, literally as printed. Singular at Re_w = 3.673 and non-passive
    near it (``docs/physics.md``, section 2). NumPy only: it never enters an optimizer.
``zhao_turbulent``
    The same with Eq. 25 (the turbulent correlation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.spring.capillary import (
    LAMINAR_REYNOLDS_LIMIT,
    QUASI_STEADY_WOMERSLEY_LIMIT,
    ZHAO_RANGES,
    churchill_friction_re_product,
    describing_velocity,
    kinetic_reynolds,
    poiseuille_resistance,
    quasi_steady_reactance,
    tube_end_reactance,
    womersley_number,
    womersley_zeta,
    zhao_friction,
)

__all__ = [
    "FLOW_MODELS",
    "FLOW_MODEL_REGISTRY",
    "RATIONAL_FLOW_MODELS",
    "SIMULATION_FLOW_MODELS",
    "SMOOTH_FLOW_MODELS",
    "FlowCheck",
    "FlowModel",
    "FlowPoint",
    "flow_check_descriptions",
    "flow_model",
    "model_design",
    "resistance",
    "resistance_function",
]


# ---------------------------------------------------------------------------
# the registry's types
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class FlowPoint:
    """Flow quantities at evaluated points, the input of the validity checks (NumPy).

    Attributes
    ----------
    reynolds : ndarray
        Steady Reynolds number at the peak velocity, ``rho U D_c / mu``.
    kinetic_reynolds : ndarray
        ``Re_w = rho w D_c^2 / mu`` (on the frequency axis, broadcastable).
    womersley_number : ndarray
        ``alpha = sqrt(Re_w) / 2`` (on the frequency axis, broadcastable).
    dimensionless_amplitude : ndarray
        ``A0 = x_max / D_c`` with ``x_max = U / w``.
    laminar_k_error : ndarray or None
        ``|k / k_exact - 1|``: the air stiffness with the model's linear law against the one
        with the exact laminar oscillating impedance ``C_u zeta(alpha)`` (same nonlinear
        part, same acoustics), where the diagnostics compute it (``quasi_steady``).
    """

    reynolds: np.ndarray
    kinetic_reynolds: np.ndarray
    womersley_number: np.ndarray
    dimensionless_amplitude: np.ndarray
    laminar_k_error: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class FlowCheck:
    """One named validity check of a flow model.

    Attributes
    ----------
    name : str
        Key in :attr:`isodesign.spring.diagnostics.Diagnostics.checks` (CSV column
        ``ok_<name>``).
    description : str
        What passing means, for warnings and reports.
    passes : callable
        ``FlowPoint -> bool ndarray`` (True = inside the model's validity).
    """

    name: str
    description: str
    passes: Callable[[FlowPoint], np.ndarray]


@dataclass(frozen=True, eq=False)
class FlowModel:
    """A capillary flow model and everything the package needs to know about it.

    Attributes
    ----------
    name : str
        The model's name (``flow=...`` in the API, ``--flow`` on the command line).
    description : str
        One line: what the model is.
    resistance_function : callable
        ``(design, omega, *, with_slope=False) -> (U -> C)``, see
        :func:`resistance_function`.
    smooth : bool
        Written for CasADi symbols and smooth in every argument: allowed in the NLP
        and in :func:`isodesign.spring.stiffness.stiffness_function`.
    rational : bool
        The small-amplitude resistance is affine in ``s`` (``C(s) = c0 + c1 s``), so the
        linear isolator is a python-control ``TransferFunction``.
    time_domain : str or None
        The tube law in the time-domain simulator: ``"inertial"`` (momentum equation
        with the model's steady friction, one state), ``"algebraic"`` (``m_dot = dp /
        C_u``, no state) or None (frequency-domain only).
    amplitude_dependent : bool
        ``C`` depends on the velocity amplitude (otherwise Eq. 37's kinematic amplitude
        needs no consistency check).
    self_consistent : bool
        The self-consistent amplitude (harmonic balance) is defined for the model.
    checks : tuple of FlowCheck
        The model's own validity checks.
    distributed : bool
        The model has a distributed (transmission-line) form: its resistance splits into
        the exact laminar impedance, carried along the line, and end terms
        (:mod:`isodesign.spring.acoustics`). The paper's models (``poiseuille``, ``zhao``,
        ``zhao_turbulent``) are lumped by definition and always evaluated lumped.
    """

    name: str
    description: str
    resistance_function: Callable
    smooth: bool
    rational: bool
    time_domain: str | None
    amplitude_dependent: bool
    self_consistent: bool
    checks: tuple[FlowCheck, ...] = ()
    distributed: bool = False

    def validity(self, point: FlowPoint) -> dict[str, np.ndarray]:
        """Evaluate the model's checks.

        Parameters
        ----------
        point : FlowPoint
            Flow quantities at the evaluated points.

        Returns
        -------
        dict of str to bool ndarray
            One entry per check, in the order of :attr:`checks`.
        """
        return {c.name: c.passes(point) for c in self.checks}


# ---------------------------------------------------------------------------
# resistance functions, one per model
# ---------------------------------------------------------------------------
def _poiseuille(design, omega, *, with_slope: bool = False):
    """Eq. 41: ``C = C_u``, independent of U and w."""
    d = design

    def c_poiseuille(U):
        c_u = poiseuille_resistance(d)
        z = 0.0 * U * omega
        return (Cx(c_u + z, z), z) if with_slope else Cx(c_u + z, z)

    return c_poiseuille


def _quasi_steady(design, omega, *, with_slope: bool = False):
    """Churchill friction and the minor loss at the describing velocity, plus inertance."""
    d = design
    area = d.capillary_area_m2
    rho, mu, dc = d.density_kg_m3, d.viscosity_pa_s, d.capillary_diameter_m
    # Eq. 17's rho du/dt, kept: inertance (4/3) L / A_c of developed laminar flow, plus
    # the mass at the tube's two ends (tube_end_correction)
    c_i = quasi_steady_reactance(d, omega)
    friction_scale = d.capillary_length_m * mu / (rho * dc * dc)
    rel_rough = d.roughness_m / dc

    def c_quasi_steady(U):
        u_eq = describing_velocity(U)
        re_eq = rho * u_eq * dc / mu
        if with_slope:
            phi, dphi = churchill_friction_re_product(re_eq, rel_rough, with_slope=True)
        else:
            phi = churchill_friction_re_product(re_eq, rel_rough)
        # (L/D) f U_eq = L mu Phi / (rho D^2): finite as U -> 0
        c_r = (friction_scale * phi + d.minor_loss * u_eq) / (2.0 * area)
        c = Cx(c_r, c_i + 0.0 * c_r)
        if not with_slope:
            return c
        k = 8.0 / (3.0 * math.pi)
        return c, (friction_scale * dphi * rho * k * dc / mu + d.minor_loss * k) / (2.0 * area)

    return c_quasi_steady


def _womersley(design, omega, *, with_slope: bool = False):
    """Womersley's laminar oscillating impedance plus the minor loss (Eq. 22 applied to K)."""
    d = design
    area = d.capillary_area_m2
    alpha = womersley_number(d, omega)
    if bk.is_casadi(alpha) or np.size(alpha) <= 64:
        zeta = womersley_zeta(alpha)
    else:  # many points share few frequencies: evaluate the Bessel functions once each
        uniq, inv = np.unique(np.asarray(alpha), return_inverse=True)
        zu = womersley_zeta(uniq)
        zeta = Cx(zu.re[inv].reshape(np.shape(alpha)), zu.im[inv].reshape(np.shape(alpha)))
    c_u = poiseuille_resistance(d)
    c_r0 = c_u * zeta.re
    c_i = c_u * zeta.im + tube_end_reactance(d, omega).im

    def c_womersley(U):
        minor = d.minor_loss * describing_velocity(U) / (2.0 * area)
        c = Cx(c_r0 + minor, c_i + 0.0 * minor)
        if not with_slope:
            return c
        return c, d.minor_loss * 8.0 / (3.0 * math.pi) / (2.0 * area) + 0.0 * minor

    return c_womersley


def _zhao_function(correlation: str, name: str):
    """The paper's Eq. 36 with Zhao's friction (Eq. 24 or 25), NumPy only."""

    def build(design, omega, *, with_slope: bool = False):
        d = design
        if bk.is_casadi(
            omega, d.capillary_diameter_m, d.capillary_length_m, d.volume_ratio, d.top_volume_m3
        ):
            raise InputError(
                f"flow: {name!r} is the paper's literal model, singular at Re_w = 3.673 and "
                "non-passive near it; it is not available on CasADi symbols (not in any NLP). "
                f"Valid for optimization: {', '.join(SMOOTH_FLOW_MODELS)}"
            )
        re_w = kinetic_reynolds(d, omega)
        area = d.capillary_area_m2

        def c_zhao(U):
            a0 = U / (omega * d.capillary_diameter_m)  # x_max / D_c, x_max = u_max / w
            fr = zhao_friction(re_w, a0, correlation)
            # Eq. 36: C = (L/D fr + K) 4 u_max / (3 pi A_c)
            c = (d.capillary_length_m / d.capillary_diameter_m * fr + d.minor_loss) * (
                4.0 * U / (3.0 * math.pi * area)
            )
            return Cx(c, 0.0)  # real: no zero array

        return c_zhao

    return build


# ---------------------------------------------------------------------------
# validity checks
# ---------------------------------------------------------------------------
_LAMINAR = FlowCheck(
    "laminar",
    f"peak Reynolds number <= {LAMINAR_REYNOLDS_LIMIT:g} (laminar model, Eq. 26)",
    lambda p: p.reynolds <= LAMINAR_REYNOLDS_LIMIT,
)
#: The tolerance of the ``quasi_steady_k`` check: the spring's air stiffness with the
#: quasi-steady laminar law (Poiseuille plus the 4/3 inertance) within this fraction of the
#: one with the exact laminar oscillating impedance (docs/spring-model.md, section 7).
QUASI_STEADY_K_TOLERANCE = 0.01


def _quasi_steady_k(p: FlowPoint) -> np.ndarray:
    if p.laminar_k_error is None:  # not computed: the impedance bound alone
        return p.womersley_number <= QUASI_STEADY_WOMERSLEY_LIMIT
    return p.laminar_k_error <= QUASI_STEADY_K_TOLERANCE


_QUASI_STEADY_K = FlowCheck(
    "quasi_steady_k",
    f"air stiffness within {QUASI_STEADY_K_TOLERANCE:.0%} of the one with the exact laminar "
    "oscillating impedance (quasi-steady laminar law; both evaluated)",
    _quasi_steady_k,
)


def _zhao_checks(correlation: str) -> tuple[FlowCheck, FlowCheck]:
    lo_w, hi_w, lo_a, hi_a = ZHAO_RANGES[correlation]
    return (
        FlowCheck(
            "zhao_re_w",
            "kinetic Reynolds number inside the stated range of the Zhao correlation",
            lambda p: (p.kinetic_reynolds >= lo_w) & (p.kinetic_reynolds <= hi_w),
        ),
        FlowCheck(
            "zhao_a0",
            "dimensionless amplitude A0 inside the stated range of the Zhao correlation",
            lambda p: (p.dimensionless_amplitude >= lo_a) & (p.dimensionless_amplitude <= hi_a),
        ),
    )


# ---------------------------------------------------------------------------
# the registry
# ---------------------------------------------------------------------------
_REGISTRY: dict[str, FlowModel] = {}


def _register(model: FlowModel) -> None:
    if model.name in _REGISTRY:
        raise ValueError(f"flow model {model.name!r} registered twice")
    _REGISTRY[model.name] = model


_register(FlowModel(
    name="quasi_steady",
    description="all-regime Churchill friction + minor loss (describing function) + inertance",
    resistance_function=_quasi_steady,
    smooth=True,
    rational=True,
    time_domain="inertial",
    amplitude_dependent=True,
    self_consistent=True,
    checks=(_QUASI_STEADY_K,),
    distributed=True,
))
_register(FlowModel(
    name="womersley",
    description="exact laminar oscillating tube flow (Womersley) + minor loss",
    resistance_function=_womersley,
    smooth=True,
    rational=False,
    time_domain=None,
    amplitude_dependent=True,
    self_consistent=True,
    checks=(_LAMINAR,),
    distributed=True,
))
_register(FlowModel(
    name="poiseuille",
    description="unidirectional laminar flow, Eq. 41 (linear, no minor loss, no inertia)",
    resistance_function=_poiseuille,
    smooth=True,
    rational=True,
    time_domain="algebraic",
    amplitude_dependent=False,
    self_consistent=True,
    checks=(_LAMINAR,),
))
_register(FlowModel(
    name="zhao",
    description="the paper's Eqs. 24 and 36 as printed (laminar Zhao correlation; NumPy only)",
    resistance_function=_zhao_function("laminar", "zhao"),
    smooth=False,
    rational=False,
    time_domain=None,
    amplitude_dependent=True,
    self_consistent=False,
    checks=_zhao_checks("laminar"),
))
_register(FlowModel(
    name="zhao_turbulent",
    description="the paper's Eqs. 25 and 36 as printed (turbulent Zhao correlation; NumPy only)",
    resistance_function=_zhao_function("turbulent", "zhao_turbulent"),
    smooth=False,
    rational=False,
    time_domain=None,
    amplitude_dependent=True,
    self_consistent=False,
    checks=_zhao_checks("turbulent"),
))

#: Every flow model by name, in the order the CLI lists them.
FLOW_MODEL_REGISTRY: Mapping[str, FlowModel] = MappingProxyType(_REGISTRY)
#: Names of the capillary flow models.
FLOW_MODELS = tuple(_REGISTRY)
#: Models written for both backends (and therefore allowed in the optimizer).
SMOOTH_FLOW_MODELS = tuple(m.name for m in _REGISTRY.values() if m.smooth)
#: Models with a rational (affine in s) small-amplitude resistance.
RATIONAL_FLOW_MODELS = tuple(m.name for m in _REGISTRY.values() if m.rational)
#: Models the time-domain simulator integrates.
SIMULATION_FLOW_MODELS = tuple(m.name for m in _REGISTRY.values() if m.time_domain)


def model_design(flow: str, design):
    """The design as the flow model evaluates it: lumped acoustics for a lumped-only model.

    The paper's models (``FlowModel.distributed`` False) are lumped by definition; a
    design naming the distributed acoustics is evaluated with ``acoustics="lumped"`` for
    them. Other designs are returned unchanged.

    Parameters
    ----------
    flow : str
        A flow model name.
    design : SpringDesign
        The spring.

    Returns
    -------
    SpringDesign
    """
    if getattr(design, "acoustics", "lumped") != "lumped" and not flow_model(flow).distributed:
        return design.replace(acoustics="lumped")
    return design


def flow_model(name: str) -> FlowModel:
    """The registered model of this name.

    Parameters
    ----------
    name : str
        One of :data:`FLOW_MODELS`.

    Returns
    -------
    FlowModel

    Raises
    ------
    InputError
        For an unknown name (the message lists the valid ones).
    """
    model = _REGISTRY.get(name) if isinstance(name, str) else None
    if model is None:
        raise InputError(f"flow: unknown model {name!r}; valid: {', '.join(FLOW_MODELS)}")
    return model


def flow_check_descriptions() -> dict[str, str]:
    """Name -> description of every flow model's validity checks (first description wins).

    Returns
    -------
    dict of str to str
    """
    out: dict[str, str] = {}
    for m in _REGISTRY.values():
        for c in m.checks:
            out.setdefault(c.name, c.description)
    return out


# ---------------------------------------------------------------------------
# the resistance C(U, w)
# ---------------------------------------------------------------------------
def resistance(flow: str, design, omega, velocity_amplitude) -> Cx:
    """Complex flow resistance ``C = (P_t - P_b) / m_dot`` in Pa s/kg.

    Parameters
    ----------
    flow : str
        One of :data:`FLOW_MODELS`.
    design : SpringDesign
        The spring (fields may be CasADi symbols for the smooth models).
    omega : array or symbol
        Angular frequency, rad/s.
    velocity_amplitude : array or symbol
        Amplitude U of the cross-sectional mean velocity in the tube, m/s.

    Returns
    -------
    Cx
        Real part: resistance; imaginary part: ``w`` times the inertance.
    """
    return resistance_function(flow, design, omega)(velocity_amplitude)


def resistance_function(flow: str, design, omega, *, with_slope: bool = False):
    """Return ``U -> C(U, w)`` for one model, design and set of frequencies.

    The parts that do not depend on the velocity amplitude (the Womersley
    impedance, the inertance) are computed once, so a solver iterating on ``U``
    pays only for the amplitude-dependent part. :func:`resistance` is this
    function applied once.

    Parameters
    ----------
    flow : str
        One of :data:`FLOW_MODELS`.
    design : SpringDesign
        The spring (fields may be CasADi symbols for the smooth models).
    omega : array or symbol
        Angular frequency, rad/s.
    with_slope : bool
        (NumPy, smooth models) the returned function gives ``(C, dRe(C)/dU)``:
        every model's inertance is independent of ``U``.

    Returns
    -------
    callable
        ``U -> Cx`` (or ``U -> (Cx, slope)``).
    """
    return flow_model(flow).resistance_function(design, omega, with_slope=with_slope)
