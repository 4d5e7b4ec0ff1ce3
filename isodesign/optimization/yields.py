"""Yield: the fraction of built tables that pass, by sampling the tolerance distributions.

Each draw is one built table: its payload, ambient pressure and temperature, and its
spring's manufacturing deviations, drawn from the ``[scenarios]`` laws (uniform, or normal
with the tolerance as three standard deviations; a list uniformly). Each is judged with
the NumPy analysis (:func:`.exchange.scenario_check`): it *passes* when the instrument's
criterion holds in every target band (worst band margin >= 0 dB on the analysis grid),
every constraint holds (violation <= :data:`.solution.FEASIBILITY_TOLERANCE`) and the
continuous peak of |T| is within :data:`.refine.PEAK_TOLERANCE_DB` of its bound.

A table study (``[table]``) is judged with the table's analysis: each draw is the table
study under the draw's scenario (:func:`.table_scenario.table_scenario`: its payload, its
centre-of-gravity offsets ``cg_offset_x_m`` / ``cg_offset_y_m``, its temperature, the built
spring's tolerances), its band response in three axes solved by the table's NumPy closure
(:func:`isodesign.table.response.table_band_response`, on the study's
``points_per_band``); it *passes* when the criterion holds at every instrument point, in
every axis and band, and the largest diagonal |T| of every axis is within
:data:`.refine.PEAK_TOLERANCE_DB` of ``constraints.max_peak_transmissibility_db``. A draw
whose leveling or closure fails does not pass.

The pass fraction comes with an exact Clopper-Pearson interval (and the Wilson score
interval); the draws run in forked workers through the optimizer's one map
(:func:`.multistart.map_in_workers`: the study inherited, only the draws and the verdicts
cross).
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np

from isodesign.errors import InputError
from isodesign.optimization.grid import build_grid
from isodesign.optimization.multistart import available_cores, map_in_workers
from isodesign.optimization.refine import PEAK_TOLERANCE_DB
from isodesign.optimization.scenario_check import scenario_check
from isodesign.optimization.solution import FEASIBILITY_TOLERANCE
from isodesign.plotting.robust import yield_histogram
from isodesign.results import ResultDisplay

__all__ = ["DEFAULT_YIELD_SAMPLES", "YieldResult", "clopper_pearson", "estimate_yield",
           "optimum_yields", "table_draw_response", "wilson"]

#: Draws of each yield a robust optimize run computes by default (``--yield-samples``,
#: the sweep's ``yield_samples``, :func:`optimum_yields`), the same for a vertical and a
#: table study. 200 draws bound a yield to within about +-7 % (95 % Clopper-Pearson, at
#: 50 %) and a 100 % yield to at least 98.2 %; a table draw costs about twice a vertical
#: one, and 2 x 500 table draws would add about 40 s to the 50 s of the robust built-in
#: table run (docs/robust.md, section 6).
DEFAULT_YIELD_SAMPLES = 200

_DB = 10.0 / math.log(10.0)
_CTX = None  # (study, values, grid) inherited by forked workers


def clopper_pearson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) binomial interval for ``k`` passes in ``n`` draws.

    Parameters
    ----------
    k, n : int
        Passes and draws (``0 <= k <= n``, ``n >= 1``).
    confidence : float
        Two-sided confidence level.

    Returns
    -------
    (float, float)
        Lower and upper bounds of the pass probability.
    """
    from scipy.stats import beta

    a = 1.0 - confidence
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def wilson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for ``k`` passes in ``n`` draws.

    Parameters
    ----------
    k, n : int
    confidence : float

    Returns
    -------
    (float, float)
    """
    from scipy.stats import norm

    z = float(norm.ppf(0.5 + confidence / 2))
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, c - h), min(1.0, c + h)


def _judge(theta) -> dict:
    study, values, grid = _CTX
    try:
        c = scenario_check(study, values, theta, grid=grid)
    except InputError as exc:  # a draw that is not a valid spring fails
        return {"passes": False, "reason": f"invalid: {exc}", "margin_db": math.nan,
                "max_violation": math.inf, "objective": math.nan, "peak_excess_db": math.nan}
    mt_margin = c["criterion_margin_db"]
    reasons = [n for n, v in c["violations"].items() if v > FEASIBILITY_TOLERANCE]
    if c["peak_excess_db"] is not None and c["peak_excess_db"] > PEAK_TOLERANCE_DB:
        reasons.append("continuous_peak_transmissibility")
    if mt_margin < 0:
        reasons.insert(0, "criterion")
    return {"passes": not reasons, "reason": ", ".join(reasons), "margin_db": mt_margin,
            "max_violation": c["max_violation"], "objective": c["objective"],
            "peak_excess_db": c["peak_excess_db"]}


def table_draw_response(study, values: dict, theta):
    """The band response of one drawn table: the table study under scenario ``theta``
    (:func:`.table_scenario.table_scenario`), the design ``values`` held, its NumPy closure
    over every point, axis and band (``models.points_per_band`` points per band).

    Parameters
    ----------
    study : Study
        With ``[table]`` and ``[scenarios]``.
    values : dict
        The design (SI).
    theta : array
        The scenario, in ``study.scenarios.names`` order.

    Returns
    -------
    (TableBandResponse, Study or ScenarioStudy)
        The response and the scenario's study.
    """
    import warnings

    from isodesign.optimization.table_scenario import table_scenario
    from isodesign.table.response import table_band_response

    sc = table_scenario(study, theta)
    d = sc.design_at(values)
    m = sc.models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = table_band_response(d, sc.table, sc.floor_axes, sc.target, bands=sc.bands,
                                points_per_band=m["points_per_band"], flow=m["flow"],
                                amplitude_mode=m["amplitude_mode"],
                                diaphragm=m["diaphragm"], warn=False,
                                distortion=bool(m.get("distortion", False)))
    return r, sc


def _judge_table(theta) -> dict:
    """The verdict of one drawn table: the table study under the draw's scenario, its band
    response over every point, axis and band (the NumPy closure)."""
    from isodesign.errors import SolverError

    study, values, _ = _CTX
    try:
        r, sc = table_draw_response(study, values, theta)
    except (InputError, SolverError) as exc:  # not a valid table, or no closure: fails
        return {"passes": False, "reason": f"invalid: {exc}", "margin_db": math.nan,
                "max_violation": math.inf, "objective": math.nan, "peak_excess_db": math.nan}
    margin = float(r.worst_margin_db)
    lim = study.constraints.get("max_peak_transmissibility_db")
    peak = None
    if lim is not None and lim is not False:
        peak = float(r.peak_transmissibility_db().max() - lim)
    reasons = ["criterion"] if margin < 0 else []
    if peak is not None and peak > PEAK_TOLERANCE_DB:
        reasons.append("peak_transmissibility")
    vals = sc.built_values(values) if hasattr(sc, "built_values") else values
    objective = margin if study.objective["kind"] == "worst_band_margin" else \
        vals["top_volume_m3"] * (1.0 + vals["volume_ratio"])
    return {"passes": not reasons, "reason": ", ".join(reasons), "margin_db": margin,
            "max_violation": max(peak or 0.0, 0.0), "objective": objective,
            "peak_excess_db": peak}


def _judge_chunk(item):
    """``(first draw's index, draws)`` -> ``(index, draws, verdicts)``."""
    i0, chunk = item
    judge = _judge_table if getattr(_CTX[0], "table", None) is not None else _judge
    return i0, chunk, [judge(th) for th in chunk]


@dataclass(frozen=True, eq=False, repr=False)
class YieldResult(ResultDisplay):
    """Outcome of :func:`estimate_yield`: draws, verdicts, pass fraction with intervals."""

    study: object
    values: dict
    draws: np.ndarray
    verdicts: tuple
    confidence: float
    seed: int
    wall_s: float = 0.0
    workers: int = 1
    label: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def samples(self) -> int:
        """Number of draws."""
        return len(self.verdicts)

    @property
    def passed(self) -> int:
        """Draws that pass."""
        return sum(1 for v in self.verdicts if v["passes"])

    @property
    def fraction(self) -> float:
        """Pass fraction."""
        return self.passed / self.samples

    @property
    def interval(self) -> tuple[float, float]:
        """Clopper-Pearson interval of the pass probability."""
        return clopper_pearson(self.passed, self.samples, self.confidence)

    @property
    def wilson_interval(self) -> tuple[float, float]:
        """Wilson score interval."""
        return wilson(self.passed, self.samples, self.confidence)

    def failure_counts(self) -> dict:
        """Reason -> number of failing draws (a draw may fail for several)."""
        out: dict = {}
        for v in self.verdicts:
            for r in filter(None, v["reason"].split(", ")):
                out[r] = out.get(r, 0) + 1
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    def worst_margin_db(self) -> float:
        """The smallest criterion margin over the draws, dB."""
        m = np.array([v["margin_db"] for v in self.verdicts], float)
        return float(np.nanmin(m)) if np.isfinite(m).any() else math.nan

    def worst(self, key: str, sense: str = "max") -> float:
        """The largest (``sense="max"``) or smallest value of a verdict field over the draws
        (``objective``, ``max_violation``, ``peak_excess_db``, ``margin_db``)."""
        v = np.array([np.nan if d[key] is None else d[key] for d in self.verdicts], float)
        return float(np.nanmax(v) if sense == "max" else np.nanmin(v))

    def to_frame(self):
        """One row per draw: parameters, margin, verdict."""
        import pandas as pd

        df = pd.DataFrame(self.draws, columns=list(self.study.scenarios.names))
        df["margin_db"] = [v["margin_db"] for v in self.verdicts]
        df["objective"] = [v["objective"] for v in self.verdicts]
        df["peak_excess_db"] = [v["peak_excess_db"] for v in self.verdicts]
        df["max_violation"] = [v["max_violation"] for v in self.verdicts]
        df["passes"] = [v["passes"] for v in self.verdicts]
        df["reason"] = [v["reason"] for v in self.verdicts]
        return df

    def _summary_items(self):
        lo, hi = self.interval
        return [("yield", f"{100 * self.fraction:.1f} % ({self.passed}/{self.samples})"),
                (f"{100 * self.confidence:g} % CI", f"{100 * lo:.1f}-{100 * hi:.1f} %"),
                ("worst margin", f"{self.worst_margin_db():+.2f} dB")]

    def summary(self) -> str:
        """Text summary."""
        lo, hi = self.interval
        wl, wh = self.wilson_interval
        sp = self.study.scenarios
        lines = [f"yield of {self.label or 'the design'} under study {self.study.name!r}: "
                 f"{self.passed} of {self.samples} draws pass = {100 * self.fraction:.1f} %",
                 f"  {100 * self.confidence:g} % interval: Clopper-Pearson {100 * lo:.2f}-"
                 f"{100 * hi:.2f} %, Wilson {100 * wl:.2f}-{100 * wh:.2f} %",
                 f"  worst criterion margin over the draws: {self.worst_margin_db():+.3f} dB",
                 "  drawn from: " + "; ".join(
                     f"{p.label()} ({'list' if p.discrete else p.distribution})"
                     for p in sp.parameters),
                 f"  {self.workers} worker(s), seed {self.seed}, {self.wall_s:.1f} s"]
        fails = self.failure_counts()
        if fails:
            lines.append("  failures: " + ", ".join(f"{k} {v}" for k, v in fails.items()))
        return "\n".join(lines)

    def record(self) -> dict:
        """JSON-ready summary (yield.json)."""
        lo, hi = self.interval
        wl, wh = self.wilson_interval
        return {"samples": self.samples, "passed": self.passed, "fraction": self.fraction,
                "confidence": self.confidence, "clopper_pearson": [lo, hi],
                "wilson": [wl, wh], "worst_margin_db": self.worst_margin_db(),
                "failures": self.failure_counts(), "values": self.values, "seed": self.seed,
                "workers": self.workers, "wall_s": self.wall_s, "label": self.label,
                "parameters": [p.label() for p in self.study.scenarios.parameters]}

    def plot(self, ax=None):
        """Histogram of the criterion margin over the draws (failures marked).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw into it (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return yield_histogram(self, ax=ax)


def _fix_given_levers(study, values):
    """``(study, spring values)``: a co-designed optimum's values (``res.values``) name its
    levers too; the study's free levers are fixed at them (the table that is built), a
    fixed lever given at another value is refused naming it (it would judge another
    table). Values without levers pass unchanged."""
    import math

    if not isinstance(values, dict):
        return study, values
    own = {v.name: v for v in getattr(study, "levers", ())}
    given = {k: v for k, v in values.items() if k in own}
    if not given:
        return study, values
    for k, v in given.items():
        spec = own[k]
        if spec.fixed and isinstance(v, int | float) and not isinstance(v, bool) \
                and not math.isclose(v, spec.start, rel_tol=1e-9, abs_tol=1e-12):
            raise InputError(f"values[{k!r}] = {v:g}, but variables.{k} is fixed at "
                             f"{spec.start:g} in the study: the yield would judge another "
                             "table; free the lever or give its fixed value")
    if any(v.free for v in own.values()):
        study = study.with_levers_fixed(given)  # its errors name values[...]
    return study, {k: v for k, v in values.items() if k not in own}


def estimate_yield(study, values: dict, *, samples: int = 1000, seed: int = 0,
                   confidence: float = 0.95, workers: int | None = None,
                   label: str = "", progress=None) -> YieldResult:
    """Sample the tolerance distributions and judge every draw with the NumPy analysis.

    A study with ``[table]`` judges every draw with the table's analysis (payload, CG
    offsets, temperature and tolerances applied; every point, axis and band), any other
    with the vertical one (see the module docstring).

    Parameters
    ----------
    study : Study
        With ``[scenarios]`` (the laws to draw from).
    values : dict
        The drawn design (SI): any design, e.g. a nominal or robust optimum's ``values``
        or a design file's variables.
    samples : int
        Number of draws (1..1,000,000).
    seed : int
    confidence : float
        Level of the intervals, in (0, 1).
    workers : int, optional
        Worker processes (default ``study.solver["workers"]``), capped by the cores.
    label : str
        What the design is (for the summary).
    progress : callable, optional
        ``progress(first, draws, verdicts)`` after each chunk of draws is judged (in
        completion order): the index of its first draw, its draws and their verdicts
        (``isodesign yield`` keeps them for the table an interrupt leaves).

    Returns
    -------
    YieldResult
    """
    global _CTX
    from isodesign.io.designfile import check_design_values  # bad input: named (issue 23)
    from isodesign.optimization.study import Study

    if not isinstance(study, Study):
        raise InputError(f"study: expected a Study (load_study), got {type(study).__name__}")
    study, values = _fix_given_levers(study, values)
    values = check_design_values(values, "values")
    if study.scenarios is None:
        raise InputError("yield: the study has no [scenarios] table (the laws to draw from)")
    from isodesign.optimization.variables import refuse_free_levers

    refuse_free_levers(study, "yield")
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= 10**6:
        raise InputError(f"samples: must be an integer in [1, 1000000], got {samples!r:.30}")
    if isinstance(confidence, bool) or not isinstance(confidence, int | float) \
            or not 0 < confidence < 1:
        raise InputError(f"confidence: must be in (0, 1), got {confidence!r:.40}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed: must be an integer >= 0, got {seed!r:.40}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or not 1 <= workers <= 64):
        raise InputError(f"workers: must be an integer in [1, 64] or None, got {workers!r:.40}")
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    draws = study.scenarios.draws(samples, rng)
    workers = min(workers or study.solver.get("workers", 2), available_cores(), samples)
    grid = build_grid(study) if getattr(study, "table", None) is None else None
    _CTX = (study, dict(values), grid)
    try:
        # the optimizer's one forked map (the workers inherit the study through fork)
        # chunks of at most 50 draws (the work an interrupt can keep), 4 per worker at least
        n_chunks = min(samples, max(workers * 4, -(-samples // 50)))
        bounds = np.linspace(0, samples, n_chunks + 1).astype(int)
        chunks = [(int(a), draws[a:b]) for a, b in itertools.pairwise(bounds)]
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r:.40}")
        report = None if progress is None else (lambda _d, _n, out: progress(*out))
        parts = map_in_workers(_judge_chunk, chunks, workers=workers, progress=report)
        verdicts = [v for part in parts for v in part[2]]
    finally:
        _CTX = None
    return YieldResult(study=study, values=dict(values), draws=draws, verdicts=tuple(verdicts),
                       confidence=confidence, seed=seed, wall_s=time.perf_counter() - t0,
                       workers=workers, label=label)


def optimum_yields(study, result, samples: int | None = None, *, workers: int | None = None):
    """The yields a robust ``isodesign optimize`` run reports: its nominal and robust optima.

    The same for a vertical and a table study, and the same through the CLI
    (``--yield-samples``), a sweep's ``optimize`` task (``yield_samples``) and the API.

    Parameters
    ----------
    study : Study
        With ``[scenarios]`` (its ``seed`` seeds both estimates).
    result : RobustResult or TableRobustResult
        ``isodesign.optimize(study)``; a result without a feasible design has no yields.
    samples : int, optional
        Draws of each estimate (default :data:`DEFAULT_YIELD_SAMPLES`; 0: none).
    workers : int, optional
        Worker processes (default ``study.solver["workers"]``).

    Returns
    -------
    list of YieldResult
        ``[nominal optimum, robust optimum]``, or ``[]`` for 0 samples or no feasible design.

    Examples
    --------
    >>> res = isodesign.optimize(study)                      # doctest: +SKIP
    >>> nominal, robust = optimum_yields(study, res)         # doctest: +SKIP
    """
    n = DEFAULT_YIELD_SAMPLES if samples is None else samples
    if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= 10**6:
        raise InputError(f"yield_samples: must be an integer in [0, 1000000], got {n!r:.30}")
    if n == 0 or not result.feasible:
        return []
    seed = study.scenarios.settings["seed"]
    return [estimate_yield(study, result.nominal.values, samples=n, seed=seed,
                           workers=workers, label="nominal optimum"),
            estimate_yield(study, result.values, samples=n, seed=seed, workers=workers,
                           label="robust optimum")]
