"""isodesign: design optimizer for vibration-isolation tables on dual-chamber air springs.

The public API, importable from the top level (``isodesign.complex_stiffness``, ...):

* the spring: :class:`SpringDesign`, :class:`Gas`, :func:`complex_stiffness`,
  :class:`StiffnessResult`, the diaphragm models, the flow-model registry;
* the payload's response: :class:`Payload`, :func:`band_response`,
  :func:`harmonic_response`, :func:`stability_figures`, python-control interop;
* the floor: :func:`criterion`, :func:`criterion_names`, :class:`FloorSpectrum`,
  :func:`third_octave_bands`;
* design studies: :func:`load_study`, :func:`default_study` (the built-in table co-designed),
  :func:`table_study`, :func:`vertical_study`, :func:`optimize`, :func:`analyze`,
  :func:`pareto_front`, :func:`transmissibility` (of a table per point and axis, or of a
  payload; the subpackage is :mod:`isodesign.optimization`);
* sweeps of many studies on Dask: :func:`sweep` (:mod:`isodesign.sweeps`);
* verification: :func:`simulate_stiffness` (time-domain rig);
* errors: :class:`InputError`, :class:`SolverError`, :class:`ModelValidityWarning`.

The package is imported lazily: ``import isodesign`` and ``isodesign --help`` load
neither NumPy, SciPy, CasADi nor pandas. Each public name is resolved from its defining
module on first use (:data:`__all__` lists them).
"""

from __future__ import annotations

from isodesign._lazy import lazy_exports

__version__ = "0.1.0"

#: Public name -> module (relative to the package) that defines it.
_EXPORTS = {
    # the spring
    "SpringDesign": "spring.design",
    "piston_area_from_diaphragm": "spring.design",
    "Gas": "spring.gas",
    "AIR": "spring.gas",
    "pressure_from_load": "spring.gas",
    "complex_stiffness": "spring.stiffness",
    "stiffness_function": "spring.stiffness",
    "StiffnessResult": "spring.stiffness",
    "AMPLITUDE_MODES": "spring.stiffness",
    "Diagnostics": "spring.diagnostics",
    "FLOW_MODELS": "spring.flow_models",
    "FlowModel": "spring.flow_models",
    "flow_model": "spring.flow_models",
    "DIAPHRAGM_MODELS": "spring.diaphragm",
    "ViscoelasticDiaphragm": "spring.diaphragm",
    "TableDiaphragm": "spring.diaphragm",
    "NoDiaphragm": "spring.diaphragm",
    "diaphragm_model": "spring.diaphragm",
    # the payload's response
    "Payload": "response.isolator",
    "loaded_design": "response.isolator",
    "linear_transmissibility": "response.model",
    "band_response": "response.random_input",
    "BandResponse": "response.band",
    "RANDOM_METHODS": "response.random_input",
    "harmonic_response": "response.harmonic",
    "HarmonicResponse": "response.harmonic",
    "stability_figures": "response.stability",
    "StabilityFigures": "response.stability",
    "to_frd": "response.control",
    "to_transfer_function": "response.control",
    # the floor
    "criterion": "floor.curves",
    "criterion_names": "floor.curves",
    "CriterionCurve": "floor.curves",
    "criterion_from_csv": "floor.curve_files",
    "FloorSpectrum": "floor.spectrum",
    "Bands": "floor.bands",
    "third_octave_bands": "floor.bands",
    # design studies
    "Study": "optimization.study",
    "load_study": "optimization.study",
    "default_study": "optimization.study",
    "table_study": "optimization.study",
    "vertical_study": "optimization.study",
    "optimize": "optimization.dispatch",
    "analyze": "optimization.analyze",
    "OptimizationResult": "optimization.result",
    "StudyResult": "optimization.result",
    "pareto_front": "optimization.pareto",
    "transmissibility": "optimization.transmissibility",
    "TableTransmissibility": "optimization.transmissibility",
    "ParetoResult": "optimization.pareto",
    # sweeps (Dask)
    "sweep": "sweeps.runner",
    "SweepResult": "sweeps.runner",
    # design files
    "load_design": "io.designfile",
    "save_design": "io.designfile",
    # time-domain verification
    "simulate_stiffness": "simulation.harmonic_rig",
    "simulate_grid": "simulation.harmonic_rig",
    "SimulationResult": "simulation.harmonic_rig",
    "simulate_random_response": "simulation.monte_carlo",
    "MonteCarloResult": "simulation.monte_carlo",
    # reports
    "report": "reporting.render",
    # errors
    "InputError": "errors",
    "SolverError": "errors",
    "ModelValidityWarning": "errors",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
