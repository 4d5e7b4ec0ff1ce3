"""``isodesign response --verify-monte-carlo``: the closure against the time-domain verifier."""

from __future__ import annotations

import re

from isodesign.cli import main


def test_verify_monte_carlo_prints_the_band_errors(capsys):
    rc = main(["response", "--diaphragm", "none", "--verify-monte-carlo", "1",
               "--mc-duration-s", "40", "--bands", "1:10"])  # fmt: skip
    out, _ = capsys.readouterr()
    assert rc == 0
    assert "Monte Carlo: 1 seeds x 40 s" in out
    rows = [ln for ln in out.splitlines() if re.match(r"^\s+(1|1\.25|10)\s+\S+\s+\S+\s+nan", ln)]
    assert len(rows) == 3  # one seed: no standard error
    m = re.search(r"worst band \S+ Hz: ([+-]\d+\.\d+) dB", out)
    assert m and abs(float(m.group(1))) < 0.5


def test_verify_monte_carlo_bad_input_is_one_line(capsys):
    rc = main(["response", "--verify-monte-carlo", "0"])
    _, err = capsys.readouterr()
    assert rc == 2 and err.strip().startswith("isodesign: error: --verify-monte-carlo:")
    rc = main(["response", "--flow", "zhao", "--amplitude-mode", "kinematic",
               "--random-method", "equivalent_amplitude", "--verify-monte-carlo", "1"])
    _, err = capsys.readouterr()
    assert rc == 2 and "isodesign: error: --verify-monte-carlo: flow:" in err
    assert len([ln for ln in err.splitlines() if ln.startswith("isodesign: error")]) == 1
    assert "Traceback" not in err
