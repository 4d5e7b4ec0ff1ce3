"""Independent time-domain verifiers of the frequency-domain models.

* :mod:`~isodesign.simulation.harmonic_rig`: the spring alone on a test rig, driven by a sine
  piston motion; integrates the nonlinear lumped equations and returns the first-harmonic
  complex stiffness (checks :func:`isodesign.complex_stiffness`).
"""

from isodesign.simulation.harmonic_rig import (
    SimulationGridResult,
    SimulationResult,
    agreement_table,
    simulate_grid,
    simulate_stiffness,
)

__all__ = [
    "SimulationGridResult",
    "SimulationResult",
    "agreement_table",
    "simulate_grid",
    "simulate_stiffness",
]
