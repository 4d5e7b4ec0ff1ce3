"""Run a sweep: every point one Dask task, results written as each finishes, resumable.

The sweep directory (``-o DIR``)::

    DIR/record.json          kind "isodesign sweep": the sweep's identity, status, counts
    DIR/study_base.toml      the base study, resolved (replay)
    DIR/sweep.parquet        one row per point (isodesign.sweeps.table), rewritten whole
                             and atomically as the points finish (after each point, or
                             once for the points that finished together)
    DIR/points/<hash16>/     each point's run directory (docs/cli.md contract), named by
                             the first 16 hex digits of its resolved study's SHA-256
    DIR/charts/<objective>.png   design charts (isodesign.plotting.sweep)

Unlike a single run, the sweep directory is filled as the points finish (a point's run
directory appears whole, moved into place by the worker that computed it), so a sweep
that stops (SIGINT, a crash, a lost cluster) leaves every finished point usable. Its
identity is the task, its options, the base study's hash and the set of swept keys: a
rerun with the same identity skips the points whose run directory is finished
(``complete`` or ``infeasible``, matched by the study hash) and runs the others (new
values, failed points); a directory that holds another sweep is refused unless
``overwrite``. One sweep at a time per directory (a lock file).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import io
import json
import os
import shutil
import statistics
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from isodesign import __version__
from isodesign.errors import InputError
from isodesign.io.files import atomic_write_text
from isodesign.io.record import resolved_study_dict, study_toml
from isodesign.io.rundir import (
    RECORD_NAME,
    check_outside_whole_runs,
    check_run_target,
    read_run_record,
)
from isodesign.optimization.study import Study, default_study, load_study
from isodesign.results import ResultDisplay
from isodesign.sweeps.continuation import chains
from isodesign.sweeps.spec import (
    build_points,
    check_key,
    combine,
    parse_vary,
    read_points,
    study_hash,
)
from isodesign.sweeps.table import TABLE_NAME, collect_rows, frame, write_table
from isodesign.sweeps.tasks import (
    FINISHED,
    POINT_FILE,
    get_task,
    record_failed_point,
    run_point,
)

__all__ = ["SweepResult", "sweep"]

KIND = "isodesign sweep"
POINTS = "points"
CHARTS = "charts"
#: The binding map's file in the charts directory (a sweep of two or more keys).
BINDING_MAP = "binding_map.png"
LOCK = ".sweep.lock"
#: Entries of a sweep directory that a sweep writes (an overwrite removes only these).
OWNED = (RECORD_NAME, TABLE_NAME, "study_base.toml", POINTS, CHARTS, LOCK)
#: Retries of a task that raised (Dask's ``retries``): a point that fails twice is failed.
RETRIES = 1


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


@dataclass(frozen=True, eq=False, repr=False)
class SweepResult(ResultDisplay):
    """A finished (or interrupted) sweep: its directory and its table.

    Attributes
    ----------
    directory : Path
    table : pandas.DataFrame
        One row per point (:mod:`isodesign.sweeps.table`), every point of the directory.
    keys : tuple of str
        The swept keys.
    task : str
    ran, reused, failed : int
        Points computed by this call, found finished, failed (this call).
    wall_s : float
    where : str
        Where it ran.
    status : str
        ``complete``, ``failed`` (some point failed) or ``interrupted``.
    point_wall_s : tuple of float
        The wall time of each point computed now.
    nlp_builds : int
        NLPs built by the points computed now, summed over the workers and points as each
        worker's :class:`~isodesign.optimization.parametric.ProblemCache` counts them (one
        per structure and worker process, and a table structure's NLP with movable peak
        frequencies one more; ``docs/sweep.md``, section 7).
    values : dict
        Each swept key's values in the sweep's order.
    """

    directory: Path
    table: object
    keys: tuple
    task: str
    ran: int
    reused: int
    failed: int
    wall_s: float
    where: str
    status: str
    point_wall_s: tuple = field(default_factory=tuple)
    #: NLPs built by the points run now, summed over workers (docs/sweep.md, section 7).
    nlp_builds: int = 0
    #: Each swept key's values in the sweep's order (the binding map's axes and panels).
    values: dict = field(default_factory=dict)

    def to_frame(self):
        """The table (a copy)."""
        return self.table.copy()

    def _summary_items(self):
        n = len(self.table)
        med = statistics.median(self.point_wall_s) if self.point_wall_s else float("nan")
        return [("task", self.task), ("keys", ", ".join(self.keys) or "(points file)"),
                ("points", f"{n} in the table; {self.ran} run now, {self.reused} reused, "
                           f"{self.failed} failed"),
                ("status", self.status), ("where", self.where),
                ("NLPs built", f"{self.nlp_builds} for {self.ran} points run now"),
                ("wall time", f"{self.wall_s:.1f} s (median point {med:.2f} s)")]

    def plot(self, objective: str | None = None):
        """The design chart of one objective (default: the first in the table).

        Parameters
        ----------
        objective : str, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.sweep import design_chart

        return design_chart(self.table, self.keys, objective=objective)

    def binding_map(self, x: str | None = None, y: str | None = None):
        """The binding set of every point as categories over two swept keys, one panel per
        value of the others, the boundaries where the set changes drawn
        (:func:`isodesign.plotting.sweep.binding_map`; ``OUTDIR/charts/binding_map.png``).

        Parameters
        ----------
        x, y : str, optional
            Swept keys for the axes (default: the numeric keys with the most values).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.sweep import binding_map

        return binding_map(self.table, self.keys, x=x, y=y, order=self.values)


# ---------------------------------------------------------------------------------------
# the directory
# ---------------------------------------------------------------------------------------
def _check_dir(target: Path, identity: dict, overwrite: bool, option: str) -> str:
    """``new`` or ``resume``; InputError for another sweep, another run, other files."""
    if str(target).strip() == "":
        raise InputError(f"{option}: empty; give a directory name")
    check_outside_whole_runs(target, option=option)  # not inside another sweep's directory
    if target.exists() and not target.is_dir():
        raise InputError(f"{option}: {target} exists and is not a directory")
    if not target.exists() or not any(target.iterdir()):
        check_run_target(target, option=option)  # a parent that is a file, unwritable
        return "new"
    rec = read_run_record(target)
    if rec is not None and rec.get("kind") == KIND:
        theirs = (rec.get("sweep") or {}).get("identity")
        if theirs == identity:
            return "resume"
        if not overwrite:
            t = theirs or {}
            raise InputError(
                f"{option}: {target} holds another sweep (task {t.get('task')!r} over "
                f"{', '.join(t.get('keys') or []) or 'a points file'}, base study "
                f"{str(t.get('base_study_hash'))[:16]}); choose a new directory, or give "
                "--overwrite to replace it")
        for e in OWNED:
            p = target / e
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
        return "new"
    if rec is not None:
        raise InputError(f"{option}: {target} holds an {rec.get('kind')} run, not a sweep; "
                         "choose a new or empty directory")
    raise InputError(f"{option}: {target} is not empty and holds no isodesign sweep; choose a "
                     "new or empty directory")


@contextlib.contextmanager
def _locked(target: Path, option: str):
    import fcntl

    target.mkdir(parents=True, exist_ok=True)
    fh = open(target / LOCK, "a+")
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise InputError(f"{option}: another isodesign sweep is running in {target}; "
                             "wait for it or choose another directory") from None
        yield
    finally:
        fh.close()
        with contextlib.suppress(OSError):  # nothing but the lock: leave no trace
            if [e.name for e in target.iterdir()] == [LOCK]:
                (target / LOCK).unlink()
                target.rmdir()


def _clean_leftovers(points_dir: Path) -> None:
    """Staging directories of points whose worker died or was interrupted (under the lock)."""
    if not points_dir.is_dir():
        return
    for p in points_dir.iterdir():
        if ".isodesign-partial-" in p.name or ".isodesign-old-" in p.name \
                or ".interrupted" in p.name:
            shutil.rmtree(p, ignore_errors=True)


# ---------------------------------------------------------------------------------------
# the sweep
# ---------------------------------------------------------------------------------------
def _base_study(study) -> Study:
    if study is None:
        return default_study()
    if isinstance(study, Study):
        return study
    if not isinstance(study, str | os.PathLike):
        raise InputError(f"study: expected a Study, a study file name or None (the default "
                         f"study), got {type(study).__name__} {study!r:.40}")
    return load_study(study)


def _tables(vary, mode, points) -> tuple[list[dict], list[str]]:
    if points is not None and vary:
        raise InputError("--points-file: give a points file or --vary, not both")
    if points is not None:
        if isinstance(points, str | Path):
            tables = read_points(points)
        elif isinstance(points, list | tuple) and all(isinstance(t, dict) for t in points):
            tables = [dict(t) for t in points]
            for t in tables:
                for k in t:
                    if not isinstance(k, str):
                        raise InputError(f"points: keys must be dotted study keys "
                                         f"('payload.mass_kg'), got {k!r:.40}")
                    check_key(k, "points")  # a list value is fine in a points table
        else:
            raise InputError("points: expected a points file name or a list of change tables "
                             f"({{'payload.mass_kg': 600}}), got {type(points).__name__} "
                             f"{points!r:.40}")
        keys = []
        for t in tables:
            keys += [k for k in t if k not in keys]
        return tables, keys
    if not vary:
        raise InputError("--vary: give at least one KEY=VALUES (or --points-file FILE)")
    if isinstance(vary, str):
        vary = [vary]
    if not isinstance(vary, dict | list | tuple) or (
            not isinstance(vary, dict) and not all(isinstance(v, str) for v in vary)):
        raise InputError("vary: expected {key: values} or a list of 'KEY=VALUES' strings, got "
                         f"{type(vary).__name__} {vary!r:.40}")
    items = vary.items() if isinstance(vary, dict) else [parse_vary(v) for v in vary]
    varies = []
    for k, v in items:
        if not isinstance(k, str):
            raise InputError(f"vary: keys must be dotted study keys ('payload.mass_kg'), got "
                             f"{k!r:.40}")
        if isinstance(v, str):
            varies.append(parse_vary(f"{k}={v}"))
        else:
            if not isinstance(v, list | tuple | range) and not hasattr(v, "tolist"):
                raise InputError(f"--vary {k}: expected a list of values or a 'lo:hi:n' string, "
                                 f"got {type(v).__name__} {v!r:.40}")
            vals = list(v.tolist() if hasattr(v, "tolist") else v)
            key, _ = parse_vary(f"{k}=0")  # checks the key
            if not vals:
                raise InputError(f"--vary {key}: no values")
            varies.append((key, vals))
    return combine(varies, mode), [k for k, _ in varies]


def _identity(task: str, options: dict, base: Study, keys: list[str]) -> dict:
    b = base.with_changes(solver={"workers": 1})
    return {"task": task, "options": json.loads(json.dumps(options, sort_keys=True)),
            "base_study_hash": study_hash(b), "keys": sorted(keys)}


def _write_record(target: Path, rec: dict) -> None:
    atomic_write_text(target / RECORD_NAME, json.dumps(rec, indent=2, default=str) + "\n")


def sweep(study=None, vary=None, *, output, combine: str = "product", points=None,
          task: str = "optimize", options: dict | None = None, scheduler: str | None = None,
          workers: int | None = None, overwrite: bool = False, charts: bool = True,
          progress=None, argv=None) -> SweepResult:
    """Run a sweep of study changes, one Dask task per point (see the module docstring).

    Parameters
    ----------
    study : Study, str or Path, optional
        The base study (default: the built-in default study).
    vary : dict or list of str, optional
        Key -> values (a list, or a ``"300:1500:13"`` / ``"VC-A,VC-B"`` string), or
        ``["payload.mass_kg=300:1500:13", ...]`` (:func:`isodesign.sweeps.spec.parse_vary`).
    output : str or Path
        The sweep directory.
    combine : {'product', 'zip'}
        How the varied keys combine.
    points : str, Path or list of dict, optional
        Instead of ``vary``: a points file (:func:`isodesign.sweeps.spec.read_points`) or
        change tables.
    task : str
        ``optimize``, ``response``, ``pareto`` (or a registered task).
    options : dict, optional
        Task options (``plots``; ``objectives``, ``points`` for ``pareto``).
    scheduler : str, optional
        A Dask scheduler address (default ``DASK_SCHEDULER_ADDRESS``, else a local
        cluster); ``"serial"`` runs the points one by one in this process (no Dask: the
        baseline of the benchmark, and for debugging).
    workers : int, optional
        Worker processes of a local cluster (default: one per core available).
    overwrite : bool
        Replace a directory holding another sweep.
    charts : bool
        Write the design charts when the sweep ends.
    progress : callable, optional
        ``progress(done, total, row, running)`` after each point (``row`` None at start;
        ``running``: the points being computed, at most one per worker).
    argv : list of str, optional
        The command line recorded.

    Returns
    -------
    SweepResult

    Examples
    --------
    >>> import isodesign
    >>> res = isodesign.sweep(vary={"payload.mass_kg": "300:1500:13"},
    ...                       output="out/mass_sweep")                    # doctest: +SKIP
    >>> res.table[["payload.mass_kg", "objective_value", "binding"]]      # doctest: +SKIP
    """
    t_all = time.perf_counter()
    _check_arguments(output, workers, scheduler, overwrite, charts, combine, task, options)
    spec = get_task(task)
    options = {k: v for k, v in (options or {}).items() if v is not None}
    unknown = set(options) - set(spec.options)
    if unknown:
        raise InputError(f"--task {task}: option {sorted(unknown)[0]!r} does not apply; "
                         f"valid: {', '.join(spec.options) or 'none'}")
    base = _base_study(study)
    if spec.check is not None:
        spec.check(base)
    tables, keys = _tables(vary, combine, points)
    pts, dropped = build_points(base, tables,
                                 "--points-file" if points is not None else "--vary")
    if spec.check is not None:  # a point the --vary changed (a [scenarios] added): refused
        for p in pts:          # before any runs, as the base is
            try:
                spec.check(p.study)
            except InputError as exc:
                at = ", ".join(f"{k}={v}" for k, v in p.changes.items())
                raise InputError(f"{exc} (at the point {at})") from None
    if task == "pareto":  # every point's front, checked before any runs
        from isodesign.optimization.pareto import DEFAULT_OBJECTIVES, check_front

        for p in pts:
            try:
                check_front(p.study, options.get("objectives") or DEFAULT_OBJECTIVES)
            except InputError as exc:
                at = ", ".join(f"{k}={v}" for k, v in p.changes.items())
                raise InputError(f"--objectives at the point {at}: {exc}") from None
    if task == "optimize":  # a robust table no optimizer answers, refused before any runs
        from isodesign.optimization.dispatch import study_kind
        from isodesign.optimization.robust_table import check_robust_table

        for p in (p for p in pts if study_kind(p.study) == "robust table"):
            try:
                check_robust_table(p.study)
            except InputError as exc:
                at = ", ".join(f"{k}={v}" for k, v in p.changes.items())
                raise InputError(f"{exc} (at the point {at})") from None
    identity = _identity(task, options, base, keys)
    target = Path(output)
    mode = _check_dir(target, identity, overwrite, "--output")
    if scheduler not in (None, "serial", "local") and scheduler.strip() == "":
        raise InputError("--scheduler: empty; give tcp://host:port")
    with _locked(target, "--output"):
        return _run(target, mode, base, pts, dropped, keys, identity, task, options,
                    scheduler, workers, charts, progress, argv, t_all, combine)


def _check_arguments(output, workers, scheduler, overwrite, charts, combine, task,
                     options) -> None:
    """The Python arguments' types and ranges, named as the CLI option (before any work)."""
    if not isinstance(output, str | os.PathLike):
        raise InputError(f"--output: expected a directory name (a string or path), got "
                         f"{type(output).__name__} {output!r:.40}")
    if str(output).strip() == "":
        raise InputError("--output: empty (it would write into the current directory); give "
                         "a directory name")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or not 1 <= workers <= 64):
        raise InputError(f"--workers: must be an integer in [1, 64] (worker processes of the "
                         f"local cluster), got {workers!r:.40}")
    if scheduler is not None and not isinstance(scheduler, str):
        raise InputError(f"--scheduler: expected an address (tcp://host:port), 'local' or "
                         f"'serial', got {type(scheduler).__name__} {scheduler!r:.40}")
    for name, v in (("--overwrite", overwrite), ("charts", charts)):
        if not isinstance(v, bool):
            raise InputError(f"{name}: expected true or false, got {v!r:.40}")
    if combine not in ("product", "zip"):
        raise InputError(f"--combine: unknown value {combine!r:.40}; valid: product, zip")
    if not isinstance(task, str):
        raise InputError(f"--task: expected a task name, got {type(task).__name__}")
    if options is not None and not isinstance(options, dict):
        raise InputError(f"options: expected a dict of task options, got "
                         f"{type(options).__name__}")


def _run(target, mode, base, pts, dropped, keys, identity, task, options, scheduler, workers,
         charts, progress, argv, t_all, mode_combine) -> SweepResult:
    points_dir = target / POINTS
    rows = collect_rows(points_dir)
    todo = [p for p in pts if rows.get(p.study_hash, {}).get("status") not in FINISHED]
    reused = len(pts) - len(todo)
    conn = None
    if todo and scheduler != "serial":  # an unreachable scheduler fails before any write
        from isodesign.sweeps.cluster import connect

        conn = connect(None if scheduler == "local" else scheduler, workers)
    points_dir.mkdir(exist_ok=True)
    _clean_leftovers(points_dir)
    rec = {"kind": KIND, "run_status": "running", "isodesign_version": __version__,
           "argv": list(sys.argv if argv is None else argv), "started_utc": _now(),
           "output_directory": str(target),
           "sweep": {"identity": identity, "task": task, "options": options, "keys": keys,
                     "combine": mode_combine, "points": len(pts),
                     "duplicates_dropped": dropped, "base_study_source": base.source,
                     "values": key_values(pts, keys),
                     "base_study": resolved_study_dict(base)},
           "table": TABLE_NAME}
    prev = read_run_record(target)
    if mode == "resume" and prev is not None:
        rec["first_started_utc"] = prev.get("first_started_utc", prev.get("started_utc"))
    _write_record(target, rec)
    if mode == "new":
        atomic_write_text(target / "study_base.toml", study_toml(base, header=(
            "Base study of an isodesign sweep (resolved). Each point is this study with its\n"
            "changes applied (see sweep.parquet, column changes, and points/*/)")))
    table_path = target / TABLE_NAME
    tables = [p.changes for p in pts]
    order = chains(tables, keys, 1 if conn is None else max(conn.workers, 1))
    builds = [0]  # NLPs built by the points computed now (the branch pass's too)

    def built(row) -> int:
        # the NLPs the point built (its worker's ProblemCache count: a table point may build
        # two, its structure's and the one with movable peak frequencies); a row without the
        # count (a task that keeps no cache) says only whether it built one
        n = row.get("nlp_builds")
        if n is None or n != n:  # None or NaN: not counted
            return int(bool(row.get("nlp_built")))
        return int(n)

    def table_now():
        return frame(rows.values(), keys)

    write_table(table_now(), table_path)
    total, done, failed = len(pts), 0, 0
    walls: list[float] = []
    unwritten = []  # rows handed over but not yet in the table (a batch cut short)
    where = "nothing to run" if not todo else ""
    status = "complete"
    if progress:
        progress(reused, total, None,
                 0 if conn is None else min(max(conn.workers, 1), len(todo)))

    def finished(p, row, write=True):
        # write=False: more rows that have already arrived follow at once, and the last of
        # them writes the table (one rewrite for all the points finished meanwhile)
        nonlocal done, failed
        rows[p.study_hash] = row
        builds[0] += 0 if row.get("reused") else built(row)
        done += 1
        failed += row.get("status") == "failed"
        if row.get("wall_s") is not None and not row.get("reused"):
            walls.append(float(row["wall_s"]))
        unwritten.append(p.study_hash)
        if write:
            write_table(table_now(), table_path)
            unwritten.clear()
        if progress:
            slots = 1 if conn is None else max(conn.workers, 1)  # a point per worker
            progress(reused + done, total, row, min(slots, len(todo) - done))

    todo_hashes = {p.study_hash for p in todo}

    def again(p, row, write=True):  # a point solved again (the branch pass): not a new one
        rows[p.study_hash] = row
        builds[0] += built(row)
        if write:
            write_table(table_now(), table_path)

    error = None
    try:
        if todo and scheduler == "serial":
            where = "serial (this process, no Dask)"
            with _interrupts_seen() as seen:
                def serial(items, done_now):
                    for i, nb, again in items:
                        p = pts[i]
                        pdir = str(points_dir / p.key)
                        said = io.StringIO()  # the point's stderr, shown unless interrupted
                        with contextlib.redirect_stderr(said):
                            try:
                                row = run_point(task, resolved_study_dict(p.study),
                                                p.study_hash, p.changes, pdir, options,
                                                neighbours=nb, resolve=again)
                            except Exception as exc:  # a bug in the task: recorded, goes on
                                row = record_failed_point(task, p.study_hash, p.changes, pdir,
                                                          f"{type(exc).__name__}: {exc}")
                        if seen:
                            # a Ctrl-C inside the solver (CasADi turns it into a failed
                            # solve): the point ran under the interrupt, so it is not kept
                            if not row.get("reused"):
                                shutil.rmtree(pdir, ignore_errors=True)
                            raise KeyboardInterrupt(seen[0])
                        sys.stderr.write(said.getvalue())
                        done_now(p, row)

                for ch in order:
                    prev = None
                    for i in ch:
                        p = pts[i]
                        if p.study_hash in rows and p.study_hash not in todo_hashes:
                            prev = rows[p.study_hash]
                            continue
                        serial([(i, [prev] if prev else [], False)], finished)
                        prev = rows[p.study_hash]
                _branch_pass(pts, rows, order, task, lambda items: serial(items, again),
                             todo_hashes)
        elif todo:
            where = conn.where
            # the branch pass runs as the chains go (_run_dask): no serial tail after them
            _run_dask(conn.client, pts, order, todo_hashes, rows, task, options, points_dir,
                      finished, again=again)
    except KeyboardInterrupt:
        status = "interrupted"
        raise
    except BaseException as exc:
        status, error = "failed", f"{type(exc).__name__}: {exc}"
        raise
    finally:
        if conn is not None:
            conn.close()
        if status == "complete":
            mine = {p.study_hash for p in pts}
            if any(r.get("status") == "failed" for h, r in rows.items() if h in mine):
                status = "failed"
        if status == "interrupted":  # a point finished on disk just before the signal
            mine = {p.study_hash for p in pts}
            late = {h: r for h, r in collect_rows(points_dir).items()
                    if h in mine and h not in rows}
            if late:
                rows.update(late)
                unwritten.extend(late)
        if unwritten:  # interrupted inside a batch: its rows reach the table all the same
            write_table(table_now(), table_path)
        if status != "interrupted":  # every task has ended: no worker writes any more
            _clean_leftovers(points_dir)
        rec["nlp_builds"] = builds[0]
        _finish(target, rec, rows, pts, status, where, keys,
                charts and status != "interrupted", error, ran=done > 0)
    return SweepResult(directory=target, table=table_now(), keys=tuple(keys),
                       task=task, ran=done, reused=reused, failed=failed,
                       wall_s=time.perf_counter() - t_all, where=where, status=status,
                       point_wall_s=tuple(walls),
                       nlp_builds=rec["nlp_builds"], values=rec["sweep"]["values"])


@contextlib.contextmanager
def _interrupts_seen():
    """A list that receives the name of each SIGINT/SIGTERM while the block runs (main
    thread): the handler in force is still called, but a solver that swallows the
    KeyboardInterrupt it raises (CasADi returns a failed solve) no longer hides it."""
    import signal
    import threading

    seen: list[str] = []
    if threading.current_thread() is not threading.main_thread():
        yield seen
        return
    old = {}

    def make(prev):
        def handler(signum, frame):
            seen.append(signal.Signals(signum).name)
            if callable(prev):
                prev(signum, frame)
            else:
                raise KeyboardInterrupt(signal.Signals(signum).name)
        return handler

    for sig in (signal.SIGINT, signal.SIGTERM):
        prev = signal.getsignal(sig)
        if callable(prev):  # SIG_DFL of SIGTERM (end the process) is left alone
            old[sig] = prev
            signal.signal(sig, make(prev))
    try:
        yield seen
    finally:
        for sig, prev in old.items():
            signal.signal(sig, prev)


def _submit(client, p, task, options, points_dir, tag, neighbours, resolve=False,
            worker=None):
    # a chain's worker is a preference (allow_other_workers): a lost worker's chain moves
    where = {"workers": [worker], "allow_other_workers": True} if worker else {}
    return client.submit(run_point, task, resolved_study_dict(p.study), p.study_hash,
                         p.changes, str(points_dir / p.key), options, neighbours=neighbours,
                         resolve=resolve, key=f"isodesign-point-{p.key}-{tag}", pure=False,
                         retries=RETRIES, **where)


def _worker_addresses(client) -> list[str]:
    try:
        return sorted(client.scheduler_info(n_workers=-1)["workers"])
    except Exception:  # an old scheduler, a test double: no preference
        return []


def _run_dask(client, pts, order, todo_hashes, rows, task, options, points_dir,
              finished, again=None) -> None:
    """Submit every point as a task, each chain's points in order (a point's task takes its
    predecessor's future: its row arrives as the neighbour), each chain on one worker (the
    chains dealt round the workers, a preference Dask keeps unless the worker is lost);
    hand each row to ``finished`` as it completes. With ``again``, the branch pass
    (:func:`_branch_pass`) runs while the chains go on: a row that changed branch submits
    its predecessor's re-solve at once (:func:`_resolve_next`), whose row goes to
    ``again``; the sweep ends when the chains and the re-solves have."""
    tag = uuid.uuid4().hex[:8]
    futures = {}
    workers = _worker_addresses(client)
    for c, ch in enumerate(order):
        w = workers[c % len(workers)] if workers else None
        prev = None
        for i in ch:
            p = pts[i]
            if p.study_hash not in todo_hashes:
                prev = rows.get(p.study_hash)
                continue
            fut = _submit(client, p, task, options, points_dir, tag,
                          [prev] if prev is not None else [], worker=w)
            futures[fut] = p
            prev = fut
    if again is None or task != "optimize":
        _collect(client, futures, task, points_dir, finished)
        return
    index = {p.study_hash: i for i, p in enumerate(pts)}
    where = {i: (c, k) for c, ch in enumerate(order) for k, i in enumerate(ch)}
    tried: set[int] = set()
    resolving: set = set()

    def done(p, row, write=True):
        first = p.study_hash not in resolving
        resolving.discard(p.study_hash)
        (finished if first else again)(p, row, write=write)
        more = {}
        for a, nb in _resolve_next(pts, rows, order, where, index[p.study_hash], row, first,
                                   todo_hashes, tried):
            resolving.add(pts[a].study_hash)
            more[_submit(client, pts[a], task, options, points_dir, f"{tag}-again", nb,
                         resolve=True)] = pts[a]
        return more

    _collect(client, futures, task, points_dir, done)


def _resolve_next(pts, rows, order, where, i, row, first, ran, tried) -> list:
    """The re-solve the row of point ``i`` calls for, as :func:`_branch_pass` decides it:
    a chain point (``first``) that changed branch, its predecessor; a re-solved point whose
    answer is its later neighbour's branch (``best_neighbour`` 1), its predecessor too.
    ``[(index, neighbour rows)]`` (empty: none); ``tried`` grows."""
    c, k = where[i]
    ch = order[c]
    if not k or ch[k - 1] in tried or pts[ch[k - 1]].study_hash not in ran:
        return []
    a = ch[k - 1]
    ra = rows.get(pts[a].study_hash) or {}
    if first:
        if not (row.get("branch_changed") and ra.get("question") == "vertical"
                and ra.get("feasible")):
            return []
    elif row.get("best_neighbour") != 1:
        return []
    tried.add(a)
    return [(a, [rows.get(pts[ch[k - 2]].study_hash) if k > 1 else None, row])]


def _collect(client, futures: dict, task, points_dir, finished) -> None:
    from distributed import as_completed

    try:
        # the futures finished since the last batch (usually one): their rows, then one
        # rewrite of the table (a large cluster finishes points faster than whole rewrites)
        # (``finished`` may return more futures, point by future: waited for too)
        pending = as_completed(list(futures), loop=client.loop)
        for batch in pending.batches():
            for i, fut in enumerate(batch):
                p = futures.pop(fut)
                try:
                    row = fut.result()
                except Exception as exc:  # KilledWorker, or a task that raised twice
                    msg = " ".join(str(exc).split())[:500]
                    row = record_failed_point(task, p.study_hash, p.changes,
                                              str(points_dir / p.key),
                                              f"{type(exc).__name__}: {msg}")
                more = finished(p, row, write=i == len(batch) - 1)
                for f, q in (more or {}).items():
                    futures[f] = q
                    pending.add(f)
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(list(futures), force=True)
        raise


def _branch_pass(pts, rows: dict, order, task: str, solve, ran: set) -> None:
    """Solve again, from the later neighbour's optimum, each point whose successor in its
    chain changed branch (``branch_changed``: its answer left the branch its predecessor's
    optimum led to); backwards while the answer is the later neighbour's branch.

    ``solve(items)`` runs ``(index, neighbour rows, resolve)`` items and stores their rows.
    Only ``optimize`` points are continued (the other tasks have no starts), and only the
    points computed now (``ran``: study hashes): a finished point of an earlier run is never
    rewritten (a resumed or extended sweep runs only its new points).
    """
    if task != "optimize":
        return
    where = {i: (c, k) for c, ch in enumerate(order) for k, i in enumerate(ch)}
    todo = []
    for ch in order:
        for k in range(1, len(ch)):
            ra, rb = rows.get(pts[ch[k - 1]].study_hash), rows.get(pts[ch[k]].study_hash)
            if ra and rb and pts[ch[k - 1]].study_hash in ran \
                    and ra.get("question") == "vertical" and ra.get("feasible") \
                    and rb.get("branch_changed"):
                todo.append(ch[k - 1])
    tried: set[int] = set()
    while todo:
        items = []
        for a in todo:
            c, k = where[a]
            ch = order[c]
            # [predecessor (or nothing), successor]: best_neighbour 1 is the successor's
            nb = [rows.get(pts[ch[k - 1]].study_hash) if k else None,
                  rows.get(pts[ch[k + 1]].study_hash)]
            items.append((a, nb, True))
            tried.add(a)
        solve(items)
        nxt = []
        for a in todo:  # moved to the later branch: its predecessor may follow it
            c, k = where[a]
            if not k or order[c][k - 1] in tried or pts[order[c][k - 1]].study_hash not in ran:
                continue
            ra = rows.get(pts[a].study_hash) or {}
            if ra.get("best_neighbour") == 1:
                nxt.append(order[c][k - 1])
        todo = nxt


def key_values(pts, keys) -> dict:
    """Each swept key's distinct values in the sweep's order (the charts' axes and panels
    follow it: floors as given, not sorted by name); ``{}`` past 10,000 values in all."""
    out = {k: list(dict.fromkeys(p.changes[k] for p in pts if k in p.changes
                                 and isinstance(p.changes[k], str | int | float | bool)))
           for k in keys}
    return out if sum(len(v) for v in out.values()) <= 10_000 else {}


def _finish(target, rec, rows, pts, status, where, keys, charts, error=None,
            ran: bool = True) -> None:
    ours = [rows[p.study_hash] for p in pts if p.study_hash in rows]
    counts = {s: sum(1 for r in ours if r.get("status") == s)
              for s in ("complete", "infeasible", "failed")}
    counts["missing"] = len(pts) - len(ours)
    rec.update(run_status=status, finished_utc=_now(), where=where, counts=counts,
               points_in_table=len(rows))
    if status == "failed" and not error:
        rec["error"] = (f"{counts['failed']} of {len(pts)} points failed (see the table's error "
                        "column); rerun the same command to retry them")
    if error:
        rec["error"] = error
    elif status == "interrupted":
        rec["error"] = (f"interrupted: {len(ours)} of {len(pts)} points finished; rerun the "
                        "same command to run the others")
    if charts and rows:
        with contextlib.suppress(Exception):  # a chart never costs the results
            rec["charts"] = _write_charts(target, frame(rows.values(), keys), keys, ran,
                                          order=(rec.get("sweep") or {}).get("values"))
    _write_record(target, rec)


def _write_charts(target: Path, df, keys, ran: bool = True, order=None) -> list[str]:
    """The design charts and the binding map into ``target/charts``. A rerun that ran no
    point keeps the charts drawn since the last point finished (drawing them imports
    matplotlib: most of such a rerun's time)."""
    from isodesign.plotting.sweep import chart_objectives, has_binding_map

    names = [f"{CHARTS}/{obj}.png" for obj in chart_objectives(df)]
    if has_binding_map(df, keys):
        names.append(f"{CHARTS}/{BINDING_MAP}")
    if not ran and _charts_current(target, names):
        return names
    from isodesign.io.files import atomic_path
    from isodesign.plotting.style import save_figure
    from isodesign.plotting.sweep import binding_map, design_chart

    (target / CHARTS).mkdir(exist_ok=True)
    for name in names:
        if name.endswith("/" + BINDING_MAP):
            fig = binding_map(df, keys, order=order)
        else:
            fig = design_chart(df, keys, objective=name[len(CHARTS) + 1: -len(".png")])
        with atomic_path(target / name) as tmp:
            save_figure(fig, tmp, dpi=110)
    return names


def _charts_current(target: Path, names: list[str]) -> bool:
    """Every chart exists and was drawn after every point's row was written."""
    try:
        drawn = min((target / n).stat().st_mtime for n in names) if names else 0.0
        rows = (p.stat().st_mtime for p in (target / POINTS).glob("*/" + POINT_FILE))
        return bool(names) and all(t < drawn for t in rows)
    except OSError:
        return False


def sweep_record(directory) -> dict | None:
    """The ``record.json`` of a sweep directory (None if it holds no sweep).

    Parameters
    ----------
    directory : str or Path
    """
    rec = read_run_record(directory)
    return rec if rec is not None and rec.get("kind") == KIND else None

