"""Fixtures shared by the whole suite (tests mirror the package: tests/<discipline>/)."""

from __future__ import annotations

import copy
import importlib.util
import json
from pathlib import Path

import pytest

from isodesign.optimization.study import study_from_dict, table_study
from isodesign.spring.design import SpringDesign

#: Session fixtures of a directory's conftest that take seconds to minutes (a time-domain
#: rig, an optimize or Pareto run): the tests that read one share its xdist group.
SHARED_SESSION_FIXTURES = frozenset({"single_chamber_rig", "dual_chamber_rig", "optimize_run",
                                     "pareto_run", "builtin_table_run"})


def _shared_keys(item) -> list[str]:
    """What ``item`` shares with other tests: its ``xdist_group`` names and the fixtures,
    computed once per test process, that it reads (module- or class-scoped fixtures of the
    suite with their parameter, and :data:`SHARED_SESSION_FIXTURES`)."""
    keys = [f"group:{m.args[0] if m.args else m.kwargs.get('name', 'default')}"
            for m in item.iter_markers("xdist_group")]
    info = getattr(item, "_fixtureinfo", None)
    params = getattr(getattr(item, "callspec", None), "params", {})
    for name in getattr(item, "fixturenames", ()):
        defs = info.name2fixturedefs.get(name) if info is not None else None
        if not defs:
            continue
        d = defs[-1]
        if (d.scope in ("module", "class", "package") and d.baseid.startswith("tests")) or (
                name in SHARED_SESSION_FIXTURES):
            keys.append(f"{d.baseid}::{name}[{params.get(name, '')!r}]")
    return keys


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """One ``xdist_group`` per set of tests that share an expensive fixture.

    Under ``--dist loadgroup`` (``make test``, ``make test-slow``) pytest-xdist runs a group
    on one worker, so that a module-scoped fixture (an optimization, a demo run, a
    simulated grid) is computed once rather than once per worker. Tests that share any key
    of :func:`_shared_keys` (directly or through another test) form one group; the others
    are distributed one by one. Without ``--dist loadgroup`` the groups do nothing.
    """
    parent: dict[str, str] = {}

    def find(k: str) -> str:
        while parent.setdefault(k, k) != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    keys = {}
    for item in items:
        keys[item] = _shared_keys(item)
        for k in keys[item][1:]:
            parent[find(k)] = find(keys[item][0])
    for item, ks in keys.items():
        if not ks:
            continue
        item.own_markers[:] = [m for m in item.own_markers if m.name != "xdist_group"]
        root = find(ks[0])
        name = root.removeprefix("group:").replace("/", ".").replace("::", ".")
        item.add_marker(pytest.mark.xdist_group(name=name))


@pytest.fixture(scope="session")
def ref() -> SpringDesign:
    """The paper's Table 1 spring (SI units), the suite's common starting point."""
    return SpringDesign.reference()


@pytest.fixture(scope="session")
def study_script():
    """``load(name)``: the script ``studies/<name>.py`` imported as a module (the studies are
    scripts, not a package), so that a test runs the very code a study prints."""
    root = Path(__file__).parents[1] / "studies"

    def load(name: str):
        spec = importlib.util.spec_from_file_location(name, root / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod

    return load


@pytest.fixture(scope="session")
def small_table_study():
    """``make(**sections)``: the built-in table study, reduced (one start, one worker, 3 points
    per band, bands 4-20 Hz), with the given top-level sections of the study replaced."""

    def make(**sections):
        raw = copy.deepcopy(table_study().raw)
        raw["solver"].update(starts=1, workers=1)
        raw["models"]["points_per_band"] = 3
        raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
        raw.update(sections)
        return study_from_dict(raw, source="small_table.toml", fill_defaults=False)

    return make


@pytest.fixture(scope="session")
def optimum():
    """``solve(study, analyze=True)``: ``isodesign.optimize(study)`` on one worker process,
    solved once per test process (per pytest-xdist worker) for each question.

    The tests that ask the same question (the built-in table study's optimum, a lever
    freed, ...) share one solve: the key is the study's resolved dictionary (``raw``, its
    name and description included) and ``analyze``, so two studies share a result only
    when they are the same study. Computed lazily, on the first test that asks; results
    are immutable (a test reads one, never changes it). One worker process, as the tests
    call ``optimize_table(study, workers=1)``: ``solver.workers`` changes how a study is
    solved, not its answer.
    """
    import isodesign

    cache: dict = {}

    def solve(study, *, analyze: bool = True):
        key = (json.dumps(study.raw, sort_keys=True, default=repr), study.source, analyze)
        if key not in cache:
            one = study.with_changes(solver={"workers": 1})
            cache[key] = isodesign.optimize(one, analyze=analyze)
        return cache[key]

    return solve


@pytest.fixture(scope="session")
def builtin_table_run(tmp_path_factory):
    """``isodesign optimize --builtin table --starts 1 --workers 1 -o DIR``, run once for the
    tests that read it (an xdist group, tests/conftest.py): (what it printed, DIR)."""
    import contextlib
    import io

    from isodesign.cli import main

    out = tmp_path_factory.mktemp("builtin_table") / "o"
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        status = main(["optimize", "--builtin", "table", "--starts", "1", "--workers", "1",
                       "-o", str(out)])
    assert status == 0, e.getvalue()
    return o.getvalue(), out


class CliProcess:
    """``python -m isodesign ...`` in a process group of its own, interrupted as Ctrl-C in a
    terminal does (SIGINT to the whole group) at an event the test waits for, never after a
    fixed delay: :meth:`start`, :meth:`wait_for`, :meth:`interrupt`."""

    def __init__(self):
        self.procs: list = []

    def start(self, *argv):
        """The command ``isodesign ARGV`` (this checkout first on ``PYTHONPATH``, no
        ``DASK_SCHEDULER_ADDRESS``), stdout and stderr as text pipes."""
        import os
        import subprocess
        import sys

        env = dict(os.environ)
        env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1]) + os.pathsep + \
            env.get("PYTHONPATH", "")
        env.pop("DASK_SCHEDULER_ADDRESS", None)
        proc = subprocess.Popen([sys.executable, "-m", "isodesign", *map(str, argv)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=env, start_new_session=True)
        self.procs.append(proc)
        return proc

    @staticmethod
    def wait_for(proc, cond, what: str, timeout_s: float = 120.0) -> None:
        """Poll ``cond()`` until it holds; fail naming ``what`` (and the process's stderr)
        if the process ends first or ``timeout_s`` passes."""
        import time

        t0 = time.monotonic()
        while not cond():
            if proc.poll() is not None or time.monotonic() - t0 > timeout_s:
                proc.kill()
                _o, err = proc.communicate()
                pytest.fail(f"{what} never happened (status {proc.returncode}): {err}")
            time.sleep(0.005)

    @staticmethod
    def interrupt(proc, timeout_s: float = 60.0) -> tuple[str, str]:
        """SIGINT to the process group, then its ``(stdout, stderr)``; fail if it has not
        ended ``timeout_s`` later."""
        import os
        import signal
        import subprocess

        os.killpg(proc.pid, signal.SIGINT)
        try:
            return proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            pytest.fail(f"the command did not end within {timeout_s:g} s of SIGINT")


@pytest.fixture
def cli_process():
    """A :class:`CliProcess`; a command still running at the test's end is killed."""
    import os
    import signal

    runner = CliProcess()
    yield runner
    for proc in runner.procs:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
