"""Optimize a design study: the spring's N, V_t0, L_c and D_c for a payload, floor and target.

STUDY.toml (default: the built-in default study, isodesign/data/default_study.toml: the
600 kg table in six degrees of freedom with its springs, its horizontal element and its
isolator spacing co-designed, docs/table.md; --builtin vertical: the one-degree-of-freedom
payload) states the payload, the spring hardware, the floor, the instrument's criterion,
the models, the variables' bounds, the constraints, the objective and the solver
(docs/optimization.md).
Multi-start IPOPT finds the optimum; the flat direction L_c/D_c^4 is resolved by the
documented tie-break (largest D_c); the optimum is re-checked with the NumPy analysis.
Prints start design against optimum, every constraint with its margin (binding ones
marked), the starts that reached the best design, the flat direction and the re-check.
Writes to OUTDIR: design.json, design.toml, bands.csv, starts.csv, record.json,
study_resolved.toml (replay: isodesign optimize OUTDIR/study_resolved.toml -o NEWDIR) and
response.png. OUTDIR appears whole when the run ends, its record.json carrying the run's
status; an OUTDIR that holds a run is refused unless --overwrite (docs/cli.md). Exit status
0: feasible optimum; 1: no feasible design (report printed, record.json, starts.csv and
study_resolved.toml still written); 2: bad input; 130: interrupted.
"""

from __future__ import annotations

import argparse
import sys

from isodesign.commands import (
    BUILTIN_CHOICES,
    BUILTIN_HELP,
    add_output_dir_arguments,
    run_directory,
)
from isodesign.commands import int_option as _int_option
from isodesign.errors import InputError, ModelValidityWarning
from isodesign.io.designfile import design_to_toml
from isodesign.io.record import (
    command_line,
    constraint_rows,
    environment,
    optimization_design,
    optimization_record,
    resolved_study_dict,
    study_toml,
)
from isodesign.optimization.dispatch import optimize
from isodesign.optimization.explain import BINDING_NOTE, constraint_table_rows, limiting_summary
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.problem import Problem
from isodesign.optimization.solution import Solution
from isodesign.optimization.study import default_study, load_study
from isodesign.plotting import optimization_plot

#: Files written by ``isodesign optimize`` (feasible run, plots on).
OUTPUT_FILES = (
    "design.json",
    "design.toml",
    "bands.csv",
    "starts.csv",
    "record.json",
    "study_resolved.toml",
    "response.png",
)


def add_study_arguments(parser: argparse.ArgumentParser) -> None:
    """The study file and the solver overrides (shared with ``isodesign pareto``)."""
    parser.add_argument(
        "study",
        nargs="?",
        metavar="STUDY.toml",
        help="study file (docs/optimization.md, docs/table.md); default: the built-in default "
        "study, the built-in table co-designed (--builtin default)",
    )
    parser.add_argument(
        "--builtin",
        choices=BUILTIN_CHOICES,
        help="a built-in study instead of STUDY.toml (" + BUILTIN_HELP + ")",
    )
    parser.add_argument(
        "--starts",
        type=_int_option,
        metavar="N",
        help="number of starts: the study's start plus N-1 Latin-hypercube points "
        "(overrides solver.starts; 1..256)",
    )
    parser.add_argument(
        "--workers",
        type=_int_option,
        metavar="N",
        help="worker processes for the starts (overrides solver.workers; 1..64)",
    )
    parser.add_argument(
        "--seed",
        type=_int_option,
        metavar="N",
        help="seed of the Latin hypercube (overrides solver.seed; >= 0)",
    )
    parser.add_argument(
        "--acoustics",
        choices=("distributed", "lumped"),
        help="acoustic model of tube and chambers (overrides models.acoustics): distributed "
        "(docs/acoustics.md) or lumped (the paper's, with its model-validity limits)",
    )
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="no progress bar; print only the result (warnings and errors still go to stderr)",
    )
    parser.add_argument("--no-plots", action="store_true", help="write no PNG files")


#: ``--yield-samples`` default, as the help states it (the help does not import NumPy):
#: :data:`isodesign.optimization.yields.DEFAULT_YIELD_SAMPLES` (a test checks they agree).
YIELD_SAMPLES_DEFAULT = 200


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign optimize``."""

    add_study_arguments(parser)
    parser.add_argument(
        "--yield-samples",
        type=_int_option,
        metavar="N",
        help="a study with [scenarios]: draws of the yield estimate of the nominal and the "
        f"robust optimum, vertical or [table] (0..1000000; default {YIELD_SAMPLES_DEFAULT}; "
        "0: none)",
    )
    add_output_dir_arguments(parser)


# ---------------------------------------------------------------------------
# helpers shared with ``isodesign pareto`` (imports inside: --help stays light)
# ---------------------------------------------------------------------------
def load_study_from_args(args):
    """The study of ``args.study`` (or the default) with the solver options applied.

    The overrides are folded into the study, so ``study.raw`` (written as
    ``study_resolved.toml``) replays the run without the options.
    """

    changes = {}
    for opt, key, lo, hi in (("--starts", "starts", 1, 256), ("--workers", "workers", 1, 64),
                             ("--seed", "seed", 0, SEED_MAX)):
        v = getattr(args, key, None)
        if v is None:
            continue
        if v < lo or v > hi:
            raise InputError(f"{opt}: must be an integer in [{lo}, {hi}], got {v}")
        changes[key] = v
    if getattr(args, "builtin", None) is not None:
        if args.study is not None:
            raise InputError("--builtin: give STUDY.toml or --builtin, not both")
        from isodesign.optimization.study import BUILTIN_STUDIES

        study = BUILTIN_STUDIES[args.builtin]()
    else:
        study = default_study() if args.study is None else load_study(args.study)
    if changes:
        study = study.with_changes(solver=changes)
    if getattr(args, "acoustics", None) is not None:
        from isodesign.commands import acoustics_override

        study = acoustics_override(study, args.acoustics)
    return study


#: Largest --seed (NumPy's generators take any integer; this keeps records readable).
SEED_MAX = 2**32 - 1


def open_run(args, command: str = "optimize", known_outputs=OUTPUT_FILES):
    """The run directory of ``args.output`` (checked now: before any computation)."""

    return run_directory(args, command, known_outputs=known_outputs)


def canonical_command(args, name: str) -> list[str]:
    """The command line equivalent to ``args`` (for the run record)."""
    words = ["isodesign", name]
    if args.study is not None:
        words.append(str(args.study))
    if getattr(args, "builtin", None) is not None:
        words += ["--builtin", args.builtin]
    for opt in ("objectives", "points", "starts", "workers", "seed", "acoustics"):
        v = getattr(args, opt, None)
        if v is not None:
            words += [f"--{opt}", str(v)]
    words += ["-o", str(args.output)]
    for flag in ("no_plots", "quiet", "overwrite"):
        if getattr(args, flag, False):
            words.append("--" + flag.replace("_", "-"))
    return words


def study_label(study) -> str:
    """``'name' (source)`` for summaries."""
    src = "built-in vertical study" if study.source == "<default>" else study.source
    return f"{study.name!r} ({src})"


def progress_enabled(args) -> bool:
    """A progress bar only on an interactive terminal and without ``--quiet``."""
    return not args.quiet and sys.stderr.isatty()


class StartProgress:
    """A rich progress bar over the starts (a no-op when disabled).

    Use as a context manager; call it as ``progress(done, total, out)`` (the
    callback of :func:`isodesign.optimization.driver.optimize`).
    """

    def __init__(self, enabled: bool, total: int, objective: str, what: str = "starts"):
        self.enabled = enabled
        self.total = total
        self.objective = objective
        self.what = what
        self.best = None
        self._progress = None
        self._task = None

    def __enter__(self):
        if self.enabled:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self._progress = Progress(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TimeElapsedColumn(), console=Console(stderr=True), transient=True,
            )
            self._progress.start()
            self._task = self._progress.add_task(self.what, total=self.total)
        return self

    def update(self, done: int, total: int, description: str | None = None) -> None:
        """Move the bar (and change its label)."""
        if self._progress is not None:
            kw = {} if description is None else {"description": description}
            self._progress.update(self._task, completed=done, total=total, **kw)

    def __call__(self, done: int, total: int, out=None) -> None:
        if self._progress is None:
            return

        if isinstance(out, Solution) and out.feasible:
            obj = OBJECTIVES[self.objective]
            v = obj.to_natural(out.objective)
            better = (v > self.best if obj.maximized else v < self.best) \
                if self.best is not None else True
            if better:
                self.best = v
        label = self.what
        if self.best is not None:
            label += f"  best {format_objective(self.objective, self.best)}"
        if done >= total:
            label = "tie-break, re-check, band analysis"
        self.update(done, total, label)

    def __exit__(self, *exc):
        if self._progress is not None:
            self._progress.stop()
        return False


def format_objective(kind: str, value) -> str:
    """An objective value in display units (dB, L, um/s)."""

    if value is None:
        return "n/a"
    if kind in OBJECTIVES:
        return OBJECTIVES[kind].format(value)
    return f"{value:.6g}"


def table(rows: list[list[str]], header: list[str], *, indent: str = "  ",
          align: str | None = None) -> str:
    """Aligned text table (``align``: one of ``<``/``>`` per column, default all left)."""
    cols = len(header)
    align = align or "<" * cols
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(cols)]
    lines = []
    for r in [header, *rows]:
        cells = [f"{r[i]!s:{align[i]}{widths[i]}}" for i in range(cols)]
        lines.append((indent + "  ".join(cells)).rstrip())
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# the summary
# ---------------------------------------------------------------------------
def _g(x, fmt="#.4g", scale=1.0) -> str:
    return "n/a" if x is None else f"{x * scale:{fmt}}"


def design_rows(result, figures: dict, start_figures: dict) -> list[list[str]]:
    """Start against optimum: variables and derived figures (display units)."""
    v0, v1 = result.start_values, result.values
    f0, f1 = start_figures, figures

    def margin(f):
        if f.get("worst_band_margin_db") is None:
            return "n/a"
        return f"{f['worst_band_margin_db']:+.2f} at {f['worst_band_hz']:g} Hz"

    rows = [
        ["N = V_b0/V_t0", _g(v0["volume_ratio"]), _g(v1["volume_ratio"])],
        ["V_t0 (L)", _g(v0["top_volume_m3"], scale=1e3), _g(v1["top_volume_m3"], scale=1e3)],
        ["L_c (mm)", _g(v0["capillary_length_m"], scale=1e3),
         _g(v1["capillary_length_m"], scale=1e3)],
        ["D_c (mm)", _g(v0["capillary_diameter_m"], scale=1e3),
         _g(v1["capillary_diameter_m"], scale=1e3)],
        ["total volume (L)", _g(f0["total_volume_m3"], scale=1e3),
         _g(f1["total_volume_m3"], scale=1e3)],
        ["p0 (bar abs)", _g(f0["pressure_pa"], scale=1e-5), _g(f1["pressure_pa"], scale=1e-5)],
        ["k_s (kN/m)", _g(f0["single_chamber_stiffness_k_s_n_per_m"], scale=1e-3),
         _g(f1["single_chamber_stiffness_k_s_n_per_m"], scale=1e-3)],
        ["static stiffness K0 (kN/m)", _g(f0.get("static_stiffness_n_per_m"), scale=1e-3),
         _g(f1.get("static_stiffness_n_per_m"), scale=1e-3)],
        ["natural frequency (Hz)", _g(f0.get("natural_frequency_hz")),
         _g(f1.get("natural_frequency_hz"))],
        ["Zener damping ratio", _g(f0.get("zener_damping_ratio"), ".3g"),
         _g(f1.get("zener_damping_ratio"), ".3g")],
        ["peak |T| at A* (dB)", _g(f0.get("peak_transmissibility_db"), ".2f"),
         _g(f1.get("peak_transmissibility_db"), ".2f")],
        ["peak |T| linear (dB)", _g(f0.get("linear_peak_transmissibility_db"), ".2f"),
         _g(f1.get("linear_peak_transmissibility_db"), ".2f")],
        ["worst-band margin (dB)", margin(f0), margin(f1)],
        ["tilt margin", _g(f0.get("tilt_margin"), ".3g"), _g(f1.get("tilt_margin"), ".3g")],
        [f"objective {result.objective} (NLP grid)",
         format_objective(result.objective, result.start_objective),
         format_objective(result.objective, result.objective_value)],
    ]
    return rows


def constraint_table(rows: list[dict]) -> str:
    """Every constraint: value, bound, margin (own unit), binding ones marked ``*``."""
    out = []
    for c in rows:
        bounds = []
        if c["lower"] is not None:
            bounds.append(f">= {c['lower']:.5g}")
        if c["upper"] is not None:
            bounds.append(f"<= {c['upper']:.5g}")
        out.append(["*" if c["binding"] else "", c["name"], f"{c['value']:.5g}",
                    ", ".join(bounds), _g(c["margin"], ".3g"), c["unit"]])
    return table(out, ["", "constraint", "value", "bound", "margin", "unit"],
                 align="<<><><")


def bounds_text(design: dict) -> str:
    """Which free variables ended on a bound (bounds are not NLP constraints)."""
    at = design["variables_at_bounds"]
    if not at:
        return "variables at a bound: none"
    parts = [f"{n} ({side} bound {design['variables'][n][side]:g})" for n, side in at.items()]
    return "variables at a bound: " + ", ".join(parts)


def flat_text(result) -> str:
    """The flat-direction report and the tie-break, one paragraph."""
    fd = result.flat_direction
    if fd is None:
        if not result.study.solver["tie_break"]:
            return "flat direction: not examined (solver.tie_break = false)"
        return "flat direction: not examined (D_c is fixed)"
    d0, d1 = fd["capillary_diameter_range_m"]
    l0, l1 = fd["capillary_length_range_m"]

    tol = format_objective(result.objective, fd["objective_tolerance"]) \
        if OBJECTIVES[result.objective].db \
        else f"{fd['objective_tolerance']:.3g} (relative)"
    tol = tol.lstrip("+")
    state = ("flat: a valley, the objective does not fix the pair" if fd["flat"]
             else "not flat: the constraints or the non-laminar terms fix the pair")
    return (f"flat direction ({fd['pair']}): within {tol} of the optimum, D_c spans "
            f"{d0 * 1e3:#.4g}-{d1 * 1e3:#.4g} mm and L_c {min(l0, l1) * 1e3:#.4g}-"
            f"{max(l0, l1) * 1e3:#.4g} mm ({state});\n  tie-break: {fd['tie_break']} -> "
            f"D_c = {fd['chosen_capillary_diameter_m'] * 1e3:#.4g} mm")


def starts_text(result) -> str:
    """How many starts converged, were feasible and reached the best design."""
    n = len(result.starts)
    conv = sum(1 for s in result.starts if s.success)
    feas = sum(1 for s in result.starts if s.feasible)
    st = result.study.solver
    lhs = max(0, n - 1)
    return (f"{n} starts (the study's start + {lhs} Latin hypercube, seed {st['seed']}; "
            f"{st['workers']} workers): {conv} converged, {feas} feasible, "
            f"{result.n_reached_best} reached the best design")


def summary(result, design: dict) -> str:
    """The full text summary of a feasible run."""
    st = result.study
    p = st.payload
    tg = st.raw["target"]
    sense = "maximize" if design["objective"]["sense"] == "maximize" else "minimize"
    lines = [
        f"study {study_label(st)}: {sense} {result.objective}",
        f"  payload {p.mass_kg:g} kg on {p.isolators} isolators; floor: "
        f"{result.analysis.floor_name}; target {result.analysis.target_name} in "
        f"{tg['band_min_hz']:g}-{tg['band_max_hz']:g} Hz ({len(st.bands)} bands); "
        f"flow {st.models['flow']}, {st.models['amplitude_mode']}, diaphragm "
        f"{st.models['diaphragm']}, acoustics {st.models.get('acoustics', 'distributed')}",
        f"  {starts_text(result)}; {result.wall_s:.1f} s",
        "  Hessian: {hessian} ({reason})".format(**result.hessian_choice()),
        "",
        table(design_rows(result, design["derived"], design["start_derived"]),
              ["", "start", "optimum"], align="<>>"),
        "",
        bounds_text(design),
        "",
        "constraints at the optimum (" + BINDING_NOTE + "):",
        table(constraint_table_rows(result), ["", "constraint", "value", "bound", "margin",
                                              "unit"], align="<<><><"),
        "",
        limiting_summary(result) + ":",
        *[f"  - {t}" for t in design["limited_by"]],
        "",
        flat_text(result),
        f"re-check: the NumPy analysis agrees with the NLP to "
        f"{result.recheck_max_rel_diff:.2g} relative "
        f"(required {result.settings['recheck_rtol']:g})",
        f"start:   {design['start_derived'].get('verdict')}",
        f"optimum: {design['verdict']}",
        "",
        *result.scope.lines(),
    ]
    return "\n".join(lines)


def failure_report(result) -> str:
    """Report of a run without a feasible design: status, violations, best point."""

    cons = {c["name"]: c for c in constraint_rows(result)}
    lines = [
        f"study {study_label(result.study)}: NO FEASIBLE DESIGN",
        f"  {starts_text(result)}",
        f"  IPOPT status of the best point found: {result.status}",
        "  most violated constraints (violation in the NLP's units: ln of the quantity, "
        "or dB):",
    ]
    rows = []
    for name, amount in result.violations[:6]:
        c = cons.get(name)
        if c is not None:
            bound = c["upper"] if c["upper"] is not None and c["value"] > c["upper"] \
                else c["lower"]
            rel = "above" if c["upper"] is not None and c["value"] > c["upper"] else "below"
            detail = f"{c['value']:.4g} {c['unit']} {rel} its bound {bound:.4g}"
        elif name == "implicit_equations":
            detail = "the flow/stroke equations are not solved at this point"
        else:
            detail = ""
        rows.append([name, f"{amount:.3g}", detail])
    lines.append(table(rows, ["constraint", "violation", "at the best point"], indent="    "))
    v = result.values
    lines.append(
        f"  best point found (not a design): N = {v['volume_ratio']:.4g}, V_t0 = "
        f"{v['top_volume_m3'] * 1e3:.4g} L, L_c = {v['capillary_length_m'] * 1e3:.4g} mm, "
        f"D_c = {v['capillary_diameter_m'] * 1e3:.4g} mm"
    )
    lines.append("  relax the violated constraints or widen the variables' bounds "
                 "(docs/optimization.md, 'When no design is feasible')")
    return "\n".join(lines)


def bands_frame(result) -> dict:
    """The columns of ``bands.csv``: ``analysis.columns()`` of the optimum (its
    ``to_frame()``'s) plus the start design's columns (a mapping: written without pandas,
    :meth:`~isodesign.io.rundir.RunDirectory.write_csv`)."""
    cols = dict(result.analysis.columns())
    s = result.start_analysis
    cols["start_payload_velocity_rms_m_s"] = s.payload_velocity_rms_m_s
    cols["start_margin_db"] = s.margin_db
    cols["start_passes"] = s.band_passes
    return cols


def write_outputs(result, run, args, *, plots: bool, prefix: str = "") -> list:
    """Write every output file of a run into the run directory; return the paths.

    ``run`` is a :class:`~isodesign.io.rundir.RunDirectory`; ``prefix`` a subdirectory
    inside it (``"optimize/"`` for ``isodesign demo``). The run record's fields go into
    ``run.record`` (written as ``record.json`` when the run ends, with its status).
    """

    written = []
    rec = optimization_record(result, argv=canonical_command(args, "optimize")[1:],
                              extra={"argv": list(sys.argv)})
    if prefix:
        run.record.setdefault("parts", {})[prefix.rstrip("/")] = rec
    else:
        run.record.update(rec)
    # the tables as columns: written without importing pandas (half a second of CPU)
    written.append(run.write_csv(prefix + "starts.csv", result.starts_columns()))
    name = prefix + "study_resolved.toml"
    written.append(run.write_text(name, study_toml(result.study, header=(
        f"Resolved study of an isodesign optimize run (defaults filled in, command-line\n"
        f"overrides applied). Replay: isodesign optimize {run.final_path(name)} -o NEWDIR"))))
    if prefix:  # a part of a larger run (demo): its own record too
        written.append(run.write_json(prefix + "record.json", {
            **rec, "run_status": "complete" if result.feasible else "infeasible"}))
    if not result.feasible:
        return written
    design = optimization_design(result)
    written.append(run.write_json(prefix + "design.json", design))
    models = resolved_study_dict(result.study).get("models")  # a diaphragm table: absolute
    header = (f"Optimized spring of study {result.study.name!r} (isodesign optimize); p0 from "
              f"the payload ({result.study.payload.mass_kg:g} kg on "
              f"{result.study.payload.isolators} isolators).")
    written.append(run.write_text(prefix + "design.toml",
                                  design_to_toml(result.design, models=models, header=header)))
    written.append(run.write_csv(prefix + "bands.csv", bands_frame(result)))
    if plots:

        with run.writing(prefix + "response.png") as tmp:
            optimization_plot(result, tmp)
        written.append(run.final_path(prefix + "response.png"))
    return written


#: Modules the output writing needs, imported while CasADi builds the NLP (not pandas: the
#: run's CSV tables are written without it, :mod:`isodesign.io.csvtable`).
PREFETCHED_MODULES = ("matplotlib.figure", "matplotlib.backends.backend_agg")


def prefetch_imports(modules=PREFETCHED_MODULES, *, then=()):
    """Import ``modules`` in a background thread; return the started thread (join it).

    ``then``: callables the thread calls after the imports (their results are dropped:
    caches to fill, like :func:`isodesign.io.record.environment`'s package versions).

    CasADi releases the GIL while it builds the NLP's derivatives (about half a second),
    so the imports that writing the outputs needs (Matplotlib: a few tenths of a
    second) run meanwhile on the other core. Join the thread before anything forks (the
    starts' worker processes): a fork while a thread holds the import lock could leave a
    child waiting on it for ever. An import that fails here is left to fail where it is
    used.
    """
    import importlib
    import threading

    def work():
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception:  # the real import reports it
                return
        for fn in then:
            try:
                fn()
            except Exception:  # the real call reports it
                return

    thread = threading.Thread(target=work, name="isodesign-prefetch", daemon=True)
    thread.start()
    return thread


class _PrefetchingProblem(Problem):
    """:class:`~isodesign.optimization.problem.Problem` whose solver build imports the
    output writers' modules meanwhile (:func:`prefetch_imports`).

    CasADi releases the GIL while it generates IPOPT's derivative functions (the last and
    longest step of the build, :meth:`_build_solver`), so the imports run there on the
    other core. Started before the build, the import thread shared the GIL with the
    build's Python steps and slowed them down about as much as it hid.
    """

    def _build_solver(self, nlp) -> None:
        import gc

        thread = prefetch_imports(then=(environment,))  # the run record's versions too
        try:
            super()._build_solver(nlp)
        finally:
            thread.join()  # before anything forks (the starts' worker processes)
        # every object alive now (the modules, the study, the NLP) lives until the run
        # ends: the collector skips them from here on (a full collection during the plot
        # took 80 ms), and the forked workers do not copy their pages by collecting them.
        # run_optimization / execute unfreeze them.
        gc.freeze()


def run_optimization(study, args, *, background: list | None = None):
    """``optimize(study)`` of a vertical study with the progress bar of ``args``.

    The NLP is built first, while :func:`prefetch_imports` imports the output writers'
    dependencies (:class:`_PrefetchingProblem`); the thread is joined before the starts
    run.

    Parameters
    ----------
    study : Study
    args : argparse.Namespace
    background : list, optional
        When given, the NLP is freed in a thread appended to it, to be joined once the
        outputs are written: freeing CasADi's graphs takes about 0.2 s with the GIL
        released, so it runs beside the writing of the outputs and the plot (CasADi is
        built with thread-safe symbolics). The objects frozen for the garbage collector
        when the NLP was built stay frozen: the caller calls ``gc.unfreeze()`` after the
        outputs (:func:`execute`). Default: freed and unfrozen on return.

    Returns
    -------
    OptimizationResult
    """
    import gc

    gc.freeze()  # the modules imported so far: the build's collections skip them too
    try:
        # no collections during the build: CasADi's expressions and Matplotlib's import (in
        # the prefetch thread) made some 150 of them, about 0.17 s of CPU, for little
        # garbage; everything alive after it is frozen (_PrefetchingProblem)
        gc.disable()
        try:
            problem = _PrefetchingProblem(study)
        finally:
            gc.enable()
        with StartProgress(progress_enabled(args), study.solver["starts"],
                           study.objective["kind"]) as bar:
            result = optimize(study, progress=bar, problem=problem)
    finally:
        if background is None:
            gc.unfreeze()
    if background is not None:
        import threading

        holder = [problem]
        del problem  # the thread drops the last reference
        thread = threading.Thread(target=holder.clear, name="isodesign-release", daemon=True)
        thread.start()
        background.append(thread)
    return result


def execute(study, run, args, *, prefix: str = "", result=None) -> int:
    """Optimize ``study`` into the run directory ``run`` and print the report; the status.

    ``result``: the study's optimum when already computed (a sweep point); computed here
    otherwise.

    A :class:`~isodesign.errors.SolverError` propagates (the run directory records it as
    a failed run); an infeasible study sets ``run.status = "infeasible"`` and returns 1.
    """
    import gc
    import warnings


    # what is known before the solve: recorded even if the run fails or is interrupted;
    # the environment's package versions are looked up while the NLP is built (None if
    # the run is interrupted before)
    base = {"kind": "isodesign optimize",
            "command_line": command_line(canonical_command(args, "optimize")[1:]),
            "environment": None, "study": resolved_study_dict(study),
            "study_source": study.source}
    if prefix:
        run.record.setdefault("parts", {})[prefix.rstrip("/")] = base
    else:
        run.record.update(base)
    rec = base if prefix else run.record
    background: list = []
    try:
        if result is None:
            result = run_optimization(study, args, background=background)
    except BaseException:
        gc.unfreeze()
        rec["environment"] = environment()
        raise
    rec["environment"] = environment()
    try:
        written = write_outputs(result, run, args, plots=not args.no_plots, prefix=prefix)
    finally:
        for thread in background:
            thread.join()
        gc.unfreeze()
    out = run.final_path(prefix) if prefix else run.target
    if not result.feasible:
        run.status = "infeasible"
        print(failure_report(result))
        worst = ", ".join(f"{n} ({v:.3g})" for n, v in result.violations[:3])
        print(f"isodesign: error: no feasible design ({result.status}); most violated: "
              f"{worst}; wrote {run.final_path('record.json')} (run_status infeasible)",
              file=sys.stderr)
        return 1

    design = optimization_design(result)
    if args.quiet:
        print(f"{result.study.name}: {result.objective} "
              f"{format_objective(result.objective, result.objective_value)}; "
              f"{design['verdict']}")
    else:
        print(summary(result, design))
        print("wrote " + ", ".join(str(p.name) for p in written) + f" to {out}")
    sys.stdout.flush()
    for line in result.analysis.warnings:
        warnings.warn(f"optimum: spring model at A*: {line}", ModelValidityWarning,
                      stacklevel=2)
    for line in design["notes"]:
        warnings.warn(f"optimum: {line}", ModelValidityWarning, stacklevel=2)
    return 0
