"""Shareable HTML reports of a design, an optimization or a Pareto run, or a comparison.

:func:`report` is also ``isodesign.report``; ``isodesign report INPUT... -o FILE.html`` is
the command line (:mod:`isodesign.commands.report`). :func:`load_case` reads an input
(design file, study file, run directory) as a design with its job.
"""

from isodesign.reporting.inputs import Case, load_case
from isodesign.reporting.render import report
from isodesign.reporting.sections import SECTIONS

__all__ = ["SECTIONS", "Case", "load_case", "report"]
