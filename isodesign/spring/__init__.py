"""The dual-chamber pneumatic spring: design, gas, capillary flow, diaphragm, Eqs. 37-42.

One concept a module:

* :mod:`~isodesign.spring.design`: the spring's geometry and state (:class:`SpringDesign`).
* :mod:`~isodesign.spring.gas`: the gas (ideal gas, Sutherland viscosity, polytropic index).
* :mod:`~isodesign.spring.capillary`: the capillary's flow models (resistance ``C``).
* :mod:`~isodesign.spring.diaphragm`: the rolling diaphragm's stiffness ``k_D*``.
* :mod:`~isodesign.spring.equations`: the air-spring equations (Eqs. 37, 38, 42).
* :mod:`~isodesign.spring.amplitude`: the self-consistent tube-velocity solver.
* :mod:`~isodesign.spring.stiffness`: :func:`complex_stiffness` ``k*(X_p, w)``.
* :mod:`~isodesign.spring.diagnostics`: flow figures and the validity checks.
"""
