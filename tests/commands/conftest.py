"""Fixtures of the command-line and input tests."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources

import pytest

from isodesign.optimization.study import study_from_dict


@pytest.fixture(scope="module")
def table_raw():
    """The built-in table study's file as a dictionary (``table_study()``)."""
    with resources.as_file(resources.files("isodesign") / "data" / "table_study.toml") as p:
        return tomllib.loads(p.read_text())


@pytest.fixture(scope="module")
def changed_table_study(table_raw):
    """``changed_table_study(changes)``: the built-in table study's file with ``changes``
    (dotted key -> value, as a user would write them in the file) read as ``table.toml``
    (the file name the messages name)."""

    def make(changes: dict):
        d = copy.deepcopy(table_raw)
        for path, value in changes.items():
            *head, last = path.split(".")
            cur = d
            for k in head:
                cur = cur.setdefault(k, {})
            cur[last] = value
        return study_from_dict(d, source="table.toml")

    return make


@pytest.fixture(scope="module")
def refused_naming(changed_table_study):
    """``refused_naming(changes, fragments)``: reading the changed table study raises one
    InputError of one line that holds every fragment (the key as typed, its range)."""
    from isodesign.errors import InputError

    def check(changes: dict, fragments) -> None:
        with pytest.raises(InputError) as err:
            changed_table_study(changes)
        msg = str(err.value)
        assert "\n" not in msg
        for f in fragments:
            assert f in msg

    return check


@pytest.fixture(scope="module")
def warned_naming(changed_table_study):
    """``warned_naming(changes, fragments)``: reading the changed table study warns a
    UnitWarning that holds every fragment (a unit slip, named)."""
    import warnings

    from isodesign.io.plausible import UnitWarning

    def check(changes: dict, fragments) -> None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            changed_table_study(changes)
        msgs = [str(w.message) for w in caught if issubclass(w.category, UnitWarning)]
        assert any(all(f in m for f in fragments) for m in msgs), msgs

    return check
