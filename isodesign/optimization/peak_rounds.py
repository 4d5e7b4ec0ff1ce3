"""A round of the table's continuous peak refinement (docs/table.md, section 6): how many
rounds, and how a round's NLP is solved. One rule for :func:`.table_driver.optimize_table`'s
refinement and the table Pareto front's (:mod:`.table_pareto`)."""

from __future__ import annotations

from isodesign.optimization.table_problem import TABLE_PEAK_ROUNDS

__all__ = ["MAX_PEAK_ROUNDS", "PEAK_ROUNDS_CAP_FACTOR", "solve_round"]

#: The continuous peak refinement's rounds continue while its movable frequencies last (the
#: robust exchange's rule, :meth:`~.robust_table.TableScenarioNLPs.place_peak_slots`), at
#: most this many times :data:`~.table_problem.TABLE_PEAK_ROUNDS` (each round places 3 to 9
#: of the ``9 x TABLE_PEAK_ROUNDS``). A peak that moves 5-10 % as the design improves is
#: chased past the fourth round (the co-design script's ``all`` case with the tube rows:
#: 0.048 dB above its bound after four rounds, docs/table.md section 6).
PEAK_ROUNDS_CAP_FACTOR = 3


def solve_round(prob, best, params=None, **kwargs):
    """One round of the continuous peak refinement: ``prob`` solved from ``best``'s design
    with the frequencies just placed (:func:`.table_driver.optimize_table`'s rounds and the
    table Pareto front's, docs/table.md, section 6).

    On the same NLP as ``best`` (every round but the first of an NLP built with movable
    frequencies) IPOPT starts warm from ``best``'s multipliers, the new frequencies' rows from
    those their slots had; a round that fails so (IPOPT's iteration limit) is solved once more
    cold, as the first round of a new NLP is.

    Parameters
    ----------
    prob : TableProblem
        The NLP, its movable frequencies set.
    best : Solution
        The design the round starts from.
    params : ndarray, optional
        The NLP's parameters (default: its first objective's).
    **kwargs
        To ``prob.solve`` (the outer fixed point's cap, :func:`.distortion_rows.capped`).

    Returns
    -------
    Solution
    """
    same = best.lam_g is not None and len(best.lam_g) == len(prob.lbg)
    sol = prob.solve(best.x, params, warm=best if same else best.as_start(), **kwargs)
    if not sol.feasible and same:
        sol = prob.solve(best.x, params, warm=best.as_start(), **kwargs)
    return sol


#: The most rounds of the continuous peak refinement (while its movable frequencies last).
MAX_PEAK_ROUNDS = PEAK_ROUNDS_CAP_FACTOR * TABLE_PEAK_ROUNDS
