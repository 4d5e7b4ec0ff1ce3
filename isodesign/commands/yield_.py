"""Yield of a design under a study's tolerances: the fraction of built tables that pass.

DESIGN_OR_RUN is a design file (TOML, docs/design-file.md) or an ``isodesign optimize``
run directory (its robust design when the run was robust, else its optimum). The study
(``--study``; default: the run's ``study_resolved.toml``) must have a ``[scenarios]``
table: the laws the built tables are drawn from (docs/robust.md). Each draw is judged with
the NumPy analysis: the criterion in every target band, every constraint, the continuous
peak of |T|. Prints the pass fraction with its Clopper-Pearson and Wilson intervals and the
failure reasons; writes yield.json, yield.csv (every draw), yield.png and record.json to
OUTDIR. Exit status 0; 2 bad input.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from isodesign.commands import add_output_dir_arguments, run_directory
from isodesign.commands import int_option as _int_option

OUTPUT_FILES = ("yield.json", "yield.csv", "yield.png", "record.json")
#: The table an interrupted ``isodesign yield`` leaves: the draws judged so far (the
#: columns of yield.csv), in the set-aside ``OUTDIR.interrupted``.
PARTIAL_TABLE = "yield_partial.csv"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign yield``."""
    parser.add_argument("design", metavar="DESIGN_OR_RUN",
                        help="design file (TOML) or isodesign optimize run directory")
    parser.add_argument("--study", metavar="STUDY.toml",
                        help="study with a [scenarios] table (default: the run's "
                        "study_resolved.toml)")
    parser.add_argument("--samples", type=_int_option, default=1000, metavar="N",
                        help="number of draws (1..1000000; default 1000)")
    parser.add_argument("--seed", type=_int_option, default=0, metavar="N",
                        help="seed of the draws (>= 0; default 0)")
    parser.add_argument("--workers", type=_int_option, metavar="N",
                        help="worker processes (1..64; default the study's solver.workers)")
    parser.add_argument("--confidence", type=float, default=0.95, metavar="C",
                        help="level of the intervals, in (0, 1) (default 0.95)")
    parser.add_argument("--no-plots", action="store_true", help="write no PNG file")
    add_output_dir_arguments(parser)


def _design_values(path: Path) -> tuple[dict, str, Path | None]:
    """(design-variable values, label, the run's resolved study or None)."""

    from isodesign.errors import InputError
    from isodesign.io.designfile import load_design
    from isodesign.optimization.variables import DESIGN_VARIABLES

    if path.is_dir():
        study = path / "study_resolved.toml"
        rob = path / "robust.json"
        if rob.is_file():
            from isodesign.io.designfile import check_design_values
            from isodesign.io.files import read_json

            data = read_json(rob, what="robust.json")
            if not isinstance(data, dict):
                raise InputError(f"robust.json file {rob}: expected a JSON object, got "
                                 f"{type(data).__name__}")
            if data.get("feasible"):
                return (check_design_values(data.get("values"), f"{rob}: values"),
                        f"robust optimum of {path}", study)
        if (path / "design.toml").is_file():
            path_d = path / "design.toml"
            d = load_design(path_d)
            return ({n: float(getattr(d, n)) for n in DESIGN_VARIABLES}, f"optimum of {path}",
                    study if study.is_file() else None)
        raise InputError(f"DESIGN_OR_RUN: {path} is neither a design file nor a run directory "
                         "with design.toml")
    if not path.is_file():
        raise InputError(f"DESIGN_OR_RUN: no such file or directory: {path}")
    d = load_design(path)
    return {n: float(getattr(d, n)) for n in DESIGN_VARIABLES}, str(path), None


def _check_run_levers(path: Path, study, study_path):
    """A co-designed run's levers (its ``design.json``) against the study's: a lever the
    study fixes at another value would judge another table than the run's optimum (the
    spring alone is in ``design.toml``), so it is refused naming the key; levers the study
    leaves free are fixed at the run's values (the optimum's table is the one built).
    Returns the study to draw from."""
    import math

    from isodesign.errors import InputError
    from isodesign.io.files import read_json
    from isodesign.optimization.variables import CODESIGN_LEVERS, GROUP_SPRING_LEVERS

    dj = path / "design.json" if path.is_dir() else None
    if dj is None or not dj.is_file() or (path / "robust.json").is_file():
        return study
    try:
        variables = read_json(dj, what="design.json").get("variables") or {}
    except (AttributeError, InputError):
        return study  # the design itself is read from design.toml; its errors name it
    levers = {n: v.get("value") for n, v in variables.items() if isinstance(v, dict)
              and n in (*CODESIGN_LEVERS, *GROUP_SPRING_LEVERS)}
    own = {v.name: v for v in getattr(study, "levers", ())}
    for name, value in levers.items():
        spec = own.get(name)
        if not isinstance(value, int | float) or spec is None or not spec.fixed:
            continue  # a vertical study has none; a free one is refused by the yield
        if not math.isclose(value, spec.start, rel_tol=1e-9, abs_tol=1e-12):
            raise InputError(f"--study: variables.{name} is fixed at {spec.start:g} in "
                             f"{study_path}, but the optimum of {path} has {name} = "
                             f"{value:g} (a co-designed lever): the yield would judge another "
                             f"table; fix it at the run's value (fixed = true, start = "
                             f"{value!r})")
    free = [v.name for v in own.values() if v.free]
    if free and all(isinstance(levers.get(n), int | float) for n in free):
        return study.with_levers_fixed(levers)  # the run's co-designed table
    return study


def _write_partial(path: Path, study, values: dict, finished: dict, args, label: str):
    """Write the finished draws (in draw order) as ``yield_partial.csv``; its name, or None
    when no draw had finished."""
    if not finished:
        return None
    import numpy as np

    from isodesign.io.files import atomic_write_text
    from isodesign.optimization.yields import YieldResult

    order = sorted(finished)
    part = YieldResult(study=study, values=dict(values),
                       draws=np.concatenate([finished[i][0] for i in order]),
                       verdicts=tuple(v for i in order for v in finished[i][1]),
                       confidence=args.confidence, seed=args.seed, label=label)
    atomic_write_text(path / PARTIAL_TABLE, part.to_frame().to_csv(index=False))
    return PARTIAL_TABLE


def run(args) -> int:
    """Run ``isodesign yield``."""
    from isodesign.commands import check_count
    from isodesign.errors import InputError
    from isodesign.io.record import command_line, environment
    from isodesign.optimization.study import load_study
    from isodesign.optimization.yields import estimate_yield
    from isodesign.plotting.robust import yield_histogram
    from isodesign.plotting.style import save_figure

    check_count(args.samples, "--samples", 1, 10**6)
    check_count(args.seed, "--seed", 0, 2**32 - 1)
    if args.workers is not None:
        check_count(args.workers, "--workers", 1, 64)
    if not 0 < args.confidence < 1:
        raise InputError(f"--confidence: must be in (0, 1), got {args.confidence:g}")
    values, label, run_study = _design_values(Path(args.design))
    study_path = args.study or run_study
    if study_path is None:
        raise InputError("--study: a design file needs a study with a [scenarios] table "
                         "(the tolerance laws)")
    study = load_study(study_path)
    if study.scenarios is None:
        raise InputError(f"--study: {study_path} has no [scenarios] table (the laws the "
                         "built tables are drawn from; docs/robust.md)")
    study = _check_run_levers(Path(args.design), study, study_path)
    with run_directory(args, "yield", known_outputs=OUTPUT_FILES) as rundir:
        rundir.record.update({"kind": "isodesign yield", "environment": environment(),
                              "command_line": command_line(["yield", str(args.design),
                                                            "--study", str(study_path),
                                                            "--samples", str(args.samples),
                                                            "--seed", str(args.seed),
                                                            "-o", str(args.output)])})
        finished: dict = {}  # first draw's index -> (draws, verdicts), as they complete

        def keep(first, draws, verdicts):
            finished[first] = (draws, verdicts)

        def partial_table(path):  # an interrupt: the draws judged so far, as yield.csv is
            return _write_partial(path, study, values, dict(finished), args, label)

        rundir.interrupt_hooks.append(partial_table)
        res = estimate_yield(study, values, samples=args.samples, seed=args.seed,
                             confidence=args.confidence, workers=args.workers, label=label,
                             progress=keep)
        rundir.record["yield"] = res.record()
        rundir.write_json("yield.json", res.record())
        rundir.write_csv("yield.csv", res.to_frame())
        if not args.no_plots:
            with rundir.writing("yield.png") as tmp:
                save_figure(yield_histogram(res), tmp)
        print(res.summary())
        print(f"wrote yield.json, yield.csv{'' if args.no_plots else ', yield.png'} to "
              f"{rundir.target}")
    return 0
