"""Hostile and extreme inputs, command by command: every one gets one clear answer.

Each case runs the CLI in-process and requires exit status 2 and exactly one stderr line
``isodesign: error: ...`` that contains the given fragments (the option, key or file the
user typed and, where there is one, the valid range), never a traceback or an internal
name. ``HOSTILE`` is the table; ``python -m pytest tests/commands/test_hostile_inputs.py
--collect-only -q`` lists the cases, and :func:`hostile_counts` counts them by command.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from isodesign.cli import main

BIG = "1" + "0" * 400  # a 400-digit integer

REFERENCE = """\
volume_ratio = 1.851851851851852
top_volume_m3 = 0.00081
capillary_length_m = 0.012
capillary_diameter_m = 0.0009
piston_area_m2 = 0.0053
pressure_pa = 493000.0
"""


def _design(**changes) -> str:
    lines = []
    for ln in REFERENCE.splitlines():
        key = ln.split(" = ")[0]
        if key in changes:
            if changes[key] is not None:
                lines.append(f"{key} = {changes[key]}")
        else:
            lines.append(ln)
    return "\n".join(lines) + "\n"


#: Files the cases refer to as {name}; written into a temporary directory.
FILES: dict[str, bytes] = {
    "big_int.toml": _design(volume_ratio=BIG).encode(),
    "big_float.toml": _design(volume_ratio="1e400").encode(),
    "nan.toml": _design(top_volume_m3="nan").encode(),
    "str_number.toml": _design(volume_ratio='"2"').encode(),
    "bool_number.toml": _design(volume_ratio="true").encode(),
    "negative.toml": _design(capillary_length_m="-0.012").encode(),
    "missing_key.toml": _design(capillary_diameter_m=None).encode(),
    "unknown_key.toml": (REFERENCE + "colour = 3\n").encode(),
    "orifice.toml": _design(capillary_diameter_m="0.02").encode(),
    "load_heavy.toml": (_design(pressure_pa=None) + "[load]\nmass_kg = 1e308\nisolators = 4\n"
                        ).encode(),
    "load_big.toml": (_design(pressure_pa=None) + f"[load]\nmass_kg = 1e308\nisolators = {BIG}\n"
                      ).encode(),
    "binary.toml": bytes(range(256)) * 4,
    "latin1.toml": "name = \"caf\xe9\"\n".encode("latin-1"),
    "empty.toml": b"",
    "malformed.toml": b"volume_ratio = = 2\n",
    "deep.toml": b"x = " + b"[" * 5000 + b"]" * 5000 + b"\n",
    "study_big_int.toml": f"[payload]\nmass_kg = {BIG}\n".encode(),
    "study_big_isolators.toml": f"[payload]\nisolators = {BIG}\n".encode(),
    "study_float_isolators.toml": b"[payload]\nisolators = 4.5\n",
    "study_huge_payload.toml": b"[payload]\nmass_kg = 1e308\n",
    "study_str_mass.toml": b"[payload]\nmass_kg = \"600\"\n",
    "study_unknown.toml": b"[payload]\nmass = 600\n",
    "study_plain.toml": b"name = \"plain\"\n",
    "study_table_cg_out.toml": (b"[table]\nisolators_m = [[0, 0], [1, 0], [1, 1], [0, 1]]\n"
                                b"cg_m = [2.0, 0.5, 0.3]\nbox_m = [1, 1, 0.5]\n"),
    "study_starts.toml": b"[solver]\nstarts = 100000000\n",
    "study_workers.toml": b"[solver]\nworkers = 0\n",
    "study_ppb.toml": b"[models]\npoints_per_band = 100000000\n",
    "study_big_start.toml": f"[variables.volume_ratio]\nstart = {BIG}\n".encode(),
    "study_all_fixed.toml": "".join(
        f"[variables.{n}]\nstart = {v}\nfixed = true\n" for n, v in (
            ("volume_ratio", 1.85), ("top_volume_m3", 8.1e-4), ("capillary_length_m", 0.012),
            ("capillary_diameter_m", 0.0009))).encode(),
    "study_fixed_outside.toml": b"[variables.volume_ratio]\nstart = 9.0\nlower = 0.5\n"
                                b"upper = 8.0\nfixed = true\n",
    "study_max_pressure.toml": b"[constraints]\nmax_pressure_pa = 2e5\n",
    "design_ok.toml": REFERENCE.encode(),
    "scen_inverted.toml": b"[scenarios]\npayload_mass_kg = {min = 720.0, max = 480.0}\n",
    "scen_empty.toml": b"[scenarios]\npayload_mass_kg = {values = []}\n",
    "scen_nonpositive.toml": b"[scenarios]\ncapillary_diameter_m = {absolute = 1e-3}\n",
    "scen_unknown.toml": b"[scenarios]\ndrill = {relative = 0.05}\n",
    "scen_big.toml": f"[scenarios]\npayload_mass_kg = {{min = 1.0, max = {BIG}}}\n".encode(),
    "study_max_pressure_str.toml": b"[constraints]\nmax_pressure_pa = \"1e6\"\n",
    "floor_binary.csv": bytes(range(256)) * 4,
    "floor_latin1.csv": "f_hz,v\n1,caf\xe9\n".encode("latin-1"),
    "not_a_dir": b"a file",
    # issue 14: finite and positive, but outside the models' domain
    "vr_absurd.toml": _design(volume_ratio="1e10").encode(),
    "vr_1e300.toml": _design(volume_ratio="1e300").encode(),
    "p_1e300.toml": _design(pressure_pa="1e300").encode(),
    "temp_tiny.toml": (REFERENCE + "temperature_k = 1e-300\n").encode(),
    "gas_viscous.toml": (REFERENCE + "[gas]\nviscosity_pa_s = 1e300\n").encode(),
    "study_vr_upper.toml": b"[variables.volume_ratio]\nstart = 2.0\nlower = 0.5\nupper = 1e10\n",
    "study_vr_fixed.toml": b"[variables.volume_ratio]\nstart = 1e10\nfixed = true\n",
    "study_band_200.toml": b"[target]\ncriterion = \"VC-C\"\nband_max_hz = 200\n",
    "study_piston_tiny.toml": b"[hardware]\npiston_area_m2 = 1e-30\n",
    "study_temp_tiny.toml": b"[hardware]\ntemperature_k = 1e-300\n",
}

# (command, argv with {tmp}/{name} placeholders, fragments the one error line contains)
HOSTILE: list[tuple[str, list[str], list[str]]] = [
    # -- stiffness: design files ---------------------------------------------------------
    ("stiffness", ["{big_int.toml}"], ["big_int.toml", "volume_ratio", "401 digits"]),
    ("stiffness", ["{big_float.toml}"], ["big_float.toml", "volume_ratio", "finite"]),
    ("stiffness", ["{nan.toml}"], ["nan.toml", "top_volume_m3"]),
    ("stiffness", ["{str_number.toml}"], ["str_number.toml", "volume_ratio", "a string"]),
    ("stiffness", ["{bool_number.toml}"], ["bool_number.toml", "volume_ratio", "a boolean"]),
    ("stiffness", ["{negative.toml}"], ["negative.toml", "capillary_length_m", "> 0"]),
    ("stiffness", ["{missing_key.toml}"], ["missing_key.toml", "capillary_diameter_m"]),
    ("stiffness", ["{unknown_key.toml}"], ["unknown_key.toml", "colour"]),
    ("stiffness", ["{orifice.toml}"], ["orifice.toml", "capillary_diameter_m"]),
    ("stiffness", ["{load_heavy.toml}"], ["load_heavy.toml", "load.mass_kg", "1e+308 kg"]),
    ("stiffness", ["{load_big.toml}"], ["load_big.toml", "load.isolators", "[1, 1000]"]),
    ("stiffness", ["{binary.toml}"], ["binary.toml", "not a UTF-8 text file"]),
    ("stiffness", ["{latin1.toml}"], ["latin1.toml", "not a UTF-8 text file"]),
    ("stiffness", ["{empty.toml}"], ["empty.toml", "missing key"]),
    ("stiffness", ["{malformed.toml}"], ["malformed.toml", "malformed TOML"]),
    ("stiffness", ["{deep.toml}"], ["deep.toml"]),
    ("stiffness", ["{tmp}/nope.toml"], ["nope.toml", "cannot read"]),
    ("stiffness", ["{tmp}"], ["is a directory"]),
    # -- stiffness: value lists ---------------------------------------------------------------
    ("stiffness", ["--freq", "-1,2"], ["--freq", "> 0 Hz", "-1"]),
    ("stiffness", ["--freq", "-1"], ["--freq", "> 0 Hz"]),
    ("stiffness", ["--freq", "0"], ["--freq", "> 0 Hz"]),
    ("stiffness", ["--freq", "nan"], ["--freq", "finite"]),
    ("stiffness", ["--freq", "inf"], ["--freq", "finite"]),
    ("stiffness", ["--freq", "1e400"], ["--freq", "finite"]),
    ("stiffness", ["--freq", "abc"], ["--freq", "not a number", "Hz"]),
    ("stiffness", ["--freq", "1,,2"], ["--freq", "empty item"]),
    ("stiffness", ["--freq", ""], ["--freq", "empty"]),
    ("stiffness", ["--freq", ",,,"], ["--freq", "empty item"]),
    ("stiffness", ["--freq", "0.2:24:100000000"], ["--freq", "[2, 10000]"]),
    ("stiffness", ["--freq", "0.2:24:" + BIG], ["--freq", "[2, 10000]"]),
    ("stiffness", ["--freq", "0.2:24:1"], ["--freq", "[2, 10000]"]),
    ("stiffness", ["--freq", "0.2:24:-5"], ["--freq", "[2, 10000]"]),
    ("stiffness", ["--freq", "0.2:24:2.5"], ["--freq", "[2, 10000]"]),
    ("stiffness", ["--freq", "24:0.2:5"], ["--freq", "stop must be greater"]),
    ("stiffness", ["--freq", "1:2:3:4"], ["--freq", "start:stop:count"]),
    ("stiffness", ["--freq", "1:2"], ["--freq", "start:stop:count"]),
    ("stiffness", ["--freq", "5furlong"], ["--freq", "unknown unit 'furlong'", "Hz"]),
    ("stiffness", ["--freq", ",".join(["1"] * 10001)], ["--freq", "between 1 and 10000"]),
    ("stiffness", ["--amplitude", "0.05furlong"],
     ["--amplitude", "unknown unit 'furlong'", "um, mm, m"]),
    ("stiffness", ["--amplitude", "-1mm"], ["--amplitude", "> 0 m"]),
    ("stiffness", ["--amplitude", "0mm"], ["--amplitude", "> 0 m"]),
    ("stiffness", ["--amplitude", "mm"], ["--amplitude", "no value before the unit"]),
    ("stiffness", ["--amplitude", "1e999um"], ["--amplitude", "finite"]),
    ("stiffness", ["--freq", "0.1:50:1000", "--amplitude", "1:2:1000mm"],
     ["--freq x --amplitude", "at most 200000"]),
    ("stiffness", ["--flow", "turbo"], ["--flow", "invalid choice"]),
    ("stiffness", ["--amplitude-mode", "x"], ["--amplitude-mode", "invalid choice"]),
    ("stiffness", ["--diaphragm", "bogus"], ["--diaphragm", "viscoelastic, none"]),
    ("stiffness", ["--diaphragm", "table:{tmp}/nope.csv"], ["nope.csv", "cannot read"]),
    ("stiffness", ["--diaphragm", "table:{floor_binary.csv}"], ["floor_binary.csv"]),
    # -- stiffness: output paths (checked before the computation) -----------------------------
    ("stiffness", ["-o", "{tmp}"], ["--output", "is a directory"]),
    ("stiffness", ["-o", "{tmp}/missing/k.csv"], ["--output", "does not exist"]),
    ("stiffness", ["-o", "{not_a_dir}/k.csv"], ["--output", "is a file"]),
    ("stiffness", ["-o", ""], ["--output", "empty"]),
    ("stiffness", ["--plot", "{tmp}/k.txt"], ["--plot", ".png"]),
    ("stiffness", ["--plot", "{tmp}"], ["--plot", "is a directory"]),
    ("stiffness", ["--bogus"], ["unrecognized arguments"]),
    # -- criteria -----------------------------------------------------------------------------
    ("criteria", ["--names", ",,,"], ["--names", "no criterion named"]),
    ("criteria", ["--names", ""], ["--names", "no criterion named"]),
    ("criteria", ["--names", " , "], ["--names", "no criterion named"]),
    ("criteria", ["--names", "VC-A,,VC-B"], ["--names", "empty item"]),
    ("criteria", ["--names", "VC-Q"], ["--names", "VC-Q", "VC-A"]),
    ("criteria", ["--fmin", "-1"], ["--fmin", "> 0"]),
    ("criteria", ["--fmin", "nan"], ["--fmin", "finite"]),
    ("criteria", ["--fmax", "1e400"], ["--fmax", "finite"]),
    ("criteria", ["--fmin", "10", "--fmax", "2"], ["--fmin", "--fmax"]),
    ("criteria", ["--fmin", "abc"], ["--fmin", "invalid float"]),
    ("criteria", ["--unit", "furlong/s"], ["--unit", "furlong/s", "um/s"]),
    ("criteria", ["--format", "xml"], ["--format", "invalid choice"]),
    ("criteria", ["-o", "{tmp}"], ["--output", "is a directory"]),
    ("criteria", ["-o", "{not_a_dir}/c.csv"], ["--output", "is a file"]),
    # -- response -----------------------------------------------------------------------------
    ("response", ["--payload-kg", "1e308"], ["--payload-kg", "1e+308 kg"]),
    ("response", ["--payload-kg", "-5"], ["--payload-kg", "> 0 kg"]),
    ("response", ["--payload-kg", "0"], ["--payload-kg", "> 0 kg"]),
    ("response", ["--payload-kg", "nan"], ["--payload-kg", "> 0 kg"]),
    ("response", ["--payload-kg", "inf"], ["--payload-kg", "finite"]),
    ("response", ["--payload-kg", "heavy"], ["--payload-kg", "invalid float"]),
    ("response", ["--isolators", "0"], ["--isolators", "[1, 1000]"]),
    ("response", ["--isolators", "-3"], ["--isolators", "[1, 1000]"]),
    ("response", ["--isolators", "100000000"], ["--isolators", "[1, 1000]"]),
    ("response", ["--isolators", BIG], ["--isolators", "at most 12 digits"]),
    ("response", ["--isolators", "4.5"], ["--isolators", "expected an integer"]),
    ("response", ["--points-per-band", "100000000"], ["--points-per-band", "[2, 2000]"]),
    ("response", ["--points-per-band", "1"], ["--points-per-band", "[2, 2000]"]),
    ("response", ["--points-per-band", "many"], ["--points-per-band", "expected an integer"]),
    ("response", ["--bands", "1:x"], ["--bands", "FMIN:FMAX"]),
    ("response", ["--bands", "5:1"], ["--bands", "FMIN <= FMAX"]),
    ("response", ["--bands", "nan:inf"], ["--bands", "finite"]),
    ("response", ["--bands", "-1:5"], ["--bands"]),
    ("response", ["--floor", "bogus"], ["--floor", "bogus", "VC-A"]),
    ("response", ["--floor", "{floor_binary.csv}"], ["--floor", "floor_binary.csv"]),
    ("response", ["--floor", "{floor_latin1.csv}"], ["--floor", "floor_latin1.csv"]),
    ("response", ["--target", "{tmp}/nope.csv"], ["--target", "nope.csv"]),
    ("response", ["--target", "VC-Z"], ["--target", "VC-Z"]),
    ("response", ["--spacing-m", "-1"], ["--spacing-m", "> 0 m"]),
    ("response", ["--cg-height-m", "nan"], ["--cg-height-m", "> 0 m"]),
    ("response", ["--spacing-m", "inf"], ["--spacing-m", "finite"]),
    ("response", ["--diaphragm", "bogus"], ["--diaphragm", "viscoelastic"]),
    ("response", ["{big_int.toml}"], ["big_int.toml", "volume_ratio"]),
    ("response", ["{binary.toml}"], ["binary.toml", "not a UTF-8 text file"]),
    ("response", ["-o", "{not_a_dir}/r.csv"], ["--output", "is a file"]),
    ("response", ["--plot", "{tmp}/missing/r.png"], ["--plot", "does not exist"]),
    ("response", ["--plot", "{tmp}/r.txt"], ["--plot", "unsupported file type", ".png"]),
    # -- transmissibility ---------------------------------------------------------------------
    ("transmissibility", ["--freq", "-1,2"], ["--freq", "> 0 Hz"]),
    ("transmissibility", ["--freq", "0.2:24:100000000"], ["--freq", "[2, 10000]"]),
    ("transmissibility", ["--floor-amplitude", "1furlong"],
     ["--floor-amplitude", "unknown unit"]),
    ("transmissibility", ["--floor-amplitude", "-1um"], ["--floor-amplitude", "> 0 m"]),
    ("transmissibility", ["--freq", "0.5:50:10000", "--floor-amplitude", "1:10:100um"],
     ["--freq x --floor-amplitude", "at most 200000"]),
    ("transmissibility", ["--payload-kg", "1e308"], ["--payload-kg"]),
    ("transmissibility", ["--isolators", "100000000"], ["--isolators", "[1, 1000]"]),
    ("transmissibility", ["--branch", "middle"], ["--branch", "invalid choice"]),
    ("transmissibility", ["--diaphragm", "x"], ["--diaphragm"]),
    ("transmissibility", ["{latin1.toml}"], ["latin1.toml", "not a UTF-8 text file"]),
    ("transmissibility", ["-o", "{tmp}"], ["--output", "is a directory"]),
    ("transmissibility", ["--plot", "{tmp}/t"], ["--plot", "unsupported file type"]),
    # -- optimize (every case fails before the solver starts) ---------------------------------
    ("optimize", ["{study_big_int.toml}", "-o", "{tmp}/o"], ["study_big_int.toml",
                                                             "payload.mass_kg", "401 digits"]),
    ("optimize", ["{study_big_isolators.toml}", "-o", "{tmp}/o"],
     ["study_big_isolators.toml", "isolators", "[1, 1000]"]),
    ("optimize", ["{study_float_isolators.toml}", "-o", "{tmp}/o"],
     ["study_float_isolators.toml", "isolators"]),
    ("optimize", ["{study_huge_payload.toml}", "-o", "{tmp}/o"],
     ["study_huge_payload.toml", "payload.mass_kg", "1e+308 kg"]),
    ("optimize", ["{study_all_fixed.toml}", "-o", "{tmp}/o"],
     ["study_all_fixed.toml", "every design variable is fixed"]),
    ("optimize", ["{study_fixed_outside.toml}", "-o", "{tmp}/o"],
     ["study_fixed_outside.toml", "variables.volume_ratio.start (9)", "[0.5, 8]"]),
    ("optimize", ["{study_max_pressure.toml}", "-o", "{tmp}/o"],
     ["study_max_pressure.toml", "constraints.max_pressure_pa", "needs p0"]),
    ("optimize", ["{study_max_pressure_str.toml}", "-o", "{tmp}/o"],
     ["study_max_pressure_str.toml", "constraints.max_pressure_pa"]),
    ("pareto", ["{study_all_fixed.toml}", "-o", "{tmp}/p"],
     ["study_all_fixed.toml", "every design variable is fixed"]),
    ("optimize", ["{study_str_mass.toml}", "-o", "{tmp}/o"], ["study_str_mass.toml",
                                                              "payload.mass_kg"]),
    ("optimize", ["{study_unknown.toml}", "-o", "{tmp}/o"], ["study_unknown.toml", "'mass'"]),
    ("optimize", ["{study_starts.toml}", "-o", "{tmp}/o"], ["solver.starts", "[1, 256]"]),
    ("optimize", ["{study_workers.toml}", "-o", "{tmp}/o"], ["solver.workers", "[1, 64]"]),
    ("optimize", ["{study_ppb.toml}", "-o", "{tmp}/o"], ["models.points_per_band", "[3, 200]"]),
    ("optimize", ["{study_big_start.toml}", "-o", "{tmp}/o"],
     ["study_big_start.toml", "variables.volume_ratio.start"]),
    ("optimize", ["{binary.toml}", "-o", "{tmp}/o"], ["binary.toml", "not a UTF-8 text file"]),
    ("optimize", ["{latin1.toml}", "-o", "{tmp}/o"], ["latin1.toml", "not a UTF-8 text file"]),
    ("optimize", ["{malformed.toml}", "-o", "{tmp}/o"], ["malformed.toml", "malformed TOML"]),
    ("optimize", ["{tmp}/nope.toml", "-o", "{tmp}/o"], ["nope.toml", "cannot read"]),
    ("optimize", ["--starts", "0", "-o", "{tmp}/o"], ["--starts", "[1, 256]"]),
    ("optimize", ["--starts", "100000000", "-o", "{tmp}/o"], ["--starts", "[1, 256]"]),
    ("optimize", ["--starts", BIG, "-o", "{tmp}/o"], ["--starts", "at most 12 digits"]),
    ("optimize", ["--starts", "abc", "-o", "{tmp}/o"], ["--starts", "expected an integer"]),
    ("optimize", ["--workers", "0", "-o", "{tmp}/o"], ["--workers", "[1, 64]"]),
    ("optimize", ["--workers", "1000", "-o", "{tmp}/o"], ["--workers", "[1, 64]"]),
    ("optimize", ["--seed", "-1", "-o", "{tmp}/o"], ["--seed", "[0, 4294967295]"]),
    ("optimize", ["--seed", "99999999999", "-o", "{tmp}/o"], ["--seed", "[0, 4294967295]"]),
    ("optimize", ["-o", "{not_a_dir}"], ["--output", "not a directory"]),
    ("optimize", ["-o", "{not_a_dir}/sub/run"], ["--output", "is a file"]),
    ("optimize", ["-o", ""], ["--output", "empty"]),
    ("optimize", ["-o", "{foreign}"], ["--output", "not empty", "--overwrite"]),
    ("optimize", ["-o", "{earlier_run}"], ["--output", "already holds a run", "--overwrite"]),
    ("optimize", [], ["--output", "required"]),
    # -- pareto -------------------------------------------------------------------------------
    ("pareto", ["--points", "100000000", "-o", "{tmp}/p"], ["--points", "[2, 500]"]),
    ("pareto", ["--points", "1", "-o", "{tmp}/p"], ["--points", "[2, 500]"]),
    ("pareto", ["--points", BIG, "-o", "{tmp}/p"], ["--points", "at most 12 digits"]),
    ("pareto", ["--points", "x", "-o", "{tmp}/p"], ["--points", "expected an integer"]),
    ("pareto", ["--objectives", ",,,", "-o", "{tmp}/p"], ["--objectives", "two names"]),
    ("pareto", ["--objectives", "", "-o", "{tmp}/p"], ["--objectives", "two names"]),
    ("pareto", ["--objectives", "a,b", "-o", "{tmp}/p"], ["--objectives", "unknown", "'a'"]),
    ("pareto", ["--objectives", "total_volume,total_volume", "-o", "{tmp}/p"],
     ["--objectives", "two different"]),
    ("pareto", ["--objectives", "x" * 5000, "-o", "{tmp}/p"], ["--objectives"]),
    ("pareto", ["--workers", "65", "-o", "{tmp}/p"], ["--workers", "[1, 64]"]),
    ("pareto", ["{study_big_int.toml}", "-o", "{tmp}/p"], ["study_big_int.toml"]),
    ("pareto", ["-o", "{earlier_run}"], ["--output", "already holds a run"]),
    ("pareto", ["-o", "{not_a_dir}"], ["--output", "not a directory"]),
    # -- floor, fit, report -------------------------------------------------------------------
    ("floor", ["{tmp}/nope.csv", "-o", "{tmp}/f"], ["nope.csv"]),
    ("floor", ["{floor_binary.csv}", "-o", "{tmp}/f"], ["floor_binary.csv"]),
    ("floor", ["{floor_latin1.csv}", "-o", "{earlier_run}"], ["--output", "already holds a run"]),
    ("floor", ["{floor_latin1.csv}", "-o", "{not_a_dir}"], ["--output", "not a directory"]),
    ("floor", ["{floor_latin1.csv}", "--percentile", "0", "-o", "{tmp}/f"],
     ["--percentile", "(0, 100]"]),
    ("floor", ["{floor_latin1.csv}", "--percentile", "nan", "-o", "{tmp}/f"], ["--percentile"]),
    ("fit", ["diaphragm", "{tmp}/nope.csv"], ["nope.csv"]),
    ("fit", ["diaphragm", "{floor_binary.csv}"], ["floor_binary.csv"]),
    ("fit", ["diaphragm", "{floor_latin1.csv}", "--plot", "{tmp}/p.txt"],
     ["--plot", "unsupported file type"]),
    ("fit", ["diaphragm", "{floor_latin1.csv}", "-o", "{tmp}"], ["--output", "is a directory"]),
    ("fit", ["bogus", "{floor_latin1.csv}"], ["invalid choice"]),
    ("optimize", ["{scen_inverted.toml}", "-o", "{tmp}/o"],
     ["scenarios.payload_mass_kg", "inverted"]),
    ("optimize", ["{scen_empty.toml}", "-o", "{tmp}/o"], ["scenarios.payload_mass_kg.values"]),
    ("optimize", ["{scen_nonpositive.toml}", "-o", "{tmp}/o"],
     ["scenarios.capillary_diameter_m.absolute", "non-positive"]),
    ("optimize", ["{scen_unknown.toml}", "-o", "{tmp}/o"], ["'drill'", "[scenarios]"]),
    ("optimize", ["{scen_big.toml}", "-o", "{tmp}/o"], ["scenarios.payload_mass_kg"]),
    ("optimize", ["--yield-samples", "-1", "-o", "{tmp}/o"], ["--yield-samples"]),
    ("yield", ["{tmp}/nope.toml", "--study", "{scen_inverted.toml}", "-o", "{tmp}/y"],
     ["nope.toml"]),
    ("yield", ["{binary.toml}", "--study", "{scen_inverted.toml}", "-o", "{tmp}/y"],
     ["binary.toml"]),
    ("yield", ["{big_int.toml}", "-o", "{tmp}/y"], ["big_int.toml"]),
    ("yield", ["{tmp}/earlier_run", "-o", "{tmp}/y"], ["earlier_run"]),
    ("yield", ["{design_ok.toml}", "-o", "{tmp}/y"], ["--study"]),
    ("yield", ["{design_ok.toml}", "--study", "{study_unknown.toml}", "-o", "{tmp}/y"],
     ["[payload]"]),
    ("yield", ["{design_ok.toml}", "--study", "{empty.toml}", "-o", "{tmp}/y"],
     ["--study", "[scenarios]"]),
    ("yield", ["{design_ok.toml}", "--study", "{scen_inverted.toml}", "-o", "{tmp}/y"],
     ["scenarios.payload_mass_kg", "inverted"]),
    ("yield", ["{design_ok.toml}", "--study", "{scen_empty.toml}", "--samples", "0", "-o",
               "{tmp}/y"], ["--samples", "[1, 1000000]"]),
    ("yield", ["{design_ok.toml}", "--samples", BIG, "-o", "{tmp}/y"],
     ["--samples", "at most 12 digits"]),
    ("yield", ["{design_ok.toml}", "--confidence", "2", "-o", "{tmp}/y"], ["--confidence"]),
    ("report", ["{tmp}/nope.toml", "-o", "{tmp}/r.html"], ["nope.toml"]),
    ("report", ["{binary.toml}", "-o", "{tmp}/r.html"], ["binary.toml"]),
    ("report", ["{big_int.toml}", "-o", "{tmp}/r.html"], ["big_int.toml", "401 digits"]),
    ("report", ["{study_all_fixed.toml}", "-o", "{tmp}/r.html"], ["study_all_fixed.toml"]),
    ("report", ["{latin1.toml}", "-o", "{tmp}/r.txt"], ["--output", ".html"]),
    ("report", ["{latin1.toml}", "-o", "{tmp}"], ["--output", "is a directory"]),
    # -- sweep -------------------------------------------------------------------------------
    ("sweep", ["--vary", "payload.mas_kg=300,600", "-o", "{tmp}/s"],
     ["--vary", "unknown key 'payload.mas_kg'", "mass_kg"]),
    ("sweep", ["--vary", "payload.mass_kg=300:1500:0", "-o", "{tmp}/s"],
     ["--vary payload.mass_kg", "empty range"]),
    ("sweep", ["--vary", "payload.mass_kg=300:1500:" + BIG, "-o", "{tmp}/s"],
     ["--vary payload.mass_kg", "count"]),
    ("sweep", ["--vary", "payload.mass_kg", "-o", "{tmp}/s"], ["--vary", "KEY=VALUES"]),
    ("sweep", ["--vary", "payload.mass_kg=0,600", "-o", "{tmp}/s"],
     ["--vary payload.mass_kg=0", "payload.mass_kg"]),
    ("sweep", ["{study_unknown.toml}", "--vary", "payload.mass_kg=300", "-o", "{tmp}/s"],
     ["study_unknown.toml", "mass"]),
    ("sweep", ["--points-file", "{malformed.toml}", "-o", "{tmp}/s"], ["malformed.toml"]),
    ("sweep", ["--points-file", "{tmp}/nope.toml", "-o", "{tmp}/s"], ["--points-file",
                                                                       "nope.toml"]),
    ("sweep", ["--vary", "payload.mass_kg=300", "--task", "optimise", "-o", "{tmp}/s"],
     ["--task", "unknown task 'optimise'"]),
    ("sweep", ["--vary", "payload.mass_kg=300", "--workers", "0", "-o", "{tmp}/s"],
     ["--workers", "[1, 64]"]),
    ("sweep", ["--vary", "payload.mass_kg=300", "-o", "{foreign}"],
     ["--output", "holds no isodesign sweep"]),
    ("sweep", ["--vary", "payload.mass_kg=300", "-o", "{earlier_run}"],
     ["--output", "isodesign optimize run, not a sweep"]),
    ("sweep", ["--vary", "payload.mass_kg=300", "-o", "{not_a_dir}"],
     ["--output", "not a directory"]),
    ("sweep", ["--vary", "payload.mass_kg=300"], ["--output", "required"]),
    # -- modes (a table study) -----------------------------------------------------------------
    ("modes", ["{tmp}/nope.toml", "-o", "{tmp}/m"], ["nope.toml"]),
    ("modes", ["{study_unknown.toml}", "-o", "{tmp}/m"], ["study_unknown.toml", "mass"]),
    ("modes", ["{study_plain.toml}", "-o", "{tmp}/m"], ["INPUT", "has no [table]"]),
    ("modes", ["{study_table_cg_out.toml}", "-o", "{tmp}/m"],
     ["study_table_cg_out.toml", "table.cg_m", "outside the support polygon"]),
    ("modes", ["-o", "{tmp}/m"], ["INPUT", "--builtin table"]),
    ("modes", ["{study_plain.toml}", "--builtin", "table", "-o", "{tmp}/m"],
     ["--builtin", "not both"]),
    ("modes", ["--builtin", "table", "-o", "{foreign}"], ["--output", "not empty"]),
    ("response", ["{study_table_cg_out.toml}"], ["table.cg_m"]),
    # -- stability (a table study) -------------------------------------------------------------
    ("stability", ["{tmp}/nope.toml", "-o", "{tmp}/m"], ["nope.toml"]),
    ("stability", ["{study_plain.toml}", "-o", "{tmp}/m"], ["INPUT", "has no [table]"]),
    ("stability", ["{study_table_cg_out.toml}", "-o", "{tmp}/m"],
     ["study_table_cg_out.toml", "table.cg_m", "outside the support polygon"]),
    ("stability", ["-o", "{tmp}/m"], ["INPUT", "--builtin table"]),
    ("stability", ["--builtin", "table", "-o", "{foreign}"], ["--output", "not empty"]),
    # -- issue 14: unwritable and odd output paths, refused before the computation -------
    ("stiffness", ["-o", "/proc/version"], ["--output", "/proc/version"]),
    ("stiffness", ["-o", "/sys/x.csv"], ["--output", "/sys"]),
    ("stiffness", ["--plot", "/sys/x.png"], ["--plot", "/sys"]),
    ("response", ["-o", "/proc/version"], ["--output", "/proc/version"]),
    ("response", ["--plot", "/sys/x.png"], ["--plot", "/sys"]),
    ("transmissibility", ["-o", "/sys/x.csv"], ["--output", "/sys"]),
    ("criteria", ["-o", "/proc/x.csv"], ["--output", "/proc"]),
    ("optimize", ["-o", "/proc/x"], ["--output", "/proc"]),
    ("pareto", ["-o", "/sys/x"], ["--output", "/sys"]),
    ("floor", ["{floor_latin1.csv}", "-o", "/proc/f"], ["--output", "/proc"]),
    ("report", ["{latin1.toml}", "-o", "/sys/r.html"], ["--output", "/sys"]),
    ("demo", ["-o", "/proc/x"], ["--output", "/proc"]),
    # -- issue 14: finite values outside the models' domain: range errors, not "did not
    # converge" or an overflow -------------------------------------------------------------
    ("stiffness", ["--freq", "1e-320"], ["--freq", "[1e-06, 1e+06] Hz", "1e-320"]),
    ("stiffness", ["--freq", "1e308"], ["--freq", "[1e-06, 1e+06] Hz", "1e308"]),
    ("stiffness", ["--freq", "1:1e308:5"], ["--freq", "1e308"]),
    ("stiffness", ["--amplitude", "1e300"], ["--amplitude", "[1e-30, 10] m", "1e300"]),
    ("stiffness", ["--amplitude", "1e-320um"], ["--amplitude", "[1e-30, 10] m"]),
    ("transmissibility", ["--freq", "1e308"], ["--freq", "[1e-06, 1e+06] Hz"]),
    ("transmissibility", ["--floor-amplitude", "1e300"], ["--floor-amplitude", "[1e-30, 10] m"]),
    ("stiffness", ["{vr_absurd.toml}"], ["vr_absurd.toml", "volume_ratio", "[0.001, 1000]"]),
    ("stiffness", ["{vr_1e300.toml}"], ["vr_1e300.toml", "volume_ratio", "[0.001, 1000]"]),
    ("response", ["{vr_absurd.toml}"], ["vr_absurd.toml", "volume_ratio", "[0.001, 1000]"]),
    ("transmissibility", ["{p_1e300.toml}"], ["p_1e300.toml", "pressure_pa"]),
    ("stiffness", ["{temp_tiny.toml}"], ["temp_tiny.toml", "temperature_k"]),
    ("stiffness", ["{gas_viscous.toml}"], ["gas_viscous.toml", "viscosity_pa_s"]),
    ("optimize", ["{study_vr_upper.toml}", "-o", "{tmp}/o"],
     ["study_vr_upper.toml", "variables.volume_ratio.upper", "[0.001, 1000]"]),
    ("optimize", ["{study_vr_fixed.toml}", "-o", "{tmp}/o"],
     ["study_vr_fixed.toml", "variables.volume_ratio.start"]),
    ("optimize", ["{study_band_200.toml}", "-o", "{tmp}/o"],
     ["study_band_200.toml", "target.band_max_hz = 200", "VC-A floor"]),
    ("response", ["{study_band_200.toml}"], ["study_band_200.toml", "target.band_max_hz = 200"]),
    ("response", ["--bands", "1:200"], ["--bands 1:200", "VC-A floor"]),
    ("optimize", ["{study_piston_tiny.toml}", "-o", "{tmp}/o"],
     ["study_piston_tiny.toml", "hardware.piston_area_m2"]),
    ("optimize", ["{study_temp_tiny.toml}", "-o", "{tmp}/o"],
     ["study_temp_tiny.toml", "hardware.temperature_k"]),
    ("optimize", ["{study_plain.toml}", "--builtin", "table", "-o", "{tmp}/o"],
     ["--builtin", "not both"]),
    ("pareto", ["--builtin", "table", "--objectives", "peak_transmissibility,total_volume",
                "-o", "{tmp}/p"], ["--objectives", "worst_band_margin,total_volume"]),
    # -- demo ---------------------------------------------------------------------------------
    ("demo", ["-o", "{earlier_run}"], ["--output", "already holds a run"]),
    ("demo", ["-o", "{not_a_dir}"], ["--output", "not a directory"]),
    ("demo", ["-o", "{foreign}"], ["--output", "not empty"]),
]


def hostile_counts() -> dict[str, int]:
    """Number of hostile CLI inputs per command in :data:`HOSTILE`."""
    out: dict[str, int] = {}
    for cmd, _, _ in HOSTILE:
        out[cmd] = out.get(cmd, 0) + 1
    return out


@pytest.fixture(scope="module")
def hostile_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    for name, data in FILES.items():
        (d / name).write_bytes(data)
    foreign = d / "foreign"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("mine")
    earlier = d / "earlier_run"
    earlier.mkdir()
    (earlier / "record.json").write_text('{"kind": "isodesign optimize", "run_status": '
                                         '"complete", "files": ["design.json"]}')
    (earlier / "design.json").write_text("{}")
    return d


def _fill(arg: str, d: Path) -> str:
    names = {n: str(d / n) for n in FILES}
    names.update(tmp=str(d), foreign=str(d / "foreign"), earlier_run=str(d / "earlier_run"))
    for k, v in names.items():
        arg = arg.replace("{" + k + "}", v)
    return arg


@pytest.mark.parametrize(
    ("command", "argv", "fragments"), HOSTILE,
    ids=[f"{c}-{i}" for i, (c, _, _) in enumerate(HOSTILE)],
)
def test_hostile_input_gets_one_clear_error(command, argv, fragments, hostile_dir, capsys,
                                            monkeypatch):
    # nothing may reach the solver: a case that would start the optimizer fails loudly
    def _no_solve(*a, **k):
        raise AssertionError("the computation started before the input was rejected")

    # every name a command solves through, where the command looks it up
    for target in ("isodesign.optimization.driver.optimize",
                   "isodesign.commands.optimize.optimize",
                   "isodesign.commands.pareto.pareto_front"):
        monkeypatch.setattr(target, _no_solve)
    before = sorted(os.listdir(hostile_dir))
    args = [command, *(_fill(a, hostile_dir) for a in argv)]
    status = main(args)
    _out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert status == 2, (status, err)
    assert len(lines) == 1, err
    assert lines[0].startswith("isodesign: error: "), err
    assert "Traceback" not in err and "internal error" not in err
    for f in fragments:
        assert _fill(f, hostile_dir) in lines[0], (f, lines[0])
    # a rejected run writes nothing
    assert sorted(os.listdir(hostile_dir)) == before
    assert (hostile_dir / "earlier_run" / "design.json").exists()


def test_the_table_covers_every_command_that_takes_input():
    from isodesign.cli import COMMANDS

    counts = hostile_counts()
    assert set(counts) == set(COMMANDS)
    assert sum(counts.values()) == len(HOSTILE) >= 150


def test_a_device_is_refused_as_an_output_file_and_never_replaced():
    # checked on the path check alone: were it to pass, a command run as root would rename
    # its temporary file over the device node (an earlier version replaced /dev/null)
    from isodesign.commands import check_output_path
    from isodesign.errors import InputError

    for dev in ("/dev/null", "/dev/full"):
        if not os.path.exists(dev):
            continue
        with pytest.raises(InputError, match=r"--output: .* is not a regular file"):
            check_output_path(dev, "--output")
        assert not Path(dev).is_file()  # still a device
