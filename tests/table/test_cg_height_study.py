"""studies/table_cg_height.py: the trends docs/table.md states, on three heights."""

from __future__ import annotations

import numpy as np


def test_cg_height_study_trends(tmp_path, study_script):
    mod = study_script("table_cg_height")
    assert mod.main(["-o", str(tmp_path), "--heights", "0.2:0.6:3"]) == 0
    import pandas as pd

    df = pd.read_csv(tmp_path / "table_cg_height.csv")
    assert (tmp_path / "table_cg_height.png").is_file()
    for pair in ("x+ry", "y+rx"):
        assert np.all(np.diff(df[f"{pair}_low_hz"]) < 0)   # the lower member drops
        assert np.all(np.diff(df[f"{pair}_high_hz"]) > 0)  # the upper one rises
    h = df["cg_height_m"].to_numpy()
    np.testing.assert_allclose(df["rocking_margin_weak"] * h, df["rocking_margin_weak"][0] * h[0],
                               rtol=1e-9)  # 1/h
    assert np.all(np.diff(df["worst_margin_z_db"]) < 0)
