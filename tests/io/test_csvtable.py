"""The run's CSV tables written without pandas are the text pandas writes
(isodesign.io.csvtable)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from isodesign.io.csvtable import columns_csv, records_columns


def _pandas(columns) -> str:
    return pd.DataFrame(columns).to_csv(index=False)


@pytest.mark.parametrize("columns", [
    {},
    {"a": []},
    {"i": [1, 2, 3], "f": [0.1, 1e-5, 1.2345678901234568e17], "b": [True, False, True]},
    {"i64": np.arange(3), "f64": np.array([4.9999999999999996e-05, -0.0, 5e-324]),
     "b": np.array([True, False, False]), "f32": np.array([0.1, 2.0, 3.5], np.float32)},
    {"missing_int": [1, None, 3], "missing_bool": [True, None, False],
     "nan": [math.nan, 1.0, 2.0], "inf": [math.inf, -math.inf, 0.0]},
    {"mixed": [1.0, "a", None], "text": ["x,y", 'q"r', "line\nbreak"],
     "ints_floats": [1, 2.5, np.int64(3)], "labels": ["4", "5", "6.3"]},
])
def test_columns_csv_is_the_text_pandas_writes(columns):
    assert columns_csv(columns) == _pandas(columns)


def test_records_columns_like_a_frame_of_records():
    rows = [{"start": 0, "objective": 7.8, "final_x": 1.0},
            {"start": 1, "objective": math.nan, "status": "failed"},
            {"start": 2, "objective": 4.0, "final_x": 2.0, "status": "ok"}]
    cols = records_columns(rows)
    assert list(cols) == ["start", "objective", "final_x", "status"]
    assert columns_csv(cols) == pd.DataFrame(rows).to_csv(index=False)


def test_unequal_columns_refused():
    with pytest.raises(ValueError, match="different lengths"):
        columns_csv({"a": [1, 2], "b": [1]})


def test_band_response_columns_are_its_frame():
    """bands.csv of a run (BandResponse.columns) is the text of BandResponse.to_frame()."""
    from isodesign.optimization.analyze import analyze
    from isodesign.optimization.study import vertical_study

    st = vertical_study()
    res = analyze(st, {v.name: v.start for v in st.variables})
    res = getattr(res, "analysis", res)
    assert columns_csv(res.columns()) == res.to_frame().to_csv(index=False)
