"""Sweeps: many studies at once, one Dask task per point, on a laptop or a cluster.

:func:`sweep` (``isodesign sweep``) runs a study for every combination of study changes
(:mod:`.spec`), each point one task (:mod:`.tasks`) on a Dask cluster (:mod:`.cluster`),
writes each point's run directory and the sweep table (:mod:`.table`) as the points
finish, and resumes where it stopped (:mod:`.runner`). Design charts:
:mod:`isodesign.plotting.sweep`. See ``docs/sweep.md``.
"""

from __future__ import annotations

from isodesign._lazy import lazy_exports

_EXPORTS = {
    "sweep": "runner",
    "SweepResult": "runner",
    "sweep_record": "runner",
    "SweepTask": "tasks",
    "register_task": "tasks",
    "get_task": "tasks",
    "TASKS": "tasks",
    "parse_vary": "spec",
    "read_points": "spec",
    "study_hash": "spec",
    "read_table": "table",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
