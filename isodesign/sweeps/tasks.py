"""What each sweep point runs: the task registry and the Dask task :func:`run_point`.

A task is a :class:`SweepTask`: a name (``--task``), the run-directory command it writes
(``record.json["kind"] = "isodesign <command>"``), the options it takes and a function
``run(study, run, options) -> dict`` that computes the point into the open
:class:`~isodesign.io.rundir.RunDirectory` ``run`` and returns the point's row fields
(``feasible``, ``objective``, ``objective_value``, the design variables, ``binding``, ...).

Built in: ``optimize`` (the point's answer from :func:`isodesign.optimize`: the robust
optimum of a study with ``[scenarios]``, the six-degree-of-freedom optimum of one with
``[table]``; the files of ``isodesign optimize`` for that kind of study),
``response`` (the band response of the study's start design: vary
``variables.<name>.start`` to sweep a design) and ``pareto`` (the point's Pareto front, the
files of ``isodesign pareto``). Another capability adds its own with
:func:`register_task`; a task that a later capability provides (``yield``, from robust
design) is looked up in :data:`OPTIONAL_TASKS` and, when its module is absent, refused
with a message saying so.

:func:`run_point` is what a Dask worker runs for one point. It is idempotent: a point whose
run directory already holds a finished run of the same study hash is read back, not
recomputed, so a task retried after its worker died (or finished just before dying)
neither loses nor duplicates the point. Inside it the optimizer's starts run serially
(:func:`isodesign.optimization.executor.use_executor`): no nested pools.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib
import json
import os
import socket
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from isodesign.errors import InputError, SolverError
from isodesign.io.rundir import RunDirectory, read_run_record
from isodesign.sweeps.points import (  # noqa: F401 - the optimize task's helpers, re-exported
    _LOCAL,
    PEAK_MASS_EXPONENT,
    _analysis_fields,
    _optimize_table,
    _optimize_vertical,
    _preset_peak_slots,
    _table_row,
    _variables,
    _vertical_row,
    payload_varies,
    problem_cache,
    table_continuation_study,
)

__all__ = [
    "OPTIONAL_TASKS",
    "POINT_FILE",
    "TASKS",
    "SweepTask",
    "get_task",
    "register_task",
    "run_point",
]

#: The row of a point, written into its run directory (the sweep table is built from these).
POINT_FILE = "sweep_point.json"
#: Run statuses of a finished point that a rerun skips.
FINISHED = ("complete", "infeasible")


@dataclass(frozen=True)
class SweepTask:
    """A kind of sweep point.

    Attributes
    ----------
    name : str
        The ``--task`` name.
    command : str
        The run-directory kind written (``isodesign <command>``).
    run : callable
        ``run(study, run, options) -> dict``: computes the point into the open run
        directory and returns its row fields; sets ``run.status = "infeasible"`` when the
        point has no feasible design.
    options : tuple of str
        The options it reads from the sweep's task options.
    description : str
        One line for ``--help`` and the docs.
    check : callable, optional
        ``check(study)`` raises InputError when the base study cannot run this task
        (called before anything runs).
    """

    name: str
    command: str
    run: Callable
    options: tuple[str, ...] = field(default_factory=tuple)
    description: str = ""
    check: Callable | None = None


#: Registered tasks, by name.
TASKS: dict[str, SweepTask] = {}
#: Tasks another capability provides: name -> (module it needs, what provides it). When
#: the module imports, the task is registered (by the module itself, or from
#: :data:`_OPTIONAL_BUILDERS` here).
OPTIONAL_TASKS: dict[str, tuple[str, str]] = {
    "yield": ("isodesign.optimization.yields", "robust design (yield under tolerances)"),
}


def register_task(task: SweepTask) -> SweepTask:
    """Add a task to the registry (replacing one of the same name).

    Parameters
    ----------
    task : SweepTask

    Returns
    -------
    SweepTask
    """
    TASKS[task.name] = task
    return task


def get_task(name: str, option: str = "--task") -> SweepTask:
    """The task called ``name``, or InputError naming what is available.

    Parameters
    ----------
    name : str
    option : str
        For messages.

    Returns
    -------
    SweepTask
    """
    if name in TASKS:
        return TASKS[name]
    if name in OPTIONAL_TASKS:
        module, what = OPTIONAL_TASKS[name]
        try:
            importlib.import_module(module)
        except ModuleNotFoundError:
            raise InputError(
                f"{option}: {name!r} is not available in this isodesign: it comes with "
                f"{what} ({module} is not installed); available: {', '.join(sorted(TASKS))}"
            ) from None
        if name not in TASKS and name in _OPTIONAL_BUILDERS:
            register_task(_OPTIONAL_BUILDERS[name]())
        if name in TASKS:
            return TASKS[name]
    raise InputError(f"{option}: unknown task {name!r}; available: "
                     f"{', '.join(sorted(TASKS))}")


# ---------------------------------------------------------------------------------------
# the built-in tasks
# ---------------------------------------------------------------------------------------
def _args(run: RunDirectory, *, plots: bool, **extra) -> argparse.Namespace:
    """The command-line namespace a point's records are written with (its replay command)."""
    return argparse.Namespace(study=str(run.final_path("study_resolved.toml")), starts=None,
                              workers=None, seed=None, output=str(run.target),
                              no_plots=not plots, quiet=True, overwrite=False, **extra)


def _optimize(study, run: RunDirectory, options: dict) -> dict:
    """The point's answer from :func:`isodesign.optimize` (vertical, table, robust or robust
    table) and the files ``isodesign optimize`` writes for that kind of study."""
    import contextlib
    import io

    from isodesign.commands.optimize import write_outputs
    from isodesign.commands.optimize_cli import execute_study
    from isodesign.optimization.dispatch import study_kind
    from isodesign.sweeps.robust_points import optimize_robust, optimize_robust_table, robust_row

    kind = study_kind(study)
    extra: dict = {}
    if kind == "vertical":
        result, extra = _optimize_vertical(study, options)
    elif kind == "table":
        # solved from the neighbour's optimum: its files record the study solved (the
        # replay starts where the point did)
        result, extra, study = _optimize_table(study, options)
    elif kind == "robust":
        result, extra = optimize_robust(study, options)
    else:
        # as a table point: its files record the study solved
        result, extra, study = optimize_robust_table(study, options)
    plots = bool(options.get("plots", False))
    args = _args(run, plots=plots, yield_samples=options.get("yield_samples"))
    if kind == "vertical":
        write_outputs(result, run, args, plots=plots)
        row = _vertical_row(result)
    else:
        # the command's writers print its report: a sweep point keeps its output quiet
        # (the run directory and the row say everything)
        with contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            execute_study(study, run, args, result)
        row = _table_row(result) if kind == "table" else robust_row(result)
        # the yields the command computed (robust.json), as the row's columns
        yields = (run.record.get("robust_result") or {}).get("yields") or []
        for y, col in zip(yields, ("yield_nominal", "yield"), strict=False):
            row[col] = float(y["fraction"])
    row.update(extra)
    if not row["feasible"]:
        run.status = "infeasible"
    return row


def _response(study, run: RunDirectory, options: dict) -> dict:
    from isodesign.io.record import design_figures, resolved_study_dict, study_toml
    from isodesign.optimization.analyze import vertical_band_response

    _check_response(study)  # a point's study never answers the nominal question
    if study.table is not None:
        return _table_response(study, run)
    m = study.models
    analysis = vertical_band_response(  # through the payload's symmetric table (one model)
        study.start_design(), study.payload, study.floor, study.target, bands=study.bands,
        derive_pressure=False, warn=False, flow=m["flow"], amplitude_mode=m["amplitude_mode"],
        diaphragm=m["diaphragm"], random_method=m["random_method"],
        distortion=bool(m.get("distortion", False)))
    values = {v.name: v.start for v in study.variables}
    run.record.update({"study": resolved_study_dict(study), "study_source": study.source,
                       "design": values})
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign sweep point (task response: the band response of\n"
        "the study's start design)")))
    run.write_csv("bands.csv", analysis.to_frame())
    run.write_json("response.json", {"design": values, "verdict": analysis.verdict(),
                                     "figures": design_figures(study.start_design(),
                                                               analysis)})
    return {"feasible": bool(analysis.passes), "objective": "worst_band_margin",
            "objective_value": float(analysis.worst_margin_db), **_variables(values),
            "binding": "", **_analysis_fields(analysis)}


def _table_response(study, run: RunDirectory) -> dict:
    """The table's band response of the start design (three axes, every point), as
    ``isodesign response`` answers a table study."""
    from isodesign.io.record import resolved_study_dict, study_toml
    from isodesign.optimization.table_driver import _analyze

    analysis, modes, _ = _analyze(study, study.start_design())
    values = {v.name: v.start for v in study.variables}
    run.record.update({"study": resolved_study_dict(study), "study_source": study.source,
                       "design": values, "table": True})
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign sweep point (task response: the table's band\n"
        "response of the study's start design)")))
    run.write_csv("bands.csv", analysis.to_frame())
    run.write_json("response.json", {"design": values, "verdict": analysis.verdict(),
                                     "worst_margin_db": analysis.worst_margin_db,
                                     "table": True})
    _, axis, band, _ = analysis.worst
    z = [f for f, n in zip(modes.frequency_hz, modes.names, strict=True) if n == "z"]
    return {"feasible": bool(analysis.passes), "objective": "worst_band_margin",
            "objective_value": float(analysis.worst_margin_db), **_variables(values),
            "binding": "", "worst_band_margin_db": float(analysis.worst_margin_db),
            "worst_band_hz": float(band), "worst_axis": str(axis),
            "passes": bool(analysis.passes), "natural_frequency_hz": float(z[0]) if z else None,
            "peak_transmissibility_db": float(analysis.peak_transmissibility_db().max())}


def _front_or_infeasible(study, run: RunDirectory, objectives, points: int,
                         objective: str) -> tuple:
    """``(front, None)``, or ``(None, row)`` with the point marked infeasible when no
    design is feasible (a vertical or a table front: the same call, the same refusal)."""
    from isodesign.optimization.pareto import pareto_front

    try:
        return pareto_front(study, objectives, points), None
    except SolverError as exc:
        if "no feasible design" not in str(exc):
            raise
        run.status = "infeasible"
        run.record["error"] = str(exc)
        return None, {"feasible": False, "objective": objective, "binding": "",
                      "solver_status": str(exc)}


def _pareto(study, run: RunDirectory, options: dict) -> dict:
    import numpy as np

    from isodesign.commands.pareto import pareto_json
    from isodesign.io.record import pareto_record, resolved_study_dict, study_toml
    from isodesign.optimization.objectives import OBJECTIVES
    from isodesign.optimization.pareto import DEFAULT_OBJECTIVES

    objectives = tuple(options.get("objectives") or DEFAULT_OBJECTIVES)
    points = int(options.get("points") or 10)
    run.record.update({"study": resolved_study_dict(study), "study_source": study.source})
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign sweep point (task pareto)")))
    if study.table is not None:
        return _table_pareto(study, run, options, points)
    result, infeasible = _front_or_infeasible(study, run, objectives, points, "hypervolume")
    if result is None:
        return infeasible
    run.write_csv("pareto.csv", result.to_frame())
    run.write_json("pareto.json", pareto_json(result))
    run.record.update(pareto_record(result, study))
    if options.get("plots"):
        from isodesign.plotting import pareto_plot

        with run.writing("pareto.png") as tmp:
            pareto_plot(result, tmp)
    a = objectives[0]
    va = np.where(result.front, OBJECTIVES[a].minimized(result.values[:, 0]), np.inf)
    best = int(np.argmin(va))
    return {"feasible": True, "objective": "hypervolume",
            "objective_value": float(result.hypervolume), **_variables(result.designs[best]),
            "binding": "", "n_front": int(np.sum(result.front)),
            f"best_{a}": float(result.values[best, 0])}


def _table_pareto(study, run: RunDirectory, options: dict, points: int) -> dict:
    """The front of a table study (the files of ``isodesign pareto`` for a table)."""
    import contextlib
    import io
    import math

    import numpy as np

    from isodesign.commands.pareto import execute_table_front
    from isodesign.optimization.pareto import TABLE_OBJECTIVES

    objectives = tuple(options.get("objectives") or TABLE_OBJECTIVES)
    result, infeasible = _front_or_infeasible(study, run, objectives, points,
                                              "worst_band_margin")
    if result is None:
        return infeasible
    args = _args(run, plots=bool(options.get("plots", False)), points=points)
    with contextlib.redirect_stdout(io.StringIO()):
        execute_table_front(study, run, args, result)
    m = np.where(result.front, result.worst_margin_db, -np.inf)
    best = int(np.argmax(m))
    return {"feasible": True, "objective": "worst_band_margin",
            "objective_value": float(result.worst_margin_db[best]),
            **_variables(result.designs[best]), "binding": "",
            "n_front": int(np.sum(result.front)), "hypervolume": float(result.hypervolume),
            "best_worst_band_margin": float(result.worst_margin_db[best]),
            "min_total_volume_m3": float(np.nanmin(np.where(result.front,
                                                            result.total_volume_m3,
                                                            math.inf)))}


def _check_pareto(study) -> None:
    from isodesign.optimization.dispatch import refuse
    from isodesign.optimization.pareto import PARETO_WHAT

    refuse(study, PARETO_WHAT, table=False)


def _check_response(study) -> None:
    from isodesign.commands.response import refuse_robust_response

    refuse_robust_response(study)  # the line of isodesign response


def _check_yield(study) -> None:
    if getattr(study, "scenarios", None) is None:
        raise InputError("--task yield: the study has no [scenarios] table (the tolerance laws "
                         "the built tables are drawn from; docs/robust.md)")


def _yield(study, run: RunDirectory, options: dict) -> dict:
    from isodesign.io.record import resolved_study_dict, study_toml
    from isodesign.optimization.yields import estimate_yield

    values = {v.name: v.start for v in study.variables}
    run.record.update({"study": resolved_study_dict(study), "study_source": study.source,
                       "design": values})
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign sweep point (task yield: the yield of the study's\n"
        "start design under its [scenarios])")))
    n = options.get("samples")  # default: estimate_yield's, as isodesign yield
    res = estimate_yield(study, values, **({} if n is None else {"samples": int(n)}),
                         seed=int(options.get("seed") or 0), workers=1,
                         label="the study's start design")
    run.write_json("yield.json", res.record())
    run.write_csv("yield.csv", res.to_frame())
    lo, hi = res.record()["clopper_pearson"]
    return {"feasible": bool(res.passed > 0), "objective": "yield",
            "objective_value": float(res.fraction), **_variables(values), "binding": "",
            "yield_low": float(lo), "yield_high": float(hi), "samples": int(res.samples),
            "worst_band_margin_db": float(res.worst_margin_db())}


#: Builders of the optional tasks whose code lives here (registered once their module is).
_OPTIONAL_BUILDERS = {
    "yield": lambda: SweepTask("yield", "yield", _yield, ("samples", "seed"),
                               "yield of the study's start design under its [scenarios]",
                               check=_check_yield),
}


register_task(SweepTask("optimize", "optimize", _optimize, ("plots", "yield_samples"),
                        "the point's optimum, robust with [scenarios], in six degrees of "
                        "freedom with [table] (the files of isodesign optimize)"))
register_task(SweepTask("response", "response", _response, (),
                        "band response of the study's start design, in three axes at every "
                        "point with [table] (bands.csv, response.json); refuses a study "
                        "with [scenarios] (isodesign yield answers it)",
                        check=_check_response))
register_task(SweepTask("pareto", "pareto", _pareto, ("objectives", "points", "plots"),
                        "the point's Pareto front (the files of isodesign pareto)",
                        check=_check_pareto))


# ---------------------------------------------------------------------------------------
# one point, as a Dask task
# ---------------------------------------------------------------------------------------
def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def worker_name() -> str:
    """The Dask worker's address, else ``local:<host>:<pid>``.

    Returns
    -------
    str
    """
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return f"local:{socket.gethostname()}:{os.getpid()}"


def read_point(directory, study_hash: str | None = None) -> dict | None:
    """The row of a finished point in ``directory`` (None if absent, unfinished or another).

    Parameters
    ----------
    directory : str or Path
        A point's run directory.
    study_hash : str, optional
        Required hash (None: any).

    Returns
    -------
    dict or None
    """
    d = Path(directory)
    rec = read_run_record(d)
    if rec is None or rec.get("run_status") not in (*FINISHED, "failed"):
        return None
    try:
        row = json.loads((d / POINT_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if study_hash is not None and row.get("study_hash") != study_hash:
        return None
    return row


def run_point(task_name: str, study_raw: dict, study_hash: str, changes: dict, point_dir: str,
              options: dict | None = None, neighbours=(), resolve: bool = False) -> dict:
    """Compute one sweep point into its run directory; return its row (a Dask task).

    Parameters
    ----------
    task_name : str
        A registered task.
    study_raw : dict
        The point's resolved study (:func:`isodesign.io.record.resolved_study_dict`).
    study_hash : str
        Its hash (:func:`isodesign.sweeps.spec.study_hash`), checked here.
    changes : dict
        The point's study changes (dotted key -> value), recorded.
    point_dir : str
        The point's run directory (on a file system the workers share).
    options : dict, optional
        Task options.
    neighbours : sequence of dict or None
        Rows of finished neighbours (:mod:`isodesign.sweeps.continuation`): their optima
        are further starts of an ``optimize`` point (a Dask task receives them from its
        predecessor's future).
    resolve : bool
        Compute the point again even when it is finished (the branch pass).

    Returns
    -------
    dict
        The row: ``point``, ``study_hash``, ``task``, ``question`` (the study's kind:
        ``vertical``, ``table``, ``robust`` or ``robust table``), ``status`` (the run's
        ``run_status``), ``error``, ``warnings``, ``worker``, ``started_utc``, ``wall_s``,
        ``cpu_s`` (the CPU time of the thread that computed it: much less than ``wall_s``
        when the point waited for a core), ``run_dir`` and the task's fields. A point
        already finished in ``point_dir`` is read back (``reused`` true).
    """
    from isodesign.optimization.dispatch import study_kind
    from isodesign.optimization.executor import SerialExecutor, use_executor
    from isodesign.optimization.study import study_from_dict
    from isodesign.sweeps.spec import study_hash as _hash

    options = dict(options or {})
    task = get_task(task_name)
    done = read_point(point_dir, study_hash)
    if done is not None and done.get("status") in FINISHED and not resolve:
        return {**done, "reused": True}
    with warnings.catch_warnings():  # the sweep warned of the point's values, naming it
        warnings.simplefilter("ignore")
        study = study_from_dict(study_raw, source="<dict>", fill_defaults=False)
    if _hash(study) != study_hash:  # pragma: no cover - a bug, never a silent mismatch
        raise RuntimeError("sweep point: the study changed on its way to the worker")
    row = {"point": study_hash[:16], "study_hash": study_hash, "task": task_name,
           "question": study_kind(study),
           "changes": json.dumps(changes), "status": None, "error": "", "warnings": "",
           "worker": worker_name(), "started_utc": _now(), "wall_s": None, "cpu_s": None,
           "run_dir": f"points/{Path(point_dir).name}", "reused": False}
    t0, c0 = time.perf_counter(), time.thread_time()
    run = RunDirectory(point_dir, command=task.command, overwrite=True,
                       argv=["isodesign", "sweep", "--task", task_name])
    with run, use_executor(SerialExecutor()), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run.record["sweep_point"] = {"study_hash": study_hash, "changes": changes,
                                     "task": task_name, "options": options}
        run.record["sweep_point"]["neighbours"] = [r.get("point") for r in neighbours if r]
        inner = {**options, "_neighbours": list(neighbours), "_resolved": resolve,
                 "_payload": payload_varies(changes)}
        try:
            row.update(task.run(study, run, inner))
            status, error = run.status, None
        except (SolverError, InputError) as exc:  # the point's own failure: not retried
            status, error = "failed", f"{type(exc).__name__}: {exc}"
        msgs = sorted({str(w.message) for w in caught})
        row.update(status=status, error=error or "", warnings=" | ".join(msgs)[:2000],
                   wall_s=time.perf_counter() - t0, cpu_s=time.thread_time() - c0)
        run.write_json(POINT_FILE, row)
        if status == "failed":
            run.finish("failed", error=error)
    return row


def record_failed_point(task_name: str, study_hash: str, changes: dict, point_dir: str,
                        error: str) -> dict:
    """Write the run directory of a point whose task failed on Dask (twice); return its row.

    Parameters
    ----------
    task_name, study_hash, changes, point_dir
        As :func:`run_point`.
    error : str
        What Dask reported (``KilledWorker: ...`` when its workers died).

    Returns
    -------
    dict
    """
    task = get_task(task_name)
    row = {"point": study_hash[:16], "study_hash": study_hash, "task": task_name,
           "changes": json.dumps(changes), "status": "failed", "error": error,
           "warnings": "", "worker": "", "started_utc": _now(), "wall_s": None, "cpu_s": None,
           "run_dir": f"points/{Path(point_dir).name}", "reused": False}
    run = RunDirectory(point_dir, command=task.command, overwrite=True,
                       argv=["isodesign", "sweep", "--task", task_name])
    with run:
        run.record["sweep_point"] = {"study_hash": study_hash, "changes": changes,
                                     "task": task_name}
        run.write_json(POINT_FILE, row)
        run.finish("failed", error=error)
    return row
