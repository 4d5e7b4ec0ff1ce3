"""Design studies: what to optimize, under which constraints, on which floor.

A study is a TOML file with SI values (``docs/optimization.md``; built-in: :func:`default_study`,
:func:`table_study`, :func:`vertical_study`). :func:`load_study` validates every key.

Tables and keys
---------------
``name``, ``description``
``[payload]``      mass_kg, isolators, spacing_m, cg_height_m
``[hardware]``     piston_area_m2 (or diaphragm_r1_m + diaphragm_r2_m), temperature_k,
                   minor_loss, polytropic_index, roughness_m, ``[hardware.gas]``
``[floor]``        criterion = "VC-A" | csv = "path" (+ quantity, kind, unit)
                   | record = "survey.csv" (+ statistic, percentile, axis, unit,
                   sample_rate_hz): a survey time history (docs/criteria.md, section 5);
                   with a ``[table]``: the vertical floor, also applied to x and y unless
                   ``[floor.x]``/``[floor.y]`` (same keys) or ``x = false``/``y = false``
                   say otherwise (a record gives its own x and y axes)
``[table]``        a rigid table in six DOFs (docs/table.md): isolators_m, cg_m,
                   inertia_kg_m2 | box_m, leveling_groups, instrument_points_m,
                   point_names, supply_pressure_pa, ``[table.horizontal]``
``[target]``       criterion, band_min_hz, band_max_hz
``[models]``       flow, amplitude_mode, diaphragm, random_method, points_per_band,
                   peak_points; ``diaphragm`` a name (``fit:PATH.toml`` too) or a
                   ``[models.diaphragm]`` table (model + viscoelastic parameters)
``[variables.<name>]`` for volume_ratio, top_volume_m3, capillary_length_m,
                   capillary_diameter_m: start, lower, upper, fixed; a table study's
                   levers pendulum_length_m, elastic_centre_height_m,
                   lateral_stiffness_n_per_m, lateral_loss_factor (fixed by default;
                   docs/table.md, section 13)
``[constraints]``  max_total_volume_m3, min_capillary_diameter_m, min_tilt_margin,
                   min_natural_frequency_hz, max_natural_frequency_hz,
                   max_peak_transmissibility_db, min_damping_ratio, max_mach,
                   model_validity (each numeric one may be ``false`` to switch it off);
                   table studies also min/max_rocking_frequency_hz, max_stroke_m and
                   stroke_peak_factor
``[objective]``    kind, frequency_hz (for ``transmissibility_at``), band_min_hz,
                   band_max_hz (for ``rms_velocity``)
``[solver]``       starts, seed, max_iter, tol, tie_break, workers (forked processes
                   for the starts and the Pareto sweep; capped by the cores available
                   to the process and by the number of starts)
``[scenarios]``    uncertain parameters and tolerances for robust design (optional;
                   :mod:`isodesign.optimization.uncertainty`, docs/robust.md)
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from isodesign.errors import InputError, did_you_mean
from isodesign.io.files import read_toml
from isodesign.io.plausible import unit_slips, warn_unit_slips
from isodesign.optimization.study_parsers import (  # noqa: F401  (their home before the split)
    _KEYS,
    _OBJECTIVE_OPTIONS,
    DISTORTION_DEFAULT,
    _bool,
    _check_bands_covered,
    _constraints,
    _hardware,
    _int_in,
    _models,
    _objective,
    _payload,
    _solver,
    _table,
    _target,
    _variables,
    default_distortion,
)
from isodesign.optimization.study_tables import (
    _check_acoustics,
    _floor_axes,
    _merge,
    _undot,
)
from isodesign.optimization.variables import (
    LAYOUT_CONSTRAINTS,
    POSITION_LEVER,
    VariableSpec,
    fixed_lever_changes,
    parse_levers,
    refuse_group_number,
    table_with_levers,
)
from isodesign.results import ResultDisplay
from isodesign.spring.design import ACOUSTIC_MODELS, SpringDesign
from isodesign.spring.diagnostics import MAX_STATIC_PRESSURE_PA
from isodesign.spring.flow_models import model_design

__all__ = [
    "Study",
    "default_study",
    "load_study",
    "study_from_dict",
    "table_study",
    "vertical_study",
]

_DEFAULT = {
    "name": "default",
    "description": (
        "Reference spring hardware (paper Table 1: A_p = 5.3e-3 m^2, K = 1.5) under a 600 kg "
        "optical table on 4 isolators, on a VC-A floor, for an instrument that needs VC-C in "
        "the 4-80 Hz bands."
    ),
    "payload": {"mass_kg": 600.0, "isolators": 4, "spacing_m": 1.2, "cg_height_m": 0.35},
    "hardware": {
        "piston_area_m2": 5.3e-3,
        "temperature_k": 293.15,
        "minor_loss": 1.5,
        "roughness_m": 0.0,
        "chamber_aspect_ratio": 1.0,
        "chamber_heat_exchange": False,
    },
    "floor": {"criterion": "VC-A"},
    "target": {"criterion": "VC-C", "band_min_hz": 4.0, "band_max_hz": 80.0},
    "models": {
        "flow": "womersley",
        "amplitude_mode": "self_consistent",
        "diaphragm": "viscoelastic",
        "random_method": "statistical",
        "points_per_band": 6,
        "peak_points": 80,
        "acoustics": "distributed",
        # models.distortion: not filled in (its default depends on the study:
        # study_parsers.default_distortion, resolved in _study)
    },
    "variables": {
        "volume_ratio": {"start": 1.5e-3 / 8.1e-4, "lower": 0.5, "upper": 8.0},
        "top_volume_m3": {"start": 8.1e-4, "lower": 2e-4, "upper": 4e-3},
        "capillary_length_m": {"start": 1.2e-2, "lower": 2e-3, "upper": 0.5},
        "capillary_diameter_m": {"start": 0.9e-3, "lower": 0.3e-3, "upper": 3e-3},
    },
    "constraints": {
        "max_total_volume_m3": 6e-3,
        "min_capillary_diameter_m": 0.3e-3,
        "min_tilt_margin": 1.5,
        "min_natural_frequency_hz": 0.8,
        "max_natural_frequency_hz": 3.0,
        "max_peak_transmissibility_db": 15.0,
        "min_damping_ratio": 0.05,
        "max_mach": 0.3,
        "max_pressure_pa": MAX_STATIC_PRESSURE_PA,
        "model_validity": True,
    },
    "objective": {"kind": "worst_band_margin"},
    "solver": {"starts": 8, "seed": 0, "max_iter": 300, "tol": 1e-9, "tie_break": True,
               "workers": 2},
}

#: The study schema's keys per table (``""``: top level; ``"variable"``: the keys of each
#: ``[variables.<name>]`` table), for tools that address keys by name (``isodesign sweep``).
SCHEMA_KEYS = _KEYS


@dataclass(frozen=True, eq=False, repr=False)
class Study(ResultDisplay):
    """A validated design study. Build with :func:`load_study` or :func:`default_study`.

    ``raw`` holds the resolved dictionary (defaults filled in), which is what a
    run records so that the study can be replayed. ``repr`` is one short line,
    ``str`` and ``_repr_html_`` (notebooks) give the job, the models, the free
    variables, the constraints in force and the objective.
    """

    name: str
    raw: dict
    payload: Any
    hardware: dict
    floor: Any
    target: Any
    bands: Any
    models: dict
    variables: tuple[VariableSpec, ...]
    constraints: dict
    objective: dict
    solver: dict
    source: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)
    table: Any = None
    floor_axes: Any = None
    #: The ``[scenarios]`` table (:class:`~.uncertainty.UncertaintySpace`), None: nominal only.
    scenarios: Any = None
    #: A table study's levers (:data:`~.variables.CODESIGN_LEVERS`, fixed unless freed).
    levers: tuple[VariableSpec, ...] = ()

    def _summary_items(self) -> list[tuple[str, str]]:
        """Name, job, models, variables, constraints, objective (for repr and notebooks)."""
        p = self.payload
        tg = self.raw.get("target", {})
        free = [v.name for v in (*self.variables, *self.levers) if not v.fixed]
        on = [f"{k} = {self.constraints[k]:g}" for k in _DEFAULT["constraints"]
              if k != "model_validity" and self.constraints.get(k) is not None]
        src = "built-in" if self.source == "<default>" else self.source
        items = [
            ("", repr(self.name)),
            ("payload", f"{p.mass_kg:g} kg on {p.isolators} isolators"),
            ("floor", getattr(self.floor, "name", "") or str(self.raw.get("floor"))),
            ("target", f"{self.target.name} {tg.get('band_min_hz', '?'):g}-"
                       f"{tg.get('band_max_hz', '?'):g} Hz"),
            ("objective", self.objective["kind"]),
            ("free", ", ".join(free) or "none"),
            ("constraints", ", ".join(on) + (" + model validity"
                                             if self.constraints.get("model_validity")
                                             else "")),
            ("models", f"{self.models['flow']} flow, {self.models['diaphragm']} diaphragm"),
            ("solver", f"{self.solver['starts']} starts, seed {self.solver['seed']}"),
            ("source", src),
        ]
        return items

    def __repr__(self) -> str:
        items = dict(self._summary_items())
        return (f"<Study {self.name!r}: {items['payload']}, {items['floor']} -> "
                f"{items['target']}, {items['objective']}, source {items['source']}>")

    def variable(self, name: str) -> VariableSpec:
        """The spec of one design variable or lever (InputError naming them for another)."""
        specs = (*self.variables, *self.levers)
        for v in (v for v in specs if v.name == name):
            return v
        raise InputError(f"name: unknown design variable {name!r:.60}; this study's: "
                         f"{', '.join(v.name for v in specs)}")

    def table_at(self, values: dict | None = None):
        """The table with its levers at ``values`` (fixed or missing ones at their start).

        Parameters
        ----------
        values : dict, optional
            Lever values by name (:data:`~.variables.CODESIGN_LEVERS`), SI.

        Returns
        -------
        Table or None
            ``self.table`` itself when every lever keeps the table's value.
        """
        if self.table is None or not self.levers:
            return self.table
        return table_with_levers(self.table, self.levers, values)

    def with_levers_fixed(self, values: dict) -> Study:
        """The study with its free levers fixed at ``values`` and written into its
        ``[table.horizontal]`` (a co-designed optimum's table; self when none is free).

        Parameters
        ----------
        values : dict
            Lever values by name, SI (an optimum's ``values``).
        """
        free = [v.name for v in self.levers if v.free]
        if not free:
            return self
        return self.with_changes(name=self.name, description=str(self.raw.get("description", "")),
                                 **fixed_lever_changes(self.table, self.levers, values))

    def start_design(self):
        """The spring at the variables' start values, p0 from the payload."""
        return self.design_at({v.name: v.start for v in self.variables})

    def design_at(self, values: dict):
        """The spring at given design-variable values (fixed ones from the study)."""
        vals = {v.name: (v.start if v.fixed else values.get(v.name, v.start))
                for v in self.variables}
        acoustics = self.models.get("acoustics", ACOUSTIC_MODELS[0])
        d = model_design(self.models["flow"], SpringDesign(pressure_pa=2e5, **vals,
                                                           acoustics=acoustics,
                                                           **self.hardware))
        return d.with_load(self.payload.mass_kg, self.payload.isolators,
                           g_m_s2=self.payload.g_m_s2)

    def with_changes(self, changes: dict | None = None, /, **tables) -> Study:
        """A copy with some tables replaced or updated (validated again).

        ``study.with_changes(objective={"kind": "total_volume"})``, or by the dotted keys
        ``isodesign sweep --vary`` takes: ``study.with_changes({"payload.mass_kg": 800})``
        (also ``with_changes(**{"payload.mass_kg": 800})``).

        A changed study is another study, so it does not keep the old name and description
        silently: unless ``name`` (and ``description``) are given, a change of any table
        but ``[solver]`` names the copy ``"<name> (changed)"`` and appends to its
        description which tables changed. Solver settings (starts, seed, workers, ...)
        change how the study is solved, not the study: they keep the name.

        Parameters
        ----------
        changes : dict, optional
            Dotted keys (``{"payload.mass_kg": 800, "floor.criterion": "VC-B"}``) or tables,
            merged with ``tables``.
        **tables
            Tables of the study schema (``payload={"mass_kg": 900.0}``), dotted keys, and
            optionally ``name`` and ``description`` (strings).

        Returns
        -------
        Study

        Raises
        ------
        InputError
            A change that is not a key of the schema, or an invalid value (named as given).
        """
        tables = _undot(changes, tables)
        changed = sorted(k for k in tables if k not in ("solver", "name", "description"))
        if changed and "name" not in tables:
            base = self.name.removesuffix(" (changed)")
            tables["name"] = f"{base} (changed)"
        if changed and "description" not in tables:
            old = str(self.raw.get("description", "")).strip()
            note = f"Changed from study {self.name!r}: [{'], ['.join(changed)}]."
            tables["description"] = f"{old} {note}".strip()
        raw = _merge(self.raw, tables)  # nested tables merge like a study file's
        _follow_table(raw, tables)
        if isinstance(tables.get("models"), dict) and "acoustics" in tables["models"]:
            _check_all_keys(raw, self.source)
            _check_acoustics(copy.deepcopy(raw), _models(raw["models"], self.source,
                                                         self.source),
                             _hardware(raw["hardware"], self.source), tables, self.source)
        st = study_from_dict(raw, source=self.source, fill_defaults=False)
        warn_unit_slips(tables, self.source, isolators=st.payload.isolators)
        _warn_table_slips(st, tables, self.source)
        return st


def _follow_table(raw: dict, tables: dict) -> None:
    """A change of the ``[table]``'s geometry without the matching ``[payload]`` key: the
    payload key follows the table (it is taken from it again, not compared)."""
    tt, pp = tables.get("table"), tables.get("payload")
    if not isinstance(tt, dict) or not isinstance(raw.get("payload"), dict):
        return
    pp = pp if isinstance(pp, dict) else {}
    for tkey, pkeys in (("isolators_m", ("isolators", "spacing_m")), ("cg_m", ("cg_height_m",))):
        if tkey in tt:
            for k in pkeys:
                if k not in pp:
                    raw["payload"].pop(k, None)


def _warn_table_slips(st: Study, given: dict, where: str) -> None:
    """One :class:`~isodesign.io.plausible.UnitWarning` per implausible ``[table]`` key the
    user gave (a length in mm typed as m, an inertia that does not fit the table)."""
    if st.table is None or not isinstance(given.get("table"), dict):
        return
    import warnings

    from isodesign.io.plausible import UnitWarning
    from isodesign.table.study import table_unit_slips

    for msg in table_unit_slips(st.table, given["table"], where):
        warnings.warn(msg, UnitWarning, stacklevel=4)


def _check_keys(d: dict, table: str, where: str):
    if not isinstance(d, dict):
        raise InputError(f"{where}: [{table}] must be a table")
    allowed = _KEYS[table]
    for k in d:
        if k not in allowed:
            tname = f"[{table}]" if table else "top level"
            refuse_group_number(k, table, where)
            raise InputError(f"{where}: unknown key {k!r} in {tname}{did_you_mean(k, allowed)}; "
                             f"valid: {', '.join(sorted(allowed))}")


def study_from_dict(d: dict, *, source: str = "<dict>", fill_defaults: bool = True) -> Study:
    """Validate a study dictionary (the TOML schema), filling in defaults.

    Missing tables and keys take the built-in vertical study's values, so a
    study file need only state what differs. Every error names the file, the
    table and the key. Each table is validated by its own function
    (``_payload``, ``_hardware``, ``_floor``, ``_target``, ``_models``,
    ``_variables``, ``_constraints``, ``_objective``, ``_solver``).

    Parameters
    ----------
    d : dict
        The study's tables, as parsed from TOML (see the module docstring for the
        schema); SI values, frequencies in Hz.
    source : str
        Where ``d`` came from: the study file's path (relative floor CSV and
        diaphragm table paths are resolved against its directory; errors start
        with it), or ``"<dict>"`` / ``"<default>"``.
    fill_defaults : bool
        Fill missing tables and keys from the vertical study (:func:`vertical_study`);
        False when ``d`` is already resolved (:meth:`Study.with_changes`).

    Returns
    -------
    Study
        Validated; ``raw`` holds the resolved dictionary.

    Raises
    ------
    InputError
        An unknown key, a value of the wrong type or outside its range, an
        inconsistent combination (e.g. ``lower >= upper``, ``min_tilt_margin``
        without ``payload.spacing_m`` and ``cg_height_m``), or a start design
        that is not a valid spring.
    """

    where = source
    if not isinstance(source, str):
        raise InputError(f"source: expected a string (a file name or '<dict>'), got "
                         f"{type(source).__name__}")
    if not isinstance(d, dict):
        raise InputError(f"study_from_dict: d must be a dict of study tables (the TOML schema), "
                         f"got {type(d).__name__} {d!r:.40}")
    _check_all_keys(d, where)
    try:
        return _study(d, where, source, fill_defaults)
    except InputError as exc:  # a value the schema refuses may be a unit slip: say so
        msg = str(exc)
        hints = [h.split("; a unit slip? ", 1)[1] for h in unit_slips(d)
                 if "; a unit slip? " in h and h.split(" = ", 1)[0] in msg]
        if hints:
            raise InputError(f"{msg} (a unit slip? {hints[0]})") from None
        raise


def _study(d: dict, where: str, source: str, fill_defaults: bool) -> Study:
    """The validation of :func:`study_from_dict` after the key check."""
    raw = _resolve(d, fill_defaults)
    payload = _payload(raw["payload"], where)
    hw = _hardware(raw["hardware"], where)
    given = d.get("payload") if fill_defaults else raw.get("payload")
    table = _table(raw, payload, hw, where, set(given) if isinstance(given, dict) else set())
    if table is not None:  # the payload's geometry is the table's (checked or taken)
        payload = _payload(raw["payload"], where)
    for k in ("min_rocking_frequency_hz", "max_rocking_frequency_hz",
              "min_leveling_gain_margin_db", "min_leveling_phase_margin_deg", "max_stroke_m",
              "stroke_peak_factor", *LAYOUT_CONSTRAINTS):
        if table is None and raw.get("constraints", {}).get(k) not in (None, False):
            raise InputError(f"{where}: constraints.{k} applies only to a study with a [table] "
                             "(docs/table.md)")
    floor, floor_axes = _floor_axes(raw["floor"], where, source, table)
    target, bands, band_hz = _target(raw["target"], where)
    _check_bands_covered(floor, target, bands, band_hz, where)
    models = _models(raw["models"], where, source)
    if "distortion" not in raw["models"]:  # its default where the study's NLP carries it
        models["distortion"] = default_distortion({"models": raw["models"], "table": table})
    _check_acoustics(raw, models, hw, d if fill_defaults else {}, where)
    variables = _variables(raw["variables"], where)
    cons = _constraints(raw["constraints"], where, variables, payload)
    obj = _objective(raw["objective"], where, band_hz)
    solver = _solver(raw["solver"], where)
    name = raw.get("name", "study")
    if not isinstance(name, str):
        raise InputError(f"{where}: name must be a string, got {type(name).__name__} {name!r:.40}")
    if not isinstance(raw.get("description", ""), str):
        raise InputError(f"{where}: description must be a string, got "
                         f"{type(raw['description']).__name__} {raw['description']!r:.40}")
    st = Study(name=name, raw=raw, payload=payload, hardware=hw, floor=floor, target=target,
               bands=bands, models=models, variables=variables, constraints=cons,
               objective=obj, solver=solver, source=source, table=table,
               floor_axes=floor_axes, levers=parse_levers(raw["variables"], table, where, cons, hw))
    _check_start_design(st, where)
    if fill_defaults:  # the user's own values (with_changes warns on its changes)
        warn_unit_slips(d, where, isolators=payload.isolators)
        _warn_table_slips(st, d, where)
    if raw.get("scenarios"):  # robust design (docs/robust.md); off by default
        from isodesign.optimization.uncertainty import parse_scenarios

        st = dataclasses.replace(st, scenarios=parse_scenarios(raw["scenarios"], where, st))
    return st


def _check_all_keys(d: dict, where: str) -> None:
    """Unknown keys in any table."""
    _check_keys(d, "", where)
    for t in ("payload", "hardware", "floor", "target", "models", "variables", "constraints",
              "objective", "solver"):
        if t in d:
            _check_keys(d[t], t, where)
    if "gas" in d.get("hardware", {}):
        _check_keys(d["hardware"]["gas"], "hardware.gas", where)
    for name, spec in d.get("variables", {}).items():
        if name != POSITION_LEVER:  # its keys: table.study.parse_position_lever's
            _check_keys(spec, "variable", f"{where} [variables.{name}]")


def _resolve(d: dict, fill_defaults: bool) -> dict:
    """The study with the vertical study's values filled in."""
    raw = _merge(_DEFAULT, d) if fill_defaults else copy.deepcopy(d)
    # a user's floor or hardware table replaces the default's alternatives
    if fill_defaults and "floor" in d:
        raw["floor"] = copy.deepcopy(d["floor"])
    if fill_defaults and "hardware" in d and (
        "diaphragm_r1_m" in d["hardware"] or "diaphragm_r2_m" in d["hardware"]
    ):
        raw["hardware"].pop("piston_area_m2", None)
    # a variable the user fixes keeps only the bounds the user gave (the default study's
    # bounds are not its own: a fixed value outside them is the user's choice)
    for name, spec in (d.get("variables") or {}).items() if fill_defaults else ():
        if isinstance(spec, dict) and spec.get("fixed") is True:
            for k in ("lower", "upper"):
                if k not in spec:
                    raw["variables"][name].pop(k, None)
    return raw



def _check_start_design(st: Study, where: str) -> None:
    """The start design must be a valid spring (names the field otherwise)."""
    try:
        d = st.start_design()
    except InputError as exc:
        msg = str(exc)
        if msg.startswith("mass_kg:"):  # the payload's weight, not the spring, is at fault
            raise InputError(f"{where}: payload.{msg}") from None
        raise InputError(f"{where}: start design: {exc}") from None
    if not math.isfinite(d.pressure_pa):
        raise InputError(f"{where}: payload gives a non-finite pressure")
    pmax = st.constraints.get("max_pressure_pa")
    if pmax and d.pressure_pa > pmax:
        # p0 = p_atm + m g / (n A_p) depends on the payload and the piston area only: no
        # design variable can meet the bound, so the study is refused, not optimized
        p = st.payload
        what = (" (the model's validity bound, the default: ideal gas and rolling diaphragm, "
                "docs/spring-model.md section 10; false runs it anyway, with a FAIL verdict)"
                if pmax == MAX_STATIC_PRESSURE_PA else "")
        raise InputError(
            f"{where}: constraints.max_pressure_pa = {pmax:g} Pa{what}, but the payload "
            f"({p.mass_kg:g} kg on {p.isolators} isolators of A_p = "
            f"{d.piston_area_m2:g} m^2) needs p0 = {d.pressure_pa:.4g} Pa; no design "
            "variable changes p0: more isolators, a larger piston_area_m2 or a lighter "
            "payload meet it"
        )


def load_study(path) -> Study:
    """Read and validate a study TOML file (missing keys take the vertical study's values).

    Parameters
    ----------
    path : str or path-like
        The study file (TOML, SI values). Relative paths inside it (floor CSV,
        diaphragm table) are taken relative to its directory.

    Returns
    -------
    Study

    Raises
    ------
    InputError
        An unreadable or malformed file, or an invalid study (see
        :func:`study_from_dict`); the message names the file and the key.
    """
    if not isinstance(path, str | Path) and not hasattr(path, "__fspath__"):
        raise InputError(f"path: expected a study file name (a string or path), got "
                         f"{type(path).__name__} {path!r:.40}")
    if isinstance(path, str) and not path.strip():
        raise InputError("path: empty; give a study file name")
    return study_from_dict(read_toml(path, what="study"), source=str(path))


def default_study() -> Study:
    """The built-in default study (``data/default_study.toml``): :func:`table_study` with its
    co-design levers free within practical bounds (docs/table.md, section 13)."""
    return _builtin("default_study.toml")


def vertical_study() -> Study:
    """The built-in vertical study: every key at its default (``data/vertical_study.toml``)."""
    return study_from_dict({"name": "vertical"}, source="<default>")


def table_study() -> Study:
    """The built-in table study (``isodesign/data/table_study.toml``, docs/table.md): 600 kg
    on four isolators 1.2 x 0.8 m apart, CG 0.35 m above them, VC-A floor in three axes."""
    return _builtin("table_study.toml")


def _builtin(name: str) -> Study:
    from importlib import resources
    with resources.as_file(resources.files("isodesign") / "data" / name) as p:
        return load_study(p)


BUILTIN_STUDIES = {"default": default_study, "table": table_study, "vertical": vertical_study}
