"""The robust table design has what the vertical robust design has (issue 23): the
design-held sensitivities, the constraint table with the sentence naming what stopped the
design, a robust.json the report's robustness section reads, and ``isodesign report`` of
the run."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict, table_study

ROOT = Path(__file__).resolve().parents[2]


def robust_table(scenarios):
    raw = copy.deepcopy(table_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    raw["scenarios"] = scenarios
    return study_from_dict(raw, source="robust_table.toml", fill_defaults=False)


def test_table_sensitivities_agree_with_the_table_nlps_margin():
    """The central differences of the table's NumPy band response (the yield's analysis)
    against wider differences of the worst margin the table NLP's own expressions give at
    each scenario's NumPy closure (a second path: the CasADi graph)."""
    from isodesign.optimization.robust_table import _Scenarios, table_sensitivities

    st = robust_table({"payload_mass_kg": {"min": 540.0, "max": 660.0},
                       "capillary_diameter_m": {"relative": 0.05},
                       "cg_offset_x_m": {"absolute": 0.05}})
    values = {v.name: v.start for v in st.variables}
    sens = {s.parameter: s for s in table_sensitivities(st, values)}
    assert set(sens) == set(st.scenarios.names)
    sc = _Scenarios(st)
    th0 = st.scenarios.nominal()
    for k, p in enumerate(st.scenarios.parameters):
        s = sens[p.name]
        assert s.quantity == "objective" and s.unit == "dB" and not s.binding
        h = 0.05 * p.half_width
        m = []
        for sign in (1.0, -1.0):
            th = th0.copy()
            th[k] += sign * h
            m.append(sc.check(th, values, None)["margin_db"])
        scale = 0.01 if p.mode == "relative" else 1.0
        second = (m[0] - m[1]) / (2 * h) * scale
        assert s.per_unit == pytest.approx(second, rel=1e-3, abs=1e-6), p.name
        assert s.effect == pytest.approx(s.per_unit / scale * p.half_width, rel=1e-12)
        assert s.parameter_unit == ("%" if p.mode == "relative" else p.unit)
    assert abs(sens["cg_offset_x_m"].per_unit) > 0.1  # the CG offset moves the margin


def cli(*argv, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "isodesign", *argv], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=900)


@pytest.mark.slow
def test_a_robust_table_run_explains_its_design_and_reports_it(tmp_path):
    st = robust_table({"payload_mass_kg": {"min": 560.0, "max": 640.0},
                       "cg_offset_y_m": {"absolute": 0.03}})
    f = tmp_path / "rt.toml"
    f.write_text(study_toml(st))
    p = cli("optimize", str(f), "-o", "out", "--no-plots", "--yield-samples", "4",
            cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    out = tmp_path / "out"
    rob = json.loads((out / "robust.json").read_text())
    rec = json.loads((out / "record.json").read_text())
    assert rec["robust"] is True and rob["table"] is True
    # the constraint table and the sentence naming what stopped the design, on stdout
    assert "constraints at the optimum (each in the scenario where its margin is smallest)" \
        in p.stdout
    binding = [c["name"] for c in rob["constraints"] if c["binding"]]
    assert binding and all(n in p.stdout for n in binding)
    assert "the design is stopped by" in p.stdout and rob["limited_by"]
    assert f"verdict: {rob['verdict']}" in p.stdout
    # the worst margin of the verdict is the scenarios' worst
    assert rob["worst_margin_db"] == pytest.approx(
        min(r["margin_db"] for r in rob["scenarios"]), abs=1e-12)
    # the sensitivities: robust.json, sensitivities.csv and stdout
    import pandas as pd

    sens = pd.read_csv(out / "sensitivities.csv")
    assert set(sens["design"]) >= {"robust", "nominal"}
    assert set(sens["parameter"]) == {"payload_mass_kg", "cg_offset_y_m"}
    assert len(rob["sensitivities"]["robust"]) == 2
    assert np.all(np.isfinite(sens["per_unit"]))
    assert "sensitivities of the robust design's worst margin" in p.stdout
    # the keys of the report's robustness section, as the vertical robust run's
    for k in ("nominal_optimum", "robust_at_nominal_scenario", "last_search_score"):
        assert k in rob, k
    nom_row = next(r for r in rob["scenarios"] if r["index"] == 0)
    assert rob["robust_at_nominal_scenario"] == pytest.approx(nom_row["objective"], abs=1e-9)
    # the report of the run: the table's verdict and the robustness section
    r = cli("report", "out", "-o", "rep.html", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "rep.html").read_text()
    assert "Robustness" in page and "Central differences of the table" in page
    assert "point-axis-bands" in page  # the table's verdict, not the vertical one
