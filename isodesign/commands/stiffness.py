"""Complex stiffness k*(X_p, f) of a dual-chamber spring over frequency x amplitude.

Evaluates the spring of DESIGN.toml (default: the paper's Table 1 reference
spring) at every frequency with every amplitude, prints a summary, and writes
one CSV row per point (stiffness, loss factor, flow diagnostics and validity
checks) with -o, a plot with --plot. Points outside a model's validity are
flagged in the CSV (ok_* and valid columns) and reported as warnings.

Value lists: comma list (0.2,1,5) or log-spaced range start:stop:count
(0.2:24:50). Frequencies in Hz; amplitudes in metres, or with a unit suffix
mm or um that applies to the whole list (0.05,0.15,0.5mm; 0.05:0.5:3mm).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from isodesign.commands import (
    FREQUENCY_UNITS,
    LENGTH_UNITS,
    check_acoustics,
    check_grid_size,
    check_output_path,
    input_error,
    option_names,
    parse_values,
    write_figure,
    write_frame,
)
from isodesign.domain import AMPLITUDE_DOMAIN_M, FREQUENCY_DOMAIN_HZ
from isodesign.errors import ModelValidityWarning
from isodesign.io.designfile import load_design
from isodesign.plotting import plot_stiffness
from isodesign.spring.design import SpringDesign

# The model choices come from the library's registries (declared once there). Loading them
# loads NumPy, not SciPy, pandas or CasADi; ``isodesign --help`` does not import this module.
from isodesign.spring.diaphragm import DIAPHRAGM_SPECS
from isodesign.spring.flow_models import FLOW_MODELS
from isodesign.spring.stiffness import AMPLITUDE_MODES, complex_stiffness

#: Frequencies of the paper's Table 2 (Hz), the default.
TABLE2_FREQUENCIES_HZ = (
    0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.8, 2.0, 2.2,
    2.4, 2.7, 3.0, 3.3, 3.7, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 12.0, 14.0, 16.0, 20.0, 24.0,
)  # fmt: skip
#: Default amplitudes (m): 0.05, 0.15 and 0.5 mm, low, middle and top of Table 2.
DEFAULT_AMPLITUDES_M = (0.05e-3, 0.15e-3, 0.5e-3)

#: File types of --plot.
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign stiffness``."""
    parser.add_argument(
        "design",
        nargs="?",
        metavar="DESIGN.toml",
        help="design file (docs/design-file.md); default: the paper's reference spring",
    )
    add_model_arguments(parser)
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUT.csv",
        help="write the table (one row per point) to this CSV file; '-' = standard output "
        "(then no summary is printed)",
    )
    parser.add_argument(
        "--plot", metavar="OUT.png", help="plot Re k and the loss factor vs frequency (PNG)"
    )


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """The grid and model options (shared with other commands)."""
    parser.add_argument(
        "--freq",
        metavar="LIST",
        help="frequencies, Hz: 0.2,1,5 or start:stop:count (log-spaced); "
        "default: the paper's Table 2, 35 values 0.2..24",
    )
    parser.add_argument(
        "--amplitude",
        metavar="LIST",
        help="piston displacement amplitudes, m (suffix mm or um allowed: 0.05,0.5mm, "
        "0.05:0.5:4mm); default 0.05,0.15,0.5mm",
    )
    parser.add_argument(
        "--flow",
        default="quasi_steady",
        choices=FLOW_MODELS,
        help="capillary flow model (default %(default)s; 'zhao' is the paper's Eq. 24)",
    )
    parser.add_argument(
        "--amplitude-mode",
        default="self_consistent",
        choices=AMPLITUDE_MODES,
        help="tube velocity amplitude: self_consistent (harmonic balance, default) or "
        "kinematic (the paper's Eq. 37; required by the zhao models)",
    )
    parser.add_argument(
        "--acoustics",
        choices=("distributed", "lumped"),
        help="acoustic model of tube and chambers (default: the design file's, else "
        "distributed; lumped is the paper's, docs/acoustics.md)",
    )
    parser.add_argument(
        "--diaphragm",
        default="viscoelastic",
        metavar="MODEL",
        help=f"{', '.join(DIAPHRAGM_SPECS.values())} (default viscoelastic, illustrative "
        "parameters; a table is measured k_D* on a frequency x amplitude grid)",
    )


def grid_from_args(args) -> tuple[list[float], list[float]]:
    """Frequencies (Hz) and amplitudes (m) from ``--freq`` and ``--amplitude``."""
    freq = (
        list(TABLE2_FREQUENCIES_HZ)
        if args.freq is None
        else parse_values(args.freq, "--freq", units=FREQUENCY_UNITS, unit_name="Hz",
                       domain=FREQUENCY_DOMAIN_HZ)
    )
    amp = (
        list(DEFAULT_AMPLITUDES_M)
        if args.amplitude is None
        else parse_values(args.amplitude, "--amplitude", units=LENGTH_UNITS, unit_name="m",
                       domain=AMPLITUDE_DOMAIN_M)
    )
    check_grid_size(len(freq), len(amp), "--freq", "--amplitude")
    return freq, amp


def load(path):
    """The design of ``path``, or the reference spring for ``None``; and its label."""

    if path is None:
        return SpringDesign.reference(), "reference spring (paper Table 1)"

    return load_design(path), str(path)


def model_label(flow: str, amplitude_mode: str, diaphragm: str) -> str:
    """Short label of a model combination."""
    return f"flow={flow}, amplitude_mode={amplitude_mode}, diaphragm={diaphragm}"


def compute(design, freq, amp, *, flow, amplitude_mode, diaphragm, label=None):
    """Run :func:`~isodesign.spring.stiffness.complex_stiffness`; a warning per failed check.

    Returns
    -------
    StiffnessResult
    """
    import warnings


    with option_names(diaphragm="--diaphragm", amplitude_mode="--amplitude-mode"):
        res = complex_stiffness(design, freq, amp, flow=flow, amplitude_mode=amplitude_mode,
                                diaphragm=diaphragm, warn=False)
    prefix = f"{label}: " if label else f"{flow}/{amplitude_mode}: "
    for line in res.warnings:
        warnings.warn(prefix + line, ModelValidityWarning, stacklevel=2)
    return res


def _fmt_amp(x_m: float) -> str:
    return f"{x_m * 1e3:.4g} mm"


def summary(res, *, title: str | None = None) -> str:
    """Compact text summary of a stiffness result (grid, range of k, peak loss factor).

    Assumes the grid layout of :func:`compute` (frequency x amplitude).
    """
    import numpy as np

    f = np.asarray(res.frequency_hz)
    x = np.asarray(res.amplitude_m)
    k = np.asarray(res.k)
    eta = np.asarray(res.loss_factor)
    valid = np.asarray(res.valid)
    if k.ndim != 2:  # pragma: no cover - compute() always builds a 2-D grid
        f, x, k, eta, valid = (a.reshape(-1, 1) for a in (f, x, k, eta, valid))
    d = res.design
    lines = []
    if title:
        lines.append(title)
    lines.append(f"  model: {model_label(res.flow, res.amplitude_mode, res.diaphragm)}")
    fs = f[:, 0]
    lines.append(
        f"  grid: {fs.size} frequencies {fs.min():.4g}..{fs.max():.4g} Hz x "
        f"{x.shape[1]} amplitudes = {k.size} points"
    )
    if d is not None:
        load = float(d.load_n)
        lines.append(
            f"  static: p0 = {d.pressure_pa / 1e3:.5g} kPa (abs.) carries {load:.5g} N "
            f"({load / 9.80665:.4g} kg) per spring"
        )
        lines.append(
            f"  air spring limits: k_s/(N+1) = {d.static_stiffness_n_per_m:.5g} N/m (static), "
            f"k_s = {d.single_chamber_stiffness_n_per_m:.5g} N/m (tube blocked)"
        )
    header = (
        f"  {'amplitude':>10}  {'Re k min':>10}  {'Re k max':>10}  {'peak eta':>8}  "
        f"{'at (Hz)':>7}  {'flagged':>7}"
    )
    lines.append(header)
    for j in range(k.shape[1]):
        col = eta[:, j]
        if np.all(np.isnan(col)):  # pragma: no cover - defensive
            i_pk, pk = 0, float("nan")
        else:
            i_pk = int(np.nanargmax(col))
            pk = float(col[i_pk])
        lines.append(
            f"  {_fmt_amp(float(x[0, j])):>10}  {k[:, j].real.min():>10.5g}  "
            f"{k[:, j].real.max():>10.5g}  {pk:>8.3f}  {float(f[i_pk, j]):>7.3g}  "
            f"{int(np.sum(~valid[:, j])):>7d}"
        )
    lines.append("  (Re k in N/m; eta = Im k / Re k)")
    nbad = int(np.sum(~valid))
    if nbad:
        lines.append(
            f"  flagged: {nbad} of {valid.size} points outside a model's validity "
            "(see the warnings; CSV columns ok_*, valid)"
        )
    else:
        lines.append(f"  flagged: none of {valid.size} points")
    return "\n".join(lines)


def write_csv(res, path) -> int:
    """Write ``res.to_frame()`` as CSV (full precision) to ``path`` ('-' = stdout)."""

    return write_frame(res.to_frame(), path)


def run(args) -> int:
    """Run ``isodesign stiffness``."""
    freq, amp = grid_from_args(args)
    check_output_path(args.output, "--output")
    check_output_path(args.plot, "--plot")
    if args.plot and Path(args.plot).suffix.lower() not in PLOT_SUFFIXES:
        raise input_error(
            f"--plot: unsupported file type {Path(args.plot).suffix or '(none)'!r}; "
            f"valid: {', '.join(PLOT_SUFFIXES)}"
        )
    import warnings

    with warnings.catch_warnings(record=True) as loaded:
        warnings.simplefilter("always")
        design, label = load(args.design)
    if args.acoustics is not None:
        design = design.replace(acoustics=args.acoustics)
        label += f", {args.acoustics} acoustics"
    check_acoustics(design, args.flow, args.acoustics)  # its one line replaces the file's
    for w in loaded:  # warning on lumped + heat exchange (or --acoustics made it moot)
        if "with chamber_heat_exchange = true" not in str(w.message):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    res = compute(
        design,
        freq,
        amp,
        flow=args.flow,
        amplitude_mode=args.amplitude_mode,
        diaphragm=args.diaphragm,
    )
    to_stdout = args.output == "-"
    if not to_stdout:
        print(summary(res, title=f"complex stiffness: {label}"))
    if args.output:
        n = write_csv(res, args.output)
        if not to_stdout:
            print(f"wrote {args.output} ({n} rows)")
    if args.plot:

        with write_figure(args.plot) as tmp:
            plot_stiffness(tmp, [res], title=label)
        if not to_stdout:
            print(f"wrote {args.plot}")
    return 0
