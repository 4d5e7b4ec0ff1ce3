"""Sweep a study over study changes, one Dask task per point, on a laptop or a cluster.

Each --vary KEY=VALUES names a study key by its dotted path (payload.mass_kg,
floor.criterion, variables.top_volume_m3.upper, ...) and its values: a list a,b,c or a
linear range start:stop:count (both ends included). The keys combine as a cartesian
product (--combine zip: side by side), or the points come from a file of study-change
tables (--points-file). Every point runs --task (optimize, response, pareto; yield with
robust design) as one Dask task: on a LocalCluster of this machine's cores (127.0.0.1,
no dashboard), or on the scheduler of --scheduler / DASK_SCHEDULER_ADDRESS. Writes, as
each point finishes, its run directory OUTDIR/points/HASH/ (docs/cli.md contract) and
the table OUTDIR/sweep.parquet (one row per point, written whole each time); at the end
the design charts OUTDIR/charts/OBJECTIVE.png and, for two or more swept keys, the binding
map OUTDIR/charts/binding_map.png (the binding set per point over two keys, one panel per
value of the others, the boundaries where it changes drawn). A rerun of the same sweep
skips finished points (matched by the resolved study's hash) and runs only new or failed
ones; a worker
that dies loses nothing (its task is retried elsewhere); a point that fails twice is
recorded failed with its error. Render with: isodesign report OUTDIR -o report.html.
See docs/sweep.md. Exit status 0: every point finished; 1: some point failed; 2: bad
input; 130: interrupted (finished points kept; rerun to resume).
"""

from __future__ import annotations

import argparse
import sys

from isodesign.commands import BUILTIN_CHOICES, BUILTIN_HELP, check_count
from isodesign.commands import int_option as _int_option

TASK_NAMES = ("optimize", "response", "pareto", "yield")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign sweep``."""
    parser.add_argument("study", nargs="?", metavar="STUDY.toml",
                        help="base study (default: the built-in default study)")
    parser.add_argument("--builtin", choices=BUILTIN_CHOICES,
                        help="a built-in study instead of STUDY.toml (" + BUILTIN_HELP
                        + "), as isodesign optimize")
    parser.add_argument("--vary", action="append", metavar="KEY=VALUES", default=[],
                        help="a study key and its values: a,b,c or start:stop:count (linear, "
                        "both ends); repeat for several keys. A [scenarios] range is a key "
                        "too (scenarios.NAME.relative, .absolute, .min, .max): each point is "
                        "then the robust optimum of its own ranges")
    parser.add_argument("--combine", choices=("product", "zip"), default="product",
                        help="how several --vary combine (default %(default)s)")
    parser.add_argument("--points-file", metavar="FILE",
                        help="the points as study-change tables: TOML [[point]] tables or a "
                        "CSV whose header names the keys (instead of --vary)")
    parser.add_argument("--task", default="optimize", metavar="TASK",
                        help=f"what each point runs: {', '.join(TASK_NAMES)} (default "
                        "%(default)s)")
    parser.add_argument("--objectives", metavar="A,B",
                        help="task pareto: objectives A (optimized) and B (swept)")
    parser.add_argument("--pareto-points", type=_int_option, metavar="K",
                        help="task pareto: epsilon values per front (2..500; default 10)")
    parser.add_argument("--yield-samples", type=_int_option, metavar="N",
                        help="task yield: draws per point (1..1000000; default 1000, as isodesign "
                        "yield); task "
                        "optimize of a study with [scenarios]: the robust yield's draws (0..; "
                        "default 200, vertical or [table], as isodesign optimize)")
    parser.add_argument("--starts", type=_int_option, metavar="N",
                        help="starts per optimization (sets solver.starts of the base study)")
    parser.add_argument("--seed", type=_int_option, metavar="N",
                        help="Latin-hypercube seed (sets solver.seed of the base study)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler (tcp://host:8786); default DASK_SCHEDULER_ADDRESS, "
                        "else a local cluster; 'serial' runs the points in this process")
    parser.add_argument("--workers", type=_int_option, metavar="N",
                        help="worker processes of the local cluster (1..64; default: the "
                        "cores available)")
    parser.add_argument("-o", "--output", metavar="OUTDIR", required=True,
                        help="sweep directory; rerunning the same sweep into it resumes it")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace another sweep held in OUTDIR")
    parser.add_argument("--point-plots", action="store_true",
                        help="write each point's figure (response.png, pareto.png)")
    parser.add_argument("--no-plots", action="store_true", help="write no design chart")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress; print only the summary line")


class _Progress:
    """Points done, failed, running and time left: a rich bar on a terminal, else lines."""

    def __init__(self, args, keys):
        self.args = args
        self.keys = keys
        self.failed = 0
        self.bar = None
        self.task = None
        self.tty = sys.stderr.isatty() and not args.quiet

    def __enter__(self):
        if self.tty:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self.bar = Progress(TextColumn("points"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("{task.fields[state]}"), TimeElapsedColumn(),
                                TextColumn("left"), TimeRemainingColumn(),
                                console=Console(stderr=True), transient=True,
                                refresh_per_second=1)  # the clock; a point redraws at once
            self.bar.start()
            self.task = self.bar.add_task("points", total=1, state="")
        return self

    def __call__(self, done, total, row, running):
        if row is not None and row.get("status") == "failed":
            self.failed += 1
        if self.bar is not None:
            self.bar.update(self.task, completed=done, total=total,
                            state=f"failed {self.failed}, running {running}")
            self.bar.refresh()
        elif row is not None and not self.args.quiet:
            import json

            ch = json.loads(row.get("changes") or "{}")
            what = ", ".join(f"{k}={v}" for k, v in ch.items())
            val = row.get("objective_value")
            val = f"{row.get('objective')} {val:.6g}" if isinstance(val, float) else ""
            err = f" ({row.get('error')})" if row.get("error") else ""
            print(f"[{done}/{total}] {what}: {row.get('status')} {val}{err}; "
                  f"{row.get('wall_s') or 0:.1f} s on {row.get('worker') or '-'}", flush=True)

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.stop()
        return False


def summary(res) -> str:
    """The end-of-sweep summary (counts, times, where, the table, the charts)."""
    import statistics

    df = res.table
    counts = df["status"].value_counts().to_dict() if len(df) else {}
    walls = res.point_wall_s
    over = ", ".join(res.keys) or "a points file"
    lines = [f"sweep {res.directory}: task {res.task} over {over};"
             f" {len(df)} points in the table ({res.ran} run now, {res.reused} already "
             f"finished, {res.failed} failed now); {res.wall_s:.1f} s on {res.where}",
             "  status: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))]
    if res.ran:
        changed = int(df["branch_changed"].fillna(False).astype(bool).sum()) \
            if "branch_changed" in df else 0
        robust = ("question" in df and df["question"].astype(str).str.startswith(
            "robust").any())
        what = ("; a robust point's nominal NLP, scenario block and stacked NLPs, once per "
                "worker, a robust table's scenario NLPs and stacks per point" if robust else "")
        lines.append(f"  NLPs built: {res.nlp_builds} for {res.ran} points run now (summed over "
                     f"the workers: one per structure and worker, a table's movable peak "
                     f"frequencies one more{what}); {changed} points changed branch along "
                     "their line")
        if robust and {"neighbour_starts", "seeded_scenarios", "rounds"} <= set(df.columns):
            ran = df[df["question"].astype(str).str.startswith("robust")]
            cont = ran["neighbour_starts"].fillna(0).astype(int) > 0
            lines.append(f"  robust points continued from a neighbour: {int(cont.sum())} of "
                         f"{len(ran)} ({int(ran['seeded_scenarios'].fillna(0).sum())} "
                         f"scenarios carried over); exchange rounds: "
                         f"{int(ran['rounds'].fillna(0).sum())} in all")
    if walls:
        lines.append(f"  time per point: median {statistics.median(walls):.2f} s, min "
                     f"{min(walls):.2f} s, max {max(walls):.2f} s (sum {sum(walls):.1f} s: "
                     f"{sum(walls) / max(res.wall_s, 1e-9):.2f} points running on average)")
    if 0 < len(df) <= 60:
        cols = [*[k for k in res.keys if k in df], "status", "objective_value", "volume_ratio",
                "top_volume_m3", "capillary_length_m", "capillary_diameter_m", "binding"]
        cols = [c for c in cols if c in df]
        import pandas as pd

        with pd.option_context("display.width", 200, "display.max_colwidth", 60):
            lines += ["", df[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}")]
    lines.append("")
    lines.append(f"wrote {res.directory / 'sweep.parquet'}, {res.directory / 'points'}/ "
                 f"(one run directory per point)"
                 + (f", {res.directory / 'charts'}/" if (res.directory / "charts").is_dir()
                    else ""))
    lines.append(f"report: isodesign report {res.directory} -o {res.directory}/report.html")
    return "\n".join(lines)


def run(args) -> int:
    """Run ``isodesign sweep``."""
    import signal

    from isodesign.errors import InputError
    from isodesign.optimization.study import default_study, load_study
    from isodesign.sweeps.runner import sweep

    if args.workers is not None:
        check_count(args.workers, "--workers", 1, 64)
    if args.pareto_points is not None:
        check_count(args.pareto_points, "--pareto-points", 2, 500)
    options = {}
    if args.task == "pareto":
        # imported only here: isodesign.commands.pareto imports the optimize and response
        # commands (about a second), which a sweep's own process does not need
        from isodesign.commands.pareto import parse_objectives

        options = {"objectives": list(parse_objectives(args.objectives))
                   if args.objectives else None, "points": args.pareto_points}
    elif args.objectives or args.pareto_points:
        raise InputError("--objectives/--pareto-points: only for --task pareto")
    if args.task == "yield":
        if args.yield_samples is not None:
            check_count(args.yield_samples, "--yield-samples", 1, 1_000_000)
        options = {"samples": args.yield_samples, "seed": args.seed}
    elif args.task == "optimize" and args.yield_samples is not None:
        # a study with [scenarios]: the draws of each robust point's yield (0: none)
        options = {"yield_samples": check_count(args.yield_samples, "--yield-samples", 0,
                                                1_000_000)}
    elif args.yield_samples is not None:
        raise InputError("--yield-samples: only for --task yield or optimize")
    if args.point_plots:
        options["plots"] = True
    if args.points_file is not None and args.vary:
        raise InputError("--points-file: give a points file or --vary, not both")
    if getattr(args, "builtin", None) is not None:
        if args.study is not None:
            raise InputError("--builtin: give STUDY.toml or --builtin, not both")
        from isodesign.optimization.study import BUILTIN_STUDIES

        base = BUILTIN_STUDIES[args.builtin]()
    else:
        base = default_study() if args.study is None else load_study(args.study)
    changes = {}
    if args.starts is not None:
        changes["starts"] = check_count(args.starts, "--starts", 1, 256)
    if args.seed is not None:
        changes["seed"] = check_count(args.seed, "--seed", 0, 2**32 - 1)
    if changes:
        base = base.with_changes(solver=changes)
    keys = [v.partition("=")[0].strip() for v in args.vary]
    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):  # interrupt the loop: finished points stay
        old[sig] = signal.signal(sig, _raise_interrupt)
    try:
        with _Progress(args, keys) as bar:
            res = sweep(base, args.vary or None, output=args.output, combine=args.combine,
                        points=args.points_file, task=args.task, options=options,
                        scheduler=args.scheduler, workers=args.workers,
                        overwrite=args.overwrite, charts=not args.no_plots, progress=bar,
                        argv=["isodesign", *sys.argv[1:]])
    except KeyboardInterrupt as exc:
        from pathlib import Path

        from isodesign.sweeps.table import TABLE_NAME

        name = str(exc) or "SIGINT"
        table = Path(args.output) / TABLE_NAME
        _quiet_cluster_exit()
        rows = _finished_rows(table)
        if rows:  # name only what exists
            print(f"isodesign: interrupted by {name}; the {rows} finished point(s) are in "
                  f"{table} (and points/; run_status interrupted): rerun the same command "
                  "to run the others", file=sys.stderr)
        elif table.is_file():  # the table holds no point yet (a serial sweep's first solve)
            print(f"isodesign: interrupted by {name} before any point finished; its table "
                  f"{table} holds no point yet (run_status interrupted): rerun the same "
                  "command to run them", file=sys.stderr)
        else:
            print(f"isodesign: interrupted by {name} before any point ran; nothing was "
                  "written", file=sys.stderr)
        return 130
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)
    if args.quiet:
        print(f"sweep {res.directory}: {len(res.table)} points, {res.ran} run now, "
              f"{res.reused} reused, {res.failed} failed; {res.nlp_builds} NLPs built; "
              f"{res.wall_s:.1f} s")
    else:
        print(summary(res))
    if res.status == "failed":
        n = int((res.table["status"] == "failed").sum())
        print(f"isodesign: error: {n} of {len(res.table)} points failed (the table's error "
              "column; points/*/record.json); rerun the same command to retry them",
              file=sys.stderr)
        return 1
    return 0


def _raise_interrupt(signum, frame):
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not cut the cleanup
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _finished_rows(table) -> int:
    """The number of points in a sweep's table (0 if it is absent or unreadable)."""
    try:
        import pyarrow.parquet as pq

        return int(pq.ParquetFile(table).metadata.num_rows)
    except Exception:
        return 0


def _quiet_cluster_exit() -> None:
    """Close a local cluster cut short while it started, quietly: Dask's own exit hook
    (``distributed.deploy.spec.close_clusters``) asserts on the half-started workers and
    prints a 29-line traceback after the interrupt's one line. Replaced by the same close
    with every error suppressed (the process is ending on the interrupt)."""
    import atexit
    import contextlib

    spec = sys.modules.get("distributed.deploy.spec")
    if spec is None:
        return
    atexit.unregister(spec.close_clusters)

    def close() -> None:
        for cluster in list(getattr(spec.SpecCluster, "_instances", ())):
            with contextlib.suppress(BaseException):
                if getattr(cluster, "shutdown_on_close", False):
                    cluster.close(timeout=10)

    atexit.register(close)
