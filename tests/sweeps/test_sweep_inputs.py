"""Sweep inputs: --vary parsing, combinations, points files, the task registry, bad input."""

from __future__ import annotations

import contextlib
import io
import json
import socket
import time

import pytest

import isodesign
import isodesign.sweeps
from isodesign.cli import main
from isodesign.errors import InputError
from isodesign.optimization.study import vertical_study
from isodesign.sweeps.spec import build_points, combine, parse_vary, read_points, study_hash
from isodesign.sweeps.tasks import SweepTask, get_task, register_task


def run_cli(*argv) -> tuple[int, str, str]:
    o, e = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
        status = main([str(a) for a in argv])
    return status, o.getvalue(), e.getvalue()


def test_vary_takes_a_tables_levers_as_optimize_does():
    """The layout and per-group levers are study keys a sweep varies; a group number out
    of 1..3 gets the study's own message (the groups numbered from 1)."""
    from isodesign.optimization.study import table_study

    st = table_study()
    pts, _ = build_points(st, combine([parse_vary("variables.layout_length_m.fixed=false"),
                                       parse_vary("variables.volume_ratio_group2.fixed=false")],
                                      "product"))
    free = [v.name for v in pts[0].study.levers if v.free]
    assert free == ["layout_length_m", "volume_ratio_group2"]
    with pytest.raises(InputError, match=r"volume_ratio_group4: group '4' .* 1, 2 or 3"):
        build_points(st, combine([parse_vary("variables.volume_ratio_group4.fixed=false")],
                                 "product"))


@pytest.mark.parametrize("builtin, vary, objectives, words", [
    ("table", "payload.mass_kg=500,600", "worst_band_margin,footprint_area",
     "footprint_area needs a free layout"),
    ("table", "variables.layout_length_m.fixed=false,true", "worst_band_margin,footprint_area",
     "point variables.layout_length_m.fixed=True: objectives: footprint_area needs a free"),
    ("table", "payload.mass_kg=500,600", "footprint_area,worst_band_margin",
     "a study with a [table] has the fronts"),
    ("vertical", "payload.mass_kg=500,600", "worst_band_margin,footprint_area",
     "this study has no [table]"),
])
def test_a_pareto_sweep_checks_every_points_front_before_running(tmp_path, builtin, vary,
                                                                 objectives, words):
    """A front no point (or some point) can have: one line, exit 2, nothing run (each
    point failed on the cluster before, exit 1)."""
    status, _, err = run_cli("sweep", "--builtin", builtin, "--vary", vary, "--task", "pareto",
                             "--objectives", objectives, "-o", tmp_path / "out")
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and words in lines[0], err
    assert not (tmp_path / "out").exists()


# -- values and combinations ---------------------------------------------------------------
def test_a_linear_range_includes_both_ends_and_an_extension_meets_the_same_values():
    assert parse_vary("payload.mass_kg=300:1500:13") == (
        "payload.mass_kg", [300, 400, 500, 600, 700, 800, 900, 1000, 1100, 1200, 1300, 1400,
                            1500])
    _, a = parse_vary("payload.mass_kg=0.1:0.7:7")
    _, b = parse_vary("payload.mass_kg=0.1:0.9:9")
    assert a == b[:7]  # rounded to 12 digits: 0.30000000000000004 is 0.3 in both
    assert parse_vary("floor.criterion=VC-A, VC-B") == ("floor.criterion", ["VC-A", "VC-B"])
    assert parse_vary("constraints.max_mach=false,0.3")[1] == [False, 0.3]
    assert parse_vary("payload.mass_kg=600:600:1")[1] == [600.0]


@pytest.mark.parametrize("text, words", [
    ("payload.mas_kg=1,2", ["unknown key 'payload.mas_kg'", "mass_kg"]),
    ("paylod.mass_kg=1,2", ["unknown key 'paylod.mass_kg'", "payload.KEY"]),
    ("variables.N.start=1", ["unknown key", "variables.volume_ratio"]),
    ("payload.mass_kg=", ["no values"]),
    ("payload.mass_kg=300:1500:0", ["empty range", "count 0"]),
    ("payload.mass_kg=300:300:5", ["empty range", "start equals stop"]),
    ("payload.mass_kg=a:b:3", ["needs numbers"]),
    ("payload.mass_kg=1,,2", ["empty item"]),
    ("payload.mass_kg", ["KEY=VALUES"]),
])
def test_bad_vary_names_the_key(text, words):
    with pytest.raises(InputError) as e:
        parse_vary(text)
    for w in words:
        assert w in str(e.value)


def test_product_zip_and_the_point_studies():
    a, b = parse_vary("payload.mass_kg=300,600"), parse_vary("floor.criterion=VC-A,VC-B")
    prod = combine([a, b])
    assert prod[1] == {"payload.mass_kg": 300, "floor.criterion": "VC-B"} and len(prod) == 4
    assert combine([a, b], "zip") == [{"payload.mass_kg": 300, "floor.criterion": "VC-A"},
                                      {"payload.mass_kg": 600, "floor.criterion": "VC-B"}]
    with pytest.raises(InputError, match="same number of values"):
        combine([a, parse_vary("floor.criterion=VC-A")], "zip")
    pts, dropped = build_points(vertical_study(), prod + prod[:1])
    assert dropped == 1 and len(pts) == 4
    assert pts[1].study.payload.mass_kg == 300 and pts[1].study.raw["floor"]["criterion"] == "VC-B"
    assert all(p.study.solver["workers"] == 1 for p in pts)  # starts run serially in a task
    # an invalid point names its changes and the key
    with pytest.raises(InputError, match=r"--vary payload.mass_kg=-1: payload.mass_kg"):
        build_points(vertical_study(), [{"payload.mass_kg": -1}])
    # a sub-table's keys ([floor.x]) and a table with its own schema are the study's to check
    assert parse_vary("floor.x.criterion=VC-A")[0] == "floor.x.criterion"
    with pytest.raises(InputError, match=r"--vary floor.x.criterion=VC-A: floor.x applies only"):
        build_points(vertical_study(), [{"floor.x.criterion": "VC-A"}])


def test_the_study_hash_is_the_resolved_study():
    st = vertical_study()
    assert study_hash(st.with_changes(payload={"mass_kg": 600})) == study_hash(st)
    assert study_hash(st.with_changes(payload={"mass_kg": 600.0})) == study_hash(st)
    assert study_hash(st.with_changes(payload={"mass_kg": 601})) != study_hash(st)


def test_points_files_toml_and_csv(tmp_path):
    t = tmp_path / "pts.toml"
    t.write_text('[[point]]\npayload.mass_kg = 300\nfloor.criterion = "VC-B"\n\n'
                 '[[point]]\n[point.payload]\nmass_kg = 900\n', encoding="utf-8")
    assert read_points(t) == [{"payload.mass_kg": 300, "floor.criterion": "VC-B"},
                              {"payload.mass_kg": 900}]
    c = tmp_path / "pts.csv"
    c.write_text("# masses\npayload.mass_kg,target.criterion\n300,VC-C\n1200,VC-D\n",
                 encoding="utf-8")
    assert read_points(c) == [{"payload.mass_kg": 300, "target.criterion": "VC-C"},
                              {"payload.mass_kg": 1200, "target.criterion": "VC-D"}]
    bad = tmp_path / "bad.csv"
    bad.write_text("payload.mass_g\n3\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"--points-file .*bad.csv: unknown key"):
        read_points(bad)


# -- tasks ------------------------------------------------------------------------------------
def test_the_task_registry_is_extensible_and_says_what_is_missing():
    assert {"optimize", "response", "pareto"} <= set(isodesign.sweeps.TASKS)
    import importlib.util

    if importlib.util.find_spec("isodesign.optimization.yields") is None:  # not here yet
        with pytest.raises(InputError, match=r"--task: 'yield' is not available.*robust"):
            get_task("yield")
    with pytest.raises(InputError, match=r"unknown task 'optimise'; available: .*optimize"):
        get_task("optimise")

    def volume(study, run, options):
        v = study.start_design()
        run.write_json("volume.json", {"v": v.top_volume_m3})
        return {"feasible": True, "objective": "total_volume",
                "objective_value": v.top_volume_m3 * (1 + v.volume_ratio)}

    register_task(SweepTask("volume_only", "volume", volume, (), "test task"))
    try:
        assert get_task("volume_only").command == "volume"
    finally:
        isodesign.sweeps.TASKS.pop("volume_only")


def test_a_custom_task_runs_serially_and_writes_its_run_directories(tmp_path):
    def volume(study, run, options):
        v = study.start_design()
        run.write_json("volume.json", {"v": v.top_volume_m3})
        return {"feasible": True, "objective": "total_volume",
                "objective_value": v.top_volume_m3 * (1 + v.volume_ratio)}

    register_task(SweepTask("volume_only", "volume", volume))
    try:
        res = isodesign.sweep(vary={"variables.top_volume_m3.start": [5e-4, 1e-3]},
                              task="volume_only", output=tmp_path / "s", scheduler="serial",
                              charts=False)
    finally:
        isodesign.sweeps.TASKS.pop("volume_only")
    assert list(res.table["objective_value"].round(9)) == [round(5e-4 * (1 + 1.5e-3 / 8.1e-4), 9),
                                                           round(1e-3 * (1 + 1.5e-3 / 8.1e-4),
                                                                 9)]
    for p in res.table["point"]:
        rec = json.loads((tmp_path / "s" / "points" / p / "record.json").read_text())
        assert rec["kind"] == "isodesign volume" and rec["run_status"] == "complete"
        assert "volume.json" in rec["files"] and "sweep_point.json" in rec["files"]


def test_a_failing_point_is_recorded_failed_with_its_error_and_retried_on_rerun(tmp_path):
    def flaky(study, run, options):
        if study.payload.mass_kg > 700:
            raise isodesign.SolverError("IPOPT: Restoration_Failed (test)")
        return {"feasible": True, "objective": "worst_band_margin", "objective_value": 1.0}

    register_task(SweepTask("flaky", "flaky", flaky))
    try:
        res = isodesign.sweep(vary=["payload.mass_kg=600,800"], task="flaky",
                              output=tmp_path / "s", scheduler="serial", charts=False)
        assert res.status == "failed" and res.failed == 1
        row = res.table[res.table["payload.mass_kg"] == 800].iloc[0]
        assert row["status"] == "failed" and "Restoration_Failed" in row["error"]
        rec = json.loads((tmp_path / "s" / row["run_dir"] / "record.json").read_text())
        assert rec["run_status"] == "failed" and "Restoration_Failed" in rec["error"]
        again = isodesign.sweep(vary=["payload.mass_kg=600,800"], task="flaky",
                                output=tmp_path / "s", scheduler="serial", charts=False)
        assert (again.ran, again.reused) == (1, 1)  # the failed point is retried
    finally:
        isodesign.sweeps.TASKS.pop("flaky")


# -- bad input at the command line: one line, exit 2, nothing written --------------------------
@pytest.mark.parametrize("args, words", [
    (["--vary", "payload.mas_kg=300,600"], ["--vary: unknown key 'payload.mas_kg'"]),
    (["--vary", "payload.mass_kg=300:1500:0"], ["--vary payload.mass_kg", "empty range"]),
    (["--vary", "payload.mass_kg=300,600", "--task", "yield"], ["--task", "yield"]),
    (["--vary", "payload.mass_kg=300,600", "--vary", "floor.criterion=VC-A", "--combine",
      "zip"], ["--combine zip", "same number"]),
    (["--vary", "payload.mass_kg=0,600"], ["payload.mass_kg=0", "payload.mass_kg"]),
    ([], ["--vary: give at least one"]),
    (["--vary", "payload.mass_kg=300", "--workers", "0"], ["--workers", "[1, 64]"]),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, args, words):
    out = tmp_path / "s"
    status, _stdout, stderr = run_cli("sweep", *args, "-o", out)
    assert status == 2, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isodesign: error: "), stderr
    for w in words:
        assert w in lines[0]
    assert not out.exists()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_scheduler_is_a_clear_error_within_10_s(tmp_path):
    address = f"tcp://127.0.0.1:{_free_port()}"
    out = tmp_path / "s"
    t0 = time.monotonic()
    status, _, stderr = run_cli("sweep", "--vary", "payload.mass_kg=300,600", "--task",
                                "response", "--scheduler", address, "-o", out)
    assert time.monotonic() - t0 < 10.0
    assert status == 2
    line = stderr.strip()
    assert "\n" not in line and f"cannot reach the Dask scheduler at {address}" in line
    assert not out.exists()


def test_an_output_directory_holding_another_sweep_is_refused(tmp_path):
    from isodesign.io.record import dumps_toml

    vertical = tmp_path / "vertical.toml"  # the vertical study, named
    vertical.write_text(dumps_toml(vertical_study().raw), encoding="utf-8")
    vertical = str(vertical)
    out = tmp_path / "s"
    status, _, err = run_cli("sweep", vertical, "--vary", "payload.mass_kg=300,600", "--task",
                             "response", "--scheduler", "serial", "-o", out, "--quiet",
                             "--no-plots")
    assert status == 0, err
    before = sorted(p.name for p in (out / "points").iterdir())
    for args in (["--vary", "floor.criterion=VC-A,VC-B", "--task", "response"],
                 ["--vary", "payload.mass_kg=300,600", "--task", "optimize"]):
        status, _, err = run_cli("sweep", vertical, *args, "--scheduler", "serial", "-o", out)
        assert status == 2 and "holds another sweep" in err and "--overwrite" in err, err
    assert sorted(p.name for p in (out / "points").iterdir()) == before
    # a directory with other files, or another kind of run, is no sweep
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    status, _, err = run_cli("sweep", vertical, "--vary", "payload.mass_kg=300", "--task",
                             "response", "--scheduler", "serial", "-o", other)
    assert status == 2 and "holds no isodesign sweep" in err
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]
    # --overwrite replaces the other sweep
    status, _, err = run_cli("sweep", vertical, "--vary", "floor.criterion=VC-A,VC-B", "--task",
                             "response", "--scheduler", "serial", "-o", out, "--overwrite",
                             "--quiet", "--no-plots")
    assert status == 0, err
    assert len(list((out / "points").iterdir())) == 2


def test_the_local_cluster_runs_on_loopback_without_a_dashboard(tmp_path, monkeypatch):
    from isodesign.sweeps.cluster import connect

    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)
    with connect(workers=2) as conn:
        assert conn.cluster is not None and conn.workers == 2
        info = conn.client.scheduler_info(n_workers=-1)
        assert info["address"].startswith("tcp://127.0.0.1:")
        assert all(a.startswith("tcp://127.0.0.1:") for a in info["workers"])
        # every port the cluster listens on (scheduler here, workers in child processes)
        import psutil

        me = psutil.Process()
        listening = [c.laddr for p in (me, *me.children(recursive=True))
                     for c in p.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
        assert listening and all(a.ip == "127.0.0.1" for a in listening), listening
        assert 8787 not in {a.port for a in listening}  # no dashboard on its usual port
        res = isodesign.sweep(vary={"payload.mass_kg": [400, 800, 1200]}, task="response",
                              output=tmp_path / "s", scheduler=info["address"], charts=False)
    assert res.status == "complete" and len(res.table) == 3
    assert all(w.startswith("tcp://127.0.0.1:") for w in res.table["worker"])


def test_the_yield_task_when_robust_design_is_installed(tmp_path):
    import importlib.util

    if importlib.util.find_spec("isodesign.optimization.yields") is None:
        pytest.skip("robust design (isodesign.optimization.yields) is not in this isodesign")
    study = tmp_path / "robust.toml"
    study.write_text("[scenarios]\npayload_mass_kg = {relative = 0.05}\n"
                     "capillary_diameter_m = {relative = 0.05}\n", encoding="utf-8")
    res = isodesign.sweep(study, ["scenarios.capillary_diameter_m.relative=0.01,0.2"],
                          task="yield",
                          options={"samples": 20, "seed": 1}, output=tmp_path / "y",
                          scheduler="serial", charts=False)
    assert res.status == "complete" and list(res.table["objective"]) == ["yield", "yield"]
    assert all(0 <= v <= 1 for v in res.table["objective_value"])
    assert (res.table["yield_low"] <= res.table["objective_value"]).all()
    assert sorted(res.table["scenarios.capillary_diameter_m.relative"]) == [0.01, 0.2]
    for _, r in res.table.iterrows():
        y = json.loads((tmp_path / "y" / r["run_dir"] / "yield.json").read_text())
        assert y["samples"] == r["samples"] == 20 and y["fraction"] == r["objective_value"]
    with pytest.raises(InputError, match=r"--task yield: the study has no \[scenarios\]"):
        isodesign.sweep(None, ["payload.mass_kg=400"], task="yield", output=tmp_path / "z",
                        scheduler="serial")


def test_dask_scheduler_address_from_the_environment(tmp_path, monkeypatch):
    address = f"tcp://127.0.0.1:{_free_port()}"
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", address)
    t0 = time.monotonic()
    status, _, stderr = run_cli("sweep", "--vary", "payload.mass_kg=300,600", "--task",
                                "response", "-o", tmp_path / "s")
    assert status == 2 and time.monotonic() - t0 < 10.0
    assert f"DASK_SCHEDULER_ADDRESS: cannot reach the Dask scheduler at {address}" in stderr


# -- issue 23: a scheduler that answers but is not Dask, Python arguments, run kinds ---------
class _FakeServer:
    """A TCP server on 127.0.0.1 that accepts and either sends ``reply`` (then keeps the
    connection open) or, with ``reply=None``, waits for a request it never answers (an
    HTTP server's behaviour towards a client that speaks first... never)."""

    def __init__(self, reply: bytes | None):
        import threading

        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.reply, self.conns, self.stop = reply, [], threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        self.sock.settimeout(0.2)
        while not self.stop.is_set():
            try:
                c, _ = self.sock.accept()
            except OSError:
                continue
            self.conns.append(c)
            if self.reply is not None:
                with contextlib.suppress(OSError):
                    c.sendall(self.reply)

    def close(self):
        self.stop.set()
        self.thread.join(timeout=5)
        for c in [*self.conns, self.sock]:
            c.close()


@pytest.mark.parametrize("reply, words", [
    (None, ["answers but is not a Dask scheduler", "no Dask handshake"]),
    (b"\xff" * 64, ["answers but is not a Dask scheduler", "first bytes"]),
    (b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n", ["not a Dask scheduler"]),
    ((8).to_bytes(8, "little") + b"garbage!", ["not a Dask scheduler", "handshake"]),
])
def test_a_scheduler_address_that_is_not_dask_is_one_line(tmp_path, reply, words):
    srv = _FakeServer(reply)
    try:
        out = tmp_path / "s"
        t0 = time.monotonic()
        status, _, stderr = run_cli("sweep", "--vary", "payload.mass_kg=300,600", "--task",
                                    "response", "--scheduler", srv.address, "-o", out)
        assert time.monotonic() - t0 < 10.0  # the probe's 3 s, not Dask's hang
    finally:
        srv.close()
    assert status == 2
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("isodesign: error: --scheduler: "), stderr
    for w in words:
        assert w in lines[0]
    assert not out.exists()


@pytest.mark.parametrize("kwargs, words", [
    ({"workers": -2}, ["--workers", "[1, 64]", "-2"]),
    ({"workers": 0}, ["--workers"]),
    ({"workers": True}, ["--workers"]),
    ({"workers": "2"}, ["--workers"]),
    ({"workers": 2.5}, ["--workers"]),
    ({"output": ""}, ["--output", "empty"]),
    ({"output": "   "}, ["--output", "empty"]),
    ({"output": 5}, ["--output", "directory name"]),
    ({"scheduler": 8786}, ["--scheduler"]),
    ({"overwrite": "yes"}, ["--overwrite"]),
    ({"combine": "cross"}, ["--combine", "product, zip"]),
    ({"task": 3}, ["--task"]),
    ({"options": ["plots"]}, ["options"]),
])
def test_sweep_python_arguments_refused_by_name(tmp_path, kwargs, words):
    args = {"vary": {"payload.mass_kg": [300, 600]}, "output": tmp_path / "s",
            "scheduler": "serial", **kwargs}
    with pytest.raises(InputError) as exc:
        isodesign.sweep(**args)
    for w in words:
        assert w in str(exc.value)
    assert not (tmp_path / "s").exists()


def test_sweep_empty_output_on_the_command_line_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status, _, stderr = run_cli("sweep", "--vary", "payload.mass_kg=300,600", "-o", "")
    assert status == 2 and "--output: empty" in stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["modes", "yield"])
def test_overwrite_refuses_a_sweep_directory(tmp_path, command):
    """``modes``/``yield --overwrite`` into a sweep would replace its record and leave its
    table and points, so that it could no longer resume: refused, the sweep untouched."""
    from isodesign.io.rundir import check_run_target

    sw = tmp_path / "sw"
    (sw / "points").mkdir(parents=True)
    rec = {"kind": "isodesign sweep", "run_status": "complete", "files": ["sweep.parquet"]}
    (sw / "record.json").write_text(json.dumps(rec))
    (sw / "sweep.parquet").write_bytes(b"PAR1")
    with pytest.raises(InputError, match="another kind of run"):
        check_run_target(sw, overwrite=True, command=command)
    if command == "modes":
        status, _, stderr = run_cli("modes", "--builtin", "table", "-o", sw, "--overwrite")
        assert status == 2 and "another kind of run (isodesign sweep)" in stderr
    assert json.loads((sw / "record.json").read_text()) == rec
    assert sorted(p.name for p in sw.iterdir()) == ["points", "record.json", "sweep.parquet"]


def test_a_run_refused_on_its_input_writes_nothing(tmp_path):
    from isodesign.io.rundir import RunDirectory

    target = tmp_path / "run"
    with pytest.raises(InputError), RunDirectory(target, command="optimize") as run:
        run.write_text("partial.txt", "x")
        raise InputError("table.cg_m: refused")
    assert list(tmp_path.iterdir()) == []


def test_an_invalid_value_is_found_before_the_points_are_validated_one_by_one(monkeypatch):
    """30,000 points whose last value of one key is invalid: found in a few checks (each
    distinct value once), not after validating the points one by one; the error names the
    point's key and value."""
    from isodesign.optimization.study import Study

    base = vertical_study()
    varies = [parse_vary("payload.mass_kg=300:1500:100"),
              parse_vary("hardware.temperature_k=280:300:30"),
              ("hardware.minor_loss", [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 6.0])]
    varies[0] = (varies[0][0], [*varies[0][1][:-1], 0.0])  # the last mass: invalid
    tables = combine(varies, "product")
    assert len(tables) == 30_000
    calls = []
    original = Study.with_changes

    def counted(self, *a, **k):
        calls.append(1)
        return original(self, *a, **k)

    monkeypatch.setattr(Study, "with_changes", counted)
    with pytest.raises(InputError) as exc:
        build_points(base, tables)
    assert "payload.mass_kg=0.0" in str(exc.value) and "payload.mass_kg" in str(exc.value)
    assert len(calls) < 200  # the distinct values (140), not 29,700 valid points first


@pytest.mark.parametrize("address, words", [
    ("http://127.0.0.1:80", ["scheme 'http'", "tcp://host:8786"]),
    ("tcp://127.0.0.1:99999", ["not a scheduler address", "1-65535"]),
    ("tcp://:8786", ["not a scheduler address"]),
    ("tcp://127.0.0.1:port", ["not a scheduler address"]),
])
def test_a_malformed_scheduler_address_is_one_line(tmp_path, address, words):
    out = tmp_path / "s"
    status, _, stderr = run_cli("sweep", "--vary", "payload.mass_kg=300,600", "--task",
                                "response", "--scheduler", address, "-o", out)
    lines = stderr.strip().splitlines()
    assert status == 2 and len(lines) == 1 and "--scheduler" in lines[0], stderr
    for w in words:
        assert w in lines[0]
    assert not out.exists()
