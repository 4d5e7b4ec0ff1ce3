"""The model the time-domain simulators integrate: the lumped acoustics.

The harmonic rig (:mod:`.harmonic_rig`) and the Monte Carlo verifiers (:mod:`.monte_carlo`,
:mod:`.table_monte_carlo`) integrate uniform chamber pressures and a slug in the tube, with
adiabatic or polytropic chambers (no wall heat exchange), whatever acoustics a design names
(``docs/acoustics.md``, ``docs/simulation.md``).
"""

from __future__ import annotations

from isodesign.spring.design import SpringDesign

__all__ = ["lumped_twin"]


def lumped_twin(design: SpringDesign) -> SpringDesign | None:
    """The design as the time-domain simulators integrate it (``None``: it is already so).

    The rig and the Monte Carlo verifiers integrate the lumped acoustics without wall heat
    exchange; a closure judged against them is this design's (like with like).

    Parameters
    ----------
    design : SpringDesign

    Returns
    -------
    SpringDesign or None
    """
    if design.acoustics == "lumped" and not design.chamber_heat_exchange:
        return None
    return design.replace(acoustics="lumped", chamber_heat_exchange=False)
