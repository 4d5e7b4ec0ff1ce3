"""Floor spectrum from a site-survey time history (accelerometer or velocimeter record).

Reads RECORD.csv (one to three axes; a time_s column or '# sample_rate_hz: ...' in the header;
the unit in the header, '# unit: g', or --unit: g, mg, ug, m/s^2, mm/s^2, m/s, mm/s, um/s),
removes the mean, estimates the PSD by Welch's method (Hann window, 50 % overlap, segments long
enough for 10 frequency bins in the lowest band) and reports the band RMS velocity per
one-third-octave band: the mean-square average over the segments, the maximum and a
percentile. Writes DIR/bands.csv (one row per axis and band) and DIR/bands.png (the bands
against the VC curves), and DIR/floor.csv, the floor spectrum of one axis and statistic in the
format --floor reads. A record can also be given directly as --floor RECORD.csv to the other
commands (mean-square average of the z axis, or of the only axis). Method: docs/criteria.md.
"""

from __future__ import annotations

import argparse

from isodesign.commands import add_output_dir_arguments, input_error, option_names, run_directory
from isodesign.floor.survey import analyze_record, read_record


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign floor``."""
    parser.add_argument("record", metavar="RECORD.csv", help="time history (CSV)")

    add_output_dir_arguments(parser)
    parser.add_argument("--unit", help="unit of the record's values (overrides the header)")
    parser.add_argument(
        "--sample-rate", type=float, metavar="HZ", help="sample rate (without a time column)"
    )
    parser.add_argument(
        "--fmin", type=float, default=1.0, metavar="HZ", help="lowest band, Hz (default 1)"
    )
    parser.add_argument(
        "--fmax", type=float, default=80.0, metavar="HZ", help="highest band, Hz (default 80)"
    )
    parser.add_argument(
        "--percentile",
        type=float,
        default=90.0,
        help="percentile of the segments' band RMS reported (default %(default)s)",
    )
    parser.add_argument(
        "--statistic",
        choices=("mean", "max", "percentile"),
        default="mean",
        help="statistic of DIR/floor.csv (default %(default)s: the mean-square average)",
    )
    parser.add_argument("--axis", help="axis of DIR/floor.csv (default: z, or the only axis)")


def run(args) -> int:
    """Run ``isodesign floor``."""

    if not 0 < args.percentile <= 100:
        raise input_error(f"--percentile: must be in (0, 100], got {args.percentile:g}")
    rundir = run_directory(args, "floor", known_outputs=OUTPUT_FILES)  # checked first
    try:
        with option_names(**({"sample_rate_hz": "--sample-rate"} if args.sample_rate is not None
                              else {})):
            rec = read_record(args.record, unit=args.unit, sample_rate_hz=args.sample_rate)
    except UnicodeDecodeError as exc:
        raise input_error(f"record {args.record}: not a UTF-8 text file (undecodable byte at "
                          f"offset {exc.start})") from None
    res = analyze_record(rec, f_min_hz=args.fmin, f_max_hz=args.fmax, percentile=args.percentile)
    floor = res.floor(args.statistic, args.axis)
    with rundir as run:
        return _write(run, res, floor, args)


def axes_note(res, axis, statistic: str) -> str:
    """Which survey axis ``floor.csv`` holds and which it drops (the scope of the floor).

    Parameters
    ----------
    res : SurveyResult
    axis : str or None
        ``--axis`` (None: z, or the only axis).
    statistic : str
        ``--statistic``.

    Returns
    -------
    str
    """
    used = res.axes[res._axis_index(axis)]
    dropped = [a for a in res.axes if a != used]
    text = f"floor.csv: axis {used} ({statistic})"
    if dropped:
        text += (f"; axis {', '.join(dropped)} not in it (bands.csv and bands.png have every "
                 "axis): the vertical model takes one floor axis; a study with a [table] "
                 "takes one floor per axis ([floor.x], [floor.y])")
    return text


#: Files written by ``isodesign floor``.
OUTPUT_FILES = ("bands.csv", "floor.csv", "bands.png", "record.json")


def _write(run, res, floor, args) -> int:
    """Write the survey's files into the run directory ``run``."""
    out = run.target
    run.record["record"] = str(args.record)
    print(res.summary())
    df = res.to_frame()
    run.write_csv("bands.csv", df)
    print(f"wrote {out / 'bands.csv'} ({len(df)} rows)")
    lines = [
        f"# name: {floor.name}; quantity: velocity; kind: band_rms; unit: m/s",
        "frequency_hz,value",
    ]
    v = res.statistic(args.statistic, args.axis)
    lines += [f"{n:g},{x:.9g}" for n, x in zip(res.bands.nominal_hz, v, strict=True)]
    run.write_text("floor.csv", "\n".join(lines) + "\n")
    print(f"wrote {out / 'floor.csv'} (use it as --floor)")
    print(axes_note(res, args.axis, args.statistic))
    run.record["floor_axis"] = res.axes[res._axis_index(args.axis)]
    run.record["axes_not_in_floor_csv"] = [a for a in res.axes
                                           if a != run.record["floor_axis"]]
    with run.writing("bands.png") as tmp:
        res.plot(tmp)
    print(f"wrote {out / 'bands.png'}")
    return 0
