"""studies/table_stability.py: the loop gives way before the statics (docs/table.md, s. 12)."""

from __future__ import annotations

import numpy as np


def test_the_loop_gives_way_before_the_statics(tmp_path, capsys, study_script):
    import pandas as pd

    study = study_script("table_stability")
    assert study.main(["-o", str(tmp_path), "--heights", "0.3:0.9:3"]) == 0
    df = pd.read_csv(tmp_path / "table_stability.csv")
    assert (tmp_path / "table_stability.png").is_file()
    assert df["loop_stable"].tolist() == [True, True, False]
    assert df["static_stable"].all()
    assert np.all(np.diff(df["loop_gain_margin_db"]) < 0)
    h = df["cg_height_m"].to_numpy()
    np.testing.assert_allclose(df["static_margin"] * h, df["critical_height_m"], rtol=1e-12)
    # the leveling oscillation is the lowest rocking mode's
    np.testing.assert_allclose(df["oscillation_frequency_hz"], df["lowest_mode_hz"], rtol=0.03)
    out = capsys.readouterr().out
    assert "the leveling loop gives way at h = " in out
