"""A run refused on its input writes nothing (docs/cli.md, "Output directories", item 5).

An input error raised after the run directory was opened (inside the computation: a
table whose damping bound no design variable can meet, found when the optimizer freezes
the modes; or any step of a command's computation) leaves the target as it was: absent, or
the previous run untouched with ``--overwrite``; no staging directory is left beside it.
Every command that opens a run directory: optimize (vertical and table), pareto, modes,
stability, yield. (``response`` writes single files; a ``sweep`` point refused on its
input is one of the sweep's answers, recorded as a failed point: docs/sweep.md.)
"""

from __future__ import annotations

import os
from importlib import resources

import pytest

from isodesign.cli import main
from isodesign.errors import InputError, SolverError
from isodesign.io.rundir import RunDirectory

FAST = """\
name = "fast"

[models]
points_per_band = 4
peak_points = 30

[solver]
starts = 1
workers = 1
"""

SCENARIOS = FAST + """
[scenarios]
payload_mass_kg = {min = 540.0, max = 660.0}
"""


def run(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def snapshot(d) -> dict:
    """Every file under ``d`` (relative name -> bytes)."""
    out = {}
    for root, _, files in os.walk(d):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, d)] = fh.read()
    return out


def previous_run(target, command: str) -> dict:
    """A finished run of ``command`` in ``target`` (a file of its own and a user's file
    beside it); its snapshot."""
    with RunDirectory(target, command=command, argv=["isodesign", command]) as r:
        r.write_text("design.json", '{"previous": true}\n')
    (target / "notes.txt").write_text("the user's own file\n")
    return snapshot(target)


def assert_untouched(target, before: dict | None) -> None:
    if before is None:
        assert not target.exists()
    else:
        assert snapshot(target) == before
    leftovers = [e for e in os.listdir(target.parent) if e.startswith(f".{target.name}.")
                 or e.startswith(f"{target.name}.") or e.startswith(f"{target.name}-")]
    assert leftovers == []


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    from isodesign.io.designfile import design_to_toml
    from isodesign.optimization.study import vertical_study

    d = tmp_path_factory.mktemp("inputs")
    (d / "fast.toml").write_text(FAST)
    (d / "robust.toml").write_text(SCENARIOS)
    (d / "design.toml").write_text(design_to_toml(vertical_study().start_design()))
    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    # a damping bound only the horizontal element could meet on the yaw mode (2.5 Hz): the
    # loader accepts it, the table optimizer finds it when it freezes the start's modes
    damp = src.replace("[solver]\nstarts = 4", "[constraints]\nmin_damping_ratio = 0.2\n\n"
                       "[solver]\nstarts = 1\nworkers = 1") + "\n[models]\npoints_per_band = 4\n"
    (d / "damp.toml").write_text(damp)
    return d


@pytest.fixture
def entered(monkeypatch):
    """The run directories entered during a test (the refusal came after the opening)."""
    seen = []
    real = RunDirectory.__enter__

    def spy(self):
        seen.append(self.target)
        return real(self)

    monkeypatch.setattr(RunDirectory, "__enter__", spy)
    return seen


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_table_refused_inside_the_optimizer_writes_nothing(capsys, inputs, tmp_path,
                                                             entered, overwrite):
    target = tmp_path / "run"
    before = previous_run(target, "optimize") if overwrite else None
    entered.clear()
    status, out, err = run(capsys, "optimize", inputs / "damp.toml", "-o", target, "--quiet",
                           "--no-plots", *(["--overwrite"] if overwrite else []))
    assert status == 2, err
    assert "constraints.min_damping_ratio" in err and len(err.strip().splitlines()) == 1
    assert entered == [target]  # opened, then refused
    assert "wrote" not in out + err
    assert_untouched(target, before)


def _boom(exc):
    def f(*a, **k):
        raise exc("table.leveling_groups: refused inside the computation")
    return f


# command line, the step that raises (after the run directory is opened), the run's kind
CASES = {
    "optimize": (["optimize", "{fast}", "--quiet", "--no-plots"],
                 "isodesign.commands.optimize.optimize", "optimize"),
    "optimize-table": (["optimize", "--builtin", "table", "--quiet", "--no-plots"],
                       "isodesign.optimization.dispatch.optimize", "optimize"),
    "pareto": (["pareto", "{fast}", "--points", "3", "--quiet", "--no-plots"],
               "isodesign.commands.pareto.pareto_front", "pareto"),
    "pareto-table": (["pareto", "--builtin", "table", "--points", "3", "--quiet",
                      "--no-plots"], "isodesign.commands.pareto.pareto_front", "pareto"),
    "modes": (["modes", "--builtin", "table"], "isodesign.plotting.style.save_figure",
              "modes"),
    "stability": (["stability", "--builtin", "table", "--plot"],
                  "isodesign.plotting.style.save_figure", "stability"),
    "yield": (["yield", "{design}", "--study", "{robust}", "--samples", "5", "--no-plots"],
              "isodesign.optimization.yields.estimate_yield", "yield"),
}


@pytest.mark.parametrize("overwrite", [False, True])
@pytest.mark.parametrize("case", sorted(CASES))
def test_every_command_refused_after_opening_its_run_writes_nothing(
        capsys, inputs, tmp_path, monkeypatch, entered, case, overwrite):
    argv, step, kind = CASES[case]
    argv = [a.format(fast=inputs / "fast.toml", robust=inputs / "robust.toml",
                     design=inputs / "design.toml") for a in argv]
    target = tmp_path / "run"
    before = previous_run(target, kind) if overwrite else None
    entered.clear()
    monkeypatch.setattr(step, _boom(InputError))
    status, _, err = run(capsys, *argv, "-o", target, *(["--overwrite"] if overwrite else []))
    assert status == 2, err
    assert err.strip() == ("isodesign: error: table.leveling_groups: refused inside the "
                           "computation")
    assert entered == [target]
    assert_untouched(target, before)


@pytest.mark.parametrize("exc", [ValueError, FileNotFoundError])
def test_any_exit_2_error_inside_the_run_writes_nothing(capsys, inputs, tmp_path,
                                                        monkeypatch, entered, exc):
    """Not only InputError: whatever the command line reports as bad input (exit 2)."""
    target = tmp_path / "run"
    before = previous_run(target, "optimize")
    entered.clear()
    monkeypatch.setattr("isodesign.commands.optimize.optimize", _boom(exc))
    status, _, err = run(capsys, "optimize", inputs / "fast.toml", "-o", target, "--overwrite",
                         "--quiet", "--no-plots")
    assert status == 2 and "refused inside the computation" in err
    assert entered == [target]
    assert_untouched(target, before)


def test_a_solver_failure_still_records_a_failed_run(capsys, inputs, tmp_path, monkeypatch):
    """The other side of the rule: exit 1 keeps its record (what failed, with the study)."""
    import json

    target = tmp_path / "run"
    monkeypatch.setattr("isodesign.commands.optimize.optimize", _boom(SolverError))
    status, _, err = run(capsys, "optimize", inputs / "fast.toml", "-o", target, "--quiet",
                         "--no-plots")
    assert status == 1 and "refused inside" in err
    rec = json.loads((target / "record.json").read_text())
    assert rec["run_status"] == "failed" and "refused inside" in rec["error"]


def test_the_run_directory_discards_on_bad_input_only(tmp_path):
    for exc, left in ((InputError, False), (ValueError, False), (PermissionError, False),
                      (SolverError, True), (RuntimeError, True), (BrokenPipeError, True)):
        target = tmp_path / exc.__name__
        with pytest.raises(exc), RunDirectory(target, command="t") as r:
            r.write_text("partial.csv", "a\n")
            raise exc("x")
        assert target.exists() is left, exc
        assert [e for e in os.listdir(tmp_path) if e.startswith(".")] == []
