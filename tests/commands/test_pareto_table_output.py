"""``isodesign pareto`` of a table study prints what it prints of a vertical one: the
header, the models, every point with its design variables, the hypervolume with its
reference and ideal points (one printing function), and writes pareto.json (issue 23)."""

from __future__ import annotations

import copy
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict, vertical_study

ROOT = Path(__file__).resolve().parents[2]


def cli(*argv):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "isodesign", *argv], capture_output=True,
                          text=True, env=env, timeout=900)


def small_vertical():
    return vertical_study().with_changes(models={"points_per_band": 3, "peak_points": 30},
                                        solver={"starts": 2, "workers": 1})


@pytest.fixture(scope="module")
def runs(tmp_path_factory, small_table_study):
    d = tmp_path_factory.mktemp("pareto")
    out = {}
    for kind, st in (("table", small_table_study()), ("vertical", small_vertical())):
        f = d / f"{kind}.toml"
        f.write_text(study_toml(st))
        p = cli("pareto", str(f), "--points", "3", "--no-plots", "-o", str(d / kind))
        assert p.returncode == 0, p.stderr
        out[kind] = (p.stdout, d / kind)
    return out


#: The kinds of lines ``isodesign pareto`` prints, in order.
KINDS = (("header", r"(table )?study .*: Pareto front of "), ("models", r"  models in force: "),
         ("columns", r"\s+#\s+worst_band_margin"), ("point", r"\s+\d+\s"),
         ("hypervolume", r"\d+ of \d+ points non-dominated; hypervolume "),
         ("reference", r"  reference point "), ("ideal", r"  ideal point: "),
         ("wrote", r"wrote "))


def shape(stdout: str) -> list[str]:
    """The kinds of lines printed, in order (repeats merged; other lines: the scope)."""
    out = []
    for line in stdout.splitlines():
        kind = next((k for k, rx in KINDS if re.match(rx, line)), "other")
        if not out or out[-1] != kind:
            out.append(kind)
    return out


@pytest.mark.slow
def test_table_front_prints_what_the_vertical_front_prints(runs):
    table, _ = runs["table"]
    vertical, _ = runs["vertical"]
    for out in (table, vertical):
        lines = out.splitlines()
        assert "Pareto front of worst_band_margin (maximizing" in lines[0]
        assert lines[1].startswith("  models in force: ")
        header = lines[2].split()
        assert header == ["#", "worst_band_margin", "total_volume", "N", "V_t0", "(L)",
                          "L_c", "(mm)", "D_c", "(mm)", "front"]
        assert re.search(r"^\d+ of 3 points non-dominated; hypervolume 0\.\d{4} "
                         r"\(normalized", out, re.M)
        assert "  reference point (nadir + 10% of the range): worst_band_margin " in out
        assert "  ideal point: worst_band_margin " in out
        assert re.search(r"^wrote pareto\.csv, pareto\.json, record\.json", out, re.M)
    assert table.splitlines()[0].startswith("table study ")
    assert "3 axes, every instrument point" in table.splitlines()[0]
    # the same kinds of lines in the same order (the vertical adds its scope lines)
    assert shape(table) == [k for k, _ in KINDS]
    assert [k for k in shape(vertical) if k != "other"] == [k for k, _ in KINDS]


@pytest.mark.slow
def test_table_front_hypervolume_by_an_independent_raster(runs):
    """The printed and written hypervolume is the area dominated by the front in the
    normalized space (margin negated; ideal 0, reference 1), measured here on a 2000 x 2000
    raster from pareto.csv."""
    stdout, d = runs["table"]
    js = json.loads((d / "pareto.json").read_text())
    rec = json.loads((d / "record.json").read_text())
    df = pd.read_csv(d / "pareto.csv")
    assert {"volume_ratio", "top_volume_m3", "capillary_length_m",
            "capillary_diameter_m"} <= set(df.columns)
    assert js["objectives"] == ["worst_band_margin", "total_volume"]
    assert rec["hypervolume"] == pytest.approx(js["hypervolume"], abs=1e-12)
    assert f"hypervolume {js['hypervolume']:.4f}" in stdout
    on = df[df["nondominated"]]
    mins = np.column_stack([-on["worst_margin_db"], on["total_volume_m3"]])
    ideal = np.array(js["ideal_point_minimized"])
    ref = np.array(js["reference_point_minimized"])
    assert ideal == pytest.approx(mins.min(axis=0), rel=1e-12)
    nadir = mins.max(axis=0)
    assert ref == pytest.approx(nadir + 0.1 * (nadir - ideal), rel=1e-12)
    z = (mins - ideal) / (ref - ideal)
    n = 2000
    c = (np.arange(n) + 0.5) / n
    gx, gy = np.meshgrid(c, c, indexing="ij")
    covered = np.zeros_like(gx, bool)
    for x, y in z:
        covered |= (gx >= x) & (gy >= y)
    assert js["hypervolume"] == pytest.approx(covered.mean(), abs=2e-3)
    # non-dominance by the definition, on the CSV's values
    m, vol = df["worst_margin_db"].to_numpy(), df["total_volume_m3"].to_numpy()
    for i in range(len(df)):
        dom = any(m[j] >= m[i] and vol[j] <= vol[i] and (m[j] > m[i] or vol[j] < vol[i])
                  for j in range(len(df)) if np.isfinite(m[j]))
        assert bool(df["nondominated"][i]) == (np.isfinite(m[i]) and not dom)


@pytest.mark.slow
def test_an_infeasible_table_front_is_reported_as_a_vertical_one(tmp_path, small_table_study):
    """No feasible anchor: the vertical front's lines, record.json (infeasible), exit 1."""
    raw = copy.deepcopy(small_table_study().raw)
    raw["constraints"]["max_peak_transmissibility_db"] = 0.5  # no isolator does that
    f = tmp_path / "t.toml"
    f.write_text(study_toml(study_from_dict(raw, source="t.toml", fill_defaults=False)))
    p = cli("pareto", str(f), "--points", "3", "--no-plots", "-o", str(tmp_path / "p"))
    assert p.returncode == 1, p.stderr
    assert "NO FEASIBLE DESIGN when maximizing worst_band_margin alone" in p.stdout
    assert p.stderr.strip().splitlines()[-1].startswith(
        "isodesign: error: pareto: no feasible design when maximizing worst_band_margin")
    rec = json.loads((tmp_path / "p" / "record.json").read_text())
    assert rec["run_status"] == "infeasible"
    assert not (tmp_path / "p" / "pareto.csv").exists()
