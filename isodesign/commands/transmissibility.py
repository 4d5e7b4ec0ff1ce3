"""Transmissibility for harmonic floor motion: of a table per point and axis, or of a payload.

A study with a [table] (a study file or an optimize run directory of one) is answered in six
degrees of freedom: for every floor amplitude the floor translates along x, y and z in turn,
each isolator's spring closed on its own stroke amplitude; prints the peak |T| per point and
axis (and the continuous peak at the band response's closure, the report's figure); -o writes
one CSV row per amplitude, frequency, point, floor axis and point axis, --plot |T| per axis
(:func:`isodesign.optimization.transmissibility.transmissibility`, the same answer in
Python). --payload-kg, --isolators, --design-pressure and --branch are refused there.

Otherwise, for every frequency (--freq) and floor displacement amplitude (--floor-amplitude) the
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
        choices=BRANCHES,
        help="stroke returned where several exist: upper (largest, default) or lower (a "
        "payload without [table]; a table's closure follows the branch reached from small "
        "amplitudes)",
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
    from isodesign.io.plausible import warn_option_slips

    warn_option_slips(floor_amplitude_m=amp)
    check_output_path(args.output, "--output")
    check_output_path(args.plot, "--plot", suffixes=PLOT_SUFFIXES)
    with option_names(floor="--floor", target="--target", diaphragm="--diaphragm"):
        job = resolve_job(args)
    if job.study is not None and job.study.table is not None:  # six DOFs, every point
        return run_table(args, job, freq, amp)
    check_payload_pressure(job.design, job.payload, not args.design_pressure)
    m = job.models
    with option_names(diaphragm="--diaphragm", amplitude_mode="--amplitude-mode"):
        res = harmonic_response(
            job.design,
            job.payload,
            freq,
            amp,
            flow=m["flow"],
            amplitude_mode=m["amplitude_mode"],
            diaphragm=m["diaphragm"],
            derive_pressure=not args.design_pressure,
            branch=args.branch or "upper",
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


def table_summary(res, label: str, models: dict, models_source: str) -> str:
    """Header and peaks of a table's transmissibility (:class:`TableTransmissibility`)."""
    t = res.model.table
    f = res.frequency_hz
    return "\n".join([
        f"transmissibility of the table: {label}; {t.mass_kg:g} kg on {t.n_isolators} "
        f"isolators, CG ({', '.join(f'{v:g}' for v in t.cg_m)}) m; points "
        + ", ".join(res.point_names),
        models_line({k: models.get(k) for k in ("flow", "amplitude_mode", "diaphragm")}
                    | {"acoustics": getattr(res.model.designs[0], "acoustics", None)},
                    models_source),
        f"  {f.size} frequencies {f.min():.4g}..{f.max():.4g} Hz; harmonic floor motion along "
        "x, y, z in turn, each isolator closed on its own stroke (the branch reached from "
        "small amplitudes)",
        res.text(),
    ])


def run_table(args, job, freq, amp) -> int:
    """``isodesign transmissibility`` of a study with a [table]: every point and axis.

    Parameters
    ----------
    args : argparse.Namespace
    job : types.SimpleNamespace
        :func:`~isodesign.commands.response.resolve_job`'s job (its study has a table).
    freq, amp : list of float
        The parsed ``--freq`` and ``--floor-amplitude``.
    """
    from isodesign.errors import InputError
    from isodesign.optimization.transmissibility import transmissibility
    from isodesign.reporting.inputs import input_kind, load_case

    for opt, given in (("--design-pressure", args.design_pressure),
                       ("--payload-kg", args.payload_kg is not None),
                       ("--isolators", args.isolators is not None),
                       ("--branch", args.branch is not None)):
        if given:
            raise InputError(f"{opt}: not available for a study with a [table] (its loads and "
                             "pressures come from the table's leveling, each isolator closed "
                             "on its own stroke; docs/table.md)")
    values = None
    if input_kind(args.design) == "optimize":  # a co-designed optimum: its levers' values
        values = (load_case(args.design).record or {}).get("design")
    m = job.models
    models = {k: m[k] for k in ("flow", "amplitude_mode", "diaphragm")}
    with option_names(frequency_hz="--freq", floor_amplitude_m="--floor-amplitude"):
        res = transmissibility(job.study, job.design, freq, amp, values=values, models=models)
    if not res.converged.all():
        warnings_line = (f"table closure did not converge at {int((~res.converged).sum())} of "
                         f"{res.converged.size} frequency-amplitude-axis points (flagged in "
                         "the CSV's converged column)")
        import warnings

        warnings.warn(warnings_line, ModelValidityWarning, stacklevel=2)
    to_stdout = args.output == "-"
    status = write_result(res, without_plot(args), "" if to_stdout else table_summary(
        res, job.label, models, job.models_source))
    if args.plot:
        save_plot(res.plot(), args.plot)
        if not to_stdout:
            print(f"wrote {args.plot}")
    return status
