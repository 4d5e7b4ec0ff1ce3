"""Inputs of reports and of the analysis commands: a design with its job.

:func:`load_case` reads a design file, a study file or an optimize/pareto run directory.
"""

from isodesign.reporting.inputs import Case, load_case

__all__ = ["Case", "load_case"]
