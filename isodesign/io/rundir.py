"""The run-directory contract: a run's output directory is written whole, once, with its status.

Every command that writes an output directory (``optimize``, ``pareto``, ``demo``, and any
new one) goes through :class:`RunDirectory`::

    run = RunDirectory(args.output, command="optimize", overwrite=args.overwrite)  # checks
    ...validate the other inputs...
    with run:                                   # creates the staging directory
        run.record.update(kind_specific_fields)
        run.write_json("design.json", design)
        with run.writing("response.png") as tmp:
            figure.savefig(tmp)
        run.status = "infeasible"               # default "complete"

The contract (``docs/cli.md``, "Output directories"):

* The target is checked when :class:`RunDirectory` is constructed, before any
  computation: a file where a directory is needed, an unwritable parent, or a target
  that already holds a run (refused unless ``overwrite``) raise
  :class:`~isodesign.errors.InputError` naming the option.
* The run writes into a fresh staging directory beside the target
  (``.NAME.isodesign-partial-XXXX``); every file is written whole or not at all
  (:func:`isodesign.io.files.atomic_path`). When the run ends, ``record.json`` gets the
  run's ``run_status`` (``complete``, ``infeasible``, ``failed``), the list of files the
  run wrote (its manifest, with sizes and SHA-256) and, for a failure, the error; then every
  file of the staging directory is synced to disk, side by side
  (:func:`isodesign.io.files.make_durable`: written without a per-file fsync, which cost
  16 fsyncs one after the other, ~50 ms, per ``optimize`` run), the staging directory is
  renamed to the target and the rename synced. A reader sees no directory, the previous
  run, or the finished run: never a half-written one.
* With ``overwrite``, only what an earlier run wrote (the files of its manifest) is
  replaced: other files in the target are moved into the new run directory untouched.
* A run refused on its input (an exception the command line reports with exit status 2:
  :class:`~isodesign.errors.InputError`, any other ``ValueError``, an ``OSError``) raised
  inside the ``with`` block writes nothing: the staging directory is removed and the target
  is left as it was (absent, or the previous run untouched). ``failed`` is the status of a
  run that ends in any other exception (a solver failure, exit 1; a bug, exit 3).
* An interrupted run (``KeyboardInterrupt``, or SIGINT/SIGTERM through the CLI's handler
  calling :func:`interrupt_active_runs`) is never moved into place: its staging directory
  is renamed to ``NAME.interrupted`` (``NAME.interrupted-2``, ... if taken) beside the
  target, with ``run_status = "interrupted"`` in its ``record.json``; the target is left
  as it was.

The list of runs in progress (for the signal handler) is the one piece of process-wide
state; it is per process (forked workers never finish or interrupt a run).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import json
import math
import os
import shutil
import sys
import tempfile
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from isodesign import __version__
from isodesign.errors import InputError
from isodesign.io.files import (
    atomic_path,
    atomic_write_text,
    discard_pending_writes,
    make_durable,
    write_probe,
)

__all__ = [
    "RECORD_NAME",
    "RUN_STATUSES",
    "RunDirectory",
    "check_outside_whole_runs",
    "check_run_target",
    "interrupt_active_runs",
    "partial_tables",
    "read_run_record",
]

#: Kinds of run that own their whole directory (more than a manifest of files: a sweep's
#: table, points and lock); another command's ``--overwrite`` may not replace them.
WHOLE_DIRECTORY_KINDS = ("isodesign sweep",)
#: Name of the run record in every run directory.
RECORD_NAME = "record.json"
#: ``record.json["run_status"]`` of a finished run directory.
RUN_STATUSES = ("complete", "infeasible", "failed", "interrupted")
#: Status of a staging directory while the run is in progress.
RUNNING = "running"

_ACTIVE: list[RunDirectory] = []


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _jsonable(v: Any):
    """Plain JSON values: NumPy arrays and scalars converted, non-finite floats as null."""
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, Path):
        return str(v)
    if hasattr(v, "tolist") and not isinstance(v, str | bytes):  # NumPy arrays and scalars
        return _jsonable(v.tolist())
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def read_run_record(directory) -> dict | None:
    """The ``record.json`` of an isodesign run in ``directory``, or None if it holds none.

    Parameters
    ----------
    directory : str or Path
        A directory that may hold a run.
    """
    p = Path(directory) / RECORD_NAME
    try:
        rec = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if isinstance(rec, dict) and str(rec.get("kind", "")).startswith("isodesign"):
        return rec
    return None


def _nearest_existing(p: Path) -> Path:
    p = p.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_run_target(target, *, overwrite: bool = False, option: str = "--output",
                     known_outputs=(), command: str | None = None) -> list[str]:
    """Check that a run may write the directory ``target``; return the entries it replaces.

    Parameters
    ----------
    target : str or Path
        The output directory.
    overwrite : bool
        Replace an earlier run in ``target`` (only the files it wrote).
    option : str
        The option as the user typed it, for messages.
    known_outputs : iterable of str
        File names the command writes: an earlier run without a manifest (written by an
        isodesign before the run-directory contract) is taken to own these.
    command : str, optional
        The command about to write (``"modes"``): a directory that holds a run of a kind in
        :data:`WHOLE_DIRECTORY_KINDS` (a sweep, with its table and points, which would lose
        its record and could no longer resume) is refused even with ``overwrite``, unless
        it is the same kind.

    Returns
    -------
    list of str
        The entries of ``target`` an overwrite replaces (empty for a new target).

    Raises
    ------
    InputError
        ``target`` is a file, its nearest existing ancestor is a file or not writable, or
        it holds a run (or other files) and ``overwrite`` is false.
    """
    if not isinstance(target, str | os.PathLike):
        raise InputError(f"{option}: expected a directory name (a string or path), got "
                         f"{type(target).__name__} {target!r:.40}")
    if str(target).strip() == "" or (isinstance(target, str) and target.strip() == ""):
        raise InputError(f"{option}: empty; give a directory name")
    t = Path(target)
    if t.exists() and not t.is_dir():
        raise InputError(f"{option}: {t} exists and is not a directory")
    anc = _nearest_existing(t.parent if not t.exists() else t)
    if not anc.is_dir():
        raise InputError(f"{option}: {anc} is a file, so {t} cannot be created")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise InputError(f"{option}: cannot write in {anc} (permission denied)")
    why = write_probe(anc)
    if why is not None:
        raise InputError(f"{option}: cannot create {t}: cannot write in {anc} ({why.lower()})")
    if t.exists():
        parent = t.absolute().parent
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InputError(f"{option}: cannot write in {parent} (permission denied)")
    if not t.is_dir():
        return []
    entries = sorted(os.listdir(t))
    if not entries:
        return []
    prev = read_run_record(t)
    if prev is not None:
        if not overwrite:
            status = prev.get("run_status", "status not recorded")
            raise InputError(
                f"{option}: {t} already holds a run ({prev.get('kind')}, {status}); give "
                "--overwrite to replace it, or choose a new directory"
            )
        kind = prev.get("kind")
        if command is not None and kind in WHOLE_DIRECTORY_KINDS \
                and kind != f"isodesign {command}":
            raise InputError(
                f"{option}: {t} holds another kind of run ({kind}); --overwrite replaces only "
                f"an earlier isodesign {command} run: choose a new directory"
            )
        owned = prev.get("files")
        if not isinstance(owned, list):
            owned = [*known_outputs, RECORD_NAME]
        owned_top = {str(f).split("/")[0] for f in owned} | {RECORD_NAME}
        return [e for e in entries if e in owned_top]
    if not overwrite:
        raise InputError(
            f"{option}: {t} is not empty and holds no isodesign run ({len(entries)} "
            "entries); choose a new or empty directory, or give --overwrite (which keeps "
            "the files isodesign did not write)"
        )
    return []


def check_outside_whole_runs(target, *, option: str = "--output") -> None:
    """Refuse a command's output directory inside a run that owns its whole directory.

    A sweep's points (``OUTDIR/points/HASH``) belong to the sweep: its table names them and
    a rerun resumes from them, so another command writing there (``modes -o
    SWEEP/points --overwrite``) would leave the sweep unable to resume. Only the sweep
    writes inside its directory (it does not call this).

    Parameters
    ----------
    target : str or Path
        The output directory as the user gave it.
    option : str
        The option as the user typed it, for messages.

    Raises
    ------
    InputError
        An ancestor of ``target`` holds a run of a kind in :data:`WHOLE_DIRECTORY_KINDS`.
    """
    if not isinstance(target, str | os.PathLike) or not str(target).strip():
        return  # check_run_target names these
    t = Path(target).absolute()
    for anc in t.parents:
        rec = read_run_record(anc)
        if rec is not None and rec.get("kind") in WHOLE_DIRECTORY_KINDS:
            raise InputError(f"{option}: {target} is inside the directory of a run that "
                             f"owns it whole ({rec.get('kind')} in {anc}): writing there "
                             "would leave it unable to resume; choose a directory outside it")


@contextlib.contextmanager
def _signals_blocked() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back (main thread, POSIX) while a run is moved into place."""
    import signal
    import threading

    if not hasattr(signal, "pthread_sigmask") or \
            threading.current_thread() is not threading.main_thread():
        yield
        return
    sigs = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _refused(exc_type) -> bool:
    """An exception the command line reports as bad input (exit 2): an
    :class:`~isodesign.errors.InputError`, any other ``ValueError``, or an ``OSError`` (an
    input file that cannot be read, an output that cannot be written), not a closed
    standard output (``BrokenPipeError``, exit 141)."""
    return issubclass(exc_type, ValueError) or (issubclass(exc_type, OSError)
                                                and not issubclass(exc_type, BrokenPipeError))


def _sha256(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


class RunDirectory:
    """An output directory written by one run (see the module docstring for the contract).

    Parameters
    ----------
    target : str or Path
        The output directory as the user gave it.
    command : str
        The command's name (``record.json["kind"] = "isodesign <command>"``).
    overwrite : bool
        Replace an earlier run in ``target``.
    option : str
        The option naming the directory, for messages (``--output``).
    known_outputs : iterable of str
        File names the command writes (see :func:`check_run_target`).
    argv : sequence of str, optional
        The command line recorded (default ``sys.argv``).

    Attributes
    ----------
    status : str
        The run's status when the ``with`` block ends normally: ``complete`` (default)
        or ``infeasible``; an exception makes it ``failed`` (bad input, exit 2: nothing is
        written), an interrupt ``interrupted``.
    record : dict
        Fields of ``record.json`` (the command adds its own).
    files : list of str
        Names (relative to the run directory) written so far.
    """

    def __init__(self, target, *, command: str, overwrite: bool = False,
                 option: str = "--output", known_outputs=(), argv=None):
        self.target = Path(target)
        self.command = command
        self.option = option
        self.overwrite = overwrite
        self.replaces = check_run_target(target, overwrite=overwrite, option=option,
                                         known_outputs=known_outputs, command=command)
        prev = read_run_record(self.target) if self.replaces else None
        self._previous_start = None if prev is None else prev.get("started_utc")
        self.status = "complete"
        self.error: str | None = None
        self.files: list[str] = []
        self.record: dict = {
            "kind": f"isodesign {command}",
            "argv": list(sys.argv if argv is None else argv),
            "isodesign_version": __version__,
            "started_utc": None,
        }
        self.path: Path | None = None
        self.final: Path | None = None
        self._pid = os.getpid()
        #: Called with the staging directory when the run is interrupted; each may write a
        #: table of the work finished so far (whole, atomically) and return its file name.
        self.interrupt_hooks: list = []
        #: The tables the hooks wrote, in the set-aside directory (after an interrupt).
        self.partial_tables: list[Path] = []

    # -- lifecycle -----------------------------------------------------------------
    def __enter__(self) -> RunDirectory:
        parent = self.target.absolute().parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
            self.path = Path(tempfile.mkdtemp(prefix=f".{self.target.name}.isodesign-partial-",
                                              dir=parent))
            mask = os.umask(0)
            os.umask(mask)
            os.chmod(self.path, 0o777 & ~mask)  # mkdtemp's 0700 -> a normal directory
        except OSError as exc:
            raise InputError(f"{self.option}: cannot create {self.target} "
                             f"({exc.strerror or exc})") from None
        self.record["started_utc"] = _now()
        self._write_record(RUNNING)
        _ACTIVE.append(self)
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if self.final is not None or self.path is None:
            return False
        if exc_type is None:
            self.finish(self.status)
        elif issubclass(exc_type, KeyboardInterrupt):
            self.interrupt("interrupted (KeyboardInterrupt)")
        elif _refused(exc_type):
            self.discard()  # refused on its input (exit 2): the run writes nothing
        else:
            self.finish("failed", error=f"{exc_type.__name__}: {exc}")
        return False

    # -- writing ------------------------------------------------------------------
    def _staged(self, name: str) -> Path:
        if self.path is None:
            raise RuntimeError("RunDirectory: write inside its 'with' block")
        rel = Path(name)
        if rel.is_absolute() or ".." in rel.parts:
            raise ValueError(f"RunDirectory: {name!r} is not a name inside the run directory")
        p = self.path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        key = rel.as_posix()
        if key != RECORD_NAME and key not in self.files:
            self.files.append(key)
        return p

    def final_path(self, name: str) -> Path:
        """Where ``name`` will be once the run is in place (for messages)."""
        return self.target / name

    @contextlib.contextmanager
    def writing(self, name: str) -> Iterator[Path]:
        """A temporary path to write ``name`` through (whole or not at all)."""
        with atomic_path(self._staged(name), durable=False) as tmp:  # synced by finish
            yield tmp

    def write_text(self, name: str, text: str) -> Path:
        """Write a text file (UTF-8) into the run; return its final path."""
        atomic_write_text(self._staged(name), text, durable=False)  # synced by finish
        return self.final_path(name)

    def write_json(self, name: str, data) -> Path:
        """Write JSON (NumPy values converted, non-finite floats as null)."""
        return self.write_text(name, json.dumps(_jsonable(data), indent=2) + "\n")

    def write_csv(self, name: str, frame) -> Path:
        """Write a pandas DataFrame, or a mapping of columns, as CSV (no index).

        A mapping (column name -> values) is written without pandas, as the same text
        (:func:`isodesign.io.csvtable.columns_csv`).
        """
        if isinstance(frame, Mapping):
            from isodesign.io.csvtable import columns_csv

            return self.write_text(name, columns_csv(frame))
        return self.write_text(name, frame.to_csv(index=False))

    # -- the end of the run -------------------------------------------------------
    def _manifest(self) -> list[dict]:
        out = []
        for name in self.files:
            p = self.path / name
            if p.is_file():
                out.append({"name": name, "bytes": p.stat().st_size, "sha256": _sha256(p)})
        return out

    def _write_record(self, status: str, error: str | None = None) -> None:
        rec = dict(self.record)
        rec["run_status"] = status
        rec["output_directory"] = str(self.target)
        if status != RUNNING:
            rec["finished_utc"] = _now()
            manifest = self._manifest()
            rec["files"] = [m["name"] for m in manifest]
            rec["manifest"] = manifest
        if error:
            rec["error"] = error
        atomic_write_text(self.path / RECORD_NAME, json.dumps(_jsonable(rec), indent=2) + "\n",
                          durable=False)  # synced with the others by finish

    def finish(self, status: str, error: str | None = None) -> Path:
        """Write the record with ``status`` and move the run into place; return the target."""
        if status not in RUN_STATUSES:
            raise ValueError(f"status: {status!r}; valid: {', '.join(RUN_STATUSES)}")
        if status == "interrupted":
            return self.interrupt(error or "interrupted")
        self.status, self.error = status, error
        with _signals_blocked():  # an interrupt waits until the run is in place
            self._claim_target()
            self._write_record(status, error)
            make_durable(self.path)  # every file on disk before the run appears
            self._move_into_place()
            _sync_parent(self.target)
            self._deactivate()
            self.final = self.target
        return self.target

    def interrupt(self, reason: str = "interrupted") -> Path:
        """Mark the run interrupted and set it aside as ``NAME.interrupted``; return that path.

        Safe to call from a signal handler of the process that opened the run.
        """
        if self.final is not None:
            return self.final
        discard_pending_writes()
        self.status, self.error = "interrupted", reason
        written = []
        for hook in list(self.interrupt_hooks):  # the finished work, as a readable table
            with contextlib.suppress(Exception):
                name = hook(self.path)
                if name and (self.path / name).is_file():
                    written.append(name)
                    if name not in self.files:
                        self.files.append(name)
        discard_pending_writes()
        if written:
            self.record["partial_tables"] = written
        with contextlib.suppress(OSError):
            self._write_record("interrupted", reason)
            make_durable(self.path)  # what the run wrote, kept for inspection
        dest = self.target.with_name(self.target.name + ".interrupted")
        k = 2
        while dest.exists():
            dest = self.target.with_name(f"{self.target.name}.interrupted-{k}")
            k += 1
        try:
            os.rename(self.path, dest)
        except OSError:
            dest = self.path
        self._deactivate()
        self.final = dest
        self.partial_tables = [dest / n for n in written if (dest / n).is_file()]
        _PARTIAL_TABLES[str(dest)] = list(self.partial_tables)
        return dest

    def discard(self) -> None:
        """Remove the staging directory: the run leaves nothing (the target as it was)."""
        if self.final is not None:
            return
        if self.path is not None:
            shutil.rmtree(self.path, ignore_errors=True)
        self._deactivate()
        self.final = self.target

    def _deactivate(self) -> None:
        with contextlib.suppress(ValueError):
            _ACTIVE.remove(self)

    def _claim_target(self) -> None:
        """If another run finished into the target while this one ran, go beside it."""
        t = self.target
        prev = read_run_record(t) if t.is_dir() else None
        if prev is None or (self.overwrite and prev.get("started_utc") == self._previous_start):
            return
        k = 2
        dest = t.with_name(f"{t.name}-{k}")
        while dest.exists():
            k += 1
            dest = t.with_name(f"{t.name}-{k}")
        self.target, self.replaces = dest, []
        warnings.warn(f"{self.option}: {t} received another run while this one ran; this "
                      f"run is in {dest}", RuntimeWarning, stacklevel=4)

    def _move_into_place(self) -> None:
        t = self.target
        if not t.exists():
            os.rename(self.path, t)
            return
        entries = os.listdir(t)
        if not entries:
            os.rmdir(t)
            os.rename(self.path, t)
            return
        # an earlier run (overwrite): keep what it did not write, replace the rest
        keep = [e for e in entries if e not in self.replaces]
        moved = []
        try:
            for e in keep:
                dest = self.path / e
                if dest.exists():
                    dest = self.path / f"{e}.kept"
                os.rename(t / e, dest)
                moved.append((t / e, dest))
        except OSError:
            for src, dest in reversed(moved):
                os.rename(dest, src)
            raise
        old = Path(tempfile.mkdtemp(prefix=f".{t.name}.isodesign-old-", dir=t.absolute().parent))
        os.rmdir(old)
        os.rename(t, old)
        try:
            os.rename(self.path, t)
        except OSError:
            os.rename(old, t)
            raise
        shutil.rmtree(old, ignore_errors=True)


def _sync_parent(path: Path) -> None:
    """Make the rename of ``path`` durable (best effort: not every file system can)."""
    with contextlib.suppress(OSError):
        fd = os.open(path.absolute().parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


#: Set-aside directory -> the partial tables its interrupt hooks wrote (this process).
_PARTIAL_TABLES: dict[str, list[Path]] = {}


def partial_tables(path) -> list[Path]:
    """The tables of finished work an interrupted run wrote into ``path`` (existing files).

    Parameters
    ----------
    path : str or Path
        Where :meth:`RunDirectory.interrupt` set the run aside.
    """
    return [p for p in _PARTIAL_TABLES.get(str(path), []) if p.is_file()]


def interrupt_active_runs(reason: str = "interrupted") -> list[Path]:
    """Interrupt every run directory this process has open; return where each was set aside.

    Called by the CLI's SIGINT/SIGTERM handler. Runs opened by another process (a
    parent, before a fork) are left alone.

    Parameters
    ----------
    reason : str
        Recorded as the runs' ``error`` (``interrupted by SIGINT``).
    """
    out = []
    for run in list(_ACTIVE):
        if run._pid == os.getpid():
            out.append(run.interrupt(reason))
    return out
