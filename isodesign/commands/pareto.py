"""Pareto front of two objectives of a study (epsilon-constraint sweep, warm starts).

Objective A (the first of --objectives) is optimized subject to objective B <= eps, for
--points values of eps between B at A's optimum and B's own optimum, each solve
warm-started from the previous one. The default front is the worst-band margin (maximized)
against the total chamber volume (minimized): how much margin each litre of isolator buys.
Prints the front as a table and its hypervolume (normalized space, reference point = nadir
+ 10 % of the front's range). Writes to OUTDIR: pareto.csv, pareto.json (hypervolume,
reference and ideal points), pareto.png, record.json and study_resolved.toml; OUTDIR
appears whole when the run ends, with the run's status in record.json (docs/cli.md). A
study without a feasible design still gets its record (run_status infeasible) and exit 1.
See docs/optimization.md.
"""

from __future__ import annotations

import argparse
import sys

from isodesign.commands import add_output_dir_arguments, check_count, input_error
from isodesign.commands import int_option as _int_option
from isodesign.commands.optimize import OUTPUT_FILES as OPTIMIZE_FILES
from isodesign.commands.optimize import (
    StartProgress,
    add_study_arguments,
    canonical_command,
    format_objective,
    load_study_from_args,
    open_run,
    progress_enabled,
    study_label,
    table,
)
from isodesign.commands.response import models_line
from isodesign.errors import InputError, SolverError
from isodesign.io.record import (
    command_line,
    environment,
    pareto_record,
    resolved_study_dict,
    study_toml,
)
from isodesign.optimization.dispatch import refuse
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.pareto import DEFAULT_OBJECTIVES, PARETO_WHAT, pareto_front
from isodesign.plotting import pareto_plot
from isodesign.response.scope import study_scope

#: Objective names: the objective registry's.
OBJECTIVE_CHOICES = tuple(OBJECTIVES)
DEFAULT_POINTS = 20
#: The fronts of a table study: the worst margin against the total volume or, with a free
#: layout, the isolators' footprint area (docs/table.md, section 15); with a free inertia
#: base, its mass (section 16).
TABLE_FRONTS = (("worst_band_margin", "total_volume"), ("worst_band_margin", "footprint_area"),
                ("worst_band_margin", "added_mass"))
#: Range of --points (each point is an IPOPT solve of a few tenths of a second).
POINTS_RANGE = (2, 500)
#: Files written by ``isodesign pareto``.
OUTPUT_FILES = ("pareto.csv", "pareto.json", "pareto.png", "record.json",
                "study_resolved.toml")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign pareto``."""
    add_study_arguments(parser)
    parser.add_argument(
        "--objectives",
        metavar="A,B",
        default=",".join(DEFAULT_OBJECTIVES),
        help="objective A (optimized) and B (swept as a constraint); default %(default)s; "
        f"names: {', '.join(OBJECTIVE_CHOICES)}",
    )

    parser.add_argument(
        "--points",
        type=_int_option,
        default=DEFAULT_POINTS,
        metavar="K",
        help="number of epsilon values, both anchors included "
        f"({POINTS_RANGE[0]}..{POINTS_RANGE[1]}; default %(default)s)",
    )
    add_output_dir_arguments(parser)


def parse_objectives(text: str) -> tuple[str, str]:
    """``A,B`` -> (A, B); InputError naming --objectives otherwise."""

    if len(text) > 200:
        raise input_error(f"--objectives: give two names A,B, got {text[:40]!r}...")
    names = tuple(t.strip() for t in text.split(","))
    if len(names) != 2 or not all(names):
        raise input_error(f"--objectives: give two names A,B, got {text!r}")
    for n in names:
        if n not in OBJECTIVE_CHOICES:
            raise input_error(
                f"--objectives: unknown objective {n!r}; valid: {', '.join(OBJECTIVE_CHOICES)}"
            )
    if names[0] == names[1]:
        raise input_error(f"--objectives: need two different objectives, got {text!r}")
    return names  # type: ignore[return-value]


def _natural_points(result) -> dict:
    """Reference and ideal points back in each objective's natural sense and unit."""

    out = {}
    for name, pt in (("reference_point", result.reference_point),
                     ("ideal_point", result.ideal_point)):
        out[name] = {k: float(-v if OBJECTIVES[k].maximized else v)
                     for k, v in zip(result.objectives, pt, strict=True)}
    return out


def pareto_json(result) -> dict:
    """The content of ``pareto.json``."""

    nat = _natural_points(result)
    return {
        "objectives": list(result.objectives),
        "units": {k: OBJECTIVES[k].unit for k in result.objectives},
        "sense": {k: OBJECTIVES[k].sense_word for k in result.objectives},
        "hypervolume": result.hypervolume,
        "hypervolume_space": "both objectives minimized (margins negated) and normalized: "
        "ideal point -> 0, reference point -> 1",
        "reference_point": nat["reference_point"],
        "ideal_point": nat["ideal_point"],
        "reference_point_minimized": list(map(float, result.reference_point)),
        "ideal_point_minimized": list(map(float, result.ideal_point)),
        "reference_margin": result.settings.get("reference_margin"),
        "points": len(result.designs),
        "nondominated": int(sum(bool(f) for f in result.front)),
        "wall_s": result.wall_s,
        "settings": result.settings,
    }


def front_table(result) -> str:
    """Every point, sorted by objective B; dominated ones marked, failed ones kept."""
    import math


    a, b = result.objectives
    order = sorted(range(len(result.designs)),
                   key=lambda i: (math.isnan(result.values[i, 1]), result.values[i, 1]))
    rows = []
    for i in order:
        d = result.designs[i]
        va, vb = result.values[i]
        ok = not (math.isnan(va) or math.isnan(vb))
        rows.append([
            str(i), format_objective(a, va) if ok else "failed",
            format_objective(b, vb) if ok else "",
            f"{d['volume_ratio']:.4g}", f"{d['top_volume_m3'] * 1e3:.4g}",
            f"{d['capillary_length_m'] * 1e3:.4g}", f"{d['capillary_diameter_m'] * 1e3:.4g}",
            "yes" if result.front[i] else ("no" if ok else ""),
        ])
    return table(rows, ["#", a, b, "N", "V_t0 (L)", "L_c (mm)", "D_c (mm)", "front"],
                 align=">>>>>>><")


class _SweepProgress:
    """Progress bar of the anchors and the epsilon sweep (no-op when disabled)."""

    def __init__(self, enabled: bool, total: int, objective: str):

        self.bar = StartProgress(enabled, total, objective, what="anchors (multi-start)")

    def __enter__(self):
        self.bar.__enter__()
        return self

    def __call__(self, done: int, total: int) -> None:
        self.bar.update(done, total, "epsilon sweep")

    def __exit__(self, *exc):
        return self.bar.__exit__(*exc)


def _sense(name: str) -> str:

    return "maximizing" if OBJECTIVES[name].maximized else "minimizing"


def _infeasible(run, args, objectives, exc) -> int:
    """A study whose anchor has no feasible design: record, report, exit status 1."""
    a, b = objectives
    run.status = "infeasible"
    msg = f"pareto: no feasible design when {_sense(a)} {a} alone"
    run.record["error"] = msg
    run.record["solver_message"] = str(exc)
    run.record["objectives"] = list(objectives)
    run.record["sense"] = {a: _sense(a).removesuffix("imizing") + "imize",
                           b: _sense(b).removesuffix("imizing") + "imize"}
    print(f"Pareto front of {a} ({_sense(a)}) against {b}: NO FEASIBLE DESIGN when "
          f"{_sense(a)} {a} alone, so there is no front; relax the study's constraints or "
          "widen its variables' bounds (isodesign optimize STUDY.toml shows the most "
          "violated constraints)")
    print(f"isodesign: error: {msg}; wrote {run.final_path('record.json')} "
          "(run_status infeasible)", file=sys.stderr)
    return 1


def run(args) -> int:
    """Run ``isodesign pareto``."""

    objectives = parse_objectives(args.objectives)
    check_count(args.points, "--points", *POINTS_RANGE)
    study = load_study_from_args(args)
    refuse(study, PARETO_WHAT, table=False)  # the API's line: no robust front
    if study.table is not None:  # six degrees of freedom (docs/table.md, section 11)
        if tuple(objectives) not in TABLE_FRONTS:
            raise InputError("--objectives: a study with a [table] has the fronts "
                             + " and ".join(",".join(f) for f in TABLE_FRONTS))
        with open_run(args, "pareto", known_outputs=OUTPUT_FILES) as rundir:
            return execute_table_front(study, rundir, args, objectives=tuple(objectives))
    rundir = open_run(args, "pareto", known_outputs=(*OUTPUT_FILES, *OPTIMIZE_FILES))
    with rundir:
        return _execute(study, rundir, args, objectives)


def execute_table_front(study, run, args, result=None, *,
                        objectives=DEFAULT_OBJECTIVES) -> int:
    """The front of a table study: worst margin over points and axes against a cost.

    ``result``: the study's front when already computed (a sweep point), else computed
    here by :func:`isodesign.pareto_front` for ``objectives`` (one of
    :data:`TABLE_FRONTS`); either way the same files are written.
    """
    import math

    from isodesign.plotting.style import save_figure

    run.record.update({"kind": "isodesign pareto", "table": True,
                       "command_line": command_line(canonical_command(args, "pareto")[1:]),
                       "environment": environment(), "study": resolved_study_dict(study),
                       "study_source": study.source})
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign pareto run (a table study).")))
    res = result
    if res is None:
        try:
            res = pareto_front(study, objectives, args.points)
        except SolverError as exc:  # as a vertical front: the record, the reason, exit 1
            if "no feasible design" in str(exc):
                return _infeasible(run, args, objectives, exc)
            raise
    written = [run.write_csv("pareto.csv", res.to_frame())]
    written.append(run.write_json("pareto.json", pareto_json(res)))
    pts = [{"worst_band_margin": None if not math.isfinite(m) else float(m),
            res.cost: None if not math.isfinite(v) else float(v),
            "design": d, "status": stt, "nondominated": bool(f)}
           for m, v, d, stt, f in zip(res.worst_margin_db, res.costs, res.designs,
                                      res.statuses, res.front, strict=True)]
    run.record.update({"points": pts, "wall_s": res.wall_s,
                       "objectives": list(res.objectives),
                       "hypervolume": res.hypervolume})
    written += [run.final_path("record.json"), run.final_path("study_resolved.toml")]
    if not args.no_plots:
        with run.writing("pareto.png") as tmp:
            save_figure(res.plot(), tmp)
        written.append(run.final_path("pareto.png"))
    print_front(study, res, args, written, run.target, kind="table",
                what="3 axes, every instrument point")
    return 0


def print_front(study, result, args, written, out, *, kind: str = "", what: str = "",
                scope=None) -> None:
    """What ``isodesign pareto`` prints of a front, vertical or table: the header, the models,
    every point with its design variables, the scope, the hypervolume with its reference and
    ideal points, and the files written (``--quiet``: the hypervolume lines only).

    Parameters
    ----------
    study : Study
    result : ParetoResult or TableParetoResult
    args : argparse.Namespace
        ``points``, ``quiet``.
    written : list of Path
        The files written.
    out : Path
        The run directory.
    kind : str
        Before "study" in the header (``table``).
    what : str
        What objective A covers (``3 axes, every instrument point``).
    scope : Scope, optional
        The study's scope (its lines follow the table).
    """
    a, b = result.objectives
    nat = _natural_points(result)
    ref = ", ".join(f"{k} {format_objective(k, v)}" for k, v in nat["reference_point"].items())
    ideal = ", ".join(f"{k} {format_objective(k, v)}" for k, v in nat["ideal_point"].items())
    n_front = int(sum(bool(f) for f in result.front))
    if not args.quiet:
        print(f"{kind + ' ' if kind else ''}study {study_label(study)}: Pareto front of {a} "
              f"({_sense(a)}{'; ' + what if what else ''}) against {b} (epsilon-constraint, "
              f"{args.points} points, {result.settings['starts']} starts for the anchor); "
              f"{result.wall_s:.1f} s")
        print(models_line(study.models, "the study"))
        print(front_table(result))
        if scope is not None:
            print("\n".join(scope.lines()))
    print(f"{n_front} of {len(result.designs)} points non-dominated; hypervolume "
          f"{result.hypervolume:.4f} (normalized: ideal point -> 0, reference point -> 1)")
    print(f"  reference point (nadir + {result.settings['reference_margin']:.0%} of the "
          f"range): {ref}")
    print(f"  ideal point: {ideal}")
    if not args.quiet:
        print("wrote " + ", ".join(p.name for p in written) + f" to {out}")


def _execute(study, run, args, objectives) -> int:

    out = run.target
    run.record.update({"command_line": command_line(canonical_command(args, "pareto")[1:]),
                       "environment": environment(), "study": resolved_study_dict(study),
                       "study_source": study.source})
    name = "study_resolved.toml"
    run.write_text(name, study_toml(study, header=(
        "Resolved study of an isodesign pareto run (defaults filled in, command-line\n"
        f"overrides applied). Replay: isodesign pareto {run.final_path(name)} --objectives "
        f"{','.join(objectives)} --points {args.points} -o NEWDIR")))
    try:
        with _SweepProgress(progress_enabled(args), args.points, objectives[0]) as bar:
            result = pareto_front(study, objectives, args.points, progress=bar)
    except SolverError as exc:
        if "no feasible design" in str(exc):
            return _infeasible(run, args, objectives, exc)
        raise
    written = [run.write_csv("pareto.csv", result.to_frame())]
    written.append(run.write_json("pareto.json", pareto_json(result)))
    run.record.update(pareto_record(result, study, argv=canonical_command(args, "pareto")[1:],
                                    extra={"argv": list(sys.argv)}))
    written.append(run.final_path("record.json"))
    written.append(run.final_path(name))
    if not args.no_plots:

        with run.writing("pareto.png") as tmp:
            pareto_plot(result, tmp)
        written.append(run.final_path("pareto.png"))
    print_front(study, result, args, written, out, scope=study_scope(study))
    return 0
