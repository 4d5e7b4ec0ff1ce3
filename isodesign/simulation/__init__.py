"""Independent time-domain verifiers of the frequency-domain models.

* :mod:`~isodesign.simulation.harmonic_rig`: the spring alone on a test rig, driven by a sine
  piston motion; integrates the nonlinear lumped equations and returns the first-harmonic
  complex stiffness (checks :func:`isodesign.complex_stiffness`).
* :mod:`~isodesign.simulation.monte_carlo`: the payload on its springs under a random floor
  (Monte Carlo, one-third-octave band analysis; checks :func:`isodesign.response.band_response`).
* :mod:`~isodesign.simulation.table_monte_carlo`: the rigid table in six degrees of freedom on
  its nonlinear isolators under a three-axis random floor (checks
  :func:`isodesign.table.response.table_band_response`).
"""

from isodesign.simulation.harmonic_rig import (
    SimulationGridResult,
    SimulationResult,
    agreement_table,
    simulate_grid,
    simulate_stiffness,
)
from isodesign.simulation.monte_carlo import (
    MONTE_CARLO_FLOW_MODELS,
    MonteCarloResult,
    simulate_random_response,
)
from isodesign.simulation.table_monte_carlo import (
    TableMonteCarloResult,
    simulate_table_response,
)

__all__ = [
    "MONTE_CARLO_FLOW_MODELS",
    "MonteCarloResult",
    "SimulationGridResult",
    "SimulationResult",
    "TableMonteCarloResult",
    "agreement_table",
    "simulate_grid",
    "simulate_random_response",
    "simulate_stiffness",
    "simulate_table_response",
]
