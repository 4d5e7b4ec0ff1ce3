"""The cost of the distortion power (issue 26): the band response with ``distortion=True``
over the one without, interleaved medians in one run, for the vertical study's start design
(``isodesign.optimization.study.vertical_study()``, the 1-DOF ``band_response``) and the
built-in table (``table_study()``, ``table_band_response``), target <= 1.5 each.

The optimizer's cost with the distortion (``[models] distortion = true``, the outer fixed point
of ``docs/random-response.md`` section 3d): ``isodesign.optimize`` of the same two studies with
and without it, interleaved pairs (:data:`OPTIMIZE_PAIRS`, each a whole optimization), the
ratio of the medians; reported, no target of its own (the decision on the default is in the
docs, section 3d).

Run alone with ``python benchmarks/bench_distortion.py`` (prints the rows) or through
``python benchmarks/run.py distortion -o /tmp/out.md``.
"""

from __future__ import annotations

import statistics
import time
import warnings

#: Target: the band response with the distortion power at most this times the one without.
TARGET_DISTORTION_RATIO = 1.5
#: Interleaved (without, with) pairs of the optimize rows: each is a whole optimization
#: (``ISODESIGN_BENCH_OPT_PAIRS`` overrides).
OPTIMIZE_PAIRS = 2


def _vertical():
    """``dist -> BandResponse`` of the vertical study's start design, its models and bands."""
    from isodesign.optimization.study import vertical_study
    from isodesign.response import band_response

    st = vertical_study()
    m = st.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"], "diaphragm": m["diaphragm"]}
    d = st.start_design()

    def call(dist: bool):
        return band_response(d, st.payload, st.floor, st.target, bands=st.bands, warn=False,
                             distortion=dist, **kw)

    return call


def _table():
    """``dist -> TableBandResponse`` of the built-in table at its start values."""
    from isodesign.optimization.study import table_study
    from isodesign.table.response import table_band_response

    st = table_study()
    m = st.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"], "diaphragm": m["diaphragm"]}
    vals = {v.name: v.start for v in st.variables}
    d, table = st.design_at(vals), st.table_at(vals)

    def call(dist: bool):
        return table_band_response(d, table, st.floor_axes, st.target, bands=st.bands,
                                   warn=False, distortion=dist, **kw)

    return call


def _ratio_row(name: str, call, describe) -> dict:
    """Interleaved timing of ``call(False)`` and ``call(True)``; the ratio of the medians.

    Parameters
    ----------
    name : str
        The row's name.
    call : callable
        ``dist -> result``.
    describe : callable
        ``(without, with) -> str``: the figures for the notes.

    Returns
    -------
    dict
        A result row.
    """
    from run import MIN_REPEATS, repeats

    res = {dist: call(dist) for dist in (False, True)}  # warm-up
    times: dict[bool, list[float]] = {False: [], True: []}
    cpu: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(max(repeats(), MIN_REPEATS)):
        for dist in (False, True):
            t0, c0 = time.perf_counter(), time.process_time()
            call(dist)
            times[dist].append(time.perf_counter() - t0)
            cpu[dist].append(time.process_time() - c0)
    med = {k: statistics.median(v) for k, v in times.items()}
    ratio = med[True] / med[False]
    # the process's CPU time too: less moved by other processes on a shared machine
    cpu_ratio = statistics.median(cpu[True]) / statistics.median(cpu[False])
    pairs = [w / wo for w, wo in zip(times[True], times[False], strict=True)]  # interleaved
    return {
        "name": name,
        "target": f"<= {TARGET_DISTORTION_RATIO:g}",
        "unit": "ratio",
        "median": ratio,
        "min": min(pairs),  # the spread of the interleaved pairs' ratios
        "max": max(pairs),
        "repeats": len(times[True]),
        "ratio": ratio / TARGET_DISTORTION_RATIO,
        "passed": ratio <= TARGET_DISTORTION_RATIO,
        "notes": (f"medians {med[True] * 1e3:.1f} ms with, {med[False] * 1e3:.1f} ms without "
                  f"(CPU-time ratio {cpu_ratio:.2f}); " + describe(res[False], res[True])),
    }


def bench_vertical_distortion() -> dict:
    """The vertical study's start design: ``band_response(..., distortion=True)`` / without.

    Returns
    -------
    dict
        A result row.
    """
    def describe(r0, r1):
        return (f"{r1.iterations} closure evaluations (against {r0.iterations}); stroke RMS "
                f"{r1.stroke_rms_m * 1e6:.4g} um (without {r0.stroke_rms_m * 1e6:.4g} um), "
                f"tube velocity RMS {r1.tube_velocity_rms_m_s:.4g} m/s "
                f"(without {r0.tube_velocity_rms_m_s:.4g} m/s)")

    return _ratio_row("vertical study: band response with the distortion / without",
                      _vertical(), describe)


def bench_table_distortion() -> dict:
    """The built-in table: ``table_band_response(..., distortion=True)`` / without.

    Returns
    -------
    dict
        A result row.
    """
    def describe(r0, r1):
        return (f"{r1.iterations} closure evaluations (against {r0.iterations}); "
                f"{len(r1.stroke_rms_m)} isolators, stroke RMS up to "
                f"{r1.stroke_rms_m.max() * 1e6:.4g} um (without "
                f"{r0.stroke_rms_m.max() * 1e6:.4g} um)")

    return _ratio_row("built-in table: band response with the distortion / without",
                      _table(), describe)


def bench_optimize_distortion(which: str) -> dict:
    """``isodesign.optimize`` of the built-in ``which`` study (``vertical`` or ``table``) with
    ``models.distortion = true`` over without, interleaved pairs.

    Parameters
    ----------
    which : {'vertical', 'table'}
        ``vertical_study()`` or ``table_study()``.

    Returns
    -------
    dict
        A result row.
    """
    import os

    import isodesign
    from isodesign.optimization.study import table_study, vertical_study

    base = vertical_study() if which == "vertical" else table_study()
    studies = {d: base.with_changes({"models.distortion": d}) for d in (False, True)}
    pairs = int(os.environ.get("ISODESIGN_BENCH_OPT_PAIRS", OPTIMIZE_PAIRS))
    times: dict[bool, list[float]] = {False: [], True: []}
    res = {}
    for _ in range(max(1, pairs)):
        for dist in (False, True):
            t0 = time.perf_counter()
            res[dist] = isodesign.optimize(studies[dist])
            times[dist].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    ratio = med[True] / med[False]
    pr = [w / wo for w, wo in zip(times[True], times[False], strict=True)]
    r0, r1 = res[False], res[True]
    rounds = (r1.settings.get("distortion_outer_rounds") if which == "vertical"
              else r1.distortion_outer_rounds)
    return {
        "name": f"{which} study: optimize with the distortion / without",
        "target": "reported", "unit": "ratio", "median": ratio, "min": min(pr),
        "max": max(pr), "repeats": len(pr), "ratio": "", "passed": None,
        "notes": (f"medians {med[True]:.1f} s with, {med[False]:.1f} s without "
                  f"({studies[True].solver['starts']} starts); worst margin (NLP) "
                  f"{r1.objective_value:.4f} dB with, {r0.objective_value:.4f} dB without; "
                  f"analysis {r1.worst_margin_db:.4f} dB with, {r0.worst_margin_db:.4f} dB "
                  f"without; {rounds} outer rounds for the answer"),
    }


def run() -> list[dict]:
    """The distortion's cost rows.

    Returns
    -------
    list of dict
        One row per benchmark.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [bench_vertical_distortion(), bench_table_distortion(),
                bench_optimize_distortion("vertical"), bench_optimize_distortion("table")]


if __name__ == "__main__":
    for row in run():
        print(row)
