"""The objective registry: every objective of a study in one place.

Each :class:`Objective` states its name, description, natural unit, sense
(``"min"`` or ``"max"``), how the NLP writes it (minimized internally as J) on each body of
the one builder (:class:`~isodesign.optimization.problem.Problem`): the exact z reduction
of a study without ``[table]`` (:attr:`Objective.nlp`) and the table's six-degree-of-freedom
assembly (:attr:`Objective.table`, None where a table study does not offer it), its value
on NumPy metrics (:attr:`Objective.value`), the map between J and the natural value, and
how it is displayed. Adding an objective means adding one entry to :data:`OBJECTIVES`.

Internal values J (what the NLP minimizes): the negated margin (dB) for
``worst_band_margin``; dB for the transmissibilities; the natural log for the RMS
velocity and the volume (so that J is well scaled).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics import backend as bk
from isodesign.optimization.constraints import Constraint

__all__ = ["OBJECTIVES", "Objective", "objective", "rms_rows"]

_DB = 10.0 / math.log(10.0)


@dataclass(frozen=True)
class Objective:
    """One optimization objective.

    Attributes
    ----------
    name, description : str
    unit : str
        Natural unit of the reported value (``"dB"``, ``"m/s"``, ``"m^3"``).
    sense : str
        ``"max"`` or ``"min"`` (the NLP always minimizes J).
    db : bool
        J is in dB (tolerances absolute in dB) rather than a log (relative).
    nlp : callable
        ``nlp(mt, study, grid, sym) -> (J, aux variables, constraints)`` on CasADi
        metrics; ``sym(name, n)`` makes a fresh epigraph variable. Every constraint is
        separable over the grid points (a log of a sum would make the Hessian dense).
    value : callable
        ``value(mt, study, grid) -> float``: the natural value on NumPy metrics.
    to_natural, from_natural : callable
        J -> natural value and back (for epsilon bounds).
    epigraph : callable or None
        Natural value -> the tight value of the objective's epigraph variable
        (None: the objective has none).
    at_frequency : bool
        The objective needs one extra grid frequency (``objective.frequency_hz``).
    options : tuple of str
        Extra keys of the study's ``[objective]`` table it reads.
    table : callable or None
        ``table(q) -> (J, constraints)``: the form in the table's NLP
        (:class:`~isodesign.optimization.table_problem.TableProblem`) on its quantities
        ``q`` (``t_worst_band_margin``, the epigraph variable; ``margins_db``, the judged
        margins over instrument points x axes x bands; ``ln_total_volume``;
        ``ln_footprint_area``), constraints as ``(name, expr, lo, hi)`` rows. None: not an
        objective of a table study.
    display_scale, display_unit, label, display_format :
        Display: ``f"{value * display_scale:{display_format}} {display_unit}"``.
    """

    name: str
    description: str
    unit: str
    sense: str
    db: bool
    nlp: Callable
    value: Callable
    to_natural: Callable[[float], float]
    from_natural: Callable[[float], float]
    epigraph: Callable[[float], float] | None
    display_scale: float
    display_unit: str
    label: str
    display_format: str
    at_frequency: bool = False
    options: tuple[str, ...] = ()
    table: Callable | None = None

    @property
    def maximized(self) -> bool:
        """True when the natural value is maximized."""
        return self.sense == "max"

    @property
    def sense_word(self) -> str:
        """``"maximize"`` or ``"minimize"``."""
        return "maximize" if self.maximized else "minimize"

    def format(self, value) -> str:
        """A natural value in display units (``+5.010 dB``, ``6 L``, ``1.2 um/s``)."""
        if value is None:
            return "n/a"
        return f"{value * self.display_scale:{self.display_format}} {self.display_unit}"

    def minimized(self, value):
        """Natural value(s) -> value(s) to minimize (maximized ones negated)."""
        v = np.asarray(value, float)
        return -v if self.maximized else v


def objective(name: str) -> Objective:
    """The registered objective ``name`` (:class:`InputError` naming the valid ones).

    Parameters
    ----------
    name : str
        An objective kind, a key of :data:`OBJECTIVES` (``worst_band_margin``,
        ``rms_velocity``, ``peak_transmissibility``, ``transmissibility_at``,
        ``total_volume``).

    Returns
    -------
    Objective

    Raises
    ------
    InputError
        For an unknown name; the message names ``objective.kind`` and lists the
        valid kinds.
    """
    try:
        return OBJECTIVES[name]
    except KeyError:
        raise InputError(f"objective.kind: unknown {name!r}; valid: "
                         f"{', '.join(OBJECTIVES)}") from None


def rms_rows(study, grid) -> list[int]:
    """Rows of the response grid's bands inside the rms_velocity objective's range.

    Parameters
    ----------
    study : Study
        ``objective.band_min_hz`` and ``objective.band_max_hz`` (Hz) bound the
        range; each defaults to the ``[target]`` table's value, else 1 and 80 Hz.
    grid : Grid
        The NLP's grid; its response grid's bands are the candidates.

    Returns
    -------
    list of int
        Indices of the bands whose nominal centre frequency lies in the range,
        widened by 1 % at each end so that rounded nominal values at the edges
        count.

    Raises
    ------
    InputError
        When no band lies in the range.

    Notes
    -----
    The objective is ``sqrt(sum_b ms_b)`` over these rows, with ``ms_b`` the payload
    band mean-square velocity: the RMS velocity over the band range.
    """
    o = study.objective
    lo = o.get("band_min_hz", study.raw["target"].get("band_min_hz", 1.0))
    hi = o.get("band_max_hz", study.raw["target"].get("band_max_hz", 80.0))
    nominal = np.asarray(grid.response.bands.nominal_hz, float)
    rows = [r for r, fn in enumerate(nominal) if lo * 0.99 <= fn <= hi * 1.01]
    if not rows:
        raise InputError(f"objective: no target band between {lo:g} and {hi:g} Hz")
    return rows


def _sum_rows(ms, rows):
    if bk.is_casadi(ms):
        out = 0
        for r in rows:
            out = out + ms[int(r)]
        return out
    return float(np.sum(np.asarray(ms)[rows]))


def _positive_log(name: str):
    def conv(v: float) -> float:
        if v <= 0:
            raise InputError(f"epsilon bound for {name} must be > 0, got {v!r}")
        return math.log(v)
    return conv


def _identity(v: float) -> float:
    return v


def _negate(v: float) -> float:
    return -v


# -- NLP forms ------------------------------------------------------------------
def _nlp_worst_band_margin(mt, study, grid, sym):
    t = sym("t_worst_band_margin", 1)  # worst margin, dB: ms_b / lim_b^2 <= 10^(-t/10)
    lim2 = (bk.exp(mt["ln_limit2"]) if bk.is_casadi(mt["ln_limit2"])  # a sweep's parameters
            else np.exp(np.asarray(mt["ln_limit2"], float)))
    con = Constraint("epigraph_worst_band_margin", mt["ms_all"] / lim2 - bk.exp(-t / _DB),
                     -math.inf, 0.0, len(grid.target_band_rows), "band margin >= t")
    return -t, [t], [con]


def _nlp_peak_transmissibility(mt, study, grid, sym):
    t = sym("t_peak_transmissibility", 1)  # peak |T|, dB
    con = Constraint("epigraph_peak_transmissibility", _DB * mt["ln_T2_peak"] - t, -math.inf,
                     0.0, grid.n_peak, "|T|^2 (dB) <= t at every peak-grid frequency")
    return t, [t], [con]


def _nlp_transmissibility_at(mt, study, grid, sym):
    return _DB * mt["ln_T2_point"], [], []


def _nlp_rms_velocity(mt, study, grid, sym):
    rows = rms_rows(study, grid)
    t = sym("t_rms_velocity", 1)  # ln of the RMS velocity
    v_ref2 = float(np.sum(np.asarray(grid.response.floor_velocity_rms_m_s)[rows] ** 2))
    # v^2 e^(-2t) <= 1 (scaled by v_ref^2): each grid point's term times e^(-2t), so the row
    # stays separable over the grid, and it keeps its hold on t below the optimum. The form
    # v^2 <= e^(2t) lost it where e^(2t) underflows: an IPOPT step to t = -300, the
    # epigraph's box, from which the solve never came back
    con = Constraint("epigraph_rms_velocity",
                     _sum_rows(mt["ms_all"], rows) / v_ref2
                     * bk.exp(math.log(v_ref2) - 2.0 * t) - 1.0,
                     -math.inf, 0.0, 1, "RMS velocity <= e^t")
    return t, [t], [con]


def _nlp_total_volume(mt, study, grid, sym):
    return mt["ln_total_volume"], [], []


def _table_only(mt, study, grid, *args):
    raise InputError("objective.kind: footprint_area is the footprint of a table's isolators "
                     "(a study with a [table] and a free layout, docs/table.md section 15); "
                     "this study has no [table]")


# -- the table body's forms (TableProblem) ------------------------------------------
def _table_worst_band_margin(q):
    t = q["t_worst_band_margin"]  # worst margin over points x axes x bands, dB: t <= each
    return -t, [("epigraph_worst_band_margin", t - q["margins_db"], -math.inf, 0.0)]


def _table_total_volume(q):
    return q["ln_total_volume"], []


def _table_footprint_area(q):
    return q["ln_footprint_area"], []


def _table_added_mass(q):
    return q["added_mass_t"], []  # the slab's mass in tonnes (linear)


def _table_base_only(mt, study, grid, *args):
    raise InputError("objective.kind: added_mass is the mass of a table's inertia base (a "
                     "study with a [table] and variables.inertia_base_mass_kg free, "
                     "docs/table.md section 16); this study has no [table]")


def _tonnes_to_kg(j: float) -> float:
    return 1e3 * float(j)


def _kg_to_tonnes(v: float) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
        raise InputError(f"added_mass: expected a mass >= 0 kg, got {v!r:.40}")
    return float(v) / 1e3


# -- values on NumPy metrics ----------------------------------------------------------
def _value_worst_band_margin(mt, study, grid) -> float:
    return float(np.min(_DB * (mt["ln_limit2"] - mt["ln_ms_band"])))


def _value_peak_transmissibility(mt, study, grid) -> float:
    return float(np.max(_DB * mt["ln_T2_peak"]))


def _value_transmissibility_at(mt, study, grid) -> float:
    return float(_DB * mt["ln_T2_point"])


def _value_rms_velocity(mt, study, grid) -> float:
    return math.sqrt(_sum_rows(mt["ms_all"], rms_rows(study, grid)))


def _value_total_volume(mt, study, grid) -> float:
    return float(np.exp(mt["ln_total_volume"]))


def _dB_objective(name, description, sense, nlp, value, to_nat, from_nat, epigraph, label,
                  **kw) -> Objective:
    return Objective(name=name, description=description, unit="dB", sense=sense, db=True,
                     nlp=nlp, value=value, to_natural=to_nat, from_natural=from_nat,
                     epigraph=epigraph, display_scale=1.0, display_unit="dB", label=label,
                     display_format="+.3f", **kw)


#: The registry: objective name -> :class:`Objective` (the order of the docs and the CLI).
OBJECTIVES: dict[str, Objective] = {o.name: o for o in (
    _dB_objective("worst_band_margin",
                  "worst-band margin of payload velocity against the target, dB (max)", "max",
                  _nlp_worst_band_margin, _value_worst_band_margin, _negate, _negate, _identity,
                  "worst-band margin", table=_table_worst_band_margin),
    Objective(name="rms_velocity",
              description="payload RMS velocity over a band range, m/s (min)", unit="m/s",
              sense="min", db=False, nlp=_nlp_rms_velocity, value=_value_rms_velocity,
              to_natural=math.exp, from_natural=_positive_log("rms_velocity"),
              epigraph=math.log, display_scale=1e6, display_unit="um/s",
              label="payload RMS velocity", display_format=".4g",
              options=("band_min_hz", "band_max_hz")),
    _dB_objective("peak_transmissibility",
                  "resonance peak of |T| at the operating amplitude, dB (min)", "min",
                  _nlp_peak_transmissibility, _value_peak_transmissibility, _identity,
                  _identity, _identity, "peak |T|"),
    _dB_objective("transmissibility_at", "|T| at a chosen frequency, dB (min)", "min",
                  _nlp_transmissibility_at, _value_transmissibility_at, _identity, _identity,
                  None, "|T| at the chosen frequency", at_frequency=True,
                  options=("frequency_hz",)),
    Objective(name="total_volume", description="total chamber volume V_t0 (1 + N), m^3 (min)",
              unit="m^3", sense="min", db=False, nlp=_nlp_total_volume,
              value=_value_total_volume, to_natural=math.exp,
              from_natural=_positive_log("total_volume"), epigraph=None, display_scale=1e3,
              display_unit="L", label="total volume per isolator, V_t0 (1 + N)",
              display_format=".4g", table=_table_total_volume),
    Objective(name="footprint_area",
              description="the isolators' footprint, layout length x width, m^2 (min; a table "
                          "study with a free layout)", unit="m^2", sense="min", db=False,
              nlp=_table_only, value=_table_only, to_natural=math.exp,
              from_natural=_positive_log("footprint_area"), epigraph=None, display_scale=1.0,
              display_unit="m^2", label="footprint of the isolators, length x width",
              display_format=".4g", table=_table_footprint_area),
    Objective(name="added_mass",
              description="the inertia base's mass under the payload, kg (min; a table study "
                          "with variables.inertia_base_mass_kg free)", unit="kg", sense="min",
              db=False, nlp=_table_base_only, value=_table_base_only, to_natural=_tonnes_to_kg,
              from_natural=_kg_to_tonnes, epigraph=None, display_scale=1.0, display_unit="kg",
              label="added mass (inertia base)", display_format=".4g",
              table=_table_added_mass),
)}
