"""Payload band response on a vibrating floor, and compliance with a vibration criterion.

A payload of --payload-kg (default 100 kg per isolator) on --isolators identical springs
(DESIGN.toml, default: the paper's reference spring) stands on a floor given as a
criterion name (VC-A: the floor exactly on the curve) or a CSV spectrum. The spring's
amplitude dependence is closed self-consistently on the RMS stroke (equivalent
linearization). Prints one row per one-third-octave band (floor, payload, target, margin
in dB) and a PASS/FAIL verdict with the worst band; -o writes the table as CSV, --plot a
figure. The chamber pressure is derived from the payload weight unless --design-pressure.
See docs/response.md.
"""

from __future__ import annotations

import argparse

from isodesign.commands import int_option as _int_option

# The model choices come from the library's registries (declared once there). Loading them
# loads NumPy, not SciPy, pandas or CasADi; ``isodesign --help`` does not import this module.
from isodesign.response.random_input import RANDOM_METHODS
from isodesign.spring.diaphragm import DIAPHRAGM_SPECS
from isodesign.spring.flow_models import FLOW_MODELS
from isodesign.spring.stiffness import AMPLITUDE_MODES

#: Default load per isolator (kg) when --payload-kg is not given.
DEFAULT_KG_PER_ISOLATOR = 100.0
#: Library parameter -> the option a user typed (error messages).
RESPONSE_OPTION_NAMES = {"floor": "--floor", "target": "--target", "diaphragm": "--diaphragm",
                         "bands": "--bands"}
#: Ranges of the counts a user gives: --isolators, --points-per-band.
ISOLATORS_RANGE = (1, 1000)
POINTS_PER_BAND_RANGE = (2, 2000)


def add_payload_arguments(parser: argparse.ArgumentParser) -> None:
    """Design file, payload and spring-model options (shared with ``transmissibility``)."""
    parser.add_argument(
        "design",
        nargs="?",
        metavar="DESIGN.toml",
        help="design file (docs/design-file.md); default: the paper's reference spring",
    )
    parser.add_argument(
        "--payload-kg",
        type=float,
        metavar="KG",
        help="total payload mass carried by all isolators, kg "
        f"(default {DEFAULT_KG_PER_ISOLATOR:g} kg per isolator)",
    )
    parser.add_argument(
        "--isolators",
        type=_int_option,
        default=4,
        metavar="N",
        help="number of isolators (1..1000; default 4)",
    )
    parser.add_argument(
        "--design-pressure",
        action="store_true",
        help="use the design's own p0 instead of deriving it from the payload weight",
    )
    parser.add_argument(
        "--flow",
        default="quasi_steady",
        choices=FLOW_MODELS,
        help="capillary flow model (default %(default)s)",
    )
    parser.add_argument(
        "--amplitude-mode",
        default="self_consistent",
        choices=AMPLITUDE_MODES,
        help="tube velocity amplitude of the spring model (default %(default)s)",
    )
    parser.add_argument(
        "--diaphragm",
        default="viscoelastic",
        metavar="MODEL",
        help=f"{', '.join(DIAPHRAGM_SPECS.values())} (default viscoelastic, illustrative "
        "parameters)",
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign response``."""
    add_payload_arguments(parser)
    parser.add_argument(
        "--floor",
        default="VC-A",
        metavar="NAME|FILE.csv",
        help="floor: criterion name (the floor exactly on the curve) or a CSV spectrum "
        "(docs/criteria.md, section 4); default %(default)s",
    )
    parser.add_argument(
        "--target",
        default="VC-E",
        metavar="NAME|FILE.csv",
        help="the instrument's criterion: name or CSV curve; default %(default)s",
    )
    parser.add_argument(
        "--bands",
        metavar="FMIN:FMAX",
        help="band range, nominal centres in Hz (default: the target's bands within the floor)",
    )
    parser.add_argument(
        "--points-per-band",
        type=_int_option,
        default=50,
        metavar="N",
        help="integration points per band (2..2000; default %(default)s)",
    )
    parser.add_argument(
        "--random-method",
        default="equivalent_amplitude",
        choices=RANDOM_METHODS,
        help="spring amplitude of the random closure: A* = 1.88 sigma (default) or the "
        "Rayleigh average",
    )
    parser.add_argument(
        "--spacing-m", type=float, metavar="M", help="narrowest isolator spacing (tilt margin)"
    )
    parser.add_argument(
        "--cg-height-m",
        type=float,
        metavar="M",
        help="centre-of-gravity height above the diaphragms (tilt margin)",
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUT.csv",
        help="write the band table to this CSV file ('-' = standard output, no summary)",
    )
    parser.add_argument(
        "--plot", metavar="OUT.png", help="plot floor, payload and target, and |T| (PNG)"
    )


def load_design(path):
    """The design of ``path`` (or the reference spring) and its label."""
    from isodesign.spring.design import SpringDesign

    if path is None:
        return SpringDesign.reference(), "reference spring (paper Table 1)"
    from isodesign.io.designfile import load_design as _load

    return _load(path), str(path)


def make_payload(args, **extra):
    """The Payload of ``--payload-kg`` and ``--isolators`` (InputError naming the option)."""
    from isodesign.commands import check_count
    from isodesign.errors import InputError
    from isodesign.response.isolator import Payload

    n = check_count(args.isolators, "--isolators", *ISOLATORS_RANGE)
    mass = DEFAULT_KG_PER_ISOLATOR * n if args.payload_kg is None else args.payload_kg
    if not mass > 0 or mass == float("inf"):
        raise InputError(f"--payload-kg: must be finite and > 0 kg, got {args.payload_kg}")
    for opt, v in extra.items():
        if v is not None and not (0 < v < float("inf")):
            raise InputError(f"--{opt.replace('_', '-')}: must be finite and > 0 m, got {v}")
    return Payload(mass, n, **extra)


def check_payload_pressure(design, payload, derive: bool = True) -> None:
    """InputError naming ``--payload-kg`` if the payload needs a non-finite chamber pressure.

    (A finite pressure beyond the model's validity is flagged by the analysis, not refused.)
    """
    import math

    from isodesign.errors import InputError
    from isodesign.spring.gas import P_ATM

    if not derive:
        return
    p0 = P_ATM + payload.load_per_isolator_n / float(design.piston_area_m2)
    if not math.isfinite(p0):
        raise InputError(
            f"--payload-kg: {payload.mass_kg:g} kg on {payload.isolators} isolators needs a "
            f"chamber pressure beyond floating point ({p0:g} Pa); give a physical payload"
        )


def _bands(spec):
    from isodesign.errors import InputError

    if spec is None:
        return None
    import math

    parts = spec.split(":")
    try:
        lo, hi = (float(p) for p in parts)
    except ValueError:
        raise InputError(f"--bands: expected FMIN:FMAX in Hz, got {spec[:40]!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise InputError(f"--bands: FMIN and FMAX must be finite with 0 < FMIN <= FMAX Hz, "
                         f"got {spec[:40]!r}")
    return (lo, hi)


def format_table(res) -> str:
    """The band table and the verdict as text (um/s, dB)."""
    lines = [
        f"  {'band':>6}  {'floor':>9}  {'payload':>9}  {'target':>9}  {'margin':>7}  pass",
        f"  {'(Hz)':>6}  {'(um/s)':>9}  {'(um/s)':>9}  {'(um/s)':>9}  {'(dB)':>7}",
    ]
    for i, lab in enumerate(res.bands.labels):
        lines.append(
            f"  {lab:>6}  {res.floor_velocity_rms_m_s[i] * 1e6:>9.4g}  "
            f"{res.payload_velocity_rms_m_s[i] * 1e6:>9.4g}  "
            f"{res.limit_velocity_rms_m_s[i] * 1e6:>9.4g}  {res.margin_db[i]:>+7.2f}  "
            f"{'yes' if res.band_passes[i] else 'NO'}"
        )
    return "\n".join(lines)


def summary(res, design_label: str, derived: bool) -> str:
    """Header lines, the table and the verdict."""
    s = res.stability
    p = res.payload
    lines = [
        f"band response: {design_label}; payload {p.mass_kg:g} kg on {p.isolators} isolators "
        f"({p.mass_per_isolator_kg:g} kg each), p0 = {s.pressure_pa / 1e5:.4g} bar "
        + ("(from the payload)" if derived else "(design's own)"),
        f"  floor {res.floor_name}; target {res.target_name}; "
        f"model flow={res.flow}, amplitude_mode={res.amplitude_mode}, "
        f"diaphragm={res.diaphragm}; random closure {res.random_method}",
        f"  natural frequency {s.natural_frequency_hz:.4g} Hz; peak |T| "
        f"{s.peak_transmissibility:.4g} at {s.peak_frequency_hz:.4g} Hz (linear), "
        f"{s.excited_peak_transmissibility:.4g} at {s.excited_peak_frequency_hz:.4g} Hz "
        "(at A*)",
        f"  stroke RMS {res.stroke_rms_m * 1e6:.4g} um, A* = {res.equivalent_amplitude_m * 1e6:.4g}"
        f" um ({res.iterations} closure iterations); Zener damping ratio "
        f"{s.zener_damping_ratio:.3g} (optimum {s.zener_optimal_damping_ratio:.3g})",
    ]
    if s.tilt_margin is not None:
        lines.append(
            f"  tilt margin {s.tilt_margin:.3g} "
            + ("(stable)" if s.tilt_stable else "(UNSTABLE in rocking: < 1)")
        )
    lines.append(format_table(res))
    lines.append(res.verdict())
    return "\n".join(lines)


def run(args) -> int:
    """Run ``isodesign response``."""
    import warnings

    from isodesign.commands import (
        PLOT_SUFFIXES,
        check_count,
        check_output_path,
        option_names,
        write_result,
    )
    from isodesign.errors import ModelValidityWarning
    from isodesign.response import band_response

    check_output_path(args.output, "--output")
    check_output_path(args.plot, "--plot", suffixes=PLOT_SUFFIXES)
    check_count(args.points_per_band, "--points-per-band", *POINTS_PER_BAND_RANGE)
    payload = make_payload(args, spacing_m=args.spacing_m, cg_height_m=args.cg_height_m)
    design, label = load_design(args.design)
    check_payload_pressure(design, payload, not args.design_pressure)
    with option_names(**RESPONSE_OPTION_NAMES):
        res = band_response(
            design,
            payload,
            args.floor,
            args.target,
            bands=_bands(args.bands),
            points_per_band=args.points_per_band,
            flow=args.flow,
            amplitude_mode=args.amplitude_mode,
            diaphragm=args.diaphragm,
            random_method=args.random_method,
            derive_pressure=not args.design_pressure,
            warn=False,
        )
    for line in res.warnings:
        warnings.warn(f"spring model at A*: {line}", ModelValidityWarning, stacklevel=2)
    to_stdout = args.output == "-"
    return write_result(res, args, "" if to_stdout else summary(res, label,
                                                                not args.design_pressure))
