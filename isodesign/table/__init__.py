"""The table as a rigid body in six degrees of freedom on n isolators.

One concept a module:

* :mod:`~isodesign.table.layout`: the table (mass, inertia, CG, isolators, leveling groups,
  instrument points) and the isolators' horizontal element.
* :mod:`~isodesign.table.statics`: three-valve leveling, each isolator's load and p0.
* :mod:`~isodesign.table.assembly`: the 6x6 dynamic stiffness with the gravity term (NumPy
  and CasADi alike).
* :mod:`~isodesign.table.model`: the table bound to its springs, transfer functions.
* :mod:`~isodesign.table.floor`: the floor per axis and the response grid.
* :mod:`~isodesign.table.response`: the band response, the random closure per isolator;
  :mod:`~isodesign.table.closure`: the harmonic closures, the z reduction.
* :mod:`~isodesign.table.symmetric`: the symmetric table of a ``[payload]`` (a study
  without ``[table]``).
* :mod:`~isodesign.table.harmonic`: harmonic floor motion, the closure per isolator.
* :mod:`~isodesign.table.modes`: modes (nonlinear eigenproblem, every self-consistent
  solution), the static verdict with the gravity term.
* :mod:`~isodesign.table.leveling`, :mod:`~isodesign.table.leveling_loop`,
  :mod:`~isodesign.table.stability_report`: the leveling valves as a dynamic model, their
  loop (python-control), a report section.
* :mod:`~isodesign.table.lever_geometry`: the co-design levers' geometry in the assembly
  (layout, elastic centre).
* :mod:`~isodesign.table.study`, :mod:`~isodesign.table.summary`,
  :mod:`~isodesign.table.plots`: study files, text, figures.

Physics only: nothing here imports :mod:`isodesign.optimization`. The table's NLP, its
driver and Pareto front live there (:mod:`~isodesign.optimization.table_problem`,
:mod:`~isodesign.optimization.table_driver`, :mod:`~isodesign.optimization.table_pareto`).

The vertical-only :class:`~isodesign.response.isolator.Payload` is the symmetric special
case (:func:`~isodesign.table.symmetric.payload_table`, docs/table.md section 14).
"""

from isodesign.table.assembly import DOFS, dynamic_stiffness, geometry, gravity_stiffness
from isodesign.table.layout import HorizontalElement, Table, box_inertia
from isodesign.table.statics import Leveling, level

__all__ = [
    "DOFS",
    "HorizontalElement",
    "Leveling",
    "Table",
    "box_inertia",
    "dynamic_stiffness",
    "geometry",
    "gravity_stiffness",
    "level",
]
