"""benchmarks/run.py: the report, and ``--update`` keeping the sections it does not rerun."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).parents[1]


def _run_module():
    spec = importlib.util.spec_from_file_location("bench_run", ROOT / "benchmarks" / "run.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _info(date: str, commit: str) -> dict:
    return {"date (UTC)": date, "nproc": "2",
            "load average (1, 5, 15 min) at start": "0.1, 0.2, 0.3", "git commit": commit}


def test_update_keeps_other_sections_with_their_own_run():
    run = _run_module()
    first = run.render(_info("2026-01-01 00:00:00", "aaa"),
                       [(Path("bench_a.py"), "A.", [{"name": "a1", "median": 1.0, "unit": "s"}]),
                        (Path("bench_b.py"), "B.", [{"name": "b1", "median": 2.0, "unit": "s"}])],
                       "python benchmarks/run.py")
    kept = run.split_sections(first)
    assert set(kept) == {"bench_a.py", "bench_b.py"}
    second = run.render(_info("2026-02-02 00:00:00", "bbb"),
                        [(Path("bench_b.py"), "B.", [{"name": "b2", "median": 3.0, "unit": "s"}])],
                        "python benchmarks/run.py b --update", kept)
    a = second[second.index("## bench_a.py"):second.index("## bench_b.py")]
    b = second[second.index("## bench_b.py"):second.index("## Reproduce")]
    assert "| a1 |" in a and "commit aaa" in a and "2026-01-01" in a
    assert "| b2 |" in b and "| b1 |" not in b and "commit bbb" in b and "2026-02-02" in b


def test_a_report_without_run_lines_gets_the_header_run():
    run = _run_module()
    old = ("# Benchmarks\n\n## Machine\n\n| item | value |\n|---|---|\n"
           "| date (UTC) | 2025-05-05 05:05:05 |\n"
           "| load average (1, 5, 15 min) at start | 1, 2, 3 |\n"
           "| git commit | ccc |\n\n## bench_c.py\n\nC.\n\n| benchmark | target |\n|---|---|\n"
           "| c1 | < 1 |\n\n## Reproduce\n")
    c = run.split_sections(old)["bench_c.py"]
    assert ("Run: 2025-05-05 05:05:05 UTC, commit ccc, unknown x unknown, load average 1, 2, 3 "
            "at start." in c)
    assert "| c1 | < 1 |" in c


def test_bad_update_arguments_end_in_one_line_before_any_benchmark_runs(tmp_path, capsys,
                                                                        monkeypatch):
    """--update without names, a file that is no report (a section without its table, a
    binary file, a directory) and an unknown name: usage errors (exit 2), nothing run or
    written."""
    import pytest

    run = _run_module()
    monkeypatch.setattr(run, "load", lambda path: pytest.fail(f"ran {path}"))
    no_table = tmp_path / "notes.md"
    no_table.write_text("# Notes\n\n## bench_table.py\n\nsome text\n")
    binary = tmp_path / "bin.md"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    cases = [(["--update", "-o", str(no_table)], "--update: name the benchmark files"),
             (["table", "--update", "-o", str(no_table)], "not a report of benchmarks/run.py"),
             (["table", "--update", "-o", str(binary)], "not a report of benchmarks/run.py"),
             (["table", "--update", "-o", str(tmp_path)], "is a directory"),
             (["no_such_bench", "-o", str(tmp_path / "x.md")], "no benchmark file for")]
    for argv, words in cases:
        with pytest.raises(SystemExit) as exc:
            run.main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and words in err and "Traceback" not in err, argv
    assert no_table.read_text().startswith("# Notes") and not (tmp_path / "x.md").exists()


def test_a_merge_of_no_report_or_an_unwritable_output_is_refused_before_anything(
        tmp_path, capsys, monkeypatch):
    """--merge of a file that is no report (a text without the report's title, a script)
    wrote a report without sections; -o under a file ended in a traceback after the runs:
    usage errors (exit 2), nothing run or written."""
    import pytest

    run = _run_module()
    monkeypatch.setattr(run, "load", lambda path: pytest.fail(f"ran {path}"))
    text = tmp_path / "notes.md"
    text.write_text("hello\n")
    report = tmp_path / "report.md"
    report.write_text(run.render(_info("2026-01-01", "abc"), [], "python benchmarks/run.py"))
    cases = [(["--update", "--merge", str(text), "-o", str(tmp_path / "a.md")],
              "not a report of benchmarks/run.py"),
             (["--update", "--merge", str(ROOT / "benchmarks" / "run.py"), "-o",
               str(tmp_path / "b.md")], "not a report of benchmarks/run.py"),
             (["--update", "--merge", str(report), "-o", str(text)],
              "not a report of benchmarks/run.py"),
             (["--update", "--merge", str(report), "-o", str(report / "x.md")],
              "is a file")]
    for argv, words in cases:
        with pytest.raises(SystemExit) as exc:
            run.main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and words in err and "Traceback" not in err, argv
    assert text.read_text() == "hello\n"
    assert not (tmp_path / "a.md").exists() and not (tmp_path / "b.md").exists()
