"""The payload on its springs: transmissibility, closures, band response, stability.

One concept a module:

* :mod:`~isodesign.response.isolator`: the payload, transmissibility, tilt, the Zener limit.
* :mod:`~isodesign.response.model`: inputs, the bound spring model, linear transmissibility.
* :mod:`~isodesign.response.linearization`: the response grid and its quadratures (NumPy
  and CasADi alike: the optimizer uses the same functions).
* :mod:`~isodesign.response.harmonic`: the response to a sine floor motion.
* :mod:`~isodesign.response.random_input`: the band response to a random floor (its result
  type :class:`~isodesign.response.band.BandResponse` in :mod:`~isodesign.response.band`).
* :mod:`~isodesign.response.stability`: natural frequency, damping, peak |T|, tilt margin.
* :mod:`~isodesign.response.control`: python-control interop (FRD, transfer functions).
"""

from isodesign.response.band import BandResponse
from isodesign.response.control import (
    StepMetrics,
    dominant_pole_pair,
    step_metrics,
    to_frd,
    to_transfer_function,
)
from isodesign.response.harmonic import (
    BRANCHES,
    SCAN_AMPLITUDE_RANGE_M,
    HarmonicResponse,
    harmonic_response,
)
from isodesign.response.isolator import Payload, loaded_design
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    ResponseGrid,
    band_margin_db,
    band_mean_square,
    equivalent_amplitude,
    rayleigh_average,
    rayleigh_rule,
    response_grid,
    stroke_variance,
)
from isodesign.response.model import (
    LINEAR_REFERENCE_AMPLITUDE_M,
    linear_transmissibility,
    resolve_floor,
    resolve_target,
)
from isodesign.response.random_input import (
    RANDOM_METHODS,
    band_response,
    band_response_at,
    solve_stroke_rms,
)
from isodesign.response.stability import StabilityFigures, stability_figures

__all__ = [
    "BRANCHES",
    "EQUIVALENT_AMPLITUDE_FACTOR",
    "LINEAR_REFERENCE_AMPLITUDE_M",
    "RANDOM_METHODS",
    "SCAN_AMPLITUDE_RANGE_M",
    "BandResponse",
    "HarmonicResponse",
    "Payload",
    "ResponseGrid",
    "StabilityFigures",
    "StepMetrics",
    "band_margin_db",
    "band_mean_square",
    "band_response",
    "band_response_at",
    "dominant_pole_pair",
    "equivalent_amplitude",
    "harmonic_response",
    "linear_transmissibility",
    "loaded_design",
    "rayleigh_average",
    "rayleigh_rule",
    "resolve_floor",
    "resolve_target",
    "response_grid",
    "solve_stroke_rms",
    "stability_figures",
    "step_metrics",
    "stroke_variance",
    "to_frd",
    "to_transfer_function",
]
