"""Design files: a :class:`~isodesign.spring.design.SpringDesign` as a TOML document.

Schema (SI values; see ``docs/design-file.md``)::

    volume_ratio = 1.8518518518518519     # N = V_b0 / V_t0            required
    top_volume_m3 = 0.00081               # V_t0                       required
    capillary_length_m = 0.012            # L_c                        required
    capillary_diameter_m = 0.0009         # D_c                        required
    piston_area_m2 = 0.0053               # A_p, or diaphragm_r1_m + diaphragm_r2_m (Eq. 43)
    pressure_pa = 493000.0                # p0 absolute, or a [load] table (Eq. 1)
    temperature_k = 288.1                 # optional (288.15)
    minor_loss = 1.5                      # optional (1.5)
    polytropic_index = 1.2                # optional (omitted: adiabatic, n = kappa)
    roughness_m = 0.0                     # optional (0)
    acoustics = "lumped"                  # optional ("distributed": docs/acoustics.md)
    chamber_aspect_ratio = 2.0            # optional (1): chamber length / diameter
    chamber_heat_exchange = true          # optional (false): wall heat exchange
    tube_end_correction = false           # optional (true): the tube ends' entrained mass

    [load]                                # instead of pressure_pa
    mass_kg = 100.0
    isolators = 4

    [models]                              # optional: the models the design was made with
    flow = "womersley"                    # (isodesign optimize records them; response and
    amplitude_mode = "self_consistent"    #  transmissibility use them unless told otherwise)
    diaphragm = "viscoelastic"

    [gas]                                 # optional (air, Sutherland viscosity)
    name = "air"
    gas_constant_j_per_kg_k = 286.9
    heat_capacity_ratio = 1.4
    viscosity_pa_s = 1.79e-5              # omitted: Sutherland's law

    [diaphragm]                           # optional: the spring's diaphragm model
    model = "viscoelastic"                # or "none", "table:PATH.csv", "fit:PATH.toml"
    k0_n_per_m = 8400.0                   # any ViscoelasticDiaphragm parameter

Every problem raises :class:`~isodesign.errors.InputError` whose message names
the file (``source``) and the key.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from isodesign.errors import InputError
from isodesign.io.files import read_toml
from isodesign.io.plausible import warn_unit_slips
from isodesign.response.isolator import MAX_ISOLATORS
from isodesign.spring.design import SpringDesign, piston_area_from_diaphragm
from isodesign.spring.diaphragm import (
    VISCOELASTIC_PARAMETERS,
    ViscoelasticDiaphragm,
    diaphragm_from_dict,
)
from isodesign.spring.gas import G_STANDARD, Gas, pressure_from_load

__all__ = [
    "DESIGN_KEYS",
    "GAS_KEYS",
    "LOAD_KEYS",
    "MODEL_KEYS",
    "check_design_values",
    "design_from_dict",
    "design_to_toml",
    "diaphragm_to_toml",
    "load_design",
    "load_design_models",
    "load_diaphragm",
    "reference_design_path",
    "save_design",
]

def check_design_values(values, where: str = "values") -> dict:
    """The four design variables of a drawn design (``values`` of a result, robust.json or
    a Python call): a dict with each a finite number > 0; an InputError naming what is wrong.

    Parameters
    ----------
    values : dict
        ``{"volume_ratio": ..., "top_volume_m3": ..., "capillary_length_m": ...,
        "capillary_diameter_m": ...}``; other keys are refused.
    where : str
        What the values are (``"robust.json values"``), starting every message.

    Returns
    -------
    dict
        Name -> float.
    """
    import math

    from isodesign.optimization.variables import DESIGN_VARIABLES

    if not isinstance(values, dict):
        raise InputError(f"{where}: expected a table of the design variables "
                         f"({', '.join(DESIGN_VARIABLES)}), got {type(values).__name__} "
                         f"{values!r:.40}")
    unknown = [k for k in values if k not in DESIGN_VARIABLES]
    if unknown:
        raise InputError(f"{where}: unknown design variable {str(unknown[0])!r:.40}; valid: "
                         f"{', '.join(DESIGN_VARIABLES)}")
    missing = [k for k in DESIGN_VARIABLES if k not in values]
    if missing:
        raise InputError(f"{where}: missing {', '.join(missing)} (every design variable: "
                         f"{', '.join(DESIGN_VARIABLES)})")
    out = {}
    for k in DESIGN_VARIABLES:
        v = values[k]
        ok = isinstance(v, int | float) and not isinstance(v, bool)
        try:
            ok = ok and math.isfinite(float(v)) and float(v) > 0
        except OverflowError:
            ok = False
        if not ok:
            raise InputError(f"{where}: {k} must be a finite number > 0, got {v!r:.40}")
        out[k] = float(v)
    return out


#: Top-level keys and their meaning (the first four are required).
DESIGN_KEYS: dict[str, str] = {
    "volume_ratio": "N = V_b0/V_t0 (> 0)",
    "top_volume_m3": "top-chamber volume V_t0, m^3 (> 0)",
    "capillary_length_m": "capillary length L_c, m (> 0)",
    "capillary_diameter_m": "capillary diameter D_c, m (> 0, < L_c)",
    "piston_area_m2": "equivalent piston area A_p, m^2 (> 0)",
    "diaphragm_r1_m": "free width r1 of the rolling diaphragm, m (> 0; with diaphragm_r2_m)",
    "diaphragm_r2_m": "piston radius r2 of the rolling diaphragm, m (> 0; with diaphragm_r1_m)",
    "pressure_pa": "absolute static pressure p0, Pa (> 101325)",
    "temperature_k": "static gas temperature T0, K (> 0; default 288.15)",
    "minor_loss": "minor-loss coefficient K of the capillary, [0, 100] (default 1.5)",
    "polytropic_index": "polytropic index n in [1, kappa] (default: adiabatic, n = kappa)",
    "roughness_m": "capillary wall roughness, m (>= 0; default 0)",
    "acoustics": "acoustic model of tube and chambers: distributed (default) or lumped",
    "chamber_aspect_ratio": "length / diameter of the cylindrical chambers, (0.05, 20] "
    "(default 1)",
    "chamber_heat_exchange": "heat exchange with the chamber walls, true or false "
    "(default false)",
    "tube_end_correction": "the entrained mass at the tube's ends (flanged end correction), "
    "true or false (default true)",
    "load": "table [load]: mass_kg, isolators (instead of pressure_pa)",
    "gas": "table [gas]: name, gas_constant_j_per_kg_k, heat_capacity_ratio, viscosity_pa_s",
    "diaphragm": "table [diaphragm]: model (viscoelastic, none, table:PATH, fit:PATH) and the "
    "viscoelastic parameters",
    "models": "table [models]: flow, amplitude_mode, diaphragm, random_method (optional)",
}
REQUIRED_KEYS = ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m")
#: Keys of the ``[load]`` table.
LOAD_KEYS: dict[str, str] = {
    "mass_kg": "supported payload mass, kg (> 0)",
    "isolators": "number of identical isolators sharing the payload (integer, 1..1000)",
}
#: Keys of the ``[models]`` table: the spring models a design was made with (optional; not
#: part of the spring itself, so :func:`design_from_dict` checks and then ignores them).
MODEL_KEYS: dict[str, str] = {
    "flow": "capillary flow model (isodesign.spring.capillary.FLOW_MODELS)",
    "amplitude_mode": "tube velocity amplitude: self_consistent or kinematic",
    "diaphragm": "diaphragm model: viscoelastic, none or table:PATH.csv",
    "random_method": "random closure: equivalent_amplitude or rayleigh",
}
#: Keys of the ``[gas]`` table.
GAS_KEYS: dict[str, str] = {
    "name": "label (string)",
    "gas_constant_j_per_kg_k": "specific gas constant R, J/(kg K) (> 0)",
    "heat_capacity_ratio": "kappa = c_p/c_v, (1, 1.7]",
    "viscosity_pa_s": "fixed dynamic viscosity, Pa s (> 0; omitted: Sutherland's law)",
    "sutherland_mu_ref_pa_s": "Sutherland reference viscosity, Pa s (> 0)",
    "sutherland_t_ref_k": "Sutherland reference temperature, K (> 0)",
    "sutherland_s_k": "Sutherland constant S, K (> 0)",
}

#: Keys whose values are not numbers (checked by :class:`SpringDesign` itself).
_CHOICE_KEYS = ("acoustics", "chamber_heat_exchange", "tube_end_correction")
_SCALAR_KEYS = tuple(k for k in DESIGN_KEYS
                     if k not in ("load", "gas", "diaphragm", "models", *_CHOICE_KEYS))


def reference_design_path() -> Path:
    """Path of the shipped design file of the paper's Table 1 spring."""
    return Path(__file__).parent.parent / "data" / "reference.toml"


def _check_keys(d: dict, valid: dict[str, str], where: str, source: str) -> None:
    for key in d:
        if key not in valid:
            raise InputError(
                f"{source}: unknown key {key!r}{where}; valid keys: {', '.join(valid)}"
            )


def _number(d: dict, key: str, source: str, label: str | None = None) -> float:
    """A finite real number (TOML integer or float, not a bool) from ``d[key]``."""
    v = d[key]
    name = label or key
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise InputError(
            f"{source}: {name}: expected a number ({_meaning(name)}), got {_toml_type(v)} {v!r}"
        )
    try:
        v = float(v)
    except OverflowError:
        raise InputError(
            f"{source}: {name}: must be finite ({_meaning(name)}), got an integer of "
            f"{len(str(abs(v)))} digits"
        ) from None
    if not math.isfinite(v):
        raise InputError(f"{source}: {name}: must be finite ({_meaning(name)}), got {v!r}")
    return v


def _meaning(name: str) -> str:
    if name.startswith("load."):
        return LOAD_KEYS.get(name[5:], "")
    if name.startswith("gas."):
        return GAS_KEYS.get(name[4:], "")
    return DESIGN_KEYS.get(name, "")


def _toml_type(v: Any) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, list):
        return "an array"
    return f"a {type(v).__name__}"


def _with_source(exc: InputError, source: str) -> InputError:
    msg = str(exc)
    return InputError(msg if msg.startswith(f"{source}:") else f"{source}: {msg}")


def _gas(d: Any, source: str):

    if not isinstance(d, dict):
        raise InputError(f"{source}: gas: expected a table [gas], got {_toml_type(d)}")
    _check_keys(d, GAS_KEYS, " in [gas]", source)
    kw: dict[str, Any] = {}
    for key in d:
        if key == "name":
            if not isinstance(d[key], str):
                raise InputError(f"{source}: gas.name: expected a string, got {_toml_type(d[key])}")
            kw[key] = d[key]
        else:
            kw[key] = _number(d, key, source, f"gas.{key}")
    try:
        return Gas(**kw)
    except InputError as exc:
        raise _with_source(exc, source) from None


def _pressure_from_load(d: Any, piston_area_m2: float, source: str) -> float:

    if not isinstance(d, dict):
        raise InputError(f"{source}: load: expected a table [load], got {_toml_type(d)}")
    _check_keys(d, LOAD_KEYS, " in [load]", source)
    missing = [k for k in LOAD_KEYS if k not in d]
    if missing:
        raise InputError(
            f"{source}: [load] needs {' and '.join(LOAD_KEYS)}; missing {', '.join(missing)}"
        )
    mass = _number(d, "mass_kg", source, "load.mass_kg")
    if mass <= 0:
        raise InputError(f"{source}: load.mass_kg: must be > 0 kg, got {d['mass_kg']!r}")
    n = d["isolators"]
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_ISOLATORS:
        shown = f"{n!r:.40}" if not isinstance(n, int) or abs(n) < 10**15 else "a larger integer"
        raise InputError(
            f"{source}: load.isolators: must be an integer in [1, {MAX_ISOLATORS}], got {shown}"
        )
    try:
        return pressure_from_load(mass, n, piston_area_m2)
    except InputError as exc:
        msg = str(exc)
        raise InputError(f"{source}: load.{msg}" if msg.startswith("mass_kg:") else msg) from None


def design_from_dict(d: dict, source: str = "design"):
    """Build a :class:`~isodesign.spring.design.SpringDesign` from a design-file dictionary.

    Parameters
    ----------
    d : dict
        The parsed TOML document (schema in the module docstring).
    source : str
        Where ``d`` came from (a file name); every error message starts with it.

    Returns
    -------
    SpringDesign

    Raises
    ------
    InputError
        Unknown or missing keys, wrong types, values out of range, or
        conflicting alternatives (``piston_area_m2`` with diaphragm radii,
        ``pressure_pa`` with ``[load]``).
    """

    if not isinstance(d, dict):
        raise InputError(f"{source}: expected a TOML table of design keys, got {_toml_type(d)}")
    _check_keys(d, DESIGN_KEYS, "", source)
    missing = [k for k in REQUIRED_KEYS if k not in d]
    if missing:
        raise InputError(
            f"{source}: missing key(s) {', '.join(missing)}; required: {', '.join(REQUIRED_KEYS)}"
        )
    for key in _SCALAR_KEYS:
        if key in d:
            _number(d, key, source)
    if "models" in d:
        _models(d["models"], source)
    kw: dict[str, Any] = {k: float(d[k]) for k in REQUIRED_KEYS}
    for key in ("temperature_k", "minor_loss", "polytropic_index", "roughness_m",
                "chamber_aspect_ratio"):
        if key in d:
            kw[key] = float(d[key])
    if "acoustics" in d:
        if not isinstance(d["acoustics"], str):
            raise InputError(f"{source}: acoustics: expected a string (distributed or lumped), "
                             f"got {_toml_type(d['acoustics'])} {d['acoustics']!r:.40}")
        kw["acoustics"] = d["acoustics"]
    if "chamber_heat_exchange" in d:
        kw["chamber_heat_exchange"] = d["chamber_heat_exchange"]  # a bool, checked by the design
        if kw["chamber_heat_exchange"] is True and kw.get("acoustics") == "lumped":
            import warnings

            from isodesign.errors import ModelValidityWarning

            # a warning, not an error: the file reads back the design it was written from
            warnings.warn(f"{source}: acoustics = \"lumped\" with chamber_heat_exchange = true: "
                          "the lumped chambers have no wall heat exchange (it is part of the "
                          "distributed model), so it is not computed; use acoustics = "
                          "\"distributed\" or chamber_heat_exchange = false",
                          ModelValidityWarning, stacklevel=3)
    if "tube_end_correction" in d:
        kw["tube_end_correction"] = d["tube_end_correction"]  # a bool, checked by the design

    # piston area: A_p directly, or from the diaphragm radii (Eq. 43)
    radii = [k for k in ("diaphragm_r1_m", "diaphragm_r2_m") if k in d]
    if "piston_area_m2" in d and radii:
        raise InputError(
            f"{source}: piston_area_m2 and {', '.join(radii)} both given; give either "
            "piston_area_m2 or diaphragm_r1_m and diaphragm_r2_m (Eq. 43)"
        )
    try:
        if "piston_area_m2" in d:
            kw["piston_area_m2"] = float(d["piston_area_m2"])
        elif len(radii) == 2:
            kw["piston_area_m2"] = piston_area_from_diaphragm(
                float(d["diaphragm_r1_m"]), float(d["diaphragm_r2_m"])
            )
        elif radii:
            other = "diaphragm_r2_m" if radii[0] == "diaphragm_r1_m" else "diaphragm_r1_m"
            raise InputError(f"{source}: {radii[0]} given without {other}; give both (Eq. 43)")
        else:
            raise InputError(
                f"{source}: missing key piston_area_m2 (or diaphragm_r1_m and diaphragm_r2_m)"
            )
        if "piston_area_m2" in d and kw["piston_area_m2"] <= 0:
            raise InputError(
                f"{source}: piston_area_m2: must be finite and > 0 m^2, got {d['piston_area_m2']!r}"
            )

        # gas first: the polytropic-index range depends on kappa
        if "gas" in d:
            kw["gas"] = _gas(d["gas"], source)

        # pressure: p0 directly, or from the payload (Eq. 1)
        if "pressure_pa" in d and "load" in d:
            raise InputError(
                f"{source}: pressure_pa and [load] both given; give one (p0 is derived from "
                "the load by p0 = p_atm + m g / (n A_p))"
            )
        if "pressure_pa" in d:
            kw["pressure_pa"] = float(d["pressure_pa"])
        elif "load" in d:
            kw["pressure_pa"] = _pressure_from_load(d["load"], kw["piston_area_m2"], source)
        else:
            raise InputError(f"{source}: missing key pressure_pa (or a [load] table)")
        design = SpringDesign(**kw)
    except InputError as exc:
        raise _with_source(exc, source) from None
    warn_unit_slips(d, source)  # valid but implausible: the likely unit slip, named
    return design


def _models(d: Any, source: str) -> dict[str, str]:
    """The ``[models]`` table, checked: known keys, string values."""
    if not isinstance(d, dict):
        raise InputError(f"{source}: models: expected a table [models], got {_toml_type(d)}")
    _check_keys(d, MODEL_KEYS, " in [models]", source)
    for k, v in d.items():
        if not isinstance(v, str) or not v:
            raise InputError(f"{source}: models.{k}: expected a non-empty string "
                             f"({MODEL_KEYS[k]}), got {_toml_type(v)} {v!r}")
    return dict(d)


def load_design_models(path) -> dict[str, str]:
    """The models a design file records (empty when it records none).

    The ``[models]`` table names the models; a ``[diaphragm]`` table (the diaphragm with its
    parameters) stands for ``diaphragm = PATH`` (the file itself, read by
    :func:`load_diaphragm`). A file may state its diaphragm one way only.

    Parameters
    ----------
    path : str or Path
        A TOML design file.

    Returns
    -------
    dict of str to str
        ``flow``, ``amplitude_mode``, ``diaphragm``, ``random_method`` (those recorded).

    Raises
    ------
    InputError
        A malformed ``[models]`` table, or a diaphragm given both as ``models.diaphragm`` and
        as a ``[diaphragm]`` table.
    """
    d = read_toml(path, what="design")
    if not isinstance(d, dict):
        return {}
    models = _models(d["models"], f"design file {path}") if "models" in d else {}
    if "diaphragm" in d:
        if "diaphragm" in models:
            raise InputError(
                f"design file {path}: the diaphragm is given twice, as models.diaphragm and as "
                "a [diaphragm] table: keep one"
            )
        models["diaphragm"] = str(path)
    return models


def load_design(path):
    """Read a design file.

    Parameters
    ----------
    path : str or Path
        A TOML design file.

    Returns
    -------
    SpringDesign

    Raises
    ------
    InputError
        Unreadable or malformed file, or any schema error (the message names
        the file and the key).
    """

    d = read_toml(path, what="design")
    design = design_from_dict(d, source=f"design file {path}")
    if "diaphragm" in d:  # validate it now (the model is read by load_diaphragm)
        diaphragm_from_dict(d["diaphragm"], str(path))
    load_design_models(path)  # the models too (a diaphragm given twice is refused)
    return design


def load_diaphragm(path):
    """The diaphragm model of a design file's ``[diaphragm]`` table, or ``None``.

    ``model = "viscoelastic"`` (the default) with any of its parameters
    (:data:`~isodesign.spring.diaphragm.VISCOELASTIC_PARAMETERS`), ``"none"``,
    ``"table:PATH.csv"`` or ``"fit:PATH.toml"`` (a relative path is taken from the design
    file's folder). ``--diaphragm DESIGN.toml`` reads the same table.

    Parameters
    ----------
    path : str or Path
        A design file.
    """
    d = read_toml(path, what="design")
    if "diaphragm" not in d:
        return None
    return diaphragm_from_dict(d["diaphragm"], str(path))


def diaphragm_to_toml(diaphragm) -> str:
    """The ``[diaphragm]`` table of a :class:`ViscoelasticDiaphragm` (append to a design file).

    Parameters
    ----------
    diaphragm : ViscoelasticDiaphragm
        The model whose parameters are written.
    """
    if not isinstance(diaphragm, ViscoelasticDiaphragm):
        raise InputError(
            "diaphragm: only a viscoelastic diaphragm is written as parameters; refer to a fit "
            "or table file with model = 'fit:PATH.toml' or 'table:PATH.csv'"
        )
    lines = ["[diaphragm]", 'model = "viscoelastic"']
    lines += [f"{k} = {_toml_float(getattr(diaphragm, k))}" for k in VISCOELASTIC_PARAMETERS]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------
def _toml_float(v: float) -> str:
    """Shortest round-trip repr; always a TOML float."""
    v = float(v)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(v)


def _toml_string(s: str) -> str:
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04x}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def design_to_toml(design, *, header: str | None = None, models: dict | None = None) -> str:
    """A design file (TOML text) for ``design``; :func:`load_design` reads it back exactly.

    Floats are written with their shortest round-trip representation; the
    pressure is written as ``pressure_pa`` (with the load it carries as a
    comment); gas fields equal to the defaults of :class:`~isodesign.spring.gas.Gas`
    are written only for name, R, kappa and a fixed viscosity.

    Parameters
    ----------
    design : SpringDesign
        A numeric design (not CasADi symbols).
    header : str, optional
        Comment lines placed at the top (without the ``#``).
    models : dict, optional
        The models the design was made with: its keys of :data:`MODEL_KEYS` are written
        as a ``[models]`` table (read back by :func:`load_design_models`).
    """

    lines: list[str] = []
    if header:
        lines += [f"# {h}".rstrip() for h in header.splitlines()]
    d = design.to_dict()
    gas = d.pop("gas")
    for key in _SCALAR_KEYS:
        if key in d:
            lines.append(f"{key} = {_toml_float(d[key])}")
            if key == "pressure_pa":
                load = float(design.load_n)
                lines[-1] += (
                    f"  # carries A_p (p0 - p_atm) = {load:.5g} N ({load / G_STANDARD:.4g} kg) "
                    "per spring"
                )
    if "acoustics" in d:
        lines.append(f"acoustics = {_toml_string(d['acoustics'])}")
    if "chamber_heat_exchange" in d:
        lines.append(f"chamber_heat_exchange = {'true' if d['chamber_heat_exchange'] else 'false'}")
    if "tube_end_correction" in d:
        lines.append(f"tube_end_correction = {'true' if d['tube_end_correction'] else 'false'}")
    if models:
        kept = {k: str(models[k]) for k in MODEL_KEYS if models.get(k) is not None}
        if kept:
            lines += ["", "[models]"] + [f"{k} = {_toml_string(v)}" for k, v in kept.items()]
    lines += ["", "[gas]", f"name = {_toml_string(gas['name'])}"]
    for key in ("gas_constant_j_per_kg_k", "heat_capacity_ratio", "viscosity_pa_s"):
        if key in gas:
            lines.append(f"{key} = {_toml_float(gas[key])}")
    default = Gas()
    for f in dataclasses.fields(Gas):
        if f.name.startswith("sutherland_"):
            v = getattr(design.gas, f.name)
            if v != getattr(default, f.name):
                lines.append(f"{f.name} = {_toml_float(v)}")
    return "\n".join(lines) + "\n"


def save_design(design, path, *, header: str | None = None,
                models: dict | None = None) -> Path:
    """Write :func:`design_to_toml` to ``path``; return the path.

    Parameters
    ----------
    design : SpringDesign
        The spring.
    path : str or Path
        Output file.
    header : str, optional
        Comment lines written first.
    models : dict, optional
        The models the design was made with (a ``[models]`` table).
    """
    p = Path(path)
    p.write_text(design_to_toml(design, header=header, models=models), encoding="utf-8")
    return p
