"""Docstring meta-test (after python-control's): the public API is documented, numpydoc style.

Every public function and class (a name in some module's ``__all__``, defined in that
module) has a docstring whose first line is a summary; every public function with
parameters has a ``Parameters`` section naming each parameter. The few functions still
missing one are listed below by name, each with its reason: a new public function cannot
slip in undocumented, and a listed one that gets documented must leave the list.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re

import pytest

import isodesign

#: Functions without a complete Parameters section yet: (module, name) -> reason.
KNOWN_GAPS: dict[tuple[str, str], str] = {}


def _public_objects():
    out = []
    for info in pkgutil.walk_packages(isodesign.__path__, "isodesign."):
        if info.name.endswith("__main__"):
            continue  # running it is the CLI
        mod = importlib.import_module(info.name)
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__ == mod.__name__:
                out.append((mod.__name__, name, obj))
    return out


PUBLIC = _public_objects()


def _parameters(obj) -> list[str]:
    return [
        p for p in inspect.signature(obj).parameters if p not in ("self", "cls")
        and not p.startswith("_")
    ]


def _problems(obj) -> list[str]:
    doc = inspect.getdoc(obj) or ""
    if not doc.strip():
        return ["no docstring"]
    problems = []
    if not doc.splitlines()[0].strip():
        problems.append("no summary line")
    if inspect.isfunction(obj) and (params := _parameters(obj)):
        m = re.search(r"^Parameters\n-{3,}\n(.*?)(?=^\w[\w ]*\n-{3,}\n|\Z)", doc, re.M | re.S)
        if m is None:
            problems.append("no Parameters section")
        else:
            missing = [
                p for p in params if not re.search(rf"(^|[ ,*]){re.escape(p)}\b", m.group(1), re.M)
            ]
            if missing:
                problems.append(f"parameters not documented: {', '.join(missing)}")
    return problems


def test_the_walk_finds_the_api():
    names = {(m, n) for m, n, _ in PUBLIC}
    assert ("isodesign.spring.stiffness", "complex_stiffness") in names
    assert len(PUBLIC) > 150


@pytest.mark.parametrize(
    "module, name, obj", PUBLIC, ids=[f"{m}.{n}" for m, n, _ in PUBLIC]
)
def test_public_docstring(module, name, obj):
    problems = _problems(obj)
    if (module, name) in KNOWN_GAPS:
        assert problems, f"{module}.{name} is documented now: remove it from KNOWN_GAPS"
        return
    assert not problems, f"{module}.{name}: {'; '.join(problems)}"


def test_known_gaps_are_public_names():
    names = {(m, n) for m, n, _ in PUBLIC}
    assert set(KNOWN_GAPS) <= names
    assert all(reason.strip() for reason in KNOWN_GAPS.values())


def test_top_level_api_gaps_are_only_the_listed_ones():
    """The names exported by ``isodesign`` itself are documented, every one."""
    gaps = set()
    for name in isodesign.__all__:
        obj = getattr(isodesign, name)
        if (inspect.isfunction(obj) or inspect.isclass(obj)) and _problems(obj):
            gaps.add((obj.__module__, name))
    assert gaps == set()
