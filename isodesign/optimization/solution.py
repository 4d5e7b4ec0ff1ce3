"""One IPOPT solve of the NLP, typed: :class:`Solution` and the feasibility tolerance."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["FEASIBILITY_TOLERANCE", "Solution"]

#: A point is feasible when no constraint (implicit equations included) is violated by
#: more than this, in the NLP's units (log of the quantity, or dB). The one tolerance
#: the optimizer, the peak refinement, the tie-break and the Pareto sweep judge by.
FEASIBILITY_TOLERANCE = 1e-6


@dataclass(frozen=True, eq=False)
class Solution:
    """An NLP point returned by :meth:`isodesign.optimization.problem.Problem.solve`.

    Attributes
    ----------
    x : ndarray
        The NLP's variables (scaled design, ln sigma, ln U, partial sums, epigraphs).
    values : dict
        Design-variable values at ``x`` (SI; fixed ones from the study).
    objective : float
        Internal value J of the first objective (minimized).
    objectives : ndarray
        Internal values J of every objective of the NLP.
    g : ndarray
        Constraint values (implicit equations first).
    violations : tuple of (str, float)
        Worst violation of each constraint group (``implicit_equations`` first).
    status : str
        IPOPT's return status.
    success : bool
        IPOPT's success flag.
    iterations : int
    wall_s : float
        IPOPT's wall time, s.
    finished_at : float
        The instant the solve returned, s, on ``time.perf_counter`` (NaN when unknown).
        On Linux that clock is CLOCK_MONOTONIC, one system-wide clock: a reading in a
        forked worker compares with one in its parent, so a driver turns it into a time
        since its own start (``finished_s`` of the start records).
    outer_rounds : int
        Rounds of an outer fixed point around the NLP (the distortion power's,
        :mod:`.distortion_rows`; 0: none).
    outer_params : ndarray or None
        The outer fixed point's parameters of the last round (its linearization).
    outer_next : ndarray or None
        Set when the solve stopped at the round cap its caller asked for before the outer
        fixed point converged (:meth:`.distortion_rows.OuterFixedPoint.solve` ``rounds=``):
        the expansion at ``x``, the next round's; a re-solve warm from this solution
        starts from it and converges. None: converged (or no outer fixed point).
    outer_next_fresh : bool
        Whether ``outer_next``'s slopes were computed at ``x`` (True) or carried from the
        round before with the values at ``x`` (False: a round the caller re-solves with
        other peak frequencies anyway; a converging solve computes them first).
    lam_x, lam_g : ndarray or None
        IPOPT's multipliers of the bounds and the constraints at ``x`` (a warm re-solve
        of the same point starts from them: :meth:`~.nlp.NLP.solve` ``warm=``).
    """

    x: np.ndarray
    values: dict
    objective: float
    objectives: np.ndarray
    g: np.ndarray
    violations: tuple[tuple[str, float], ...]
    status: str
    success: bool
    iterations: int
    wall_s: float
    finished_at: float = math.nan
    outer_rounds: int = 0
    outer_params: np.ndarray | None = None
    outer_next: np.ndarray | None = None
    outer_next_fresh: bool = True
    lam_x: np.ndarray | None = dataclasses.field(default=None, repr=False)
    lam_g: np.ndarray | None = dataclasses.field(default=None, repr=False)

    @property
    def outer_pending(self) -> bool:
        """Whether the solve stopped at its caller's round cap before its outer fixed point
        converged (``outer_next`` set): a re-solve warm from it goes on."""
        return self.outer_next is not None

    @property
    def max_violation(self) -> float:
        """The largest constraint violation (0 when every constraint holds)."""
        return float(max((v for _, v in self.violations), default=0.0))

    @property
    def feasible(self) -> bool:
        """No violation above :data:`FEASIBILITY_TOLERANCE`."""
        return self.max_violation <= FEASIBILITY_TOLERANCE

    @property
    def equation_residual(self) -> float:
        """Residual of the implicit equations (tube velocities, stroke variance)."""
        return dict(self.violations).get("implicit_equations", 0.0)

    def violated(self) -> tuple[tuple[str, float], ...]:
        """The violated constraint groups, most violated first."""
        viol = sorted(self.violations, key=lambda t: -t[1])
        return tuple((n, v) for n, v in viol if v > FEASIBILITY_TOLERANCE)

    def replace(self, **changes) -> Solution:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def as_start(self) -> Solution:
        """This solution as the ``warm`` argument of a re-solve from its design under
        other parameters (another objective's weights, an epsilon, added frequencies):
        without its multipliers (IPOPT starts cold), with its outer fixed point's last
        expansion (an NLP with the distortion starts from it, values and slopes, instead
        of the terms' values alone: :meth:`.distortion_rows.OuterFixedPoint.solve`)."""
        return dataclasses.replace(self, lam_x=None, lam_g=None)
