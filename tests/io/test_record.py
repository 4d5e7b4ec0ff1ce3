"""Run records (isodesign.io.record): strict JSON and a resolved study that replays."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from isodesign.io.record import write_json


def _strict_loads(text: str):
    """json.loads that rejects NaN and Infinity (not JSON, RFC 8259)."""
    def reject(name):
        raise ValueError(f"invalid JSON constant {name}")
    return json.loads(text, parse_constant=reject)


def test_write_json_writes_non_finite_numpy_and_python_floats_as_null(tmp_path):
    data = {
        "np_nan": np.float64("nan"), "np_inf": np.float64("inf"),
        "np32_ninf": np.float32("-inf"), "py_nan": math.nan, "py_inf": -math.inf,
        "array": np.array([1.0, np.nan, np.inf]),
        "nested": [{"v": np.float64("nan")}, (np.float64(2.5), math.inf)],
        "finite": np.float64(1.25), "int": np.int64(3), "flag": np.bool_(True),
    }
    out = _strict_loads(write_json(tmp_path / "r.json", data).read_text(encoding="utf-8"))
    for key in ("np_nan", "np_inf", "np32_ninf", "py_nan", "py_inf"):
        assert out[key] is None, key
    assert out["array"] == [1.0, None, None]
    assert out["nested"] == [{"v": None}, [2.5, None]]
    assert out["finite"] == 1.25 and out["int"] == 3 and out["flag"] is True


def test_strict_parser_rejects_nan():
    with pytest.raises(ValueError, match="NaN"):
        _strict_loads("[NaN]")


def test_pareto_record_of_an_infeasible_sweep_point_is_strict_json(tmp_path):
    """An infeasible sweep point has NaN objective values (NumPy scalars of the front)."""
    from isodesign.io.record import pareto_record
    from isodesign.optimization.pareto import ParetoResult
    from isodesign.optimization.study import vertical_study

    st = vertical_study()
    design = {v.name: v.start for v in st.variables}
    res = ParetoResult(
        objectives=("worst_band_margin", "total_volume"),
        values=np.array([[5.0, 2e-3], [np.nan, np.nan]]), designs=(design, design),
        statuses=("Solve_Succeeded", "Infeasible_Problem_Detected"),
        front=np.array([True, False]), reference_point=np.array([-4.9, 2.1e-3]),
        ideal_point=np.array([-5.0, 2e-3]), hypervolume=0.0, wall_s=1.0)
    path = write_json(tmp_path / "record.json", pareto_record(res, st, argv=[]))
    out = _strict_loads(path.read_text(encoding="utf-8"))
    assert out["points"][0]["worst_band_margin"] == 5.0
    assert out["points"][1]["worst_band_margin"] is None
    assert out["points"][1]["total_volume"] is None


@pytest.mark.parametrize("prefix", ["table:", ""])
def test_resolved_study_replays_a_relative_diaphragm_table_from_another_cwd(
        tmp_path, monkeypatch, prefix):
    """models.diaphragm = "table:rel.csv" is relative to the study file's folder."""
    from isodesign.io.record import study_toml
    from isodesign.optimization.study import load_study

    folder, elsewhere, out = (tmp_path / n for n in ("study", "elsewhere", "out"))
    for p in (folder, elsewhere, out):
        p.mkdir()
    rows = ["frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m"]
    rows += [f"{f},{x},5000,500" for f in (0.1, 100.0) for x in (1e-5, 1e-3)]
    (folder / "rel.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    (folder / "s.toml").write_text(
        f'name = "rel"\n\n[models]\ndiaphragm = "{prefix}rel.csv"\n', encoding="utf-8")
    monkeypatch.chdir(elsewhere)  # the study file is not in the working directory
    st = load_study(folder / "s.toml")
    assert Path(st.models["diaphragm"].removeprefix("table:")).resolve() == \
        (folder / "rel.csv").resolve()
    written = out / "study_resolved.toml"
    written.write_text(study_toml(st, header="replay"), encoding="utf-8")
    monkeypatch.chdir(tmp_path)  # and loaded back from yet another directory
    back = load_study(written)
    assert Path(back.models["diaphragm"].removeprefix("table:")).resolve() == \
        (folder / "rel.csv").resolve()
    assert back.raw["models"]["diaphragm"].startswith(prefix)
