"""The command listings the docs show are what the commands print today.

Each entry of :data:`LISTINGS` names a document and the command line of one of its
```` ``` ```` blocks (the line ``$ isodesign ...``). The test runs the command in-process
(in a temporary directory, so ``-o`` paths stay there) and requires every line the
document shows, in order, in the command's stdout + stderr, after :func:`normalize` has
blanked what legitimately varies between runs (wall times, round-off-sized margins, the
re-check's agreement). A document line ``...`` stands for any number of lines; a line that
ends in ``...`` or ``...)`` matches by its start. ``ISODESIGN_UPDATE_LISTINGS=1`` rewrites
the blocks from a fresh run instead (then review the diff).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
from pathlib import Path

import pytest

from isodesign.cli import main

DOCS = Path(__file__).resolve().parents[2] / "docs"

#: (document, command line as shown after "$ ", slow)
LISTINGS = [
    ("response.md", "isodesign response --target VC-E -o bands.csv", False),
    ("response.md", "isodesign transmissibility --floor-amplitude 1,10,100um", False),
    ("optimization.md", "isodesign optimize --builtin vertical -o out/optimize", True),
    ("optimization.md", "isodesign pareto --builtin vertical -o out/pareto", True),
]

_VOLATILE = [
    (re.compile(r"\b\d+(\.\d+)? s\b"), "<time> s"),  # wall times
    (re.compile(r"[+-]?\d(\.\d+)?e-(0[7-9]|[1-9]\d)\b"), "<~0>"),  # round-off-sized
    (re.compile(r"(agrees with the NLP to )\S+"), r"\1<rel>"),
    (re.compile(r"\(\d+ closure iterations\)"), "(<n> closure iterations)"),
]


def normalize(line: str) -> str:
    """A line with its run-to-run variable parts blanked and its spacing made single."""
    line = " ".join(line.split())
    for pat, rep in _VOLATILE:
        line = pat.sub(rep, line)
    return line


def block(doc: str, command: str) -> tuple[int, int, list[str]]:
    """(first, end) line indices of the output shown after ``$ command``, and the lines."""
    lines = (DOCS / doc).read_text(encoding="utf-8").splitlines()
    starts = [i for i, ln in enumerate(lines) if ln.split("#")[0].strip() == f"$ {command}"]
    assert len(starts) == 1, f"{doc}: {len(starts)} blocks for '$ {command}'"
    i = starts[0] + 1
    j = i
    while j < len(lines) and not lines[j].startswith("```") and not lines[j].startswith("$ "):
        j += 1
    return i, j, lines[i:j]


def run_command(command: str, cwd: Path) -> list[str]:
    """stdout then stderr of ``command`` run in ``cwd`` (in-process)."""
    argv = shlex.split(command)[1:]
    out, err = io.StringIO(), io.StringIO()
    old = Path.cwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            status = main(argv)
    finally:
        os.chdir(old)
    assert status == 0, err.getvalue()
    return out.getvalue().splitlines() + err.getvalue().splitlines()


def _matches(shown: str, actual: str) -> bool:
    s, a = normalize(shown), normalize(actual)
    if s.endswith("...)") or s.endswith("..."):
        return a.startswith(s.rstrip(".)").rstrip())
    return s == a


def missing_lines(shown: list[str], actual: list[str]) -> list[str]:
    """The shown lines not found, in order, in ``actual`` (``...`` skips any lines)."""
    k = 0
    bad = []
    skipping = False
    for s in shown:
        if not s.strip():
            continue
        if s.strip() == "...":
            skipping = True
            continue
        j = k
        while j < len(actual) and not _matches(s, actual[j]):
            if not skipping and actual[j].strip():
                break
            j += 1
        if j < len(actual) and _matches(s, actual[j]):
            k = j + 1
            skipping = False
        else:
            bad.append(s)
    return bad


@pytest.mark.parametrize(
    ("doc", "command", "slow"),
    [pytest.param(*x, marks=[pytest.mark.slow] if x[2] else []) for x in LISTINGS],
    ids=[f"{d}:{c.split()[1]}" for d, c, _ in LISTINGS],
)
def test_the_listing_is_what_the_command_prints(doc, command, slow, tmp_path):
    i, j, shown = block(doc, command)
    actual = run_command(command, tmp_path)
    if os.environ.get("ISODESIGN_UPDATE_LISTINGS"):
        path = DOCS / doc
        lines = path.read_text(encoding="utf-8").splitlines()
        path.write_text("\n".join([*lines[:i], *actual, *lines[j:]]) + "\n", encoding="utf-8")
        return
    bad = missing_lines(shown, actual)
    assert not bad, (f"{doc}: the listing of '$ {command}' drifted; not printed now: {bad[:5]}"
                     "\nprinted now:\n" + "\n".join(actual))


def test_the_matcher_skips_only_where_the_document_says_so():
    actual = ["a 1", "b 2.5 s", "c", "d", "e"]
    assert missing_lines(["a 1", "b 7.1 s", "...", "e"], actual) == []
    assert missing_lines(["a 1", "c"], actual) == ["c"]  # no "..." between: b is not skipped
    assert missing_lines(["a 1", "b 1 s", "c", "d", "e 2"], actual) == ["e 2"]
    assert missing_lines(["a ..."], ["a 1 and more"]) == []


def test_readme_models_table_gives_the_springs_and_the_studys_defaults():
    import inspect

    from isodesign.optimization.study import vertical_study
    from isodesign.response import band_response
    from isodesign.spring.stiffness import complex_stiffness

    readme = (DOCS.parent / "README.md").read_text(encoding="utf-8")
    rows = {}
    for ln in readme.splitlines():
        m = re.match(r"\| `(\w+)`[^|]*\| `(\w+)` \| `(\w+)` \|", ln)
        if m:
            rows[m.group(1)] = (m.group(2), m.group(3))
    assert set(rows) == {"flow", "amplitude_mode", "diaphragm", "random_method",
                         "acoustics"}, rows
    spring = inspect.signature(complex_stiffness).parameters
    response = inspect.signature(band_response).parameters
    study = vertical_study().models
    # the acoustics is a field of the design (issue 16), the study's [models] key too
    import dataclasses

    from isodesign.spring.design import SpringDesign

    lib, st = rows.pop("acoustics")
    field = {f.name: f for f in dataclasses.fields(SpringDesign)}["acoustics"]
    assert field.default == lib and study["acoustics"] == st, (field.default, lib, st)
    for key, (lib, st) in rows.items():
        sig = spring if key in spring else response
        assert sig[key].default == lib, (key, sig[key].default, lib)
        assert response[key].default == lib, key
        assert study[key] == st, (key, study[key], st)


def test_no_file_cites_a_document_outside_the_repository():
    root = DOCS.parent
    files = [*root.glob("isodesign/**/*.py"), *root.glob("docs/**/*.md"), root / "README.md",
             *root.glob("studies/**/*.py"), *root.glob("isodesign/data/*")]
    bad = [str(p.relative_to(root)) for p in files
           if p.is_file() and re.search(r"physics[ -]notes", p.read_text(encoding="utf-8",
                                                                         errors="replace"), re.I)]
    assert not bad, bad
