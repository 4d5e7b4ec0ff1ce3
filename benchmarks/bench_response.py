"""Payload response (target): a full one-third-octave band response with the
self-consistent random-input linearization, default models, reference spring, 4 x 100 kg,
VC-A floor, VC-E target, 20 bands (1 to 80 Hz) x 50 points; plus informative rows (the
harmonic closures on the stroke, a harmonic sweep, the python-control transfer function);
and the Monte Carlo verifier (one 320 s realization of the reference case, target < 10 s).

Run alone with ``python benchmarks/bench_response.py`` (prints the rows) or through
``python benchmarks/run.py``.
"""

from __future__ import annotations

import warnings

from run import median_time

#: Target: a full band response in under 50 ms (median).
TARGET_BAND_RESPONSE_S = 0.05
#: Target of the Monte Carlo verifier: one 320 s realization in under 10 s on one core.
TARGET_MONTE_CARLO_S = 10.0


def _setup():
    from isodesign.response.isolator import Payload
    from isodesign.spring.design import SpringDesign

    return SpringDesign.reference(), Payload(400.0, 4)


def bench_band_response() -> dict:
    """The target: ``band_response(reference, 4 x 100 kg, "VC-A", "VC-E")``.

    Returns
    -------
    dict
        A result row.
    """
    from isodesign.response import band_response

    design, payload = _setup()
    holder = {}

    def call():
        holder["r"] = band_response(design, payload, "VC-A", "VC-E", warn=False)

    t = median_time(call)
    r = holder["r"]
    notes = (
        f"{len(r.bands)} bands x {r.grid.points_per_band} points = {r.grid.n_points} "
        f"frequencies (shared edges once); statistical closure, {r.iterations} evaluations "
        f"(nested secant in ln sigma, ln sigma_u) + 1 linear start; sigma = "
        f"{r.stroke_rms_m * 1e6:.3g} um, sigma_u = {r.tube_velocity_rms_m_s:.3g} m/s, "
        f"A* = {r.equivalent_amplitude_m * 1e6:.3g} um; includes the stability figures "
        f"(two peak searches) and the spring diagnostics; verdict: {r.verdict()}"
    )
    return {
        "name": "band response, default models (statistical linearization)",
        "target": f"< {TARGET_BAND_RESPONSE_S * 1e3:g} ms",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_BAND_RESPONSE_S,
        "passed": t["median"] < TARGET_BAND_RESPONSE_S,
        "notes": notes,
    }


def _informative_closure(random_method: str, name: str, detail: str) -> dict:
    """An informative row: the default band response with another ``random_method``.

    Parameters
    ----------
    random_method : str
        The closure to time.
    name : str
        The row's name.
    detail : str
        What one frequency costs (first part of the notes).

    Returns
    -------
    dict
        A result row (no target).
    """
    from isodesign.response import band_response

    design, payload = _setup()
    holder = {}

    def call():
        holder["r"] = band_response(
            design, payload, "VC-A", "VC-E", random_method=random_method, warn=False
        )

    t = median_time(call)
    r = holder["r"]
    return {
        "name": name,
        "target": "",
        "unit": "s",
        **t,
        "notes": f"{r.grid.n_points} frequencies{detail}; {r.iterations} closure "
        f"evaluations; sigma = {r.stroke_rms_m * 1e6:.4g} um",
    }


def bench_band_response_equivalent_amplitude() -> dict:
    """Informative: the same with the previous default, ``random_method="equivalent_amplitude"``.

    Returns
    -------
    dict
        A result row (no target).
    """
    return _informative_closure(
        "equivalent_amplitude", "band response, harmonic closure at A* = 1.880 sigma",
        ", self-consistent tube amplitude per frequency",
    )  # fmt: skip


#: Target: the band response with the distortion power at most this times the one without.
TARGET_DISTORTION_RATIO = 1.5


def bench_band_response_distortion() -> dict:
    """The band response with ``distortion=True`` against without, interleaved, in one run.

    Returns
    -------
    dict
        A result row (the ratio of the medians against its target).
    """
    import statistics
    import time

    from run import MIN_REPEATS, repeats

    from isodesign.response import band_response

    design, payload = _setup()
    holder = {}

    def call(dist):
        holder[dist] = band_response(design, payload, "VC-A", "VC-E", warn=False,
                                     distortion=dist)

    for dist in (False, True):
        call(dist)
    times = {False: [], True: []}
    for _ in range(max(repeats(), MIN_REPEATS)):
        for dist in (False, True):
            t0 = time.perf_counter()
            call(dist)
            times[dist].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    ratio = med[True] / med[False]
    r0, r1 = holder[False], holder[True]
    return {
        "name": "band response with the distortion power / without (interleaved medians)",
        "target": f"<= {TARGET_DISTORTION_RATIO:g}",
        "unit": "ratio",
        "median": ratio,
        "min": min(times[True]) / min(times[False]),
        "max": max(times[True]) / max(times[False]),
        "repeats": len(times[True]),
        "ratio": ratio / TARGET_DISTORTION_RATIO,
        "passed": ratio <= TARGET_DISTORTION_RATIO,
        "notes": (f"medians {med[True] * 1e3:.1f} ms with, {med[False] * 1e3:.1f} ms without; "
                  f"{r1.iterations} closure evaluations (against {r0.iterations}); stroke RMS "
                  f"{r1.stroke_rms_m * 1e6:.4g} um (without {r0.stroke_rms_m * 1e6:.4g} um)"),
    }


def bench_monte_carlo() -> dict:
    """The verifier's target: one 320 s realization of the reference case (no diaphragm).

    ``simulate_random_response(reference, 4 x 100 kg, "VC-A", seeds=1, duration_s=320,
    diaphragm="none")``: numba-compiled RK4 at 1/2048 s (20 s warm-up), FFT band analysis.
    The warm-up call of :func:`median_time` absorbs the compilation (cached on disk).

    Returns
    -------
    dict
        A result row.
    """
    from isodesign.simulation import simulate_random_response

    design, payload = _setup()
    holder = {}

    def call():
        holder["r"] = simulate_random_response(
            design, payload, "VC-A", target="VC-E", seeds=1, duration_s=320.0,
            diaphragm="none",
        )  # fmt: skip

    t = median_time(call)
    r = holder["r"]
    steps = round((r.duration_s + r.warmup_s) / r.time_step_s)
    return {
        "name": "Monte Carlo verifier, one 320 s realization",
        "target": f"< {TARGET_MONTE_CARLO_S:g} s",
        "unit": "s",
        **t,
        "ratio": t["median"] / TARGET_MONTE_CARLO_S,
        "passed": t["median"] < TARGET_MONTE_CARLO_S,
        "notes": f"{steps} RK4 steps of {r.time_step_s * 1e3:.3g} ms (numba), one core; "
        f"stroke RMS {r.stroke_rms_m * 1e6:.4g} um, tube velocity RMS "
        f"{r.tube_velocity_rms_m_s:.3g} m/s",
    }


def bench_band_response_rayleigh() -> dict:
    """Informative: the same with ``random_method="rayleigh"`` (16 nodes per frequency).

    Returns
    -------
    dict
        A result row (no target).
    """
    return _informative_closure(
        "rayleigh", "band response, Rayleigh-averaged closure", " x 16 nodes"
    )


def bench_harmonic_response() -> dict:
    """Informative: harmonic sweep, 200 frequencies x 2 floor amplitudes.

    Returns
    -------
    dict
        A result row (no target).
    """
    import numpy as np

    from isodesign.response import harmonic_response

    design, payload = _setup()
    f = np.geomspace(0.5, 50.0, 200)
    holder = {}

    def call():
        holder["h"] = harmonic_response(design, payload, f, [1e-6, 1e-5], warn=False)

    t = median_time(call)
    h = holder["h"]
    return {
        "name": "harmonic response, 200 frequencies x 2 amplitudes",
        "target": "",
        "unit": "s",
        **t,
        "notes": f"root scan 65 amplitudes per frequency, then regula falsi (max "
        f"{int(h.iterations.max())} iterations); stability figures included",
    }


def bench_transfer_function() -> dict:
    """Informative: ``to_transfer_function`` (quasi_steady, no diaphragm).

    Returns
    -------
    dict
        A result row (no target).
    """
    from isodesign.response import to_transfer_function

    design, payload = _setup()
    t = median_time(lambda: to_transfer_function(design, payload, flow="quasi_steady"))
    return {
        "name": "python-control transfer function (quasi_steady)",
        "target": "",
        "unit": "s",
        **t,
        "notes": "T(s) of the small-amplitude laminar limit, 4th order",
    }


def run() -> list[dict]:
    """All response benchmarks.

    Returns
    -------
    list of dict
        One row per benchmark.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [
            bench_band_response(),
            bench_band_response_distortion(),
            bench_band_response_equivalent_amplitude(),
            bench_band_response_rayleigh(),
            bench_harmonic_response(),
            bench_transfer_function(),
            bench_monte_carlo(),
        ]


if __name__ == "__main__":
    for row in run():
        print(row)
