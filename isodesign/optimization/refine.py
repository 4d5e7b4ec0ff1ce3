"""After the multi-start: peak refinement (exchange method), tie-break, branch choice.

* The peak of |T| is a semi-infinite constraint (every frequency): after a solve
  the continuous peak is measured and, if it lies above the bound between the
  sampled frequencies, movable grid frequencies (NLP parameters) are placed around
  it and the NLP is solved again (:func:`refine_peak`).
* Flat directions: in the laminar limit L_c and D_c act only through
  ``L_c / D_c^4`` (docs/optimization.md). :func:`tie_break` finds the range of D_c
  over which the objective stays within a tolerance of the optimum and returns the
  largest D_c in it (larger bores clog less and are easier to make to tolerance).
* The refinement costs distinct local optima differently, so the winning start is
  chosen after it: :func:`refine_branches` refines the best start of each distinct
  branch and keeps the best refined one. Only that one is tie-broken (the tie-break
  cannot change which branch is best: it moves a branch's point by at most its
  tolerance), and its peak is measured again at the tie-broken point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import SolverError
from isodesign.numerics.cplx import Cx
from isodesign.optimization.multistart import map_in_workers, runs_in_parallel
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.problem import PEAK_ROUNDS
from isodesign.response.isolator import transmissibility
from isodesign.response.linearization import EQUIVALENT_AMPLITUDE_FACTOR
from isodesign.response.non_gaussian import minor_loss_gain_shift
from isodesign.spring.capillary import statistical_resistance_function
from isodesign.spring.equations import air_stiffness, spring_stiffness
from isodesign.spring.stiffness import complex_stiffness

__all__ = [
    "BRANCH_TOLERANCE",
    "FLAT_TOLERANCE_DB",
    "FLAT_TOLERANCE_REL",
    "PEAK_TOLERANCE_DB",
    "TIE_BREAK_SLACK",
    "Refined",
    "continuous_peak_db",
    "flat_tolerance",
    "peak_slots",
    "refine_branches",
    "refine_peak",
    "tie_break",
]

#: Tolerance of the continuous peak of |T| over its sampled value (exchange method).
PEAK_TOLERANCE_DB = 0.01
#: Objective tolerance of the flat-direction tie-break: designs whose objective is
#: within this of the optimum (dB for dB objectives, relative otherwise) count as
#: equivalent.
FLAT_TOLERANCE_DB = 0.01
FLAT_TOLERANCE_REL = 1e-3
#: Slack on ``J <= J* + tolerance`` when accepting the tie-break point: IPOPT meets
#: the bound to its constraint tolerance, not exactly.
TIE_BREAK_SLACK = 1e-6
#: Starts whose objectives J differ by no more than this reached the same branch
#: (local optimum, or the same flat valley): only the first is refined.
BRANCH_TOLERANCE = 1e-5
_PEAK_SHIFTS = (0.99, 0.995, 1.0, 1.005, 1.01)


def flat_tolerance(kind: str) -> float:
    """The tie-break's objective tolerance for an objective (dB, or relative).

    Parameters
    ----------
    kind : str
        A registered objective kind (:data:`~.objectives.OBJECTIVES`).

    Returns
    -------
    float
        :data:`FLAT_TOLERANCE_DB` for an objective whose internal value J is in dB
        (an absolute tolerance of 0.01 dB), else :data:`FLAT_TOLERANCE_REL`: J is a
        natural log there, so an absolute 1e-3 on J is a relative 0.1 % on the
        natural value.
    """
    return FLAT_TOLERANCE_DB if OBJECTIVES[kind].db else FLAT_TOLERANCE_REL


#: :func:`continuous_peak_db` evaluates every PEAK_STRIDE-th of its 4001 samples, then
#: the samples around the largest of them.
PEAK_STRIDE = 10


def continuous_peak_db(prob, values: dict, sigma: float, tube_rms: float | None = None, *,
                       gain_ratio: float | None = None) -> tuple[float, float]:
    """Peak of |T| at the operating amplitude between the grid's frequencies (NumPy).

    A dense log grid over the peak grid's span, then a parabola through the
    largest sample and its neighbours in ln f. Returns (peak in dB, frequency in Hz).

    Parameters
    ----------
    prob : Problem
        The NLP: its study (payload, flow model, amplitude mode), diaphragm model
        and peak grid, whose lowest and highest frequencies bound the search.
    values : dict
        Design-variable values (SI) of the design.
    sigma : float
        RMS stroke of the spring at this design, m (e.g. ``prob.sigma(x)``); the
        stiffness is evaluated at the equivalent amplitude ``A* = 1.880 sigma``.
    tube_rms : float, optional
        The statistical closure (``prob.tube_rms(x)``): the tube velocity's RMS, m/s; the
        capillary's resistance is its linear part plus the Gaussian-equivalent resistance
        at ``tube_rms`` (:func:`isodesign.spring.capillary.statistical_resistance_function`)
        and the diaphragm is at ``A*``. ``None``: the harmonic describing function.
    gain_ratio : float, optional
        With the distortion power, the minor loss's gain ratio the closure's springs are
        linearized with (``evaluate_design(...)["distortion"].gain_ratio``); default: the
        NLP's NumPy terms at the design when ``prob`` carries the distortion, else 1.

    Returns
    -------
    (float, float)
        ``20 log10 |T|`` at the peak, dB, and its frequency, Hz.

    Notes
    -----
    ``|T|^2`` is evaluated at 4001 log-spaced frequencies with the full complex
    stiffness (:func:`isodesign.spring.stiffness.complex_stiffness`, every frequency
    at the same amplitude). Through the largest sample ``i`` and its two neighbours
    the parabola ``y = c2 x^2 + c1 x + c0`` with ``x = ln(f / f_i)`` and ``y`` in dB
    gives the peak ``c0 - c1^2 / (4 c2)`` at ``f_i exp(-c1 / (2 c2))``; if the
    samples are not concave (``c2 >= 0``) the largest sample itself is returned.
    """

    st = prob.study
    d = st.design_at(values)
    pk = prob.grid.omega[prob.grid.peak_slice] / (2.0 * math.pi)
    f = np.geomspace(pk.min(), pk.max(), 4001)
    a = EQUIVALENT_AMPLITUDE_FACTOR * sigma

    # with the distortion, the minor loss's gain ratio in the equivalent resistance, as in
    # the NLP and evaluate_design (metrics: docs/random-response.md 3c)
    gain = gain_ratio
    if (gain is None and tube_rms is not None and getattr(prob, "distortion", False)
            and st.models["flow"] != "poiseuille"):
        gain = getattr(prob.distortion_terms(d), "gain_ratio", None)
    if st.models["flow"] == "poiseuille":
        gain = None  # no minor loss

    def t2_at(fs):
        w = 2.0 * math.pi * fs
        if tube_rms is not None:  # the statistical closure (docs/random-response.md)
            c = statistical_resistance_function(st.models["flow"], d, w)(tube_rms)
            if gain is not None:
                c = Cx(c.re + minor_loss_gain_shift(d, tube_rms, float(gain)), c.im)
            k = spring_stiffness(air_stiffness(d, w, c, st.models["flow"]),
                                 prob.dia.stiffness(w, a)).to_complex()
        else:
            k = complex_stiffness(d, fs, a, flow=st.models["flow"],
                                  amplitude_mode=st.models["amplitude_mode"],
                                  diaphragm=prob.dia, pairwise=True, warn=False).k
        return np.abs(transmissibility(Cx.from_complex(k), st.payload.mass_per_isolator_kg,
                                       w).to_complex()) ** 2

    # every PEAK_STRIDE-th sample first, then the samples between the largest one's
    # neighbours (the same samples as the full evaluation there): a resonance is wider
    # than the stride (1.2 % in frequency over two decades), so the largest sample is in
    # that window; if the window's largest is at its edge, every sample is evaluated
    ic = int(np.argmax(t2_at(f[::PEAK_STRIDE])))
    lo = max(0, (ic - 1) * PEAK_STRIDE)
    hi = min(f.size - 1, (ic + 1) * PEAK_STRIDE)
    t2 = np.full(f.size, -np.inf)
    t2[lo: hi + 1] = t2_at(f[lo: hi + 1])
    j = int(np.argmax(t2))
    if (j == lo and lo > 0) or (j == hi and hi < f.size - 1):
        t2 = t2_at(f)
    i = int(np.clip(np.argmax(t2), 1, f.size - 2))
    x = np.log(f[i - 1: i + 2])
    y = 10.0 * np.log10(t2[i - 1: i + 2])
    c2, c1, c0 = np.polyfit(x - x[1], y, 2)
    if c2 < 0:
        xm = -c1 / (2.0 * c2)
        return float(c0 - c1 * c1 / (4.0 * c2)), float(f[i] * math.exp(xm))
    return float(y[1]), float(f[i])


def peak_slots(prob, round_index: int, f_peak_hz: float) -> list[float]:
    """Place five movable peak-grid frequencies within +-1 % of a peak (round k's slots).

    Parameters
    ----------
    prob : Problem
        The NLP; its movable frequencies are changed in place
        (:meth:`~isodesign.optimization.problem.Problem.set_slots`: NLP parameters,
        no rebuild).
    round_index : int
        Refinement round k, from 0: slots ``5 k`` to ``5 k + 4`` are set, so earlier
        rounds' frequencies stay (at most ``PEAK_ROUNDS`` rounds fit in
        :data:`~.problem.PEAK_SLOTS`).
    f_peak_hz : float
        Frequency of the continuous peak, Hz (:func:`continuous_peak_db`).

    Returns
    -------
    list of float
        The five frequencies placed, Hz: ``f_peak_hz`` times 0.99, 0.995, 1, 1.005
        and 1.01.
    """
    new = [f_peak_hz * r for r in _PEAK_SHIFTS]
    k = round_index * len(new)
    slots = prob.slot_hz.copy()
    slots[k: k + len(new)] = new
    prob.set_slots(slots)
    return new


def _peak_refined(study, prob) -> bool:
    """True when the peak grid is refined (a peak bound, or the peak objective)."""
    return (study.constraints.get("max_peak_transmissibility_db") is not None
            or prob.objective == "peak_transmissibility")


def refine_peak(study, prob, final, best, flat, *, known=(), tie_break_after=None,
                record=None):
    """Exchange method for the semi-infinite peak constraint (and objective).

    The NLP bounds |T| at the peak grid's frequencies only, so an optimum can hide
    a sharper peak between them. After each solve, the continuous peak at the
    operating amplitude is measured; if it exceeds the bound (or the sampled
    objective) by more than :data:`PEAK_TOLERANCE_DB`, five of the grid's movable
    frequencies (NLP parameters: no rebuild) are placed within +-1 % of it and the
    NLP is solved again from the current design (then the tie-break again, if
    ``tie_break_after``).

    Parameters
    ----------
    study : Study
        Gives ``constraints.max_peak_transmissibility_db`` (the bound, dB) and
        ``solver.tie_break``. Without a peak bound and unless the objective is
        ``peak_transmissibility``, nothing is refined.
    prob : Problem
        The NLP; its movable peak frequencies are moved in place.
    final : Solution
        The point to check: the (tie-broken) optimum of a start.
    best : Solution
        The optimum before its tie-break.
    flat : dict or None
        The flat-direction report of :func:`tie_break` for ``final``.
    known : sequence of float
        Objectives J (before their refinement) of branches already refined. A re-solve
        that lands within :data:`BRANCH_TOLERANCE` of one of them has joined that branch
        (on a grid with at least that branch's refinement frequencies): the refinement
        stops there and ``info["merged_with"]`` gives the index of that J in ``known``.
    tie_break_after : bool, optional
        Tie-break after each re-solve (the peak is then measured at the tie-broken
        point); default ``study.solver["tie_break"]``. :func:`refine_branches` refines
        the branches without it and tie-breaks the winner only.
    record : dict, optional
        The refinement record of an earlier call on the same point's branch (its
        ``info``): the rounds continue from its count (the next movable frequencies, at
        most :data:`~.problem.PEAK_ROUNDS` in all) and its added frequencies are kept.

    Returns
    -------
    (final, best, flat, info)
        The tie-broken and the refined optimum, the flat-direction report and the
        refinement's record (rounds, added frequencies, continuous peak).
        ``info`` holds ``rounds``, ``added_frequencies_hz``, ``peak_db`` and
        ``peak_frequency_hz`` (the continuous peak of the returned point, last
        measured), ``limit_db`` (the limit it was held to, dB), ``limit``
        (``"bound"`` or ``"objective"``: which one set it), ``excess_db``
        (``peak_db - limit_db``) and ``met`` (the peak is within
        :data:`PEAK_TOLERANCE_DB` of the limit; False when it is still above after
        the last round), all ``None`` when the peak is not checked (no bound, other
        objective); ``max_rounds`` and ``tolerance_db`` (:data:`~.problem.PEAK_ROUNDS`
        and :data:`PEAK_TOLERANCE_DB`).

    Raises
    ------
    SolverError
        When a re-solve after adding frequencies is infeasible.

    Notes
    -----
    The limit is the bound, or for the ``peak_transmissibility`` objective the
    smaller of the bound and the sampled peak J (the objective must not
    understate the true peak). At most :data:`~.problem.PEAK_ROUNDS` rounds; a peak
    still above the limit after the last round is not refined further: ``met`` is
    False and :func:`isodesign.optimization.driver.optimize` reports the excess as a
    violation of the returned design.
    """
    bound = study.constraints.get("max_peak_transmissibility_db")
    kind = prob.objective
    info = {"rounds": 0, "added_frequencies_hz": [], "peak_db": None, "peak_frequency_hz": None,
            "limit_db": None, "limit": None, "excess_db": None, "met": None,
            "max_rounds": PEAK_ROUNDS, "tolerance_db": PEAK_TOLERANCE_DB}
    if record is not None:
        info.update(rounds=record["rounds"],
                    added_frequencies_hz=list(record["added_frequencies_hz"]))
    if tie_break_after is None:
        tie_break_after = study.solver["tie_break"]
    if not _peak_refined(study, prob):
        return final, best, flat, info
    for _ in range(PEAK_ROUNDS + 1):
        vals = prob.values(final.x)
        peak_db, f_pk = continuous_peak_db(prob, vals, prob.sigma(final.x),
                                             prob.tube_rms(final.x))
        sampled = OBJECTIVES[kind].to_natural(final.objective) \
            if kind == "peak_transmissibility" else None
        limit = min(v for v in (bound, sampled) if v is not None)
        met = peak_db <= limit + PEAK_TOLERANCE_DB
        info.update(peak_db=peak_db, peak_frequency_hz=f_pk, limit_db=limit,
                    limit="bound" if limit == bound else "objective",
                    excess_db=peak_db - limit, met=bool(met))
        if met or info["rounds"] >= PEAK_ROUNDS:
            break
        info["added_frequencies_hz"] += peak_slots(prob, info["rounds"], f_pk)
        info["rounds"] += 1
        # the same point: warm-started from its multipliers (nlp.WARM_OPTIONS)
        sol = prob.solve(prob.initial_guess(vals), warm=best)
        if not sol.feasible:
            raise SolverError(
                f"peak refinement: the re-solve with frequencies added near {f_pk:.4g} Hz "
                f"failed ({sol.status})"
            )
        best = sol
        final = sol
        joined = [k for k, j in enumerate(known) if abs(sol.objective - j) <= BRANCH_TOLERANCE]
        if joined:
            info["merged_with"] = joined[0]
            break
        if tie_break_after:
            flat, final = tie_break(prob, sol, flat_tolerance(kind))
    return final, best, flat, info


def tie_break(prob, best, tol_j: float):
    """Range of D_c with the objective within tol of the optimum; pick the largest D_c.

    In the laminar limit L_c and D_c act through L_c/D_c^4 only: the optimum is a
    valley. Two more solves of the same NLP (parameters changed, warm-started at the
    optimum) minimize and maximize ln D_c subject to ``J <= J* + tol``; the documented
    tie-break returns the largest D_c (larger bores are easier to make to tolerance
    and clog less).

    Parameters
    ----------
    prob : Problem
        The NLP; solved twice with objective weights 0, ``ln D_c`` weight -1 (max)
        or +1 (min) and the epsilon bound ``J_1 <= J* + tol_j`` on the first
        objective.
    best : Solution
        The optimum J* to tie-break.
    tol_j : float
        Tolerance on the internal objective J (:func:`flat_tolerance`: dB, or an
        absolute tolerance on a log, i.e. relative).

    Returns
    -------
    (info, chosen)
        The flat-direction report (None when D_c is fixed) and the chosen solution.
        The report gives ``capillary_diameter_range_m`` and
        ``capillary_length_range_m`` (the valley's ends, m), the diameter at the
        optimum and the chosen one, ``objective_tolerance`` and ``flat`` (the
        diameter range exceeds 1 %). The chosen solution is the largest-D_c point
        with its epigraph variables re-tightened, if it is feasible and its J is
        within ``tol_j`` (plus :data:`TIE_BREAK_SLACK`) of J*; else ``best``.
    """
    if "capillary_diameter_m" not in prob.scaling.names:
        return None, best
    eps = [best.objective + tol_j] + [None] * (len(prob.objectives) - 1)
    sols = {}
    for name, wd in (("max", -1.0), ("min", 1.0)):
        sol = prob.solve(best.x, prob.params(weights=[0.0] * len(prob.objectives),
                                             diameter_weight=wd, eps=eps), warm=best)
        sols[name] = sol if sol.feasible else None
    d_opt = best.values["capillary_diameter_m"]
    rng = {k: (v.values if v is not None else None) for k, v in sols.items()}
    d_lo = rng["min"]["capillary_diameter_m"] if rng["min"] else d_opt
    d_hi = rng["max"]["capillary_diameter_m"] if rng["max"] else d_opt
    info = {
        "pair": "capillary_length_m / capillary_diameter_m^4",
        "objective_tolerance": tol_j,
        "capillary_diameter_range_m": (min(d_lo, d_opt), max(d_hi, d_opt)),
        "capillary_length_range_m": (
            (rng["min"] or best.values)["capillary_length_m"],
            (rng["max"] or best.values)["capillary_length_m"],
        ),
        "capillary_diameter_at_optimum_m": d_opt,
        "flat": bool(max(d_hi, d_opt) / min(d_lo, d_opt) > 1.01),
        "tie_break": "largest capillary diameter with the objective within the tolerance",
    }
    chosen = best
    if sols["max"] is not None:
        # with zero objective weight the epigraph variables are slack: make them tight
        # (the point stays feasible) and re-evaluate the objective and constraints
        cand = prob.retighten(sols["max"])
        if cand.feasible and cand.objective <= best.objective + tol_j + TIE_BREAK_SLACK:
            chosen = cand
    info["chosen_capillary_diameter_m"] = chosen.values["capillary_diameter_m"]
    return info, chosen


@dataclass(frozen=True, eq=False)
class Refined:
    """A start after the tie-break and the peak refinement.

    ``start`` is the index of the start, ``best`` the refined optimum of its
    branch, ``final`` the returned (tie-broken) point, ``slot_hz`` the movable
    peak frequencies its refinement placed, ``branches`` the refined branches
    ((start, refined objective J) each, the winner first).
    """

    start: int
    best: object
    final: object
    flat: dict | None
    peak: dict
    slot_hz: np.ndarray
    branches: tuple = ()
    alongside: object = None


def _refine_one(study, prob, i: int, sol, tol_j: float, known=()) -> Refined:
    """A branch's peak refinement from its start's optimum ``sol``, without the tie-break
    (:func:`refine_branches` tie-breaks the winner only: :func:`_finish`)."""
    final, best, flat, peak = refine_peak(study, prob, sol, sol, None, known=known,
                                          tie_break_after=False)
    return Refined(i, best, final, flat, peak, prob.slot_hz.copy())


def _finish(study, prob, r: Refined, tol_j: float) -> Refined:
    """The tie-break of a refined branch, with its peak measured again at the tie-broken point.

    The point the tie-break returns lies up to ``tol_j`` from the refined optimum, on the
    branch's grid: its continuous peak is measured, and if it exceeds the limit the
    exchange method goes on from there (:func:`refine_peak`, rounds counted on from the
    branch's, a tie-break after each re-solve). ``prob`` is left on the branch's movable
    frequencies.
    """
    if not np.array_equal(prob.slot_hz, r.slot_hz):
        prob.set_slots(r.slot_hz)
    flat, final = tie_break(prob, r.best, tol_j)
    final, best, flat, peak = refine_peak(study, prob, final, r.best, flat,
                                          tie_break_after=True, record=r.peak)
    return Refined(r.start, best, final, flat, peak, prob.slot_hz.copy())


def refine_branches(study, prob, sols: dict, tol_j: float, *, alongside=None) -> Refined:
    """Refine the feasible starts' branches and return the best refined one.

    ``sols`` maps start index -> feasible :class:`~.solution.Solution`. The starts are
    taken by their sampled objective (best first); starts within
    :data:`BRANCH_TOLERANCE` of a refined one reached the same branch and are skipped.
    A branch whose refinement re-solve lands on an earlier branch's optimum (within
    :data:`BRANCH_TOLERANCE`) has joined it and is not refined a second time.
    Every other branch is refined, however far behind on the sampled grid: the
    re-solve after a peak refinement is a new local solve and can move a branch a
    long way (on the default study at 717 kg, a start at 4.74 dB refines to 5.22 dB), so the sampled
    objective bounds nothing. The winner is the branch with the best refined
    optimum; only it is tie-broken (:func:`_finish_best`, in this process, when
    ``solver.tie_break``). The branches are refined in forked worker
    processes when ``solver.workers`` and the cores allow
    (:func:`~isodesign.optimization.multistart.map_in_workers`; the result is the same
    as one after the other). Each branch starts from the study's peak grid;
    the winner's movable frequencies are restored on ``prob`` (the re-check
    evaluates on them).

    Parameters
    ----------
    study : Study
        Gives ``solver.tie_break`` and the peak bound.
    prob : Problem
        The NLP the starts were solved with; its movable peak frequencies are
        reset before each branch and left at the winner's.
    sols : dict
        Start index -> feasible Solution.
    tol_j : float
        The tie-break's tolerance on J (:func:`flat_tolerance`).
    alongside : callable, optional
        ``alongside()``: one more task, independent of the branches, run first in the
        same map (from the study's peak grid, like each branch; the Pareto sweep's
        lexicographic anchor). It must not raise; its result (picklable) is returned
        in ``Refined.alongside``.

    Returns
    -------
    Refined
        The winning branch (its start index, refined optimum, tie-broken final
        point, flat-direction and peak-refinement reports, slot frequencies) with
        ``branches``: (start index, refined J) of every branch refined, winner
        first (a branch that joined another one carries that one's refined J), and
        ``alongside``: the result of ``alongside()`` (``None`` without it).

    Raises
    ------
    SolverError
        When the refinement fails on every branch tried (the first failure).
    """
    slots0 = prob.slot_hz.copy()
    order = sorted(sols, key=lambda i: sols[i].objective)
    if not _peak_refined(study, prob):
        order = order[:1]  # nothing to refine: the tie-break alone cannot change the winner
    branches: list[int] = []  # the first start of each distinct branch, best first
    for i in order:
        if not any(abs(sols[i].objective - sols[b].objective) <= BRANCH_TOLERANCE
                   for b in branches):
            branches.append(i)

    def refine(k: int, known=None):
        # each branch from the study's peak grid; a branch stops when it joins a better one
        if not np.array_equal(prob.slot_hz, slots0):
            prob.set_slots(slots0)
        i = branches[k]
        if known is None:
            known = [sols[b].objective for b in branches[:k]]
        try:
            return _refine_one(study, prob, i, sols[i], tol_j, known=known)
        except SolverError as exc:
            return exc

    items = ([None] if alongside is not None else []) + list(range(len(branches)))
    # in parallel, the worker that refines the best sampled branch (the likely winner) also
    # finishes it (its tie-break, _finish) while the other branches are refined: the
    # tie-break no longer runs alone after them. Used only if that branch wins (the same
    # computation on the same NLP, so the same result as finishing it afterwards).
    ahead = (bool(study.solver["tie_break"]) and len(branches) > 1
             and runs_in_parallel(study.solver.get("workers"), len(items)))

    def task(k):
        if k is None:  # the task run alongside, from the study's peak grid too
            if not np.array_equal(prob.slot_hz, slots0):
                prob.set_slots(slots0)
            return alongside()
        r = refine(k)
        if k == 0 and ahead and isinstance(r, Refined):
            try:
                return r, _finish(study, prob, r, tol_j)
            except SolverError as exc:
                return r, exc
        return r

    # the branches are independent: refined in the start workers' processes when the
    # cores allow (each worker's copy of the NLP moves its own peak frequencies)
    results = map_in_workers(task, items, workers=study.solver.get("workers"))
    side = results.pop(0) if alongside is not None else None
    finished = {}  # the first branch's finished form, computed beside the others
    if results and isinstance(results[0], tuple):
        results[0], finished[0] = results[0]
    done: list[Refined] = []
    merged: list[tuple[int, Refined]] = []  # (start, the refined branch it joined)
    error = None
    for k, r in enumerate(results):
        if isinstance(r, Refined) and r.peak.get("merged_with") is not None:
            into = branches[r.peak["merged_with"]]
            target = next((d for d in done if d.start == into), None)
            if target is not None:
                # a re-solve joined a better branch already refined: from there it would
                # repeat that branch's refinement on a grid with more frequencies (more
                # constraints), so it cannot end better; listed with that branch's optimum
                merged.append((r.start, target))
                continue
            # it joined a branch that failed or joined another: refine it in full here
            r = refine(k, known=[sols[d.start].objective for d in done])
            if isinstance(r, Refined) and r.peak.get("merged_with") is not None:
                merged.append((r.start, done[r.peak["merged_with"]]))
                continue
        if isinstance(r, SolverError):
            error = error or r
        else:
            done.append(r)
    pre = {id(results[0]): finished[0]} if finished else {}
    return _rank_branches(study, prob, done, merged, tol_j, error, pre, side)


def _rank_branches(study, prob, done: list, merged: list, tol_j: float, error=None,
                   pre: dict | None = None, alongside=None) -> Refined:
    """The winner of the refined branches, as :class:`Refined` with every branch's row.

    ``done``: the refined branches (start order); ``merged``: ``(start, the refined
    branch it joined)`` pairs, listed with that branch's optimum; ``error``: the first
    :class:`SolverError` of a branch, raised when none was refined. Sorts ``done`` by
    refined optimum, those meeting their peak limit first (:func:`_rank_key`; stable: equal
    optima keep the start order), tie-breaks the best
    (:func:`_finish_best`, ``pre`` as there) when the study asks for it and leaves the NLP
    at the winner's slots. Shared by :func:`refine_branches` and the early refinement.
    """
    if not done:
        raise error or SolverError("no branch refined")
    done = sorted(done, key=_rank_key)
    if study.solver["tie_break"]:
        done = _finish_best(study, prob, done, tol_j, pre)
    win = done[0]
    if not np.array_equal(prob.slot_hz, win.slot_hz):
        prob.set_slots(win.slot_hz)
    refined = {r.start: r.best.objective for r in done}
    rows = [(r.start, r.best.objective) for r in done]
    rows += [(i, refined.get(r.start, r.best.objective)) for i, r in merged]
    return Refined(win.start, win.best, win.final, win.flat, win.peak, win.slot_hz,
                   tuple(rows), alongside)


def _finish_best(study, prob, done: list, tol_j: float, pre: dict | None = None) -> list:
    """Tie-break the best refined branch (:func:`_finish`); the branches, best first.

    ``done``: the refined branches, best refined optimum first. Only the winner needs the
    tie-break, but the peak at its tie-broken point may call for more refinement rounds,
    which can cost it its lead: then the next branch is finished too, until the best
    finished branch is still ahead of every unfinished one. A branch whose finishing fails
    (a re-solve infeasible) drops out; :class:`SolverError` when all of them fail.
    ``pre``: ``id(branch) -> its _finish result`` (a Refined, or the SolverError it raised)
    already computed (in the worker that refined it): used instead of finishing it again.
    """
    out: list = []
    error = None
    pre = pre or {}
    for k, r in enumerate(done):
        try:
            f = pre.get(id(r))
            if f is None:
                f = _finish(study, prob, r, tol_j)
            elif isinstance(f, SolverError):
                raise f
            else:
                prob.set_slots(f.slot_hz)  # where _finish leaves the NLP
            out.append(f)
        except SolverError as exc:
            error = error or exc
        if out:
            lead = min(_rank_key(f) for f in out)
            if k + 1 == len(done) or lead <= _rank_key(done[k + 1]):
                rest = done[k + 1:]
                break
    else:
        rest = []
    if not out:
        raise error
    return sorted(out, key=_rank_key) + rest


def _rank_key(r) -> tuple:
    """The order of refined branches: those whose continuous peak meets its limit (or is not
    checked) first, then by refined optimum; a branch whose refinement left its peak above
    the limit wins only when none meets it (the table optimizer's rule, docs/table.md
    section 6: one rule for both bodies)."""
    return (r.peak.get("met") is False, r.best.objective)
