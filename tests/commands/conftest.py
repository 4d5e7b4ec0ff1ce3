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
