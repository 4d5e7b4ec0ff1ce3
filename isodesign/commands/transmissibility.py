"""Transmissibility of a payload on its isolators for harmonic floor motion.

For every frequency (--freq) and floor displacement amplitude (--floor-amplitude) the
spring's stroke X_s = |T(X_s) - 1| X_f is solved self-consistently; where several strokes
exist (jump phenomenon near resonance) the --branch one is returned and the point is
counted. Prints the peak |T| per floor amplitude; -o writes one CSV row per point, --plot
a figure (|T| in dB with its phase, and the stroke). The input, payload and model options
are those of ``isodesign response``: a study file or a run directory supplies the payload
and the models, a design file its recorded [models].

Value lists: comma list (1e-6,1e-5) or log-spaced range start:stop:count (0.5:50:200);
amplitudes in metres, or with a unit suffix mm or um for the whole list (1,10um).
"""

from __future__ import annotations

import argparse

from isodesign.commands import (
    FREQUENCY_UNITS,
    LENGTH_UNITS,
    PLOT_SUFFIXES,
    check_grid_size,
    check_output_path,
    option_names,
    parse_values,
    write_result,
)
from isodesign.commands.response import (
    _db,
    add_payload_arguments,
    check_payload_pressure,
    models_line,
    resolve_job,
    save_plot,
    without_plot,
)
from isodesign.domain import AMPLITUDE_DOMAIN_M, FREQUENCY_DOMAIN_HZ
from isodesign.errors import ModelValidityWarning
from isodesign.response import harmonic_response
from isodesign.response.harmonic import BRANCHES

#: Default floor amplitudes (m) and frequency range.
DEFAULT_FLOOR_AMPLITUDES = "1e-6,1e-5"
DEFAULT_FREQ = "0.5:50:200"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign transmissibility``."""
    add_payload_arguments(parser)
    parser.add_argument(
        "--floor-amplitude",
        default=DEFAULT_FLOOR_AMPLITUDES,
        metavar="LIST",
        help="floor displacement amplitudes, m (suffix mm or um allowed); default %(default)s",
    )
    parser.add_argument(
        "--freq",
        default=DEFAULT_FREQ,
        metavar="LIST",
        help="frequencies, Hz: list or start:stop:count (log-spaced); default %(default)s",
    )
    parser.add_argument(
        "--branch",
        default="upper",
        choices=BRANCHES,
        help="stroke returned where several exist: upper (largest, default) or lower",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUT.csv",
        help="write one row per (frequency, amplitude) to this CSV ('-' = standard output)",
    )
    parser.add_argument(
        "--plot", metavar="OUT.png",
        help="plot |T| in dB, its phase and the stroke vs frequency (PNG, PDF or SVG)",
    )


def summary(res, design_label: str, derived: bool, models_source: str = "options") -> str:
    """Header, linear figures and the peak per floor amplitude."""
    import numpy as np


    s = res.stability
    p = res.payload
    f = res.frequency_hz
    lines = [
        f"transmissibility: {design_label}; payload {p.mass_kg:g} kg on {p.isolators} "
        f"isolators, p0 = {s.pressure_pa / 1e5:.4g} bar "
        + ("(from the payload)" if derived else "(design's own)"),
        models_line({"flow": s.flow, "amplitude_mode": s.amplitude_mode,
                     "diaphragm": s.diaphragm,
                     "acoustics": getattr(res.design, "acoustics", None)}, models_source),
        f"  {f.size} frequencies {f.min():.4g}..{f.max():.4g} Hz; {res.branch} branch",
        f"  natural frequency {s.natural_frequency_hz:.4g} Hz; linear peak |T| "
        f"{_db(s.peak_transmissibility):.2f} dB at {s.peak_frequency_hz:.4g} Hz",
        f"  {'floor ampl.':>11}  {'peak |T|':>8}  {'at (Hz)':>8}  {'max stroke':>10}  "
        f"{'multi-root':>10}",
        f"  {'':>11}  {'(dB)':>8}",
    ]
    for j, xf in enumerate(res.floor_amplitude_m):
        lines.append(
            f"  {xf * 1e6:>8.4g} um  {_db(res.peak_transmissibility[j]):>8.2f}  "
            f"{res.peak_frequency_hz[j]:>8.4g}  {np.max(res.stroke_m[:, j]) * 1e6:>7.4g} um  "
            f"{int(np.sum(res.multiple_roots[:, j])):>10d}"
        )
    return "\n".join(lines)


def run(args) -> int:
    """Run ``isodesign transmissibility``."""
    import warnings


    freq = parse_values(args.freq, "--freq", units=FREQUENCY_UNITS, unit_name="Hz",
                        domain=FREQUENCY_DOMAIN_HZ)
    amp = parse_values(args.floor_amplitude, "--floor-amplitude", units=LENGTH_UNITS,
                       unit_name="m", domain=AMPLITUDE_DOMAIN_M)
    check_grid_size(len(freq), len(amp), "--freq", "--floor-amplitude")
    check_output_path(args.output, "--output")
    check_output_path(args.plot, "--plot", suffixes=PLOT_SUFFIXES)
    with option_names(floor="--floor", target="--target", diaphragm="--diaphragm"):
        job = resolve_job(args)
    if job.study is not None:  # the 1-DOF payload's |T|: not a table's (six DOFs)
        from isodesign.optimization.dispatch import refuse

        refuse(job.study, "isodesign transmissibility", scenarios=False)
    check_payload_pressure(job.design, job.payload, not args.design_pressure)
    m = job.models
    with option_names(diaphragm="--diaphragm"):
        res = harmonic_response(
            job.design,
            job.payload,
            freq,
            amp,
            flow=m["flow"],
            amplitude_mode=m["amplitude_mode"],
            diaphragm=m["diaphragm"],
            derive_pressure=not args.design_pressure,
            branch=args.branch,
            warn=False,
        )
    for line in res.warnings:
        warnings.warn(line, ModelValidityWarning, stacklevel=2)
    to_stdout = args.output == "-"
    status = write_result(res, without_plot(args), "" if to_stdout else summary(
        res, job.label, not args.design_pressure, job.models_source))
    if args.plot:
        peak = job.study.constraints.get("max_peak_transmissibility_db") if job.study else None
        peak = peak if isinstance(peak, int | float) and not isinstance(peak, bool) else None
        save_plot(res.plot(peak_limit_db=peak), args.plot)
        if not to_stdout:
            print(f"wrote {args.plot}")
    return status
