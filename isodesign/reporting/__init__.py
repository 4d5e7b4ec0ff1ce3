"""Shareable HTML reports of a design, an optimization or a Pareto run, or a comparison.

:func:`report` is also ``isodesign.report``; ``isodesign report INPUT... -o FILE.html`` is
the command line (:mod:`isodesign.commands.report`).
"""

from isodesign.reporting.inputs import Case, load_case
from isodesign.reporting.render import SECTIONS, report

__all__ = ["SECTIONS", "Case", "load_case", "report"]
