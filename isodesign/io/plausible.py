"""Values that are valid but implausible by orders of magnitude: the likely unit slip, named.

A study or design file states SI values (m, m^2, m^3, kg, K, Pa). A value the schema
accepts can still be off by a unit factor: ``max_total_volume_m3 = 8`` (litres typed into
m^3: an 8 m^3 spring), ``capillary_length_m = 12`` (millimetres), ``temperature_k = 20``
(degrees Celsius). :func:`unit_slips` finds them by the key's plausible range (two to three
orders of magnitude wider than any air spring of an isolation table) and says what the value
would be in the unit the user probably meant; :func:`warn_unit_slips` emits one
:class:`UnitWarning` per key (the CLI prints ``isodesign: warning: ...``). A warning, not an
error: an unusual but intended value still runs.
"""

from __future__ import annotations

import re
import warnings

__all__ = ["MAX_FLOOR_AMPLITUDE_M", "MIN_LOAD_PER_ISOLATOR_KG", "PLAUSIBLE", "UnitWarning",
           "option_slips", "unit_slips", "warn_option_slips", "warn_unit_slips"]


class UnitWarning(UserWarning):
    """A value far outside its key's plausible range: probably typed in another unit."""


# (lowest plausible, highest plausible, slip below, slip above): a slip is
# (unit the user probably typed, factor from that unit to SI, SI unit); None: no guess.
_L_M3 = ("L", 1e-3, "m^3")
_MM_M = ("mm", 1e-3, "m")
_CM2_M2 = ("cm^2", 1e-4, "m^2")
_T_KG = ("t", 1e3, "kg")
_BAR_PA = ("bar", 1e5, "Pa")
_KPA_PA = ("kPa", 1e3, "Pa")

#: Key (last part, as in a study or design file) -> (low, high, slip below, slip above).
PLAUSIBLE = {
    "max_total_volume_m3": (1e-7, 1.0, None, _L_M3),
    "top_volume_m3": (1e-7, 1.0, None, _L_M3),
    "capillary_length_m": (1e-5, 20.0, None, _MM_M),
    "capillary_diameter_m": (1e-6, 0.5, None, _MM_M),
    "min_capillary_diameter_m": (1e-6, 0.5, None, _MM_M),
    "spacing_m": (0.01, 50.0, None, _MM_M),
    "cg_height_m": (1e-3, 20.0, None, _MM_M),
    "diaphragm_r1_m": (1e-3, 1.0, None, _MM_M),
    "diaphragm_r2_m": (1e-3, 1.0, None, _MM_M),
    "piston_area_m2": (1e-6, 1.0, None, _CM2_M2),
    "mass_kg": (0.5, 1e7, _T_KG, None),
    "temperature_k": (150.0, 1000.0, ("degC", None, "K"), None),
    "max_pressure_pa": (2e4, 1e9, _BAR_PA, None),
    "pressure_pa": (2e4, 1e9, _BAR_PA, None),
    "supply_margin_pa": (1e3, 1e8, _KPA_PA, None),
    "max_stroke_m": (1e-5, 0.5, None, _MM_M),
    "dead_band_m": (1e-9, 0.05, None, _MM_M),
}


#: Smallest plausible payload per pneumatic isolator, kg: below it the spring's gauge pressure
#: (m g / (n A_p), a few kPa on the reference piston) is far below any air spring's working
#: range. A payload in tonnes typed as kg (``mass_kg = 0.6`` for 600 kg) falls below it.
MIN_LOAD_PER_ISOLATOR_KG = 2.0


def _load_slips(values: dict, head: str, isolators) -> list[str]:
    """The payload per isolator (``[payload]`` of a study, ``[load]`` of a design file)."""
    out = []
    for table in ("payload", "load"):
        p = values.get(table)
        if not isinstance(p, dict) or "mass_kg" not in p:
            continue
        m, n = p["mass_kg"], p.get("isolators", isolators)
        if (isinstance(m, bool) or not isinstance(m, int | float) or isinstance(n, bool)
                or not isinstance(n, int) or n < 1):
            continue
        try:
            m = float(m)
        except OverflowError:
            continue
        lo = PLAUSIBLE["mass_kg"][0]
        if not (lo <= m < float("inf")) or m / n >= MIN_LOAD_PER_ISOLATOR_KG:
            continue  # below the mass's own range: that message names it
        out.append(f"{head}{table}.mass_kg = {m:g} kg on {n} isolators is {m / n:.3g} kg per "
                   f"isolator, below the plausible minimum of a pneumatic isolator "
                   f"({MIN_LOAD_PER_ISOLATOR_KG:g} kg); a unit slip? mass_kg is in kg, and "
                   f"{_meant(m, _T_KG)}")
    return out


def _meant(value: float, slip) -> str:
    unit, factor, si = slip
    if factor is None:  # degrees Celsius
        return f"{value:g} {unit} would be {value + 273.15:g} {si}"
    return f"{value:g} {unit} would be {value * factor:g} {si}"


def unit_slips(values: dict, where: str = "", *, isolators: int | None = None) -> list[str]:
    """Messages for the values of ``values`` far outside their key's plausible range.

    Also the payload per isolator (``payload.mass_kg`` / ``isolators``, and a design file's
    ``[load]``) below :data:`MIN_LOAD_PER_ISOLATOR_KG`: tonnes typed as kg.

    Parameters
    ----------
    values : dict
        Key -> value; nested tables are walked (``{"constraints": {...}}``) and keys are
        named with their table (``constraints.max_total_volume_m3``). Keys without a
        plausible range (:data:`PLAUSIBLE`), booleans and non-numbers are skipped.
    where : str
        Prefix of each message (the file), e.g. ``"study.toml"``.
    isolators : int, optional
        The number of isolators when ``values`` does not give it (the study's, for a
        change of ``payload.mass_kg`` alone).

    Returns
    -------
    list of str
        One message per implausible value: the key as the user wrote it, the value, the
        plausible range and the likely unit slip.
    """
    out = []

    def walk(d, prefix):
        for k, v in d.items():
            name = f"{prefix}{k}"
            if isinstance(v, dict):
                walk(v, name + ".")
                continue
            if isinstance(v, list) and v and all(isinstance(g, dict) for g in v):
                for i, g in enumerate(v):  # table.group_springs: one table per group
                    walk(g, f"{name}: group {i + 1}: ")
                continue
            leaf = str(k)
            if leaf in ("start", "lower", "upper"):  # [variables.<name>]
                leaf = prefix.rstrip(".").split(".")[-1]
            leaf = re.sub(r"_group\d+$", "", leaf)  # a group's own spring variable
            rng = PLAUSIBLE.get(leaf)
            if rng is None or isinstance(v, bool) or not isinstance(v, int | float):
                continue
            lo, hi, below, above = rng
            try:
                v = float(v)
            except OverflowError:  # a 400-digit integer: the schema's own check names it
                continue
            if not (v == v and abs(v) != float("inf")) or v <= 0:
                continue  # the schema's own checks name these
            slip = below if v < lo else above if v > hi else None
            if v < lo or v > hi:
                head = f"{where}: " if where else ""
                msg = (f"{head}{name} = {v:g} is outside the plausible range [{lo:g}, {hi:g}] "
                       f"by orders of magnitude")
                if slip is not None:
                    msg += (f"; a unit slip? {leaf} is in {slip[2]}, and "
                            f"{_meant(v, slip)}")
                out.append(msg)

    walk(values, "")
    return out + _load_slips(values, f"{where}: " if where else "", isolators)


def warn_unit_slips(values: dict, where: str = "", *, isolators: int | None = None) -> list[str]:
    """Emit one :class:`UnitWarning` per message of :func:`unit_slips`; return them.

    Parameters
    ----------
    values : dict
        As for :func:`unit_slips`.
    where : str
        As for :func:`unit_slips`.
    isolators : int, optional
        As for :func:`unit_slips`.

    Returns
    -------
    list of str
        The messages warned.
    """
    msgs = unit_slips(values, where, isolators=isolators)
    for m in msgs:
        warnings.warn(m, UnitWarning, stacklevel=3)
    return msgs


#: Largest plausible floor displacement amplitude, m: a floor's vibration is micrometres (VC
#: curves) to a millimetre (a footfall on a light floor); 10 mm is far beyond any, so an
#: amplitude above it is a unit slip (``--floor-amplitude 5`` meant as 5 um or 5 mm).
MAX_FLOOR_AMPLITUDE_M = 0.01


def option_slips(*, payload_kg=None, isolators: int | None = None,
                 floor_amplitude_m=()) -> list[str]:
    """Messages for command-line values that are valid but implausible (the option named).

    Parameters
    ----------
    payload_kg : float, optional
        ``--payload-kg`` as given (kg), with ``isolators`` (``--isolators`` or the study's):
        below :data:`MIN_LOAD_PER_ISOLATOR_KG` per isolator, tonnes typed as kg.
    isolators : int, optional
        The number of isolators the payload is spread over.
    floor_amplitude_m : sequence of float
        ``--floor-amplitude`` in m: above :data:`MAX_FLOOR_AMPLITUDE_M`, no floor's vibration.

    Returns
    -------
    list of str
        One message per implausible option, naming it, its value and the likely unit slip.
    """
    out = []
    if (isinstance(payload_kg, int | float) and not isinstance(payload_kg, bool)
            and isinstance(isolators, int) and isolators >= 1
            and 0 < payload_kg / isolators < MIN_LOAD_PER_ISOLATOR_KG):
        out.append(f"--payload-kg {payload_kg:g} on {isolators} isolators is "
                   f"{payload_kg / isolators:.3g} kg per isolator, below the plausible minimum "
                   f"of a pneumatic isolator ({MIN_LOAD_PER_ISOLATOR_KG:g} kg); a unit slip? "
                   f"--payload-kg is in kg, and {_meant(float(payload_kg), _T_KG)}")
    big = [a for a in floor_amplitude_m if isinstance(a, int | float) and a > MAX_FLOOR_AMPLITUDE_M]
    if big:
        a = max(big)
        out.append(f"--floor-amplitude {a:g} m is beyond any floor's vibration (plausible up to "
                   f"{MAX_FLOOR_AMPLITUDE_M:g} m); a unit slip? a value without a unit is in m: "
                   f"write {a:g}um or {a:g}mm")
    return out


def warn_option_slips(**options) -> list[str]:
    """Emit one :class:`UnitWarning` per message of :func:`option_slips`; return them.

    Parameters
    ----------
    **options
        As for :func:`option_slips`.

    Returns
    -------
    list of str
        The messages warned.
    """
    msgs = option_slips(**options)
    for m in msgs:
        warnings.warn(m, UnitWarning, stacklevel=3)
    return msgs
