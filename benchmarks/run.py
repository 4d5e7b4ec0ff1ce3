"""Run every ``benchmarks/bench_*.py`` and write ``docs/benchmarks.md``.

Usage (from the repository root)::

    python benchmarks/run.py                 # all benchmark files
    python benchmarks/run.py spring          # only bench_spring.py
    python benchmarks/run.py -o /tmp/b.md    # write elsewhere
    python benchmarks/run.py --strict        # exit 1 when a target is missed
    python benchmarks/run.py table --update  # rerun bench_table.py, keep the other sections
    python benchmarks/run.py --update --merge /tmp/a.md  # take a.md's sections (another run)

Each ``bench_<name>.py`` module exposes ``run() -> list[dict]``, one dict per
measured row (see ``benchmarks/README.md`` for the keys). Timings use
:func:`median_time`: one warm-up call, then the median of at least 7 repeats
(``ISODESIGN_BENCH_REPEATS`` raises the count). Every number in the generated
file comes from the same run; with ``--update`` the named sections are rerun and the others kept,
and every section states the run (date, commit, load) it comes from.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import importlib.util
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DEFAULT_OUTPUT = ROOT / "docs" / "benchmarks.md"
#: Minimum number of timed repeats (after the warm-up).
MIN_REPEATS = 7


def repeats() -> int:
    """Number of timed repeats: ``ISODESIGN_BENCH_REPEATS`` or 7, never fewer than 7.

    Returns
    -------
    int
        The repeat count.
    """
    try:
        n = int(os.environ.get("ISODESIGN_BENCH_REPEATS", MIN_REPEATS))
    except ValueError:
        n = MIN_REPEATS
    return max(n, MIN_REPEATS)


def median_time(
    fn: Callable[[], object], *, n_repeats: int | None = None, warmup: int = 1
) -> dict[str, float]:
    """Wall time of ``fn()``: warm-up calls, then the median of the repeats.

    Parameters
    ----------
    fn : callable
        Called without arguments.
    n_repeats : int, optional
        Timed repeats (default :func:`repeats`; at least 7).
    warmup : int
        Untimed calls before timing (imports, caches, first-touch page faults).

    Returns
    -------
    dict
        ``median``, ``min``, ``max`` (seconds) and ``repeats``.
    """
    n = max(n_repeats or repeats(), MIN_REPEATS)
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return {
        "median": statistics.median(times),
        "min": min(times),
        "max": max(times),
        "repeats": n,
    }


# ---------------------------------------------------------------------------
# machine information
# ---------------------------------------------------------------------------
def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _version(mod: str) -> str:
    try:
        return __import__(mod).__version__
    except Exception:  # report, never fail on a missing package
        return "not installed"


def _git(*args: str) -> str:
    try:
        out = subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10, check=True
        )
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def machine_info() -> dict[str, str]:
    """Where and when the benchmarks ran.

    Returns
    -------
    dict of str to str
        nproc, CPU model, load average, Python / NumPy / SciPy / CasADi versions,
        platform, date (UTC) and git commit.
    """
    try:
        nproc = len(os.sched_getaffinity(0))
    except AttributeError:
        nproc = os.cpu_count() or 0
    try:
        load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        load = "unknown"
    dirty = _git("status", "--porcelain")
    commit = _git("rev-parse", "--short", "HEAD")
    if dirty and dirty != "unknown":
        commit += " (with uncommitted changes)"
    return {
        "date (UTC)": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S"),
        "nproc": str(nproc),
        "CPU": _cpu_model(),
        "load average (1, 5, 15 min) at start": load,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": _version("numpy"),
        "scipy": _version("scipy"),
        "casadi": _version("casadi"),
        "git commit": commit,
    }


# ---------------------------------------------------------------------------
# discovery, rendering
# ---------------------------------------------------------------------------
def discover(names: list[str] | None = None) -> list[Path]:
    """The benchmark files, ``benchmarks/bench_*.py``, sorted.

    Parameters
    ----------
    names : list of str, optional
        Keep only ``bench_<name>.py`` for these names (``spring`` or
        ``bench_spring``).

    Returns
    -------
    list of Path
    """
    files = sorted(HERE.glob("bench_*.py"))
    if names:
        wanted = {n.removeprefix("bench_").removesuffix(".py") for n in names}
        files = [f for f in files if f.stem.removeprefix("bench_") in wanted]
        missing = wanted - {f.stem.removeprefix("bench_") for f in files}
        if missing:
            raise SystemExit(f"no benchmark file for: {', '.join(sorted(missing))}")
    return files


def load(path: Path):
    """Import a benchmark file as a module (``benchmarks/`` on ``sys.path``)."""
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        if v == 0:
            return "0"
        if abs(v) >= 1e5 or abs(v) < 1e-3:
            return f"{v:.3g}"
        return f"{v:.4g}"
    return str(v)


def render_section(path: Path, desc: str, rows: list[dict], info: dict[str, str],
                   command: str) -> list[str]:
    """The Markdown lines of one benchmark file's section, with the run it comes from.

    Parameters
    ----------
    path : Path
        The benchmark file.
    desc : str
        Its description (the module docstring's first paragraph).
    rows : list of dict
        Its measured rows.
    info : dict
        Output of :func:`machine_info` for the run that measured the rows.
    command : str
        The command of that run.

    Returns
    -------
    list of str
    """
    out = ["", f"## {path.name}", ""]
    if desc:
        out += [desc, ""]
    out += [
        f"Run: {info['date (UTC)']} UTC, commit {info['git commit']}, "
        f"{info.get('nproc', '?')} x {info.get('CPU', 'unknown CPU')}, load average "
        f"{info['load average (1, 5, 15 min) at start']} at start, by `{command}`.",
        "",
        "| benchmark | target | median | unit | spread (min - max) | ratio | pass | notes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        spread = ""
        if "min" in r and "max" in r:
            spread = f"{_fmt(r['min'])} - {_fmt(r['max'])}"
        passed = r.get("passed")
        out.append(
            "| "
            + " | ".join(
                [
                    str(r.get("name", "")),
                    str(r.get("target", "")),
                    _fmt(r.get("median", "")),
                    str(r.get("unit", "")),
                    spread,
                    _fmt(r.get("ratio", "")),
                    "" if passed is None else ("pass" if passed else "**FAIL**"),
                    str(r.get("notes", "")).replace("|", "\\|").replace("\n", " "),
                ]
            )
            + " |"
        )
    return out


def split_sections(text: str) -> dict[str, str]:
    """The per-file sections of an existing report, by file name (``bench_table.py``).

    Parameters
    ----------
    text : str
        A report written by :func:`render`.

    Returns
    -------
    dict of str to str
        Each section's Markdown, from its ``## bench_...`` heading to the next heading.

    Raises
    ------
    ValueError
        A ``## bench_...`` section without its table (not a report of :func:`render`).
    """
    def cell(item: str) -> str:
        for line in text.split("\n"):
            if line.startswith(f"| {item} |"):
                return line.split("|")[2].strip()
        return "unknown"

    gen = text.split("Generated by `", 1)
    by = f", by `{gen[1].split('`', 1)[0]}`" if len(gen) == 2 else ""
    run = (f"Run: {cell('date (UTC)')} UTC, commit {cell('git commit')}, {cell('nproc')} x "
           f"{cell('CPU')}, load average {cell('load average (1, 5, 15 min) at start')} at "
           f"start{by}.")
    sections: dict[str, str] = {}
    parts = text.split("\n## ")
    for part in parts[1:]:
        name = part.split("\n", 1)[0].strip()
        if not name.startswith("bench_"):
            continue
        body = part.split("\n# ", 1)[0].rstrip("\n")
        if "\n| benchmark |" not in body:
            raise ValueError(f"its section {name} has no table of benchmarks")
        if "\nRun: " not in body:  # a report of one run: its sections state the header's run
            head, table = body.split("\n| benchmark |", 1)
            body = head.rstrip("\n") + "\n\n" + run + "\n\n| benchmark |" + table
        sections[name] = "\n## " + body
    return sections


def render(info: dict[str, str], results: list[tuple[Path, str, list[dict]]], command: str,
           kept: dict[str, str] | None = None) -> str:
    """The Markdown report.

    Parameters
    ----------
    info : dict
        Output of :func:`machine_info`.
    results : list of (path, description, rows)
        One entry per benchmark file.
    command : str
        The command that produced the report.
    kept : dict of str to str, optional
        Sections of an earlier report to keep (``--update``), by file name.

    Returns
    -------
    str
    """
    out = [
        "# Benchmarks",
        "",
        f"Generated by `{command}` (do not edit by hand; rerun the command). Every number below "
        "comes from the run its section names (one run for every row of a section; ratios are "
        "measured within one run). Fast benchmarks are medians of at least "
        f"{MIN_REPEATS} timed repeats after a warm-up call; the long ones (optimization, Pareto, "
        "NSGA-II) state their repeat count in their notes. `spread` is the fastest and slowest "
        "repeat. `ratio` is measured/target: below 1 passes for a `<` target, above 1 for a `>` "
        "target.",
        "",
        "## Machine (that wrote this file; each section names the run it comes from)",
        "",
        "| item | value |",
        "|---|---|",
    ]
    out += [f"| {k} | {v} |" for k, v in info.items()]
    fresh = {path.name: render_section(path, desc, rows, info, command)
             for path, desc, rows in results}
    kept = kept or {}
    for name in sorted(set(fresh) | set(kept)):
        if name in fresh:
            out += fresh[name]
        else:
            out += kept[name].split("\n")
    out += [
        "",
        "## Reproduce",
        "",
        "```sh",
        command,
        "```",
        "",
        "Add a benchmark: see `benchmarks/README.md`.",
        "",
    ]
    return "\n".join(out)


def _unwritable(out: Path) -> str | None:
    """Why the report ``out`` cannot be written (None: it can): a parent that is a file, a
    directory without write permission."""
    anc = out.absolute().parent
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        return f"{anc} is a file"
    if out.exists() and not os.access(out, os.W_OK):
        return "permission denied"
    if not os.access(anc, os.W_OK | os.X_OK):
        return f"cannot write in {anc} (permission denied)"
    return None


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks and write the report.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0; with ``--strict``, 1 when some row missed its target.
    """
    ap = argparse.ArgumentParser(description="Run benchmarks/bench_*.py; write the report.")
    ap.add_argument("names", nargs="*", help="only these benchmark files (e.g. spring)")
    ap.add_argument("-o", "--output", default=str(DEFAULT_OUTPUT), help="Markdown file to write")
    ap.add_argument(
        "--strict", action="store_true", help="exit with status 1 when a target is missed"
    )
    ap.add_argument(
        "--update", action="store_true",
        help="rerun only the named files and keep the other sections of the output file",
    )
    ap.add_argument(
        "--merge", nargs="+", metavar="REPORT", default=[],
        help="with --update: take the sections of these reports (runs made elsewhere, each "
             "section keeping its run line) instead of the output file's; runs nothing "
             "unless files are named",
    )
    args = ap.parse_args(argv)
    if args.merge and not args.update:
        ap.error("--merge: only with --update")
    if args.update and not args.names and not args.merge:
        ap.error("--update: name the benchmark files to rerun (e.g. table) or the reports to "
                 "--merge; without names every file reruns and no section is kept")
    try:
        paths = [] if args.merge and not args.names else discover(args.names)
    except SystemExit as exc:
        ap.error(str(exc))
    if Path(args.output).is_dir():
        ap.error(f"-o: {args.output} is a directory; give the Markdown file to write")
    why = _unwritable(Path(args.output))
    if why:  # checked before minutes of benchmarks, not when the report is written
        ap.error(f"-o: cannot write {args.output}: {why}")
    kept = None
    reports = ([args.output] if args.update and Path(args.output).exists() else []) + args.merge
    for report in reports:  # checked before minutes of benchmarks; later reports win
        try:
            text = Path(report).read_text()
            if not text.startswith("# Benchmarks\n"):
                raise ValueError("it does not start with its '# Benchmarks' title")
            kept = {**(kept or {}), **split_sections(text)}
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            ap.error(f"--update: cannot keep the sections of {report}: it is not a report "
                     f"of benchmarks/run.py ({exc})")
    info = machine_info()
    results = []
    failed = False
    for path in paths:
        print(f"running {path.name} ...", flush=True)
        mod = load(path)
        rows = mod.run()
        desc = " ".join((mod.__doc__ or "").strip().split("\n\n")[0].split())
        results.append((path, desc, rows))
        for r in rows:
            flag = {True: "pass", False: "FAIL", None: ""}[r.get("passed")]
            print(
                f"  {r.get('name')}: {_fmt(r.get('median'))} {r.get('unit', '')} "
                f"(target {r.get('target', '-')}) {flag}"
            )
            failed |= r.get("passed") is False
    rel = Path(__file__).resolve().relative_to(ROOT)
    command = " ".join(["python", str(rel), *(argv if argv is not None else sys.argv[1:])])
    report = render(info, results, command, kept)
    out = Path(args.output)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(report)
    except OSError as exc:  # what the check before the runs could not foresee (/proc)
        ap.exit(2, f"{ap.prog}: error: -o: cannot write {out} ({exc.strerror or exc})\n")
    print(f"wrote {out}")
    if failed:
        print("some targets were missed (see the pass column)")
    return 1 if (failed and args.strict) else 0


if __name__ == "__main__":
    sys.exit(main())
