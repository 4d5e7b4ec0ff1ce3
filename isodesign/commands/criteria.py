"""Floor vibration criteria over one-third-octave bands.

Lists every named criterion curve (VC-A..VC-G, the legacy VC-A/VC-B variants,
the ISO building curves, NIST-A) over the bands whose nominal centre lies in
[--fmin, --fmax], as CSV (default) or as an aligned text table.

Layouts: 'long' = one row per (criterion, band) with every unit (the CSV
default); 'wide' = one row per band and one column per criterion, band RMS
velocity in --unit (the table default). Definitions and sources: docs/criteria.md.
"""

from __future__ import annotations

import argparse
import math

from isodesign.commands import check_output_path, option_names, write_text
from isodesign.errors import InputError, check_positive
from isodesign.floor import criteria_table


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``isodesign criteria``."""
    parser.add_argument(
        "--format",
        choices=("csv", "table"),
        default="csv",
        help="output format (default %(default)s)",
    )
    parser.add_argument(
        "--layout",
        choices=("long", "wide"),
        default=None,
        help="long: a row per criterion and band; wide: a row per band, a column per "
        "criterion (default: long for csv, wide for table)",
    )
    parser.add_argument(
        "--fmin", type=float, default=1.0, metavar="HZ", help="lowest band, Hz (default 1)"
    )
    parser.add_argument(
        "--fmax", type=float, default=80.0, metavar="HZ", help="highest band, Hz (default 80)"
    )
    parser.add_argument(
        "--names",
        metavar="LIST",
        help="comma list of criteria (default: all, e.g. VC-A,VC-B,NIST-A)",
    )
    parser.add_argument(
        "--unit",
        default="um/s",
        help="velocity unit of the wide layout: m/s, mm/s, um/s, nm/s, in/s, uin/s "
        "(default %(default)s)",
    )
    parser.add_argument(
        "-o", "--output", metavar="FILE", help="write to this file instead of standard output"
    )


def _cell(v) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "-"
        return f"{v:.5g}"
    return str(v)


def format_table(df) -> str:
    """An aligned text table of a DataFrame (numbers right-aligned, NaN as '-')."""
    cols = [str(c) for c in df.columns]
    rows = [[_cell(v) for v in rec] for rec in df.itertuples(index=False, name=None)]
    numeric = [df[c].dtype.kind in "fiu" for c in df.columns]
    widths = [max([len(c), *(len(r[j]) for r in rows)]) for j, c in enumerate(cols)]

    def line(cells):
        return "  ".join(
            (s.rjust(w) if num else s.ljust(w))
            for s, w, num in zip(cells, widths, numeric, strict=True)
        ).rstrip()

    out = [line(cols), line(["-" * w for w in widths])]
    out += [line(r) for r in rows]
    return "\n".join(out) + "\n"


def run(args) -> int:
    """Run ``isodesign criteria``."""

    check_positive("--fmin", args.fmin, unit="Hz")
    check_positive("--fmax", args.fmax, unit="Hz")
    if args.fmin > args.fmax:
        raise InputError(f"--fmin: must not exceed --fmax ({args.fmin:g} > {args.fmax:g} Hz)")
    check_output_path(args.output, "--output")

    layout = args.layout or ("long" if args.format == "csv" else "wide")
    names = None
    if args.names is not None:
        items = [n.strip() for n in args.names.split(",")]
        if not any(items):
            raise InputError(
                f"--names: no criterion named in {args.names[:40]!r}; give a comma list like "
                "VC-A,VC-E,NIST-A, or leave --names out for every criterion"
            )
        if not all(items):
            raise InputError(f"--names: empty item in {args.names[:40]!r}")
        names = tuple(items)
    with option_names(unit="--unit", criterion="--names", names="--names"):
        df = criteria_table(args.fmin, args.fmax, layout=layout, names=names,
                            velocity_unit=args.unit)
    if args.format == "csv":
        text = df.to_csv(index=False)
    else:
        text = format_table(df)
        if layout == "wide":
            text = f"band RMS velocity, {args.unit}; '-' = not defined in that band\n" + text
    write_text(args.output or "-", text)
    if args.output:
        print(f"wrote {args.output} ({len(df)} rows)")
    return 0
