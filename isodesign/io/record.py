"""Run records: every optimizer run written down so that a study can be replayed.

In the spirit of OpenMDAO's case recorders (without its framework): the
output directory of a run (written under the contract of :mod:`isodesign.io.rundir`, which
adds the status fields ``run_status`` (one of :data:`RUN_STATUSES`), ``files``,
``manifest``, ``started_utc``, ``finished_utc`` and, for a failure, ``error``) holds
the resolved study (``study_resolved.toml``,
loadable with ``isodesign optimize``), the solver settings, the package
versions, every start with its status, iterations and time, and the final
design (``record.json``, ``starts.csv``, ``design.json``).
"""

from __future__ import annotations

import datetime as _dt
import functools
import json
import math
import platform
import sys
from pathlib import Path
from typing import Any

from isodesign import __version__
from isodesign.io.files import atomic_write_text
from isodesign.io.rundir import RUN_STATUSES
from isodesign.optimization.explain import limiting_factors, variables_at_bounds
from isodesign.optimization.objectives import OBJECTIVES

__all__ = [
    "RUN_STATUSES",
    "command_line",
    "constraint_rows",
    "design_figures",
    "dumps_toml",
    "environment",
    "grid_notes",
    "optimization_design",
    "optimization_record",
    "pareto_record",
    "resolved_study_dict",
    "study_toml",
    "variables_at_bounds",
    "write_json",
]


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):  # inside a list (table.group_springs): an inline table
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()
                               if x is not None) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def dumps_toml(d: dict, _prefix: str = "") -> str:
    """Serialize nested dicts of scalars and lists as TOML (tables after keys).

    Parameters
    ----------
    d : dict
        Keys (bare TOML keys, not quoted) to values: bool, int, float (``nan``
        and ``inf`` as TOML's special floats), str, lists or tuples of these (a dict
        inside a list as an inline table, ``{k = v}``), or a nested dict, written as a
        ``[table]`` (dotted name) after the keys. ``None`` values are left out.

    Returns
    -------
    str
        TOML text ending in a newline; a table whose entries are all tables gets no
        header of its own (TOML defines it implicitly).

    Raises
    ------
    TypeError
        A value of another type (a NumPy array, ...).
    """
    lines = []
    tables = []
    for k, v in d.items():
        if v is None:
            continue
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {_toml_value(v)}")
    out = "\n".join(lines)
    for k, v in tables:
        name = f"{_prefix}{k}"
        body = dumps_toml(v, f"{name}.").rstrip("\n")
        has_scalars = any(not isinstance(x, dict) and x is not None for x in v.values())
        block = (f"[{name}]\n" if has_scalars else "") + body
        out = f"{out}\n\n{block}" if out else block
    return out.strip() + "\n"


def environment() -> dict:
    """Versions of Python, the platform and the numerical packages.

    The versions and the platform are looked up once per process (reading the installed
    packages' metadata took about 50 ms: a run records them twice); the date is now's.
    """
    return {**_static_environment(), "packages": dict(_static_environment()["packages"]),
            "date_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")}


@functools.cache
def _static_environment() -> dict:
    from importlib import metadata

    pkgs = {}
    for name in ("isodesign", "numpy", "scipy", "casadi", "pandas", "control", "cvxpy",
                 "matplotlib"):
        try:
            pkgs[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pkgs[name] = None
    return {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "machine": platform.machine(),
        "packages": pkgs,
    }


def _jsonable(v):
    import numpy as np

    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.ndarray):
        return _jsonable(v.tolist())
    if isinstance(v, np.generic):
        v = v.item()  # a Python scalar: NaN or infinite NumPy floats become null below
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def write_json(path, data: dict) -> Path:
    """Write JSON (NumPy values converted, non-finite floats as null), whole or not at all.

    Parameters
    ----------
    path : str or path-like
        The file; missing parent directories are created; an existing file is
        replaced whole (written to a temporary file, then renamed).
    data : dict
        Nested dicts, lists, tuples, NumPy arrays and scalars, Python scalars.
        Keys become strings; arrays become lists; floats that are NaN or
        infinite (Python floats and NumPy scalars alike) become ``null``, so the
        file is strict JSON.

    Returns
    -------
    Path
        The path written (UTF-8, indented by 2, ending in a newline).
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(p, json.dumps(_jsonable(data), indent=2) + "\n")


# ---------------------------------------------------------------------------
# run records of the optimizer and of Pareto sweeps
# ---------------------------------------------------------------------------
def command_line(argv=None, prog: str = "isodesign") -> list[str]:
    """The command line of a run as a list of words (``argv`` without the program name).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments after the program name; default ``sys.argv[1:]``.
    prog : str
        The program name put first.
    """
    return [prog, *(sys.argv[1:] if argv is None else [str(a) for a in argv])]


def resolved_study_dict(study) -> dict:
    """The study's resolved dictionary (``study.raw``) ready to be written elsewhere.

    A floor CSV or survey record, a diaphragm table (``models.diaphragm = "table:PATH"`` or
    ``"PATH.csv"``) and a diaphragm fit file (``fit:PATH``, also inside a
    ``[models.diaphragm]`` table) named by relative paths are resolved against the study
    file's directory (as :func:`isodesign.optimization.study.load_study` does), so that the
    written study loads the same files from any directory.

    Parameters
    ----------
    study : Study
        Its ``raw`` dictionary and ``source`` (the study file's path, or
        ``"<dict>"``, ``"<default>"`` or ``""``: then a relative path is taken
        relative to the working directory).

    Returns
    -------
    dict
        A deep copy of ``study.raw`` with ``floor.csv``/``floor.record`` (also in
        ``[floor.x]`` and ``[floor.y]``) and a diaphragm table path made absolute;
        ``study.raw`` itself is not changed.
    """
    import copy

    raw = copy.deepcopy(study.raw)

    def absolute(path: str) -> str:
        p = Path(path)
        if not p.is_absolute() and study.source not in ("<dict>", "<default>", ""):
            p = Path(study.source).parent / p
        return str(p.resolve())

    fl = raw.get("floor", {})
    # a spectrum or a survey record, relative to the study file; the per-axis floors of a
    # table ([floor.x], [floor.y]) likewise
    for table in (fl, *(fl.get(a) for a in ("x", "y"))) if isinstance(fl, dict) else ():
        for key in ("csv", "record"):
            if isinstance(table, dict) and isinstance(table.get(key), str):
                table[key] = absolute(table[key])
    models = raw.get("models", {})
    dia = models.get("diaphragm") if isinstance(models, dict) else None
    if isinstance(dia, str) and (dia.startswith("table:") or dia.lower().endswith(".csv")):
        prefix = "table:" if dia.startswith("table:") else ""
        models["diaphragm"] = prefix + absolute(dia[len(prefix):])
    # a fit file (or a fit/table named in a [models.diaphragm] table), likewise
    spec = dia.get("model", "") if isinstance(dia, dict) else dia
    if (isinstance(spec, str) and spec.startswith("fit:")) or (
        isinstance(dia, dict) and isinstance(spec, str) and spec.startswith("table:")
    ):
        prefix = spec.split(":", 1)[0] + ":"
        if isinstance(dia, dict):
            dia["model"] = prefix + absolute(spec[len(prefix):])
        else:
            models["diaphragm"] = prefix + absolute(spec[len(prefix):])
    return raw


def study_toml(study, *, header: str | None = None) -> str:
    """The resolved study as TOML (:func:`dumps_toml` of :func:`resolved_study_dict`).

    Loading the text with :func:`isodesign.optimization.study.load_study` gives a study with
    the same ``raw`` dictionary: the run can be replayed from it.

    Parameters
    ----------
    study : Study
    header : str, optional
        Comment lines put first (``#`` is added to each line).
    """
    body = dumps_toml(resolved_study_dict(study))
    if not header:
        return body
    lines = [f"# {ln}".rstrip() for ln in header.strip().splitlines()]
    return "\n".join(lines) + "\n\n" + body


def _f(x):
    return None if x is None else float(x)


def _db(x):
    return None if x is None or not x > 0 else 20.0 * math.log10(float(x))


def _analysis_figures(res) -> dict:
    """Figures of a :class:`~isodesign.response.random_input.BandResponse` (None-safe)."""
    if res is None:
        return {}
    s = res.stability
    return {
        "natural_frequency_hz": _f(s.natural_frequency_hz),
        "static_stiffness_n_per_m": _f(s.static_stiffness_n_per_m),
        "air_static_stiffness_n_per_m": _f(s.air_static_stiffness_n_per_m),
        "zener_damping_ratio": _f(s.zener_damping_ratio),
        "zener_optimal_damping_ratio": _f(s.zener_optimal_damping_ratio),
        "tilt_margin": _f(s.tilt_margin),
        "pressure_pa": _f(s.pressure_pa),
        "peak_transmissibility_db": _db(s.excited_peak_transmissibility),
        "peak_frequency_hz": _f(s.excited_peak_frequency_hz),
        "linear_peak_transmissibility_db": _db(s.peak_transmissibility),
        "linear_peak_frequency_hz": _f(s.peak_frequency_hz),
        "worst_band_margin_db": _f(res.worst_margin_db),
        "worst_band_hz": _f(res.worst_band_hz),
        "stroke_rms_m": _f(res.stroke_rms_m),
        "equivalent_amplitude_m": _f(res.equivalent_amplitude_m),
        "passes": bool(res.passes),
        "verdict": res.verdict(),
    }


def design_figures(design, analysis=None) -> dict:
    """Derived figures of a loaded design: stiffnesses, f_n, damping, volumes, p0.

    Parameters
    ----------
    design : SpringDesign
        With the pressure derived from the payload (``study.design_at``).
    analysis : BandResponse, optional
        The design's band response; adds the natural frequency, damping ratio,
        tilt margin, peak ``|T|``, worst-band margin and verdict.

    Returns
    -------
    dict
        SI values (keys end with their unit).
    """
    out = {
        "single_chamber_stiffness_k_s_n_per_m": _f(design.single_chamber_stiffness_n_per_m),
        "air_static_stiffness_n_per_m": _f(design.static_stiffness_n_per_m),
        "total_volume_m3": _f(design.total_volume_m3),
        "bottom_volume_m3": _f(design.bottom_volume_m3),
        "pressure_pa": _f(design.pressure_pa),
    }
    out.update(_analysis_figures(analysis))
    return out


def _constraint_dict(c) -> dict:
    """A :class:`~isodesign.optimization.constraints.ConstraintReport`, margin in natural units."""
    lo, hi, v = c.lower, c.upper, c.value
    margins = []
    if lo is not None:
        margins.append(v - lo)
    if hi is not None:
        margins.append(hi - v)
    return {
        "name": c.name,
        "value": v,
        "lower": lo,
        "upper": hi,
        "unit": c.unit,
        "margin": min(margins) if margins else None,
        "margin_nlp": c.margin,
        "binding": bool(c.active),
        "description": c.description,
    }


def constraint_rows(result) -> list[dict]:
    """The constraints of an :class:`~isodesign.optimization.result.OptimizationResult` as dicts.

    ``margin`` is the distance to the nearest bound in the constraint's own unit
    (positive: satisfied); ``margin_nlp`` is the optimizer's margin in its
    internal (log or dB) units; ``binding`` marks the active constraints.

    Parameters
    ----------
    result : OptimizationResult
        Its ``constraints``
        (:class:`~isodesign.optimization.constraints.ConstraintReport` each).

    Returns
    -------
    list of dict
        One per constraint: ``name``, ``value``, ``lower``, ``upper`` (natural
        units, ``None`` for an absent bound), ``unit``, ``margin``, ``margin_nlp``,
        ``binding`` and ``description``.
    """
    return [_constraint_dict(c) for c in result.constraints]


#: Excess (dB) of the analysis's peak |T| over the optimizer's bound that is reported.
PEAK_EXCESS_DB = 0.005


def grid_notes(result, figures: dict) -> list[str]:
    """Notes on the peak of |T| between the frequencies the NLP samples.

    The NLP enforces ``max_peak_transmissibility_db`` at the ``models.peak_points``
    log-spaced frequencies and at the frequencies the peak refinement (exchange
    method, :func:`isodesign.optimization.refine.refine_peak`) adds near the
    continuous peak, until that peak is within the refinement's tolerance of its
    limit or the refinement's rounds run out; the band analysis locates the peak
    itself.

    Parameters
    ----------
    result : OptimizationResult
        Gives the study's ``max_peak_transmissibility_db``, ``models.peak_points``
        and the refinement's record ``result.peak`` (rounds, added frequencies,
        continuous peak, its limit and ``met``).
    figures : dict
        The optimum's :func:`design_figures` with its analysis:
        ``peak_transmissibility_db`` (the excited peak of |T|, dB) and
        ``peak_frequency_hz``.

    Returns
    -------
    list of str
        A note when the refinement ended with the continuous peak above its limit
        (the bound, or the sampled peak objective: the design, or the reported
        objective, does not hold between the grid frequencies); otherwise a note
        when the analysis's peak exceeds the bound by more than
        :data:`PEAK_EXCESS_DB`; empty otherwise (no bound, no analysis, or within).
    """
    out = []
    st = result.study
    bound = st.constraints.get("max_peak_transmissibility_db")
    npk = st.models["peak_points"]
    pk = result.peak or {}
    added = len(pk.get("added_frequencies_hz") or ())
    if pk.get("met") is False:
        what = (f"constraints.max_peak_transmissibility_db = {pk['limit_db']:g} dB"
                if pk.get("limit") == "bound" else
                f"the optimized peak objective ({pk['limit_db']:.3f} dB on the grid)")
        out.append(
            f"the continuous peak |T| at A* is {pk['peak_db']:.3f} dB at "
            f"{pk['peak_frequency_hz']:.3g} Hz, {pk['excess_db']:.3f} dB above {what}, after "
            f"{pk['rounds']} round(s) of peak refinement (the most it makes, "
            f"{added} frequencies added near the peak to the {npk} of models.peak_points): "
            "the limit holds at the NLP's grid frequencies only (raise models.peak_points "
            "for a finer base grid, or relax the bound)"
        )
        return out
    peak = figures.get("peak_transmissibility_db")
    if bound is not None and peak is not None and peak > bound + PEAK_EXCESS_DB:
        where = (f"at the {npk} frequencies of models.peak_points and {added} placed by the "
                 f"peak refinement, which met it to {pk['tolerance_db']:g} dB on its own "
                 f"continuous peak ({pk['peak_db']:.3f} dB)" if pk.get("met") else
                 f"at the {npk} frequencies of models.peak_points only (raise "
                 "models.peak_points)")
        out.append(
            f"peak |T| at A* is {peak:.3f} dB at {figures['peak_frequency_hz']:.3g} Hz in "
            f"the analysis, above constraints.max_peak_transmissibility_db = {bound:g} dB, "
            f"which the optimizer enforces {where}"
        )
    return out


def optimization_design(result) -> dict:
    """The content of ``design.json``: variables, derived figures, objective, verdict.

    Parameters
    ----------
    result : OptimizationResult
        A feasible result; the figures include the band analysis when the run
        made one (``optimize(..., analyze=True)``, the default).

    Returns
    -------
    dict
        ``study``, ``source``, ``feasible``, ``status``; ``objective`` (kind,
        natural value and start value, unit, sense); ``variables`` (name -> value,
        start, lower, upper as the study states them, fixed, ``at_bound``);
        ``derived`` and ``start_derived`` (:func:`design_figures` of the optimum and
        of the start design, SI); ``verdict``; ``notes`` (:func:`grid_notes`);
        ``binding_constraints`` (names); ``limited_by`` (sentences:
        :func:`~isodesign.optimization.explain.limiting_factors`); ``scope``
        (:class:`~isodesign.response.scope.Scope` as a dict); ``variables_at_bounds``;
        ``constraints`` (:func:`constraint_rows`) and ``spring`` (the design's ``to_dict()``).
    """

    st = result.study
    at = variables_at_bounds(result)
    variables = {}
    for v in st.variables:
        variables[v.name] = {
            "value": float(result.values[v.name]),
            "start": float(result.start_values[v.name]),
            "lower": float(v.lower),
            "upper": float(v.upper),
            "fixed": bool(v.fixed),
            "at_bound": at.get(v.name),
        }
    figures = design_figures(result.design, result.analysis)
    start_figures = design_figures(st.design_at(result.start_values), result.start_analysis)
    return {
        "study": st.name,
        "source": st.source,
        "feasible": bool(result.feasible),
        "status": result.status,
        "objective": {
            "kind": result.objective,
            "value": float(result.objective_value),
            "start_value": _f(result.start_objective),
            "unit": OBJECTIVES[result.objective].unit,
            "sense": OBJECTIVES[result.objective].sense_word,
        },
        "variables": variables,
        "derived": figures,
        "start_derived": start_figures,
        "verdict": figures.get("verdict"),
        "notes": grid_notes(result, figures),
        "binding_constraints": [c.name for c in result.constraints if c.active],
        "limited_by": limiting_factors(result),
        "scope": result.analysis.scope.to_dict() if result.analysis is not None else None,
        "variables_at_bounds": at,
        "constraints": constraint_rows(result),
        "hessian": result.hessian_choice()["hessian"],
        "hessian_reason": result.hessian_choice()["reason"],
        "spring": result.design.to_dict(),
    }


def optimization_record(result, *, argv=None, extra: dict | None = None) -> dict:
    """The run record of :func:`isodesign.optimization.driver.optimize` (``record.json``).

    Command line, isodesign version and package versions, the resolved study,
    the solver settings, every start (status, iterations, time, objective, start
    and final values), the final design, objective, constraints, flat direction,
    re-check and wall time.

    Parameters
    ----------
    result : OptimizationResult
        Feasible or not; the figures are added only for a feasible one.
    argv : sequence of str, optional
        The command line after the program name (:func:`command_line`); default
        ``sys.argv[1:]``.
    extra : dict, optional
        Further top-level entries, added last (they replace entries of the same
        name).

    Returns
    -------
    dict
        The record, ready for :func:`write_json`: ``kind``, ``command_line``,
        versions and ``environment``, ``study`` (:func:`resolved_study_dict`),
        ``solver_settings``, ``starts`` (one dict per start), ``n_reached_best``,
        status, objective and start objective (natural units), ``design`` and
        ``start_design`` (SI), ``constraints``, ``violations``, ``flat_direction``,
        ``peak_refinement``, ``recheck_max_rel_diff``, ``wall_s`` and, if feasible,
        ``figures``, ``scope`` (:class:`~isodesign.response.scope.Scope` as a dict) and
        ``limited_by`` (:func:`~isodesign.optimization.explain.limiting_factors`).
    """

    starts = []
    for s in result.starts:
        starts.append({
            "index": s.index, "status": s.status, "success": s.success,
            "feasible": s.feasible, "iterations": s.iterations, "wall_s": s.wall_s,
            "objective": s.objective, "max_violation": s.max_violation,
            "start": dict(s.start), "final": dict(s.final),
        })
    rec = {
        "kind": "isodesign optimize",
        "command_line": command_line(argv),
        "isodesign_version": __version__,
        "environment": environment(),
        "study": resolved_study_dict(result.study),
        "study_source": result.study.source,
        "solver_settings": result.settings,
        "starts": starts,
        "n_reached_best": result.n_reached_best,
        "feasible": bool(result.feasible),
        "status": result.status,
        "objective": result.objective,
        "objective_value": result.objective_value,
        "start_objective_value": result.start_objective,
        "design": {k: float(v) for k, v in result.values.items()},
        "start_design": {k: float(v) for k, v in result.start_values.items()},
        "constraints": constraint_rows(result),
        "violations": [{"name": n, "amount": v} for n, v in result.violations],
        "flat_direction": result.flat_direction,
        "peak_refinement": result.peak,
        "recheck_max_rel_diff": result.recheck_max_rel_diff,
        "wall_s": result.wall_s,
    }
    if result.feasible:
        rec["figures"] = design_figures(result.design, result.analysis)
        # what the answer covers and leaves out, and what stopped the design (issue 14)
        rec["scope"] = result.analysis.scope.to_dict() if result.analysis is not None else None
        rec["limited_by"] = limiting_factors(result)
    if extra:
        rec.update(extra)
    return rec


def pareto_record(result, study, *, argv=None, extra: dict | None = None) -> dict:
    """The run record of :func:`isodesign.optimization.pareto.pareto_front` (``record.json``).

    Parameters
    ----------
    result : ParetoResult
        The front: objective values (natural units), designs, statuses,
        non-dominated flags, hypervolume, reference and ideal points.
    study : Study
        The study the front was computed for (recorded resolved, for a replay).
    argv : sequence of str, optional
        The command line after the program name; default ``sys.argv[1:]``.
    extra : dict, optional
        Further top-level entries, added last.

    Returns
    -------
    dict
        ``kind``, ``command_line``, versions and ``environment``, ``study``,
        ``study_source``, ``objectives``, ``settings``, ``points`` (per sweep point:
        both objective values keyed by kind, ``design``, ``status``,
        ``nondominated``, ``binding``: the constraints binding there), ``hypervolume``
        (normalized space),
        ``reference_point_minimized`` and ``ideal_point_minimized`` (the objectives
        as minimized: maximized ones negated) and ``wall_s``.
    """

    points = []
    for i, d in enumerate(result.designs):
        points.append({
            result.objectives[0]: result.values[i, 0],
            result.objectives[1]: result.values[i, 1],
            "design": dict(d),
            "status": result.statuses[i],
            "nondominated": bool(result.front[i]),
            "binding": list(result.binding[i]) if i < len(result.binding) else [],
        })
    rec = {
        "kind": "isodesign pareto",
        "command_line": command_line(argv),
        "isodesign_version": __version__,
        "environment": environment(),
        "study": resolved_study_dict(study),
        "study_source": study.source,
        "objectives": list(result.objectives),
        "settings": result.settings,
        "points": points,
        "hypervolume": result.hypervolume,
        "reference_point_minimized": result.reference_point,
        "ideal_point_minimized": result.ideal_point,
        "wall_s": result.wall_s,
    }
    if extra:
        rec.update(extra)
    return rec
