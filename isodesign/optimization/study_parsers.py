"""The study file's table parsers (``[payload]``, ``[hardware]``, ``[target]``, ``[models]``,
``[variables]``, ``[constraints]``, ``[objective]``, ``[solver]``): each checks its table and
returns its resolved values, an :class:`~isodesign.errors.InputError` naming the key as typed
otherwise. :mod:`isodesign.optimization.study` builds the :class:`Study` from them (split from
it; its names stay importable there).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from isodesign.domain import CONSTRAINT_DOMAIN, DESIGN_DOMAIN, FREQUENCY_DOMAIN_HZ
from isodesign.errors import InputError, check_choice
from isodesign.floor import criterion, third_octave_bands
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.study_tables import (
    FLOOR_KEYS,
    _num,
)
from isodesign.optimization.variables import (
    CODESIGN_LEVERS,
    DESIGN_VARIABLES,
    GROUP_SPRING_LEVERS,
    LAYOUT_CONSTRAINTS,
    POSITION_LEVER,
    VariableSpec,
    check_load_range,
    footprint_bounds,
)
from isodesign.response.isolator import Payload
from isodesign.spring.design import ACOUSTIC_MODELS, piston_area_from_diaphragm
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import SMOOTH_FLOW_MODELS
from isodesign.spring.gas import Gas
from isodesign.spring.stiffness import AMPLITUDE_MODES

#: The valid keys of every table of a study file.
_KEYS = {
    "": {"name", "description", "payload", "hardware", "floor", "target", "models",
         "variables", "constraints", "objective", "solver", "table", "scenarios"},
    "payload": {"mass_kg", "isolators", "spacing_m", "cg_height_m"},
    "hardware": {"piston_area_m2", "diaphragm_r1_m", "diaphragm_r2_m", "temperature_k",
                 "minor_loss", "polytropic_index", "roughness_m", "gas",
                 "chamber_aspect_ratio", "chamber_heat_exchange", "tube_end_correction"},
    "hardware.gas": {"name", "gas_constant_j_per_kg_k", "heat_capacity_ratio", "viscosity_pa_s"},
    "floor": FLOOR_KEYS,
    "target": {"criterion", "band_min_hz", "band_max_hz"},
    "models": {"flow", "amplitude_mode", "diaphragm", "random_method", "points_per_band",
               "peak_points", "acoustics", "distortion"},
    "variables": set(DESIGN_VARIABLES) | set(CODESIGN_LEVERS) | set(GROUP_SPRING_LEVERS)
    | {POSITION_LEVER},
    "variable": {"start", "lower", "upper", "fixed"},
    "constraints": {"max_total_volume_m3", "min_capillary_diameter_m", "min_tilt_margin",
                    "min_natural_frequency_hz", "max_natural_frequency_hz",
                    "max_peak_transmissibility_db", "min_damping_ratio", "max_mach",
                    "max_pressure_pa", "model_validity", "min_rocking_frequency_hz",
                    "max_rocking_frequency_hz", "min_leveling_gain_margin_db",
                    "min_leveling_phase_margin_deg", "max_stroke_m", "stroke_peak_factor",
                    *LAYOUT_CONSTRAINTS},
    "objective": {"kind", "frequency_hz", "band_min_hz", "band_max_hz"},
    "solver": {"starts", "seed", "max_iter", "tol", "tie_break", "workers"},
}



def _payload(p: dict, where: str) -> Payload:
    """``[payload]``."""
    try:
        return Payload(
            mass_kg=_num(where, "payload.mass_kg", p.get("mass_kg"), 0, None, True, "kg"),
            isolators=p.get("isolators", 4),
            spacing_m=p.get("spacing_m"),
            cg_height_m=p.get("cg_height_m"),
        )
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(where) else f"{where}: payload.{msg}") from None


def _hardware(h: dict, where: str) -> dict:
    """``[hardware]``: the fixed spring parameters."""
    hw: dict[str, Any] = {}
    if "diaphragm_r1_m" in h or "diaphragm_r2_m" in h:
        if "piston_area_m2" in h:
            raise InputError(f"{where}: [hardware] give piston_area_m2 or diaphragm_r1_m + "
                             "diaphragm_r2_m, not both")
        try:
            hw["piston_area_m2"] = piston_area_from_diaphragm(h.get("diaphragm_r1_m"),
                                                              h.get("diaphragm_r2_m"))
        except InputError as exc:  # "diaphragm_r2_m: expected a number > 0 m, got None"
            raise InputError(f"{where}: hardware.{exc} (diaphragm_r1_m and diaphragm_r2_m "
                             "go together)") from None
    else:
        hw["piston_area_m2"] = _num(where, "hardware.piston_area_m2", h.get("piston_area_m2"),
                                    0, None, True, "m^2")
        lo_a, hi_a, _ = DESIGN_DOMAIN["piston_area_m2"]
        _num(where, "hardware.piston_area_m2", hw["piston_area_m2"], lo_a, hi_a, False, "m^2")
    for k, lo, hi in (("temperature_k", 1.0, 1000), ("minor_loss", 0, 100),
                      ("roughness_m", 0, 1e-2)):
        if k in h:
            hw[k] = _num(where, f"hardware.{k}", h[k], lo, hi, k == "temperature_k")
    if h.get("polytropic_index") is not None:
        hw["polytropic_index"] = _num(where, "hardware.polytropic_index", h["polytropic_index"],
                                      1.0, 1.67)
    if "chamber_aspect_ratio" in h:
        hw["chamber_aspect_ratio"] = _num(where, "hardware.chamber_aspect_ratio",
                                          h["chamber_aspect_ratio"], 0.05, 20.0, True)
    if "chamber_heat_exchange" in h:
        hw["chamber_heat_exchange"] = _bool(where, "hardware.chamber_heat_exchange",
                                            h["chamber_heat_exchange"])
        if hw["chamber_heat_exchange"] and "polytropic_index" in hw:
            raise InputError(f"{where}: hardware.chamber_heat_exchange = true is exclusive with "
                             "hardware.polytropic_index (the wall heat exchange sets the "
                             "polytropic index at each frequency)")
    if "tube_end_correction" in h:
        hw["tube_end_correction"] = _bool(where, "hardware.tube_end_correction",
                                          h["tube_end_correction"])
    if "gas" in h:
        try:
            hw["gas"] = Gas(**h["gas"])
        except InputError as exc:
            raise InputError(f"{where}: [hardware.gas] {exc}") from None
    return hw


def _table(raw: dict, payload, hw: dict, where: str, given: set):
    """``[table]`` (None without one), leveled; the ``[payload]``'s geometry keys the user
    gave (``given``) must agree with it, the others take its values (in ``raw``)."""
    if "table" not in raw:
        return None
    from isodesign.table.statics import level
    from isodesign.table.study import payload_from_table, table_from_dict

    t = table_from_dict(raw["table"], payload.mass_kg, payload.g_m_s2, where)
    raw["payload"] = payload_from_table(raw["payload"], given, t, where)
    try:
        level(t, hw["piston_area_m2"])
    except InputError as exc:
        raise InputError(f"{where}: table.{exc}") from None
    return t


def _target(tg: dict, where: str):
    """``[target]``: (criterion, bands, {"band_min_hz": ..., "band_max_hz": ...})."""
    if "criterion" not in tg:
        raise InputError(f"{where}: [target] criterion is required (e.g. \"VC-E\")")
    try:
        target = criterion(tg["criterion"])
    except InputError as exc:
        raise InputError(f"{where}: target.{exc}") from None
    bmin = _num(where, "target.band_min_hz", tg.get("band_min_hz", 1.0), 0, None, True, "Hz")
    bmax = _num(where, "target.band_max_hz", tg.get("band_max_hz", 80.0), 0, None, True, "Hz")
    if bmin > bmax:
        raise InputError(f"{where}: target.band_min_hz ({bmin:g}) must not exceed "
                         f"band_max_hz ({bmax:g})")
    bands = third_octave_bands(bmin, bmax)
    if len(bands) == 0:
        raise InputError(f"{where}: [target] no one-third octave band between {bmin:g} and "
                         f"{bmax:g} Hz")
    return target, bands, {"band_min_hz": bmin, "band_max_hz": bmax}


def _check_bands_covered(floor, target, bands, band_hz: dict, where: str) -> None:
    """The judged bands must lie inside the floor's data and the target's curve; the error
    names ``target.band_min_hz``/``band_max_hz``, the values given and the usable range."""
    bad = []
    for check in (floor._resolve_bands, target.velocity_rms_m_s):
        try:
            check(bands)
        except InputError as exc:
            bad.append(str(exc).removeprefix("bands: "))
    if not bad:
        return
    lab = np.asarray(bands.labels)
    ok = np.ones(len(lab), bool)
    lo_f, hi_f = floor.f_min_hz * (1 - 1e-9), floor.f_max_hz * (1 + 1e-9)
    ok &= (np.asarray(bands.lower_hz) >= lo_f) & (np.asarray(bands.upper_hz) <= hi_f)
    ok &= np.asarray(target.covers(bands), bool)
    keys = []
    if not ok[0]:
        keys.append(f"target.band_min_hz = {band_hz['band_min_hz']:g}")
    if not ok[-1]:
        keys.append(f"target.band_max_hz = {band_hz['band_max_hz']:g}")
    usable = (f"; the bands inside both run from {lab[ok][0]} to {lab[ok][-1]} Hz (nominal "
              "centres)" if ok.any() else "")
    raise InputError(f"{where}: {' and '.join(keys) or 'target bands'} Hz: judged "
                     f"{'; '.join(bad)}{usable}")


def _int_in(where: str, key: str, value, lo: int, hi: int | None) -> int:
    """An integer in [lo, hi] (hi None: no upper limit), else the schema's message."""
    if isinstance(value, bool) or not isinstance(value, int) or value < lo \
            or (hi is not None and value > hi):
        rng = f"in [{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise InputError(f"{where}: {key} must be an integer {rng}")
    return value


def _bool(where: str, key: str, value) -> bool:
    if not isinstance(value, bool):
        raise InputError(f"{where}: {key} must be true or false")
    return value


def _models(m: dict, where: str, source: str) -> dict:
    """``[models]``: flow model, amplitude mode, diaphragm, grids."""
    flow = m.get("flow", "womersley")
    if isinstance(flow, str) and flow.startswith("zhao"):
        raise InputError(
            f"{where}: models.flow = {flow!r} is the paper's literal model: singular at "
            "Re_w = 3.673 and non-passive near it, so it cannot be optimized. Valid: "
            f"{', '.join(SMOOTH_FLOW_MODELS)}"
        )
    check_choice(f"{where}: models.flow", flow, SMOOTH_FLOW_MODELS)
    check_choice(f"{where}: models.amplitude_mode", m.get("amplitude_mode", "self_consistent"),
                 AMPLITUDE_MODES)
    check_choice(f"{where}: models.random_method",
                 m.get("random_method", "statistical"), ("statistical", "equivalent_amplitude"))
    dia = m.get("diaphragm", "viscoelastic")
    if isinstance(dia, dict):  # [models.diaphragm]: model + viscoelastic parameters
        dia = dict(dia)
        m_name = dia.get("model", "viscoelastic")
        if isinstance(m_name, str) and m_name.startswith(("table:", "fit:")) and source not in (
                "<dict>", "<default>"):
            pre = m_name.split(":", 1)[0] + ":"
            if not Path(m_name[len(pre):]).is_absolute():
                dia["model"] = pre + str(Path(source).parent / m_name[len(pre):])
    elif not isinstance(dia, str):
        raise InputError(f"{where}: models.diaphragm must be a string or a table")
    elif source not in ("<dict>", "<default>") and dia.startswith("fit:"):
        # a fit file is relative to the study file, like a table or the floor's CSV
        if not Path(dia[len("fit:"):]).is_absolute():
            dia = f"fit:{Path(source).parent / dia[len('fit:'):]}"
    elif source not in ("<dict>", "<default>") and (dia.startswith("table:")
                                                    or dia.lower().endswith(".csv")):
        # a table path is relative to the study file, like the floor's CSV
        rel = dia[len("table:"):] if dia.startswith("table:") else dia
        if not Path(rel).is_absolute():
            dia = f"table:{Path(source).parent / rel}"
    try:
        diaphragm_model(dia)
    except InputError as exc:
        raise InputError(f"{where}: models.{exc}") from None
    check_choice(f"{where}: models.acoustics", m.get("acoustics", ACOUSTIC_MODELS[0]),
                 ACOUSTIC_MODELS)
    ppb = _int_in(where, "models.points_per_band", m.get("points_per_band", 6), 3, 200)
    npk = _int_in(where, "models.peak_points", m.get("peak_points", 80), 10, 2000)
    dist = _distortion(m, where)
    return {"flow": flow, "amplitude_mode": m.get("amplitude_mode", "self_consistent"),
            "diaphragm": dia, "random_method": m.get("random_method", "statistical"),
            "points_per_band": ppb, "peak_points": npk,
            "acoustics": m.get("acoustics", ACOUSTIC_MODELS[0]), "distortion": dist}


#: ``models.distortion``'s default (docs/random-response.md section 3d): on wherever the
#: optimizer carries it (:func:`default_distortion`).
DISTORTION_DEFAULT = True


def default_distortion(raw: dict) -> bool:
    """``models.distortion`` of a study that does not give it: :data:`DISTORTION_DEFAULT`
    where it applies, the statistical closure (``models.random_method``), and where the
    study's NLP carries it (not a ``[table]`` with ``models.flow = 'quasi_steady'``, whose
    friction excess the table NLP cannot shift: docs/random-response.md section 3d); off
    elsewhere."""
    m = raw.get("models") or {}
    if m.get("random_method", "statistical") != "statistical":
        return False
    if raw.get("table") and m.get("flow", "womersley") == "quasi_steady":
        return False
    return DISTORTION_DEFAULT


def _distortion(m: dict, where: str) -> bool:
    """``models.distortion``: the tubes' distortion power in the statistical closure
    (docs/random-response.md 3a-3d), true or false."""
    dist = m.get("distortion", default_distortion({"models": m}))
    if not isinstance(dist, bool):
        raise InputError(f"{where}: models.distortion must be true or false, got {dist!r:.40}")
    if dist and m.get("random_method", "statistical") != "statistical":
        raise InputError(f"{where}: models.distortion = true is the statistical closure's "
                         "residual; valid with models.random_method = 'statistical' only "
                         "(or models.distortion = false)")
    return dist



def _variables(table: dict, where: str) -> tuple[VariableSpec, ...]:
    """``[variables.<name>]`` for every design variable."""
    variables = []
    for name in DESIGN_VARIABLES:
        spec = table.get(name)
        if spec is None:
            raise InputError(f"{where}: [variables.{name}] is missing")
        w = f"{where}: variables.{name}"
        fixed = _bool(where, f"variables.{name}.fixed", spec.get("fixed", False))
        start = _num(where, f"variables.{name}.start", spec.get("start"), 0, None, True)
        if fixed:
            # a fixed variable's own bounds, where given, must hold its value
            own = {k: _num(where, f"variables.{name}.{k}", spec[k], 0, None, True)
                   for k in ("lower", "upper") if k in spec}
            if not own.get("lower", start) <= start <= own.get("upper", start):
                rng = (f"[{own.get('lower', start):g}, {own.get('upper', start):g}]")
                raise InputError(f"{w}.start ({start:g}) is fixed outside its own bounds "
                                 f"[lower, upper] = {rng}")
            lo = hi = start
        else:
            lo = _num(where, f"variables.{name}.lower", spec.get("lower"), 0, None, True)
            hi = _num(where, f"variables.{name}.upper", spec.get("upper"), 0, None, True)
            if not lo < hi:
                raise InputError(f"{w}: lower ({lo:g}) must be below upper ({hi:g})")
            if not lo <= start <= hi:
                raise InputError(f"{w}.start ({start:g}) must lie in [lower, upper] = "
                                 f"[{lo:g}, {hi:g}]")
        dlo, dhi, unit = DESIGN_DOMAIN[name]
        for k, v in (("start", start), ("lower", lo), ("upper", hi)):
            if k != "start" and fixed:
                continue
            if not dlo <= v <= dhi:
                raise InputError(f"{where}: variables.{name}.{k} = {v:g} is outside the models' "
                                 f"domain [{dlo:g}, {dhi:g}]{' ' + unit if unit else ''}")
        variables.append(VariableSpec(name, start, lo, hi, fixed))
    if all(v.fixed for v in variables):
        raise InputError(f"{where}: [variables] every design variable is fixed, so there is "
                         "nothing to optimize; free at least one (fixed = false with lower "
                         "and upper), or analyze the fixed spring with isodesign response")
    return tuple(variables)


def _constraints(c: dict, where: str, variables, payload) -> dict:
    """``[constraints]``: each numeric one a positive number or false (off)."""
    cons: dict[str, Any] = {}
    cons["footprint_m"] = footprint_bounds(where, c.get("footprint_m", False))
    for k in _KEYS["constraints"] - {"model_validity", "stroke_peak_factor", "footprint_m"}:
        v = c.get(k, False)
        if v is False or v is None:
            cons[k] = None
            continue
        lo_open = k != "max_peak_transmissibility_db"  # 0 dB is a valid peak bound
        cons[k] = _num(where, f"constraints.{k}", v, 0.0, None, lo_open)
        lo, hi, unit = CONSTRAINT_DOMAIN[k]  # the models' numeric domain
        _num(where, f"constraints.{k}", v, lo, hi, False, unit)
    check_load_range(where, cons)
    for lo_k, hi_k in (("min_natural_frequency_hz", "max_natural_frequency_hz"),
                       ("min_rocking_frequency_hz", "max_rocking_frequency_hz")):
        if cons[lo_k] and cons[hi_k] and cons[lo_k] >= cons[hi_k]:
            raise InputError(f"{where}: constraints.{lo_k} must be below {hi_k} (got "
                             f"{cons[lo_k]:g} >= {cons[hi_k]:g} Hz)")
    dmin = cons.get("min_capillary_diameter_m")
    dvar = next(v for v in variables if v.name == "capillary_diameter_m")
    if dmin and dvar.fixed and dvar.start < dmin:
        raise InputError(f"{where}: variables.capillary_diameter_m is fixed at "
                         f"{dvar.start:g} m, below constraints.min_capillary_diameter_m "
                         f"({dmin:g} m)")
    if dmin and not dvar.fixed and dvar.upper <= dmin:
        raise InputError(f"{where}: variables.capillary_diameter_m.upper ({dvar.upper:g} m) "
                         f"must exceed constraints.min_capillary_diameter_m ({dmin:g} m)")
    # a table's stroke: peak factor x RMS vertical stroke <= max_stroke_m (docs/table.md)
    cons["stroke_peak_factor"] = _num(where, "constraints.stroke_peak_factor",
                                      c.get("stroke_peak_factor", 3.0), 1.0, 100.0)
    cons["model_validity"] = _bool(where, "constraints.model_validity",
                                   c.get("model_validity", True))
    if cons["min_tilt_margin"] and (payload.spacing_m is None or payload.cg_height_m is None):
        raise InputError(f"{where}: constraints.min_tilt_margin needs payload.spacing_m and "
                         "payload.cg_height_m (or set min_tilt_margin = false)")
    return cons


#: Options of the ``[objective]`` table an objective may read (its
#: :attr:`~isodesign.optimization.objectives.Objective.options`): the target table's
#: key that gives the default (None: required) and the unit named in errors.
_OBJECTIVE_OPTIONS = {
    "frequency_hz": (None, "Hz"),
    "band_min_hz": ("band_min_hz", ""),
    "band_max_hz": ("band_max_hz", ""),
}


def _objective(o: dict, where: str, band_hz: dict) -> dict:
    """``[objective]``: the kind (a registered objective) and the options it reads."""
    kind = check_choice(f"{where}: objective.kind", o.get("kind", "worst_band_margin"),
                        tuple(OBJECTIVES))
    obj = {"kind": kind}
    for key in OBJECTIVES[kind].options:
        default, unit = _OBJECTIVE_OPTIONS[key]
        value = o.get(key, band_hz[default] if default else None)
        obj[key] = _num(where, f"objective.{key}", value, 0, None, True, unit)
        _num(where, f"objective.{key}", value, *FREQUENCY_DOMAIN_HZ, False, "Hz")
    for key in set(_OBJECTIVE_OPTIONS) - set(OBJECTIVES[kind].options):
        if key in o:  # another kind's option (kept for a sweep over kinds): still a value
            _num(where, f"objective.{key}", o[key], 0, None, True, "Hz")
            _num(where, f"objective.{key}", o[key], *FREQUENCY_DOMAIN_HZ, False, "Hz")
    return obj


def _solver(s: dict, where: str) -> dict:
    """``[solver]``: starts, seed, iteration limit, tolerance, tie-break, workers."""
    return {
        "starts": _int_in(where, "solver.starts", s.get("starts", 8), 1, 256),
        "seed": _int_in(where, "solver.seed", s.get("seed", 0), 0, None),
        "max_iter": _int_in(where, "solver.max_iter", s.get("max_iter", 300), 1, 10000),
        "tol": _num(where, "solver.tol", s.get("tol", 1e-9), 1e-14, 1e-2),
        "tie_break": _bool(where, "solver.tie_break", s.get("tie_break", True)),
        "workers": _int_in(where, "solver.workers", s.get("workers", 2), 1, 64),
    }
