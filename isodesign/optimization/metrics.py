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
)
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness
from isodesign.spring.flow_models import resistance_function

__all__ = ["combine", "design_quantities", "metrics", "point_quantities"]


def point_quantities(study, d, omega, velocity, sigma, dia) -> dict:
    """Per-frequency quantities (elementwise in ``omega``), any backend.

    ``T`` and ``R`` (absolute and relative transmissibility at the spring
    amplitude ``A* = 1.880 sigma``), ``ln_mach`` and ``ln_re`` of the tube flow.
    """

    m_i = study.payload.mass_per_isolator_kg
    a_star = EQUIVALENT_AMPLITUDE_FACTOR * sigma
    c = resistance_function(study.models["flow"], d, omega)(velocity)
    k = spring_stiffness(air_stiffness(d, omega, c), dia.stiffness(omega, a_star))
    return {
        "T": transmissibility(k, m_i, omega),
        "R": relative_transmissibility(k, m_i, omega),
        "ln_mach": bk.log(velocity / d.speed_of_sound_m_s),
        "ln_re": bk.log(d.density_kg_m3 * velocity * d.capillary_diameter_m / d.viscosity_pa_s),
    }


def design_quantities(study, grid, d, dia) -> dict:
    """Design-level quantities (volume, stability, validity), any backend."""
    m_i = study.payload.mass_per_isolator_kg
    k0 = static_stiffness(d, dia, m_i)
    out = {"ln_total_volume": bk.log(d.total_volume_m3)}
    if study.payload.spacing_m is not None and study.payload.cg_height_m is not None:
        out["ln_tilt"] = bk.log(tilt_margin(k0, study.payload))
    out["ln_fn"] = bk.log(natural_frequency_hz(k0, m_i))
    out["ln_zeta"] = bk.log(zener_damping_ratio(d, m_i))
    w_max = float(np.max(grid.omega))
    # acoustic compactness of the lumped model (diagnostics.LUMPED_LIMIT), one
    # smooth constraint per length instead of a max
    c = d.speed_of_sound_m_s
    out["ln_lumped"] = [
        bk.log(w_max * d.capillary_length_m / c),
        bk.log(w_max * bk.power(d.top_volume_m3, 1.0 / 3.0) / c),
        bk.log(w_max * bk.power(d.bottom_volume_m3, 1.0 / 3.0) / c),
    ]
    out["ln_alpha_max"] = 0.5 * bk.log(
        d.density_kg_m3 * w_max * d.capillary_diameter_m**2 / d.viscosity_pa_s
    ) - math.log(2.0)
    return out


def combine(study, grid, pq: dict, dq: dict) -> dict:
    """Grid-level quantities from the per-point and design-level ones, any backend.

    The quadratures of sigma^2 and of the band mean squares are
    :func:`isodesign.response.linearization.stroke_variance` and
    :func:`~isodesign.response.linearization.band_mean_square`, the same functions the
    band response uses.
    """

    fl, pk = grid.floor_slice, grid.peak_slice
    var = stroke_variance(take(pq["R"], fl), grid.response)
    ms = band_mean_square(take(pq["T"], fl), grid.response)
    out = dict(dq)
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


def metrics(study, grid, d, velocity, sigma, *, diaphragm=None) -> dict:
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
        Tube velocity amplitude at every grid frequency, m/s.
    sigma : float or symbol
        RMS stroke of the spring, m.
    diaphragm : diaphragm model, optional
        Default: the study's.

    Returns
    -------
    dict
        ``stroke_variance``, ``ms_all`` and ``ln_ms_band`` (target bands),
        ``ln_limit2``, ``ln_T2_peak`` (vector), ``ln_total_volume``, ``ln_tilt``,
        ``ln_fn``, ``ln_zeta``, ``ln_mach`` and ``ln_re`` (vectors),
        ``ln_alpha_max`` and ``ln_T2_point`` (for an objective at one frequency).
    """
    dia = diaphragm or diaphragm_model(study.models["diaphragm"])
    pq = point_quantities(study, d, grid.omega, velocity, sigma, dia)
    return combine(study, grid, pq, design_quantities(study, grid, d, dia))
