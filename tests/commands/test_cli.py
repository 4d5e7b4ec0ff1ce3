"""The ``isodesign`` command line: commands, outputs, exit codes, one-line errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from isodesign import SpringDesign, complex_stiffness
from isodesign.cli import COMMANDS, main
from isodesign.commands import parse_values
from isodesign.commands.stiffness import DEFAULT_AMPLITUDES_M, TABLE2_FREQUENCIES_HZ
from isodesign.io.designfile import design_to_toml, reference_design_path

STIFFNESS_COLUMNS = (
    "frequency_hz",
    "amplitude_m",
    "k_real_n_per_m",
    "k_imag_n_per_m",
    "loss_factor",
    "velocity_amplitude_m_s",
    "reynolds",
    "regime",
    "valid",
)


def run(capsys, *argv: str) -> tuple[int, str, str]:
    """Run the CLI in-process; return (status, stdout, stderr)."""
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def assert_one_error_line(err: str, *fragments: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("isodesign: error: "), err
    assert "Traceback" not in err
    for f in fragments:
        assert f in lines[0], (f, lines[0])


# -- framework --------------------------------------------------------------------------------
def test_help_lists_every_command(capsys):
    status, out, _ = run(capsys, "--help")
    assert status == 0
    for name in COMMANDS:
        assert name in out


@pytest.mark.parametrize("name", list(COMMANDS))
def test_command_help(capsys, name):
    status, out, _ = run(capsys, name, "--help")
    assert status == 0
    assert f"usage: isodesign {name}" in out


def test_version(capsys):
    import isodesign

    status, out, _ = run(capsys, "--version")
    assert status == 0
    assert out.strip() == f"isodesign {isodesign.__version__}"


def test_no_command_is_usage_error(capsys):
    status, _, err = run(capsys)
    assert status == 2
    assert_one_error_line(err, "COMMAND")


def test_unknown_command_is_usage_error(capsys):
    status, _, err = run(capsys, "optimise")
    assert status == 2
    assert_one_error_line(err, "'optimise'")


def test_command_table_modules_follow_the_protocol():
    import importlib

    for module_path, help_line in COMMANDS.values():
        mod = importlib.import_module(module_path)
        assert callable(mod.add_arguments) and callable(mod.run)
        assert help_line and "\n" not in help_line


def _choices(command: str) -> dict[str, tuple]:
    """Option -> choices of one command's parser."""
    import argparse

    from isodesign.cli import build_parser

    sub = next(
        a for a in build_parser(command)._actions if isinstance(a, argparse._SubParsersAction)
    )
    return {
        a.option_strings[-1]: tuple(a.choices)
        for a in sub.choices[command]._actions
        if a.choices is not None and a.option_strings
    }


def test_model_choices_come_from_the_registries():
    """Every command offers exactly the library's registered models (declared once)."""
    from isodesign.response.harmonic import BRANCHES
    from isodesign.response.random_input import RANDOM_METHODS
    from isodesign.spring.flow_models import FLOW_MODELS
    from isodesign.spring.stiffness import AMPLITUDE_MODES

    for command in ("stiffness", "response", "transmissibility"):
        ch = _choices(command)
        assert ch["--flow"] == FLOW_MODELS
        assert ch["--amplitude-mode"] == AMPLITUDE_MODES
    assert _choices("response")["--random-method"] == RANDOM_METHODS
    assert _choices("transmissibility")["--branch"] == BRANCHES


@pytest.mark.parametrize("command", ["stiffness", "response"])
def test_help_lists_the_diaphragm_models(command, capsys):
    from isodesign.spring.diaphragm import DIAPHRAGM_SPECS

    assert main([command, "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert ", ".join(DIAPHRAGM_SPECS.values()) in out


def test_internal_error_is_one_line_exit_3(capsys, monkeypatch):
    import isodesign.commands.criteria as crit

    def boom(args):
        raise RuntimeError("kaboom")

    monkeypatch.setattr(crit, "run", boom)
    status, _, err = run(capsys, "criteria")
    assert status == 3
    assert_one_error_line(err, "internal error", "RuntimeError", "kaboom", "--debug")
    status, _, err = run(capsys, "criteria", "--debug")
    assert status == 3
    assert "Traceback" in err and "kaboom" in err


def test_solver_error_exits_1(capsys, monkeypatch):
    import isodesign.commands.criteria as crit
    from isodesign.errors import SolverError

    def fail(args):
        raise SolverError("did not converge at 3 of 10 points")

    monkeypatch.setattr(crit, "run", fail)
    status, _, err = run(capsys, "criteria")
    assert status == 1
    assert_one_error_line(err, "did not converge")


# -- value lists --------------------------------------------------------------------------------
def test_parse_values_lists_ranges_and_units():
    from isodesign.commands import FREQUENCY_UNITS, LENGTH_UNITS

    def p(s, units=LENGTH_UNITS):
        return parse_values(s, "--x", units=units, unit_name="m")

    assert p("0.2,1,5", FREQUENCY_UNITS) == [0.2, 1.0, 5.0]
    r = p("0.2:24:50", FREQUENCY_UNITS)
    assert len(r) == 50 and r[0] == 0.2 and r[-1] == 24.0
    assert np.allclose(np.diff(np.log(r)), np.log(120) / 49)
    assert p("5Hz", FREQUENCY_UNITS) == [5.0]
    assert np.allclose(p("0.05,0.15,0.5mm"), [0.05e-3, 0.15e-3, 0.5e-3])
    assert np.allclose(p("0.05mm,0.15mm,0.5mm"), [0.05e-3, 0.15e-3, 0.5e-3])
    assert np.allclose(p("50um,0.1mm"), [50e-6, 0.1e-3])
    assert np.allclose(p("0.05:0.5:3mm"), [0.05e-3, np.sqrt(0.05 * 0.5) * 1e-3, 0.5e-3])
    assert p("1e-4") == [1e-4]


# -- stiffness ----------------------------------------------------------------------------------
def test_stiffness_defaults_csv_equals_api(capsys, tmp_path):
    out_csv = tmp_path / "k.csv"
    status, out, err = run(capsys, "stiffness", "-o", str(out_csv))
    assert status == 0, err
    assert err == ""
    df = pd.read_csv(out_csv)
    for col in STIFFNESS_COLUMNS:
        assert col in df.columns
    ref = complex_stiffness(
        SpringDesign.reference(), list(TABLE2_FREQUENCIES_HZ), list(DEFAULT_AMPLITUDES_M)
    ).to_frame()
    assert list(df.columns) == list(ref.columns)
    assert len(df) == 35 * 3
    for col in ("frequency_hz", "amplitude_m", "k_real_n_per_m", "k_imag_n_per_m", "loss_factor"):
        np.testing.assert_allclose(df[col], ref[col], rtol=1e-15, atol=0)
    assert (df["regime"] == ref["regime"]).all()
    # summary
    assert "105 points" in out
    assert "0.05 mm" in out and "0.5 mm" in out
    assert "peak eta" in out
    assert f"wrote {out_csv}" in out


def test_stiffness_design_file_options_and_units(capsys, tmp_path):
    design = SpringDesign.reference().replace(volume_ratio=3.0, capillary_length_m=0.02)
    dfile = tmp_path / "spring.toml"
    dfile.write_text(design_to_toml(design))
    out_csv = tmp_path / "k.csv"
    status, _, err = run(
        capsys,
        "stiffness",
        str(dfile),
        "--freq",
        "0.5:20:7",
        "--amplitude",
        "0.1,0.3mm",
        "--flow",
        "womersley",
        "--diaphragm",
        "none",
        "-o",
        str(out_csv),
    )
    assert status == 0, err
    df = pd.read_csv(out_csv)
    ref = complex_stiffness(
        design,
        np.geomspace(0.5, 20, 7),
        [0.1e-3, 0.3e-3],
        flow="womersley",
        diaphragm="none",
        warn=False,
    ).to_frame()
    np.testing.assert_allclose(df["k_real_n_per_m"], ref["k_real_n_per_m"], rtol=1e-12)
    np.testing.assert_allclose(df["k_imag_n_per_m"], ref["k_imag_n_per_m"], rtol=1e-12)
    assert sorted(set(df["amplitude_m"])) == pytest.approx([1e-4, 3e-4])
    assert (df["k_diaphragm_real_n_per_m"] == 0).all()


def test_stiffness_reference_file_equals_default(capsys, tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert run(capsys, "stiffness", "--freq", "1,3", "-o", str(a))[0] == 0
    path = str(reference_design_path())
    assert run(capsys, "stiffness", path, "--freq", "1,3", "-o", str(b))[0] == 0
    assert a.read_text() == b.read_text()


def test_stiffness_csv_to_stdout(capsys):
    status, out, _ = run(capsys, "stiffness", "--freq", "1,2", "--amplitude", "0.1mm", "-o", "-")
    assert status == 0
    lines = out.strip().splitlines()
    assert lines[0].startswith("frequency_hz,amplitude_m,k_real_n_per_m")
    assert len(lines) == 3


def test_stiffness_paper_model_warnings_are_one_line_each(capsys, tmp_path):
    status, out, err = run(capsys, "stiffness", "--flow", "zhao", "--amplitude-mode", "kinematic")
    assert status == 0
    lines = err.strip().splitlines()
    assert len(lines) >= 3
    assert all(line.startswith("isodesign: warning: ") for line in lines), err
    assert any("zhao_a0" in line for line in lines)
    assert any("passive" in line for line in lines)
    assert "warnings.warn" not in err and "ModelValidityWarning" not in err
    assert "flagged: 105 of 105" in out


def test_stiffness_plot(capsys, tmp_path):
    png = tmp_path / "k.png"
    status, out, err = run(capsys, "stiffness", "--freq", "0.5:10:5", "--plot", str(png))
    assert status == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {png}" in out


def test_stiffness_table_diaphragm(capsys, tmp_path):
    table = tmp_path / "dia.csv"
    rows = ["frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m"]
    for f in (0.1, 100.0):
        for x in (1e-5, 1e-3):
            rows.append(f"{f},{x},5000,500")
    table.write_text("\n".join(rows) + "\n")
    status, _, err = run(
        capsys, "stiffness", "--freq", "1,10", "--diaphragm", f"table:{table}", "-o", "-"
    )
    assert status == 0, err


BAD_INPUTS = [
    (["--freq", "0"], "--freq"),
    (["--freq", "nan"], "--freq"),
    (["--freq", "inf"], "--freq"),
    (["--freq", "1,,2"], "--freq"),
    (["--freq", "abc"], "--freq"),
    (["--freq", "1:10"], "--freq"),
    (["--freq", "10:1:5"], "--freq"),
    (["--freq", "1:10:1"], "--freq"),
    (["--amplitude", "-1"], "--amplitude"),
    (["--amplitude", "0"], "--amplitude"),
    (["--amplitude", "0.1parsec"], "--amplitude"),
    (["--flow", "laminar"], "--flow"),
    (["--amplitude-mode", "exact"], "--amplitude-mode"),
    (["--flow", "zhao"], "amplitude_mode"),
    (["--flow", "zhao_turbulent", "--amplitude-mode", "self_consistent"], "amplitude_mode"),
    (["--diaphragm", "rubber"], "diaphragm"),
    (["--diaphragm", "table:/nonexistent/dia.csv"], "dia.csv"),
    (["/nonexistent/spring.toml"], "spring.toml"),
    (["-o", "/nonexistent/dir/k.csv"], "--output"),
    (["--plot", "/nonexistent/dir/k.png"], "--plot"),
    (["--plot", "k.jpgx"], "--plot"),
    (["--bogus"], "--bogus"),
]


@pytest.mark.parametrize(("argv", "name"), BAD_INPUTS, ids=[" ".join(a) for a, _ in BAD_INPUTS])
def test_stiffness_bad_input_is_one_line_exit_2(capsys, argv, name):
    status, _, err = run(capsys, "stiffness", *argv)
    assert status == 2
    assert_one_error_line(err, name)


@pytest.mark.parametrize(
    ("text", "name"),
    [
        ("volume_ratio = [\n", "malformed TOML"),
        ("volume_ratio = 2.0\nvolume_ration = 2.0\n", "'volume_ration'"),
        (
            "volume_ratio = -2.0\ntop_volume_m3 = 1e-3\ncapillary_length_m = 0.02\n"
            "capillary_diameter_m = 1e-3\npiston_area_m2 = 5e-3\npressure_pa = 4e5\n",
            "volume_ratio",
        ),
    ],
    ids=["malformed", "unknown-key", "bad-value"],
)
def test_stiffness_bad_design_file_is_one_line_exit_2(capsys, tmp_path, text, name):
    p = tmp_path / "spring.toml"
    p.write_text(text)
    status, _, err = run(capsys, "stiffness", str(p))
    assert status == 2
    assert_one_error_line(err, name, "spring.toml")


# -- criteria -----------------------------------------------------------------------------------
def test_criteria_csv_has_vc_curves(capsys):
    status, out, _ = run(capsys, "criteria")
    assert status == 0
    from io import StringIO

    df = pd.read_csv(StringIO(out))
    names = set(df["criterion"])
    for letter in "ABCDEFG":
        assert f"VC-{letter}" in names
    vc_a = df[df["criterion"] == "VC-A"]
    assert len(vc_a) == 20
    np.testing.assert_allclose(vc_a["velocity_rms_um_s"], 50.0)


def test_criteria_table_and_file(capsys, tmp_path):
    status, out, _ = run(capsys, "criteria", "--format", "table", "--fmin", "4", "--fmax", "8")
    assert status == 0
    lines = out.splitlines()
    assert "um/s" in lines[0]
    header = lines[1].split()
    assert header[:3] == ["label", "nominal_hz", "centre_hz"] and "VC-G" in header
    assert len(lines) == 3 + 4  # title, header, rule, bands 4, 5, 6.3, 8
    out_csv = tmp_path / "c.csv"
    status, out, _ = run(
        capsys, "criteria", "--layout", "wide", "--names", "VC-A,VC-E", "-o", str(out_csv)
    )
    assert status == 0 and "wrote" in out
    df = pd.read_csv(out_csv)
    assert list(df.columns) == ["label", "nominal_hz", "centre_hz", "VC-A", "VC-E"]


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (["--fmin", "0"], "--fmin"),
        (["--fmax", "nan"], "--fmax"),
        (["--fmin", "10", "--fmax", "2"], "--fmin"),
        (["--fmin", "x"], "--fmin"),
        (["--names", "VC-Z"], "VC-Z"),
        (["--format", "xml"], "--format"),
        (["--layout", "wide", "--unit", "furlong/s"], "furlong/s"),
    ],
)
def test_criteria_bad_input(capsys, argv, name):
    status, _, err = run(capsys, "criteria", *argv)
    assert status == 2
    assert_one_error_line(err, name)


# -- demo: tests/docs/test_default_study_numbers.py (one run of the default study) -----------


# -- real processes -----------------------------------------------------------------------------
def _cli(*argv: str, **kw) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONWARNINGS="")
    return subprocess.run(
        [sys.executable, "-m", "isodesign", *argv],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        **kw,
    )


def test_subprocess_bad_input_has_no_traceback(tmp_path):
    for argv, name in (
        (["stiffness", "--freq", "0"], "--freq"),
        (["stiffness", "--amplitude", "-1"], "--amplitude"),
        (["stiffness", "--flow", "zhao"], "amplitude_mode"),
        (["stiffness", str(tmp_path / "missing.toml")], "missing.toml"),
    ):
        p = _cli(*argv)
        assert p.returncode == 2, p.stderr
        assert_one_error_line(p.stderr, name)
        assert p.stdout == ""


def test_subprocess_success_and_console_script(tmp_path):
    p = _cli("stiffness", "--freq", "1,2", "-o", str(tmp_path / "k.csv"))
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "k.csv").exists()
    script = Path(sys.executable).with_name("isodesign")
    if not script.exists():
        pytest.skip("console script not installed next to the interpreter")
    p = subprocess.run([str(script), "--help"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and "stiffness" in p.stdout


def test_help_does_not_import_heavy_modules():
    code = (
        "import sys\n"
        "from isodesign.cli import main\n"
        "assert main(['--help']) == 0\n"
        "heavy = [m for m in ('numpy', 'scipy', 'pandas', 'matplotlib', 'casadi') "
        "if m in sys.modules]\n"
        "print('HEAVY', heavy)\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert "HEAVY []" in p.stdout


def test_broken_command_module_is_internal_error(capsys, monkeypatch):
    import isodesign.cli as cli

    monkeypatch.setitem(cli.COMMANDS, "broken", ("isodesign.commands.no_such_module", "broken"))
    status, _, err = run(capsys, "broken")
    assert status == 3
    assert_one_error_line(err, "internal error", "no_such_module")


# -- the acoustic model by name (issue 16) -------------------------------------------------
def test_acoustics_option_response_and_transmissibility(capsys, tmp_path):
    """--acoustics picks the model by name; the models line says which one is in force, and
    the band table follows it (a 1 m tube: the lumped model misses its waves)."""
    d = SpringDesign.reference().replace(capillary_length_m=1.0, capillary_diameter_m=4e-3)
    f = tmp_path / "long.toml"
    f.write_text(design_to_toml(d))
    tables = {}
    for model in ("lumped", "distributed"):
        csv = tmp_path / f"{model}.csv"
        status, out, _ = run(capsys, "response", str(f), "--acoustics", model, "--bands",
                             "1:80", "-o", str(csv))
        assert status == 0
        assert f"acoustics={model}" in out and "options --acoustics" in out
        tables[model] = pd.read_csv(csv)
        status, out, _ = run(capsys, "transmissibility", str(f), "--acoustics", model)
        assert status == 0 and f"acoustics={model}" in out
    a, b = (tables[m]["payload_velocity_rms_m_s"].to_numpy() for m in ("lumped", "distributed"))
    assert np.max(np.abs(np.log(a / b))) > 0.01  # the models differ on this tube
    # without the option: the design file's model (the default, distributed)
    status, out, _ = run(capsys, "response", str(f))
    assert status == 0 and "acoustics=distributed" in out
    status, _, err = run(capsys, "response", str(f), "--acoustics", "lumpd")
    assert status == 2 and "lumped" in err


def test_acoustics_option_optimize_records_it(capsys, tmp_path):
    """optimize --acoustics lumped folds the model into the resolved study and the design file
    (a replay and a re-analysis use it), and the lumped model's validity limits apply."""
    import json
    import tomllib

    out_dir = tmp_path / "run"
    status, _out, _ = run(capsys, "optimize", "--builtin", "vertical", "--acoustics", "lumped",
                         "--starts", "1", "-o", str(out_dir), "--quiet")
    assert status == 0
    resolved = tomllib.loads((out_dir / "study_resolved.toml").read_text())
    assert resolved["models"]["acoustics"] == "lumped"
    assert 'acoustics = "lumped"' in (out_dir / "design.toml").read_text()
    rec = json.loads((out_dir / "record.json").read_text())
    assert "--acoustics" in rec["command_line"]
    names = {c["name"] for c in rec["constraints"]}
    assert "lumped_tube" in names and "plane_wave_top_chamber" not in names


def test_acoustics_option_stiffness(capsys, tmp_path):
    """stiffness --acoustics: the CSV equals the API's complex_stiffness with that model."""
    d = SpringDesign.reference().replace(capillary_length_m=1.0, capillary_diameter_m=4e-3)
    f = tmp_path / "long.toml"
    f.write_text(design_to_toml(d))
    got = {}
    for model in ("lumped", "distributed"):
        csv = tmp_path / f"{model}.csv"
        status, out, _ = run(capsys, "stiffness", str(f), "--acoustics", model, "--freq",
                             "5,120", "--amplitude", "0.1mm", "-o", str(csv))
        assert status == 0 and f"{model} acoustics" in out
        got[model] = pd.read_csv(csv)["k_real_n_per_m"].to_numpy()
        api = complex_stiffness(d.replace(acoustics=model), [5.0, 120.0], [1e-4],
                                warn=False).to_frame()
        np.testing.assert_allclose(got[model], api["k_real_n_per_m"], rtol=1e-12)
    # the 1 m tube's waves: about 2 % on Re k at 5 and 120 Hz
    assert np.min(np.abs(got["lumped"] / got["distributed"] - 1.0)) > 0.01
