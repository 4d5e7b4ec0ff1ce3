"""Property tests: the file readers answer any bytes with a value or an InputError, never
anything else (no OverflowError, UnicodeDecodeError, AttributeError, RecursionError...).

Readers covered: TOML (``read_toml``), design files (``load_design``), study files
(``load_study``), CSV columns and header comments (``read_csv_columns``,
``read_csv_header_comments``), the diaphragm table, and floor spectra and criterion curves
from CSV.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from isodesign.errors import InputError
from isodesign.io.designfile import DESIGN_KEYS, load_design
from isodesign.io.files import read_csv_columns, read_csv_header_comments, read_toml
from isodesign.optimization.study import load_study, study_from_dict
from isodesign.spring.design import SpringDesign

SETTINGS = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])

# -- building blocks --------------------------------------------------------------------------
numbers = st.one_of(
    st.integers(min_value=-(10**30), max_value=10**30),
    st.integers().map(lambda i: i * 10**400),  # far beyond float
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 1e-300, 1e308, 4.93e5, 0.0009, 0.012, 2**63]),
)
scalars = st.one_of(numbers, st.booleans(), st.text(max_size=8), st.none())
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=3),
                            st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=6,
)


def _toml_value(v) -> str | None:
    """A TOML literal for ``v`` (None: not representable, left out)."""
    if v is None:
        return None
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + "".join(c if c.isalnum() else "_" for c in v) + '"'
    if isinstance(v, list):
        items = [_toml_value(x) for x in v]
        return "[" + ", ".join(x for x in items if x is not None) + "]"
    if isinstance(v, dict):
        items = [(k, _toml_value(x)) for k, x in v.items()]
        return "{" + ", ".join(f'"{k}" = {x}' for k, x in items if x is not None) + "}"
    raise TypeError(type(v))


_TMP = tempfile.TemporaryDirectory(prefix="isodesign-prop-")


def _write(data: bytes, suffix: str) -> Path:
    p = Path(_TMP.name) / f"f{suffix}"
    p.write_bytes(data)
    return p


def _answers(fn, *args):
    """Call ``fn``: a value or InputError (a one-line message) is a clean answer."""
    try:
        return fn(*args)
    except InputError as exc:
        msg = str(exc)
        assert msg.strip() and "\n" not in msg.strip(), msg
        return exc


# -- raw bytes ---------------------------------------------------------------------------------
@SETTINGS
@given(st.binary(max_size=400))
def test_any_bytes_as_a_toml_file(data):
    p = _write(data, ".toml")
    out = _answers(read_toml, p)
    assert isinstance(out, dict | InputError)
    if isinstance(out, InputError):
        assert str(p) in str(out)


@SETTINGS
@given(st.binary(max_size=400))
def test_any_bytes_as_a_design_file(data):
    p = _write(data, ".toml")
    out = _answers(load_design, p)
    assert isinstance(out, SpringDesign | InputError)
    if isinstance(out, InputError):
        assert str(p) in str(out)


@SETTINGS
@given(st.binary(max_size=400))
def test_any_bytes_as_a_study_file(data):
    p = _write(data, ".toml")
    out = _answers(load_study, p)
    assert isinstance(out, InputError) or out.name


@SETTINGS
@given(st.binary(max_size=400))
def test_any_bytes_as_a_csv_file(data):
    p = _write(data, ".csv")
    out = _answers(read_csv_columns, p, ("frequency_hz", "value"))
    assert isinstance(out, dict | InputError)
    out = _answers(read_csv_header_comments, p)
    assert isinstance(out, dict | InputError)


# -- well-formed TOML with hostile values -------------------------------------------------------
design_docs = st.dictionaries(
    st.sampled_from([*DESIGN_KEYS, "colour"]), values, max_size=len(DESIGN_KEYS)
)


@SETTINGS
@given(design_docs)
def test_design_files_with_any_values(doc):
    text = "\n".join(f"{k} = {_toml_value(v)}" for k, v in doc.items()
                     if _toml_value(v) is not None and not isinstance(v, dict))
    tables = "\n".join(f"[{k}]\n" + "\n".join(f'"{kk}" = {_toml_value(vv)}'
                                              for kk, vv in v.items()
                                              if _toml_value(vv) is not None)
                       for k, v in doc.items() if isinstance(v, dict))
    p = _write((text + "\n" + tables + "\n").encode(), ".toml")
    out = _answers(load_design, p)
    assert isinstance(out, SpringDesign | InputError)
    if isinstance(out, SpringDesign):
        assert math.isfinite(out.pressure_pa) and out.volume_ratio > 0


study_tables = {
    "payload": ["mass_kg", "isolators", "spacing_m", "cg_height_m"],
    "hardware": ["piston_area_m2", "temperature_k", "minor_loss", "polytropic_index"],
    "target": ["criterion", "band_min_hz", "band_max_hz"],
    "models": ["flow", "points_per_band", "peak_points"],
    "constraints": ["max_total_volume_m3", "min_tilt_margin", "max_mach", "model_validity"],
    "objective": ["kind", "frequency_hz"],
    "solver": ["starts", "seed", "max_iter", "tol", "workers", "tie_break"],
}
study_docs = st.fixed_dictionaries(
    {},
    optional={t: st.dictionaries(st.sampled_from(keys), values, max_size=3)
              for t, keys in study_tables.items()}
    | {"variables": st.dictionaries(
        st.sampled_from(["volume_ratio", "top_volume_m3", "capillary_length_m",
                         "capillary_diameter_m"]),
        st.dictionaries(st.sampled_from(["start", "lower", "upper", "fixed"]), values,
                        max_size=4),
        max_size=4)},
)


@SETTINGS
@given(study_docs)
def test_study_dicts_with_any_values(doc):
    out = _answers(study_from_dict, doc)
    assert isinstance(out, InputError) or out.solver["starts"] >= 1


@pytest.mark.parametrize("reader", ["floor_spectrum", "criterion_curve", "diaphragm_table"])
def test_floor_and_diaphragm_csv_readers_on_any_bytes(reader):
    from isodesign.floor import FloorSpectrum
    from isodesign.floor.curve_files import criterion_from_csv
    from isodesign.spring.diaphragm import diaphragm_model

    fn = {"floor_spectrum": FloorSpectrum.from_csv,
          "criterion_curve": criterion_from_csv,
          "diaphragm_table": lambda p: diaphragm_model(f"table:{p}")}[reader]

    @SETTINGS
    @example(b'"\x00\n\x00')  # a quoted header with a line break: the message stays one line
    @given(st.one_of(st.binary(max_size=300),
                     st.lists(st.lists(st.one_of(st.sampled_from(
                         ["frequency_hz", "f_hz", "velocity_rms_m_s", "amplitude_m", "k_real",
                          "nan", "inf", "-1", "1e400", "0", "1", "2.5", "", "#"]),
                         st.text(max_size=5)), min_size=1, max_size=4),
                         max_size=6).map(lambda rows: "\n".join(",".join(r) for r in rows)
                                         .encode("utf-8", "surrogatepass"))))
    def check(data):
        p = _write(data, ".csv")
        _answers(fn, p)

    check()
