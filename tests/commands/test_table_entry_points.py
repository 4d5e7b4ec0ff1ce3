"""``isodesign yield`` of a table optimize run judges it with the table's analysis, as
:func:`isodesign.optimization.yields.estimate_yield` does (issue 23)."""

from __future__ import annotations

import copy
import json

import pytest

from isodesign.cli import main
from isodesign.io.record import study_toml
from isodesign.optimization.study import study_from_dict


def test_yield_of_a_table_run_is_the_tables(tmp_path, capsys, small_table_study):
    from isodesign.optimization.yields import estimate_yield

    st = small_table_study()
    raw = copy.deepcopy(st.raw)
    f = tmp_path / "t.toml"
    f.write_text(study_toml(st))
    status = main(["optimize", str(f), "--no-plots", "--quiet", "-o", str(tmp_path / "o")])
    assert status in (0, 1)  # the table's answer (FAIL: the optimum misses VC-C)
    raw["scenarios"] = {"payload_mass_kg": {"min": 560.0, "max": 640.0},
                        "cg_offset_y_m": {"absolute": 0.05}}
    robust = study_from_dict(raw, source="tr.toml", fill_defaults=False)
    g = tmp_path / "tr.toml"
    g.write_text(study_toml(robust))
    capsys.readouterr()
    assert main(["yield", str(tmp_path / "o"), "--study", str(g), "--samples", "8",
                 "--workers", "1", "--no-plots", "-o", str(tmp_path / "y")]) == 0
    out = capsys.readouterr().out
    y = json.loads((tmp_path / "y" / "yield.json").read_text())
    design = json.loads((tmp_path / "o" / "design.json").read_text())
    values = {k: v["value"] for k, v in design["variables"].items()}
    api = estimate_yield(robust, values, samples=8, workers=1)
    assert y["fraction"] == api.fraction
    assert y["worst_margin_db"] == pytest.approx(api.worst_margin_db(), abs=1e-6)
    # the table's optimum misses VC-C (about -4.4 dB at the nominal point): no draw passes
    assert api.fraction == 0.0 and "yield of" in out
    assert api.worst_margin_db() < design["derived"]["worst_band_margin_db"] + 3.0
