"""Payload band response on a vibrating floor, and compliance with a vibration criterion.

A payload of --payload-kg (default 100 kg per isolator) on --isolators identical springs
(DESIGN.toml, default: the paper's reference spring) stands on a floor given as a
criterion name (VC-A: the floor exactly on the curve) or a CSV spectrum. The input may
instead be a study file or an optimize/pareto run directory: its payload, floor, target,
judged bands and models are used (an option given on the command line still wins), and a
design file's [models] table (written by optimize) sets the models. The spring's
amplitude dependence is closed self-consistently on the RMS stroke (equivalent
linearization). Prints one row per one-third-octave band (floor, payload, target, margin
in dB) and a PASS/FAIL verdict with the worst band; -o writes the table as CSV, --plot a
figure. The chamber pressure is derived from the payload weight unless --design-pressure.
See docs/response.md.
"""

from __future__ import annotations

import argparse

from isodesign.commands import (
    PLOT_SUFFIXES,
    check_acoustics,
    check_count,
    check_output_path,
    option_names,
    write_figure,
    write_result,
)
from isodesign.commands import int_option as _int_option
from isodesign.errors import InputError, ModelValidityWarning
from isodesign.io.designfile import load_design as _load
from isodesign.io.designfile import load_design_models
from isodesign.optimization.analyze import vertical_band_response
from isodesign.plotting.style import save_figure
from isodesign.reporting.inputs import MODEL_DEFAULTS, input_kind, load_case
from isodesign.response.isolator import Payload

# The model choices come from the library's registries (declared once there). Loading them
# loads NumPy, not SciPy, pandas or CasADi; ``isodesign --help`` does not import this module.
from isodesign.response.random_input import RANDOM_METHODS
from isodesign.simulation.lumped import lumped_twin
from isodesign.simulation.monte_carlo import simulate_random_response
from isodesign.spring.design import ACOUSTIC_MODELS, SpringDesign
from isodesign.spring.diaphragm import DIAPHRAGM_SPECS
from isodesign.spring.flow_models import FLOW_MODELS
from isodesign.spring.gas import P_ATM, pressure_from_load
from isodesign.spring.stiffness import AMPLITUDE_MODES

#: Default load per isolator (kg) when --payload-kg is not given.
DEFAULT_KG_PER_ISOLATOR = 100.0
#: Library parameter -> the option a user typed (error messages).
RESPONSE_OPTION_NAMES = {"floor": "--floor", "target": "--target", "diaphragm": "--diaphragm",
                         "bands": "--bands", "amplitude_mode": "--amplitude-mode"}
#: Ranges of the counts a user gives: --isolators, --points-per-band.
ISOLATORS_RANGE = (1, 1000)
POINTS_PER_BAND_RANGE = (2, 2000)
#: Range of --verify-monte-carlo (seeds, each a time-domain simulation) and the longest
#: --mc-duration-s.
MONTE_CARLO_SEEDS_RANGE = (1, 1000)
MAX_MC_DURATION_S = 1e5


def add_payload_arguments(parser: argparse.ArgumentParser) -> None:
    """Design file, payload and spring-model options (shared with ``transmissibility``)."""
    parser.add_argument(
        "design",
        nargs="?",
        metavar="INPUT",
        help="design file (docs/design-file.md), study file, or an optimize/pareto run "
        "directory (its payload, floor, target, bands and models are used); default: the "
        "paper's reference spring",
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
        metavar="N",
        help="number of isolators (1..1000; default: the study's, else 4)",
    )
    parser.add_argument(
        "--design-pressure",
        action="store_true",
        help="use the design's own p0 instead of deriving it from the payload weight",
    )
    parser.add_argument(
        "--flow",
        choices=FLOW_MODELS,
        help="capillary flow model (default: the study's or design file's, else quasi_steady)",
    )
    parser.add_argument(
        "--amplitude-mode",
        choices=AMPLITUDE_MODES,
        help="tube velocity amplitude of the spring model (default: the study's or design "
        "file's, else self_consistent)",
    )
    parser.add_argument(
        "--acoustics",
        choices=ACOUSTIC_MODELS,
        help="acoustic model of tube and chambers: distributed (transmission line and "
        "acoustic volumes, docs/acoustics.md) or lumped (the paper's); default: the study's "
        "or design file's, else distributed",
    )
    parser.add_argument(
        "--diaphragm",
        metavar="MODEL",
        help=f"{', '.join(DIAPHRAGM_SPECS.values())} (illustrative parameters for "
        "viscoelastic; default: the study's or design file's, else viscoelastic)",
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign response``."""
    add_payload_arguments(parser)
    parser.add_argument(
        "--floor",
        metavar="NAME|FILE.csv",
        help="floor: criterion name (the floor exactly on the curve) or a CSV spectrum "
        "(docs/criteria.md, section 4); default: the study's, else VC-A",
    )
    parser.add_argument(
        "--target",
        metavar="NAME|FILE.csv",
        help="the instrument's criterion: name or CSV curve; default: the study's, else the "
        "built-in vertical study's (VC-C)",
    )
    parser.add_argument(
        "--bands",
        metavar="FMIN:FMAX",
        help="judged band range, nominal centres in Hz (default: the study's, else the "
        "target's bands within the floor)",
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
        choices=RANDOM_METHODS,
        help="closure of the random response: statistical linearization of the tube flow at "
        "its RMS velocity (default), or the older harmonic closures on the stroke, A* = 1.88 "
        "sigma or the Rayleigh average",
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
        "--plot", metavar="OUT.png",
        help="plot floor, payload and target in every band (judged ones shaded), and |T| in "
        "dB with its phase (PNG, PDF or SVG)",
    )
    parser.add_argument(
        "--verify-monte-carlo",
        type=_int_option,
        metavar="SEEDS",
        help="also simulate SEEDS random floor realizations in the time domain (nonlinear "
        "lumped model) and print the closure's error per band (docs/simulation.md)",
    )
    parser.add_argument(
        "--mc-duration-s",
        type=float,
        default=320.0,
        metavar="S",
        help="length of each Monte Carlo realization, s (default %(default)g)",
    )


def monte_carlo_table(res, mc, in_force=None) -> str:
    """The closure against the Monte Carlo verifier, per band (um/s, dB), and the RMS values.

    Parameters
    ----------
    res : BandResponse
        The closure of the model the simulator integrates (the lumped acoustics).
    mc : MonteCarloResult
    in_force : BandResponse, optional
        The closure of the model in force when it is another one (the distributed
        acoustics): one more line gives their largest difference over the simulated bands.
    """
    import numpy as np

    err = mc.error_db(res)
    se = mc.standard_error_db()
    lines = [
        f"Monte Carlo: {len(mc.seeds)} seeds x {mc.duration_s:g} s, dt = "
        f"{mc.time_step_s * 1e3:.3g} ms, flow={mc.flow}, diaphragm={mc.diaphragm} "
        f"({mc.seconds_per_realization:.2g} s per realization)",
        f"  {'band':>6}  {'closure':>9}  {'MC':>9}  {'MC s.e.':>7}  {'error':>7}",
        f"  {'(Hz)':>6}  {'(um/s)':>9}  {'(um/s)':>9}  {'(dB)':>7}  {'(dB)':>7}",
    ]
    idx = [list(res.bands.index).index(b) for b in mc.bands.index]
    for j, lab in enumerate(mc.bands.labels):
        lines.append(
            f"  {lab:>6}  {res.payload_velocity_rms_m_s[idx[j]] * 1e6:>9.4g}  "
            f"{mc.payload_velocity_rms_m_s[j] * 1e6:>9.4g}  {se[j]:>7.3f}  {err[j]:>+7.2f}"
        )
    worst = int(np.argmax(np.abs(err)))
    su = res.tube_velocity_rms_m_s
    lines.append(
        f"  worst band {mc.bands.labels[worst]} Hz: {err[worst]:+.2f} dB; stroke RMS "
        f"{res.stroke_rms_m * 1e6:.4g} um vs {mc.stroke_rms_m * 1e6:.4g} um "
        f"({100 * (res.stroke_rms_m / mc.stroke_rms_m - 1):+.1f} %); tube velocity RMS "
        + (f"{su:.3g} m/s vs " if su is not None else "")
        + f"{mc.tube_velocity_rms_m_s:.3g} m/s (kurtosis {mc.tube_velocity_kurtosis:.2f})"
    )
    if in_force is not None:
        diff = 20.0 * np.log10(np.asarray(in_force.payload_velocity_rms_m_s)[idx]
                               / np.asarray(res.payload_velocity_rms_m_s)[idx])
        k = int(np.argmax(np.abs(diff)))
        lines.append(
            "  the simulator integrates the lumped acoustics (uniform chamber pressures, a "
            "slug in the tube), so the closure above is the lumped model's; the "
            f"{in_force.design.acoustics} acoustics in force differ from it by at most "
            f"{diff[k]:+.3f} dB (band {mc.bands.labels[k]} Hz; docs/acoustics.md)")
    return "\n".join(lines)


#: The band response's name in its refusal of a study with ``[scenarios]`` (the CLI's and
#: the sweep task's line) and what answers such a study instead.
RESPONSE_WHAT = "isodesign response"
RESPONSE_INSTEAD = ("isodesign yield DESIGN_OR_RUN --study STUDY.toml (the design judged at "
                    "every draw of [scenarios])")


def refuse_robust_response(study) -> None:
    """InputError (one line naming ``[scenarios]``) for a study with ``[scenarios]``.

    The band response answers one payload, one floor and one design: the nominal case. A
    study with ``[scenarios]`` asks for the design over its scenarios, which ``isodesign
    yield`` answers (every draw judged, the worst margin); ``isodesign response`` and the
    sweep's ``response`` task refuse it with the same line rather than answer the nominal
    question.

    Parameters
    ----------
    study : Study or None

    Raises
    ------
    InputError
        ``[scenarios]: isodesign response does not answer a robust study ...``.
    """
    from isodesign.optimization.dispatch import refuse

    if study is not None:
        refuse(study, RESPONSE_WHAT, table=False, instead=RESPONSE_INSTEAD)


#: Job when neither the input nor an option states it: the built-in vertical study's floor
#: and target (tests/commands/test_cli.py checks they agree with it).
DEFAULT_FLOOR = "VC-A"
DEFAULT_TARGET = "VC-C"


def load_design(path):
    """The design of ``path`` (or the reference spring) and its label."""

    if path is None:
        return SpringDesign.reference(), "reference spring (paper Table 1)"

    return _load(path), str(path)


def make_payload(args, base=None, **extra):
    """The Payload of ``--payload-kg`` and ``--isolators`` (InputError naming the option).

    ``base`` (a study's payload) supplies what the options do not state.
    """

    n = args.isolators if args.isolators is not None else (base.isolators if base else 4)
    n = check_count(n, "--isolators", *ISOLATORS_RANGE)
    if args.payload_kg is not None:
        mass = args.payload_kg
    elif base is not None and args.isolators in (None, base.isolators):
        mass = base.mass_kg
    else:
        mass = DEFAULT_KG_PER_ISOLATOR * n
    if not mass > 0 or mass == float("inf"):
        raise InputError(f"--payload-kg: must be finite and > 0 kg, got {args.payload_kg}")
    if args.payload_kg is not None:  # tonnes typed as kg: a warning naming the option
        from isodesign.io.plausible import warn_option_slips

        warn_option_slips(payload_kg=mass, isolators=n)
    for opt, v in extra.items():
        if v is not None and not (0 < v < float("inf")):
            raise InputError(f"--{opt.replace('_', '-')}: must be finite and > 0 m, got {v}")
    if base is not None:
        extra = {k: (v if v is not None else getattr(base, k)) for k, v in extra.items()}
    with option_names(mass_kg="--payload-kg", spacing_m="--spacing-m",
                      cg_height_m="--cg-height-m"):
        return Payload(mass, n, **extra)


def check_payload_pressure(design, payload, derive: bool = True) -> None:
    """InputError naming ``--payload-kg`` if the payload needs a non-finite chamber pressure.

    (A finite pressure beyond the model's validity is flagged by the analysis, not refused.)
    """
    import math


    if not derive:
        return
    p0 = P_ATM + payload.load_per_isolator_n / float(design.piston_area_m2)
    if not math.isfinite(p0):
        raise InputError(
            f"--payload-kg: {payload.mass_kg:g} kg on {payload.isolators} isolators needs a "
            f"chamber pressure beyond floating point ({p0:g} Pa); give a physical payload"
        )
    with option_names(mass_kg="--payload-kg"):  # outside the models' domain, or nothing
        pressure_from_load(payload.mass_kg, payload.isolators, float(design.piston_area_m2),
                           g_m_s2=payload.g_m_s2)


def resolve_job(args, *, extra_payload: dict | None = None):
    """Design, payload, floor, target, judged bands and models of the command's input.

    A design file (or none) keeps the command's defaults, with the models of the file's
    ``[models]`` table; a study file or a run directory supplies its whole job. Options
    given on the command line override either.

    Returns
    -------
    types.SimpleNamespace
        ``design``, ``label``, ``payload``, ``floor``, ``target``, ``bands`` (Bands or a
        (lo, hi) range or None), ``judged_hz`` (None: all bands judged), ``models`` and
        ``models_source``.
    """
    from pathlib import Path
    from types import SimpleNamespace


    extra_payload = extra_payload or {}
    models = dict(MODEL_DEFAULTS)
    models_source = "defaults"
    study = None
    path = args.design
    kind = None
    if path is not None:
        kind = input_kind(path)
    if kind in ("study", "optimize", "pareto"):
        case = load_case(path)
        study = case.study
        design = case.design
        label = {"study": f"start design of study {study.name!r} ({path})",
                 "optimize": f"optimum of study {study.name!r} ({path})",
                 "pareto": f"best point of the Pareto run {path}"}[kind]
        models.update(case.models)
        models_source = case.models_source
    else:
        design, label = load_design(path)
        if path is not None:

            recorded = load_design_models(path)
            if recorded:
                models.update(recorded)
                models_source = f"design file {Path(path).name} [models]"
    given = {k: getattr(args, k, None) for k in MODEL_DEFAULTS}
    overridden = [k for k, v in given.items() if v is not None]
    if getattr(args, "acoustics", None) is not None:  # a field of the spring itself
        design = design.replace(acoustics=args.acoustics)
        overridden.append("acoustics")
    models.update({k: v for k, v in given.items() if v is not None})
    models["distortion"] = _distortion_in_force(models)
    check_acoustics(design, models.get("flow"), getattr(args, "acoustics", None))
    if overridden:
        models_source += "; options " + ", ".join("--" + k.replace("_", "-") for k in overridden)
    payload = make_payload(args, base=study.payload if study else None, **extra_payload)
    floor = getattr(args, "floor", None)
    target = getattr(args, "target", None)
    bands = _bands(getattr(args, "bands", None))
    judged_hz = bands
    if study is not None:
        floor = study.floor if floor is None else floor
        target = study.target if target is None else target
        if bands is None:
            tg = study.raw["target"]
            judged_hz = (float(tg["band_min_hz"]), float(tg["band_max_hz"]))
            bands = study.bands
    floor = DEFAULT_FLOOR if floor is None else floor
    target = DEFAULT_TARGET if target is None else target
    if study is not None and getattr(args, "acoustics", None) is not None:
        from isodesign.commands import acoustics_override

        study = acoustics_override(study, args.acoustics)
    return SimpleNamespace(design=design, label=label, payload=payload, floor=floor,
                           target=target, bands=bands, judged_hz=judged_hz, models=models,
                           models_source=models_source, study=study)


def _distortion_in_force(models: dict) -> bool:
    """``models.distortion`` of the command's job: the study's or design file's when given,
    else the study default (:func:`~isodesign.optimization.study_parsers.default_distortion`:
    on with the statistical closure), so that a design judged without a study is judged
    as a study would judge it; off whenever the closure in force is not the statistical one
    (``--random-method`` may change it)."""
    from isodesign.optimization.study_parsers import default_distortion

    if models.get("random_method", "statistical") != "statistical":
        return False
    if "distortion" in models:
        return bool(models["distortion"])
    return default_distortion({"models": models})


def _bands(spec):

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


def models_line(models: dict, source: str) -> str:
    """The models in force and where they come from (one summary line)."""
    dia = str(models.get("diaphragm"))
    note = " (illustrative parameters)" if dia == "viscoelastic" else ""
    acoustics = models.get("acoustics")
    return (f"  models in force: flow={models.get('flow')}, "
            f"amplitude_mode={models.get('amplitude_mode')}, diaphragm={dia}{note}"
            + (f", acoustics={acoustics}" if acoustics else "")
            + (f", random closure {models['random_method']}" if "random_method" in models
               else "")
            + ((", with the distortion power" if models["distortion"] else
                ", without the distortion power")
               if models.get("random_method") == "statistical" and "distortion" in models
               else "") + f" (from {source})")


def summary(res, design_label: str, derived: bool, models_source: str = "options") -> str:
    """Header lines, the table and the verdict."""
    s = res.stability
    p = res.payload
    models = {"flow": res.flow, "amplitude_mode": res.amplitude_mode,
              "diaphragm": res.diaphragm, "acoustics": getattr(res.design, "acoustics", None),
              "random_method": res.random_method,
              "distortion": getattr(res, "distortion_kurtosis", None) is not None}
    lines = [
        f"band response: {design_label}; payload {p.mass_kg:g} kg on {p.isolators} isolators "
        f"({p.mass_per_isolator_kg:g} kg each), p0 = {s.pressure_pa / 1e5:.4g} bar "
        + ("(from the payload)" if derived else "(design's own)"),
        f"  floor {res.floor_name}; target {res.target_name}; bands "
        f"{res.bands.labels[0]}-{res.bands.labels[-1]} Hz",
        models_line(models, models_source),
        f"  natural frequency {s.natural_frequency_hz:.4g} Hz; peak |T| "
        f"{_db(s.excited_peak_transmissibility):.2f} dB at {s.excited_peak_frequency_hz:.4g} Hz "
        f"(at A*), {_db(s.peak_transmissibility):.2f} dB at {s.peak_frequency_hz:.4g} Hz "
        "(linear)",
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
    lines += res.scope.lines()
    return "\n".join(lines)


def _db(ratio: float) -> float:
    """A transmissibility ratio in dB (``20 log10``), as optimize and the report print it."""
    import math

    return 20.0 * math.log10(ratio) if ratio > 0 else -math.inf


def save_plot(fig, path) -> None:
    """Write a figure with the Agg canvas (the ``--plot`` of a command)."""

    with write_figure(path) as tmp:  # whole or not at all
        save_figure(fig, tmp)


def without_plot(args):
    """``args`` with ``plot`` cleared (the command draws its figure itself)."""
    import argparse

    return argparse.Namespace(**{**vars(args), "plot": None})


def run(args) -> int:
    """Run ``isodesign response``."""
    import warnings


    check_output_path(args.output, "--output")
    if args.verify_monte_carlo is not None:
        check_count(args.verify_monte_carlo, "--verify-monte-carlo", *MONTE_CARLO_SEEDS_RANGE)
    if not 0 < args.mc_duration_s <= MAX_MC_DURATION_S:
        raise InputError(f"--mc-duration-s: must be in (0, {MAX_MC_DURATION_S:g}] s, got "
                         f"{args.mc_duration_s:g}")
    check_output_path(args.plot, "--plot", suffixes=PLOT_SUFFIXES)
    check_count(args.points_per_band, "--points-per-band", *POINTS_PER_BAND_RANGE)
    with option_names(**RESPONSE_OPTION_NAMES):
        job = resolve_job(args, extra_payload={"spacing_m": args.spacing_m,
                                               "cg_height_m": args.cg_height_m})
    refuse_robust_response(job.study)  # the nominal answer is not the question asked
    if job.study is not None and job.study.table is not None:  # six DOFs (docs/table.md)
        from isodesign.commands.modes import run_table_response

        with option_names(**RESPONSE_OPTION_NAMES):
            return run_table_response(args, job)
    check_payload_pressure(job.design, job.payload, not args.design_pressure)
    m = job.models
    kw = {"points_per_band": args.points_per_band, "flow": m["flow"],
          "amplitude_mode": m["amplitude_mode"], "diaphragm": m["diaphragm"],
          "random_method": m["random_method"], "derive_pressure": not args.design_pressure,
          "warn": False, "distortion": bool(m.get("distortion", False))}
    try:
        with option_names(**RESPONSE_OPTION_NAMES):
            res = vertical_band_response(job.design, job.payload, job.floor, job.target,
                                         bands=job.bands, **kw)
    except InputError as exc:  # name the user's input with the option
        msg = str(exc)
        if args.bands and msg.startswith("--bands: "):
            raise InputError(f"--bands {args.bands}: {msg[len('--bands: '):]}") from None
        raise
    for line in res.warnings:
        warnings.warn(f"spring model at A*: {line}", ModelValidityWarning, stacklevel=2)
    to_stdout = args.output == "-"
    mc = None
    mc_closure = in_force = None
    if args.verify_monte_carlo is not None:

        try:
            mc = simulate_random_response(
                job.design, job.payload, job.floor, bands=res.bands, seeds=args.verify_monte_carlo,
                duration_s=args.mc_duration_s, flow=m["flow"], diaphragm=m["diaphragm"],
                derive_pressure=not args.design_pressure,
            )  # fmt: skip
        except InputError as exc:
            raise InputError(f"--verify-monte-carlo: {exc}") from None
        # like with like: the simulator's lumped equations against the lumped closure
        twin = lumped_twin(job.design)
        mc_closure, in_force = res, None
        if twin is not None:
            with option_names(**RESPONSE_OPTION_NAMES):
                mc_closure = vertical_band_response(twin, job.payload, job.floor, job.target,
                                                    bands=res.bands, **kw)
            in_force = res
    status = write_result(res, without_plot(args), "" if to_stdout else summary(
        res, job.label, not args.design_pressure, job.models_source))
    if args.plot:
        # every band of the floor and the target, the judged ones shaded
        shown = res
        if job.judged_hz is not None:
            try:
                shown = vertical_band_response(job.design, job.payload, job.floor,
                                               job.target, bands=None, **kw)
            except ValueError:  # the judged bands are all the floor has
                shown = res
        peak = job.study.constraints.get("max_peak_transmissibility_db") if job.study else None
        peak = peak if isinstance(peak, int | float) and not isinstance(peak, bool) else None
        save_plot(shown.plot(judged=job.judged_hz, peak_limit_db=peak), args.plot)
        if not to_stdout:
            print(f"wrote {args.plot}")
    if mc is not None and not to_stdout:
        print(monte_carlo_table(mc_closure, mc, in_force))
    return status
