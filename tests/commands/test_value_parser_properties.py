"""Property tests of the CLI's value parsers: any text gives values or one clean error.

The parsers (``parse_values`` for --freq/--amplitude/--floor-amplitude, the integer option
type of --starts/--workers/--seed/--points/--isolators/--points-per-band, --objectives,
--bands, --names) return valid values or raise InputError/ArgumentTypeError; through
``main`` every text gives exit 0 or exit 2 with one ``isodesign: error:`` line.
"""

from __future__ import annotations

import argparse
import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from isodesign.cli import main
from isodesign.commands import (
    FREQUENCY_UNITS,
    LENGTH_UNITS,
    MAX_LIST_VALUES,
    parse_values,
)
from isodesign.commands import int_option as _int_option
from isodesign.commands.pareto import OBJECTIVE_CHOICES, parse_objectives
from isodesign.commands.response import _bands
from isodesign.errors import InputError

SETTINGS = settings(max_examples=200, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])

# text that looks like value lists, plus anything at all
pieces = st.sampled_from(["0", "1", "-1", "0.2", "24", "1e-3", "1e400", "nan", "inf", "-inf",
                          ",", ":", "mm", "um", "m", "Hz", "furlong", " ", "", "5", "100000000",
                          ".", "e", "+", "-", "\x00", "\u00e9", "1_0"])
listish = st.lists(pieces, max_size=8).map("".join)
texts = st.one_of(listish, st.text(max_size=30))


@SETTINGS
@given(texts, st.sampled_from([("--freq", FREQUENCY_UNITS, "Hz"),
                               ("--amplitude", LENGTH_UNITS, "m")]))
def test_parse_values_gives_positive_finite_values_or_input_error(text, opt):
    name, units, unit_name = opt
    try:
        vals = parse_values(text, name, units=units, unit_name=unit_name)
    except InputError as exc:
        assert str(exc).startswith(f"{name}: ")
        assert "\n" not in str(exc)
        return
    assert 1 <= len(vals) <= MAX_LIST_VALUES
    assert all(math.isfinite(v) and v > 0 for v in vals)


@SETTINGS
@given(st.one_of(st.integers(min_value=-(10**15), max_value=10**15).map(str),
                 st.text(max_size=20), st.integers().map(lambda i: str(i) + "0" * 30)))
def test_integer_option_type(text):
    try:
        v = _int_option(text)
    except argparse.ArgumentTypeError as exc:
        assert "integer" in str(exc)
        return
    assert isinstance(v, int) and abs(v) < 10**13


@SETTINGS
@given(st.one_of(st.lists(st.sampled_from([*OBJECTIVE_CHOICES, "", " ", "x", ","]),
                          max_size=4).map(",".join), st.text(max_size=30)))
def test_objectives(text):
    try:
        a, b = parse_objectives(text)
    except InputError as exc:
        assert str(exc).startswith("--objectives: ")
        return
    assert a != b and {a, b} <= set(OBJECTIVE_CHOICES)


@SETTINGS
@given(st.one_of(st.lists(st.sampled_from(["1", "80", "-1", "nan", "inf", "x", "", "0"]),
                          max_size=3).map(":".join), st.text(max_size=20)))
def test_bands(text):
    try:
        lo, hi = _bands(text)
    except InputError as exc:
        assert str(exc).startswith("--bands: ")
        return
    assert 0 < lo <= hi < math.inf


def _one_clean_answer(capsys, argv) -> int:
    status = main(argv)
    _out, err = capsys.readouterr()
    assert status in (0, 2), (status, err)
    assert "Traceback" not in err
    if status == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("isodesign: error: "), err
    return status


@SETTINGS
@given(texts)
def test_cli_freq_through_main(capsys, text):
    # --plot with an unsupported suffix is checked after the grid: every run ends with
    # exit 2 before any computation, naming --freq when the list is bad
    status = _one_clean_answer(capsys, ["stiffness", "--freq", text, "--plot", "x.txt"])
    assert status == 2


@SETTINGS
@given(st.one_of(st.lists(st.sampled_from(["VC-A", "VC-E", "NIST-A", "", " ", "VC-Q"]),
                          max_size=4).map(",".join), st.text(max_size=20)))
def test_cli_criteria_names_through_main(capsys, text):
    status = _one_clean_answer(capsys, ["criteria", "--names", text, "--fmin", "4",
                                        "--fmax", "5"])
    if not any(t.strip() for t in text.split(",")):
        assert status == 2  # '' and ',,,' are errors, never "list everything"


@SETTINGS
@given(st.one_of(st.integers(min_value=-5, max_value=10**9).map(str), st.text(max_size=12)))
def test_cli_counts_through_main(capsys, text):
    # every count is checked before any computation; a valid one reaches --plot's check
    for argv in (["response", "--points-per-band", text, "--plot", "x.txt"],
                 ["response", "--isolators", text, "--plot", "x.txt"]):
        assert _one_clean_answer(capsys, argv) == 2
