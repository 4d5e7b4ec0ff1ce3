"""``isodesign transmissibility`` and :func:`isodesign.transmissibility` answer the study's
question: a table study gets the table's transmissibility per point and axis (six degrees
of freedom), never the payload's vertical answer; the CLI and the API agree, and the peak at
the band response's closure is the report's (issue 23)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import isodesign
from isodesign.errors import InputError
from isodesign.io.record import study_toml
from isodesign.optimization.study import table_study, vertical_study
from isodesign.optimization.transmissibility import TableTransmissibility
from isodesign.response.harmonic import HarmonicResponse

ROOT = Path(__file__).resolve().parents[2]
FREQ = [0.1, 0.6, 0.8, 1.0, 1.3, 1.6, 2.0, 5.0]
AMPS = [1e-6, 1e-5]


def cli(*argv):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "isodesign", *argv], capture_output=True,
                          text=True, env=env, timeout=600)


@pytest.fixture(scope="module")
def table_file(tmp_path_factory):
    f = tmp_path_factory.mktemp("tr") / "table.toml"
    f.write_text(study_toml(table_study()))  # the built-in table
    return f


@pytest.fixture(scope="module")
def api_answer():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return isodesign.transmissibility(table_study(), frequency_hz=FREQ,
                                          floor_amplitude_m=AMPS)


def test_a_table_study_gets_the_tables_transmissibility(api_answer):
    res = api_answer
    assert isinstance(res, TableTransmissibility) and not isinstance(res, HarmonicResponse)
    st = table_study()
    k = len(st.table.point_names)
    assert res.transmissibility.shape == (len(FREQ), len(AMPS), k, 3, 3)
    assert res.converged.all()
    # labelled axes: a row of the frame is the array's element it names
    df = res.to_frame()
    assert len(df) == len(FREQ) * len(AMPS) * k * 9
    row = df[(df.floor_amplitude_m == AMPS[1]) & (df.frequency_hz == FREQ[3])
             & (df.point == st.table.point_names[-1]) & (df.axis_in == "x")
             & (df.axis_out == "z")].iloc[0]
    assert row.transmissibility_abs == pytest.approx(abs(res.transmissibility[3, 1, -1, 2, 0]))
    # the floor moves the table rigidly at low frequency: |T_aa| -> 1 below the modes
    low = np.abs(np.diagonal(res.transmissibility[0], axis1=2, axis2=3))
    assert np.all(np.abs(20 * np.log10(low)) < 0.5)
    # the peaks frame and the plot
    pk = res.peaks_frame()
    assert set(pk.axis) == {"x", "y", "z"} and len(pk) == len(AMPS) * k * 3
    fig = res.plot()
    assert len(fig.axes) == 3
    assert "TableTransmissibility" in repr(res) and "to_frame()" in str(res)


def test_the_table_answer_is_not_the_payloads(api_answer):
    """The payload's 1-DOF harmonic response of the same mass on the same isolators has one
    axis; the table's x and y axes (horizontal floor) are answered too, and its z peak is
    the table's, not a copy of the payload's."""
    st = table_study()
    p = isodesign.Payload(st.table.mass_kg, st.table.n_isolators)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = isodesign.harmonic_response(st.start_design(), p, FREQ, AMPS,
                                          flow=st.models["flow"], warn=False)
    assert one.transmissibility.shape == (len(FREQ), len(AMPS))
    horizontal = api_answer.peak_db()[:, :, :2]
    assert np.all(np.isfinite(horizontal)) and np.all(horizontal > 0.0)


def test_cli_and_api_agree_on_a_table_study(tmp_path, table_file, api_answer):
    out = tmp_path / "t.csv"
    p = cli("transmissibility", str(table_file), "--freq", ",".join(map(str, FREQ)),
            "--floor-amplitude", "1,10um", "-o", str(out), "--plot", str(tmp_path / "t.png"))
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("transmissibility of the table: ")
    assert "natural frequency" not in p.stdout  # the payload's summary line
    df = pd.read_csv(out)
    ref = api_answer.to_frame()
    assert list(df.columns) == list(ref.columns)
    assert (df.point.tolist(), df.axis_in.tolist(), df.axis_out.tolist()) == (
        ref.point.tolist(), ref.axis_in.tolist(), ref.axis_out.tolist())
    np.testing.assert_allclose(df.transmissibility_abs, ref.transmissibility_abs, rtol=1e-9,
                               atol=1e-12)  # round-off zeros (cross axes of a symmetric table)
    assert (tmp_path / "t.png").stat().st_size > 0
    # the printed peaks are the API's, to the printed digits
    pk = api_answer.peaks_frame()
    for _, r in pk.iterrows():
        assert f"{r.point[:10]:>10}  {r.axis:>4}  {r.peak_db:>8.2f}" in p.stdout


def test_the_closure_peak_is_the_reports(table_file, api_answer):
    """The continuous peak at the band response's closure is the figure the report's table
    section prints (and the optimizer's peak constraint bounds)."""
    from isodesign.reporting.inputs import load_case
    from isodesign.reporting.table_section import table_section

    sec = table_section(load_case(table_file))
    cp = api_answer.closure_peaks
    for i, ax in enumerate("xyz"):
        m = re.search(rf"{ax} ([+-][\d.]+) dB at ([\d.]+) Hz", sec["peak_line"])
        assert m is not None, sec["peak_line"]
        assert float(m.group(1)) == pytest.approx(cp.peak_db[:, i].max(), abs=0.006)
    assert api_answer.peak_limit_db == table_study().constraints["max_peak_transmissibility_db"]


def test_payload_options_are_refused_for_a_table_by_name(table_file):
    for opt in (["--payload-kg", "500"], ["--isolators", "6"], ["--design-pressure"],
                ["--branch", "lower"]):
        p = cli("transmissibility", str(table_file), "--freq", "1,2", *opt)
        assert p.returncode == 2, (opt, p.stdout)
        line = p.stderr.strip().splitlines()
        assert len(line) == 1 and line[0].startswith(f"isodesign: error: {opt[0]}: ")
        assert "[table]" in line[0]
    with pytest.raises(InputError, match=r"^branch: .*\[table\]"):
        isodesign.transmissibility(table_study(), frequency_hz=[1.0], branch="lower")


def test_a_vertical_study_keeps_the_payloads_answer(tmp_path):
    st = vertical_study()
    res = isodesign.transmissibility(st, frequency_hz=FREQ, floor_amplitude_m=AMPS)
    assert isinstance(res, HarmonicResponse)
    f = tmp_path / "v.toml"
    f.write_text(study_toml(st))
    out = tmp_path / "v.csv"
    p = cli("transmissibility", str(f), "--freq", ",".join(map(str, FREQ)),
            "--floor-amplitude", "1,10um", "-o", str(out))
    assert p.returncode == 0, p.stderr
    df = pd.read_csv(out)
    ref = res.to_frame()
    num = [c for c in ref.columns if pd.api.types.is_float_dtype(ref[c])]
    np.testing.assert_allclose(df[num].to_numpy(), ref[num].to_numpy(), rtol=1e-9, atol=1e-12)


def test_the_docs_peaks_of_the_builtin_table():
    """docs/table.md section 5: the built-in table's y peaks at 1 and 10 um and at the
    closure (default grid), to the 0.1 dB the page states."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = isodesign.transmissibility(table_study())
    y = res.peak_db()[:, :, 1].max(axis=1)
    assert y[0] == pytest.approx(18.3, abs=0.1) and y[1] == pytest.approx(16.9, abs=0.1)
    # the closure's springs at the optimizer's tube velocity (with the distortion's gain)
    assert res.closure_peaks.peak_db[:, 1].max() == pytest.approx(14.0, abs=0.1)


def test_an_optimize_run_of_a_table_is_answered_at_its_optimum(builtin_table_run, capsys):
    """A table optimize run directory: the optimum's table (CLI and API alike), its closure
    peak the one the run's report prints."""
    from isodesign.cli import main
    from isodesign.reporting.inputs import load_case
    from isodesign.reporting.table_section import table_section

    _, run = builtin_table_run
    assert main(["transmissibility", str(run), "--freq", "0.5:5:30",
                 "--floor-amplitude", "1um"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"transmissibility of the table: optimum of study 'table' ({run})")
    case = load_case(run)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        api = isodesign.transmissibility(case.study, case.design,
                                         np.geomspace(0.5, 5.0, 30), 1e-6,
                                         values=case.record.get("design"),
                                         models=dict(case.models))
        line = table_section(case)["peak_line"]
    for _, r in api.peaks_frame().iterrows():
        assert f"{r.point[:10]:>10}  {r.axis:>4}  {r.peak_db:>8.2f}" in out
    for i, ax in enumerate("xyz"):
        m = re.search(rf"{ax} ([+-][\d.]+) dB at ([\d.]+) Hz", line)
        assert float(m.group(1)) == pytest.approx(api.closure_peaks.peak_db[:, i].max(),
                                                  abs=0.006)
        assert f"{ax} {float(m.group(1)):+.2f} dB" in out


@pytest.mark.parametrize("kw, name", [
    ({"floor_amplitude_m": "x"}, "floor_amplitude_m"),
    ({"floor_amplitude_m": [1e-6, "y"]}, "floor_amplitude_m"),
    ({"floor_amplitude_m": -1.0}, "floor_amplitude_m"),
    ({"floor_amplitude_m": [[1e-6]]}, "floor_amplitude_m"),
    ({"frequency_hz": []}, "frequency_hz"),
    ({"frequency_hz": [1.0, float("nan")]}, "frequency_hz"),
    ({"values": 3}, "values"),
    ({"models": 3}, "models"),
    ({"study": "table.toml"}, "study"),
])
def test_bad_api_input_is_an_input_error_naming_the_parameter(kw, name):
    args = {"study": table_study(), "frequency_hz": [1.0], **kw}
    with pytest.raises(InputError, match=rf"^{name}: "):
        isodesign.transmissibility(**args)
