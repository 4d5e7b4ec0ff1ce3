"""Objective and constraint quantities of a design, on NumPy arrays or CasADi symbols.

One source of physics: the NLP (:mod:`isodesign.optimization.problem`) and the
NumPy re-check (:mod:`isodesign.optimization.recheck`) evaluate the same three
functions: :func:`point_quantities` per grid frequency, :func:`design_quantities`
per design and :func:`combine` for the grid-level quadratures.
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx
from isodesign.optimization.grid import take
from isodesign.response.isolator import (
    natural_frequency_hz,
    relative_transmissibility,
    static_stiffness,
    tilt_margin,
    transmissibility,
    zener_damping_ratio,
)
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    band_mean_square,
    stroke_variance,
    stroke_weighted_sum,
)
from isodesign.response.non_gaussian import minor_loss_gain_shift
from isodesign.spring.capillary import gaussian_equivalent_resistance, linear_resistance
from isodesign.spring.chamber import chamber_dimensions
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness, tube_velocity_gain2
from isodesign.spring.flow_models import resistance_function
from isodesign.spring.transmission_line import TRANSVERSE_MODE_FACTOR

__all__ = ["combine", "design_quantities", "metrics", "point_quantities", "statistical",
           "tube_flow_quantities", "validity_quantities"]


def point_quantities(study, d, omega, velocity, sigma, dia, c_nl=None) -> dict:
    """Per-frequency quantities (elementwise in ``omega``), any backend.

    ``T`` and ``R`` (absolute and relative transmissibility), ``ln_mach`` and ``ln_re`` of
    the tube flow at the velocity amplitude ``velocity``. The diaphragm is at the stroke
    amplitude ``A* = 1.880 sigma``. The capillary: with ``c_nl`` (the statistical closure,
    ``docs/random-response.md``) its linear part plus the Gaussian-equivalent resistance
    ``c_nl`` of the nonlinear drop, and ``G2 = |U/X|^2`` (the tube velocity per stroke) is
    returned too; without, the harmonic describing function at the amplitude ``velocity``.
    The NLP maps this function over its grid as one small CasADi Function; the
    re-check calls it on NumPy arrays.

    Parameters
    ----------
    study : Study
        Gives the payload mass per isolator and ``models["flow"]``.
    d : SpringDesign
        The spring, possibly with CasADi symbols for the free variables.
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    velocity : float, ndarray or CasADi symbol
        Capillary (tube) velocity amplitude at ``omega``, m/s (self-consistent or
        kinematic, as the study's ``amplitude_mode`` says; ``sqrt(2) sigma_u`` with the
        statistical closure, for the Mach and Reynolds checks).
    sigma : float or CasADi symbol
        RMS stroke of the spring under the random floor input, m.
    dia : diaphragm model
        From :func:`isodesign.spring.diaphragm.diaphragm_model`.
    c_nl : float or CasADi symbol, optional
        The statistical closure's Gaussian-equivalent resistance of the capillary's
        nonlinear pressure drop, Pa s/kg
        (:func:`~isodesign.spring.capillary.gaussian_equivalent_resistance`).

    Returns
    -------
    dict
        ``T`` and ``R`` (:class:`~isodesign.numerics.cplx.Cx`): absolute and relative
        (``T - 1``) transmissibility with the complex stiffness at the equivalent
        spring amplitude ``A* = 1.880 sigma``; ``ln_mach``, the log of the tube
        Mach number ``U / c``; ``ln_re``, the log of the tube Reynolds number
        ``rho U D_c / mu`` (peak values of the oscillating flow); with ``c_nl`` also
        ``G2 = |U/X|^2``.

    Notes
    -----
    The complex stiffness is Eq. 42 (:func:`isodesign.spring.equations.spring_stiffness`):
    the air spring with the flow model's resistance at ``velocity`` plus the
    diaphragm's stiffness at amplitude ``A*``. ``A* = 3 sqrt(pi/8) sigma`` is the
    harmonic amplitude whose describing function equals the Gaussian average
    (:data:`isodesign.response.linearization.EQUIVALENT_AMPLITUDE_FACTOR`).
    """

    m_i = study.payload.mass_per_isolator_kg
    a_star = EQUIVALENT_AMPLITUDE_FACTOR * sigma
    flow = study.models["flow"]
    if c_nl is None:
        c = resistance_function(flow, d, omega)(velocity)
    else:
        lin = linear_resistance(flow, d, omega)
        c = Cx(lin.re + c_nl, lin.im)
    k = spring_stiffness(air_stiffness(d, omega, c, flow), dia.stiffness(omega, a_star))
    out = {
        "T": transmissibility(k, m_i, omega),
        "R": relative_transmissibility(k, m_i, omega),
        **tube_flow_quantities(d, velocity),
    }
    if c_nl is not None:
        out["G2"] = tube_velocity_gain2(d, omega, c, flow)
    return out


def design_quantities(study, grid, d, dia) -> dict:
    """Design-level quantities (volume, stability, validity), any backend.

    Parameters
    ----------
    study : Study
        Gives the payload (mass per isolator, spacing and CG height).
    grid : Grid
        The NLP's grid; its highest frequency sets the validity quantities.
    d : SpringDesign
        The spring, possibly with CasADi symbols for the free variables.
    dia : diaphragm model
        Enters the static stiffness ``K0``.

    Returns
    -------
    dict
        Natural logs of: ``ln_total_volume`` (``V_t0 (1 + N)``, m^3); ``ln_tilt``
        (tilt margin ``n K0 (s/2)^2 / (m g h)``, only when the payload has a spacing
        and a CG height); ``ln_fn`` (undamped natural frequency
        ``sqrt(K0 / (m/n)) / (2 pi)``, Hz); ``ln_zeta`` (Zener damping ratio);
        ``ln_lumped``, a list of three: ``w_max L_c / c``, ``w_max V_t0^(1/3) / c``
        and ``w_max V_b0^(1/3) / c`` (acoustic compactness of tube and chambers, the
        lumped model's validity); ``ln_plane_wave``, a list of two: ``w_max D / (1.8412
        c)`` for each chamber's diameter (plane waves below the first transverse mode: the
        distributed model's validity);
        ``ln_alpha_max``, the Womersley number ``(D_c / 2) sqrt(w_max rho / mu)``.

    Notes
    -----
    Logs keep the NLP's rows well scaled. The acoustic compactness is one quantity
    per length (tube, each chamber) rather than their ``max``, which is not smooth.
    ``w_max`` is the grid's highest angular frequency (rad/s), a NumPy number.
    """
    m_i = study.payload.mass_per_isolator_kg
    k0 = static_stiffness(d, dia, m_i)
    out = {"ln_total_volume": bk.log(d.total_volume_m3)}
    if study.payload.spacing_m is not None and study.payload.cg_height_m is not None:
        out["ln_tilt"] = bk.log(tilt_margin(k0, study.payload))
    out["ln_fn"] = bk.log(natural_frequency_hz(k0, m_i))
    out["ln_zeta"] = bk.log(zener_damping_ratio(d, m_i))
    out.update(validity_quantities(d, float(np.max(grid.omega))))
    return out


def tube_flow_quantities(d, velocity) -> dict:
    """The tube flow's validity quantities at a velocity amplitude, any backend.

    Parameters
    ----------
    d : SpringDesign
    velocity : float, ndarray or CasADi symbol
        The tube velocity amplitude, m/s.

    Returns
    -------
    dict
        ``ln_mach``, the log of the Mach number ``U / c``; ``ln_re``, the log of the Reynolds
        number ``rho U D_c / mu``.
    """
    return {
        "ln_mach": bk.log(velocity / d.speed_of_sound_m_s),
        "ln_re": bk.log(d.density_kg_m3 * velocity * d.capillary_diameter_m / d.viscosity_pa_s),
    }


def validity_quantities(d, w_max: float) -> dict:
    """The spring's design-level validity quantities at the grid's top, any backend.

    Parameters
    ----------
    d : SpringDesign
    w_max : float
        The grid's highest angular frequency, rad/s.

    Returns
    -------
    dict
        ``ln_lumped``, a list of three: ``w_max L_c / c``, ``w_max V_t0^(1/3) / c`` and
        ``w_max V_b0^(1/3) / c`` (acoustic compactness of tube and chambers, the lumped
        model's validity, one smooth row per length instead of their ``max``);
        ``ln_plane_wave``, a list of two: ``w_max D / (1.8412 c)`` for each chamber's
        diameter (plane waves below the first transverse mode: the distributed model's
        validity); ``ln_alpha_max``, the Womersley number ``(D_c / 2) sqrt(w_max rho /
        mu)``; ``ln_bore_per_length``, ``D_c / L_c`` (the tube a tube, long enough for its
        ends' correction). Natural logs.
    """
    c = d.speed_of_sound_m_s
    return {
        "ln_lumped": [
            bk.log(w_max * d.capillary_length_m / c),
            bk.log(w_max * bk.power(d.top_volume_m3, 1.0 / 3.0) / c),
            bk.log(w_max * bk.power(d.bottom_volume_m3, 1.0 / 3.0) / c),
        ],
        "ln_plane_wave": [
            bk.log(w_max * chamber_dimensions(d, v)[1] / (TRANSVERSE_MODE_FACTOR * c))
            for v in (d.top_volume_m3, d.bottom_volume_m3)
        ],
        "ln_alpha_max": 0.5 * bk.log(
            d.density_kg_m3 * w_max * d.capillary_diameter_m**2 / d.viscosity_pa_s
        ) - math.log(2.0),
        "ln_bore_per_length": bk.log(d.capillary_diameter_m) - bk.log(d.capillary_length_m),
    }


def combine(study, grid, pq: dict, dq: dict) -> dict:
    """Grid-level quantities from the per-point and design-level ones, any backend.

    The quadratures of sigma^2 and of the band mean squares are
    :func:`isodesign.response.linearization.stroke_variance` and
    :func:`~isodesign.response.linearization.band_mean_square`, the same functions the
    band response uses.

    Parameters
    ----------
    study : Study
        The study (not read; kept so the three metric functions share a signature).
    grid : Grid
        The NLP's grid: its floor part carries the quadrature weights, its peak
        part the resonance frequencies.
    pq : dict
        :func:`point_quantities` at every grid frequency (vectors of length
        ``grid.omega.size``).
    dq : dict
        :func:`design_quantities` of the same design (copied into the result).

    Returns
    -------
    dict
        ``dq`` plus: ``stroke_variance`` (``sigma^2 = sum_j w_j |R_j|^2``, m^2, over
        the floor grid); ``ms_all`` (payload band mean-square velocity
        ``sum_j W_bj |T_j|^2``, (m/s)^2, every band of the response grid) and
        ``ln_ms_band`` (its log); ``ln_limit2`` (log of the target's squared band
        limits, NumPy); ``ln_T2_peak`` (``ln |T|^2`` at every peak-grid frequency);
        ``ln_mach`` and ``ln_re`` (passed through); ``ln_T2_point`` (``ln |T|^2`` at
        the one objective frequency, when the grid has one).

    Notes
    -----
    The band margin in dB is ``10 (ln_limit2 - ln_ms_band) / ln 10`` and the peak
    ``|T|`` in dB is ``10 ln_T2_peak / ln 10``. ``stroke_variance`` is computed from
    ``R`` at the given ``sigma``; the NLP imposes ``sigma^2`` = the same sum as
    equality constraints (a chain of partial sums), the NumPy path solves it with
    its own solver.
    """

    fl, pk = grid.floor_slice, grid.peak_slice
    r_fl = take(pq["R"], fl)
    var = stroke_variance(r_fl, grid.response)
    ms = band_mean_square(take(pq["T"], fl), grid.response)
    out = dict(dq)
    if "G2" in pq:  # the statistical closure: sigma_u^2 = integral |T-1|^2 |U/X|^2 S_x df
        out["tube_velocity_variance"] = stroke_weighted_sum(r_fl.abs2() * pq["G2"][fl],
                                                            grid.response)
    out.update({
        "stroke_variance": var,
        "ms_all": ms,
        "ln_ms_band": bk.log(ms),
        "ln_limit2": 2.0 * np.log(grid.target_limit_m_s),
        "ln_T2_peak": bk.log(take(pq["T"], pk).abs2()),
        "ln_mach": pq["ln_mach"],
        "ln_re": pq["ln_re"],
    })
    if grid.point_index is not None:
        i = grid.point_index
        out["ln_T2_point"] = bk.log(Cx(pq["T"].re[i], pq["T"].im[i]).abs2())
    return out


def statistical(study) -> bool:
    """True when the study's random closure is the statistical linearization.

    Parameters
    ----------
    study : Study
        Its ``models.random_method`` is read.

    Returns
    -------
    bool
    """
    return study.models.get("random_method") == "statistical"


def add_band_distortion(mt: dict, band_ms) -> dict:
    """The distortion power's band mean squares added to the payload's (any backend).

    ``ms_all`` and ``ln_ms_band`` of ``mt`` (:func:`combine`) are replaced by the sums with
    ``band_ms`` ((m/s)^2 per band of the response grid; docs/random-response.md 3a, 3d).

    Parameters
    ----------
    mt : dict
        :func:`combine`'s output (changed in place and returned).
    band_ms : array or CasADi column
        The added band mean squares.

    Returns
    -------
    dict
    """
    ms = mt["ms_all"] + band_ms
    mt["ms_all"] = ms
    mt["ln_ms_band"] = bk.log(ms)
    return mt


def metrics(study, grid, d, velocity, sigma, *, diaphragm=None, tube_rms=None,
            distortion=None) -> dict:
    """Objective and constraint quantities of a design (NumPy or CasADi).

    :func:`point_quantities` on every grid frequency, :func:`design_quantities`
    and :func:`combine`: the NLP evaluates the same three functions (the first
    mapped over the grid as a CasADi Function).

    Parameters
    ----------
    study : Study
    grid : Grid
    d : SpringDesign
        Design, possibly with CasADi symbols for the free variables.
    velocity : array or symbol vector
        Tube velocity amplitude at every grid frequency, m/s (harmonic closure; ignored
        with ``tube_rms``).
    sigma : float or symbol
        RMS stroke of the spring, m.
    tube_rms : float or symbol, optional
        The statistical closure: the tube velocity's RMS ``sigma_u`` (m/s); the capillary's
        nonlinear drop is its Gaussian-equivalent resistance there, the velocity of the Mach
        and Reynolds checks ``sqrt(2) sigma_u``.
    diaphragm : diaphragm model, optional
        Default: the study's.
    distortion : DistortionTerms, optional
        The distortion power's terms (:mod:`.distortion_rows`; statistical closure): the
        minor loss's gain ratio in the equivalent resistance, the band mean squares added.

    Returns
    -------
    dict
        ``stroke_variance``, ``ms_all`` and ``ln_ms_band`` (target bands),
        ``ln_limit2``, ``ln_T2_peak`` (vector), ``ln_total_volume``, ``ln_tilt``,
        ``ln_fn``, ``ln_zeta``, ``ln_mach`` and ``ln_re`` (vectors),
        ``ln_alpha_max`` and ``ln_T2_point`` (for an objective at one frequency).
    """
    dia = diaphragm or diaphragm_model(study.models["diaphragm"])
    c_nl = None
    if tube_rms is not None:
        c_nl = gaussian_equivalent_resistance(study.models["flow"], d, tube_rms)
        if distortion is not None and study.models["flow"] != "poiseuille":
            c_nl = c_nl + minor_loss_gain_shift(d, tube_rms, distortion.gain_ratio)
        velocity = math.sqrt(2.0) * tube_rms + 0.0 * grid.omega
    pq = point_quantities(study, d, grid.omega, velocity, sigma, dia, c_nl)
    out = combine(study, grid, pq, design_quantities(study, grid, d, dia))
    if distortion is not None:
        add_band_distortion(out, np.asarray(distortion.band_ms, float))
    return out
