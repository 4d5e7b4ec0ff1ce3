"""Design studies and their optimization: study schema, the CasADi NLP, Pareto fronts.

One file per concept:

======================  =======================================================================
``study``               the study schema (TOML), validated table by table
``variables``           design variables, their bounds and the log scaling of the NLP
``objectives``          the objective registry (name, unit, sense, NLP form, value, display)
``constraints``         the NLP's constraints and their report at the optimum
``grid``                the NLP's frequency grid
``metrics``             objective and constraint quantities, NumPy or CasADi (one source)
``nlp``                 what every NLP shares: IPOPT options, parameter head, constraint
                        rows and boxes, one solve, violations, design values (:class:`.nlp.NLP`)
``problem``             the vertical NLP (:class:`Problem`), built in named steps
``table_problem``       the table's NLP in three axes (:class:`~.table_problem.TableProblem`)
``lever_nlp``           the co-design levers in the table's NLP, their sensitivities
``loop_rows``           the leveling loop's gain-margin rows of the table's NLP
``table_constraints``   the table's constraint table (binding flags, natural units)
``solution``            one solve (:class:`Solution`) and :data:`FEASIBILITY_TOLERANCE`
``multistart``          space-filling starts, solved in forked workers
``refine``              peak refinement (exchange method), tie-break, branch choice
``recheck``             the NumPy re-check of the optimum, :func:`evaluate_design`
``analyze``             :func:`analyze`: every study's NumPy band response, through the table
``result``              :class:`StudyResult` (the one result type of every study kind) and
                        :class:`OptimizationResult` (the vertical kind)
``hessian``             :func:`~.hessian.hessian_choice`: exact or limited-memory, one rule
``driver``              :func:`optimize_vertical` (the vertical nominal solve)
``table_driver``        :func:`~.table_driver.optimize_table` (the table's nominal solve)
``dispatch``            :func:`optimize`: the answer to the study's question (table, robust)
``pareto``              epsilon-constraint Pareto fronts
``table_pareto``        the table's Pareto front (worst margin against volume or footprint)
``front``               non-dominance and hypervolume of a front (vertical or table)
``uncertainty``         the ``[scenarios]`` table: uncertain parameters, scenario studies
``robust``              scenario blocks stacked in one NLP (worst case by epigraph)
``exchange``            the exchange method: :func:`robust_optimize`, worst-case search
``robust_result``       :class:`RobustResult`
``robust_table``        the robust table design (:class:`~.robust_table.TableRobustResult`)
``table_scenario``      :func:`~.table_scenario.table_scenario`: a table study under one scenario
``sensitivity``         parametric sensitivities from the NLP (design held; ``lam_p``)
``yields``              yield by sampling, Clopper-Pearson and Wilson intervals
======================  =======================================================================

Public names resolve lazily (``from isodesign.optimization import optimize``), so that
importing one module of the package does not import them all.
"""

from __future__ import annotations

from isodesign._lazy import lazy_exports

_EXPORTS = {
    "Study": "study",
    "default_study": "study",
    "table_study": "study",
    "vertical_study": "study",
    "load_study": "study",
    "study_from_dict": "study",
    "DESIGN_VARIABLES": "variables",
    "VariableSpec": "variables",
    "OBJECTIVES": "objectives",
    "Objective": "objectives",
    "ConstraintReport": "constraints",
    "metrics": "metrics",
    "Problem": "problem",
    "FEASIBILITY_TOLERANCE": "solution",
    "Solution": "solution",
    "evaluate_design": "recheck",
    "analyze": "analyze",
    "vertical_band_response": "analyze",
    "OptimizationResult": "result",
    "StartRecord": "result",
    "StudyResult": "result",
    "optimize": "dispatch",
    "optimize_vertical": "driver",
    "study_kind": "dispatch",
    "ParetoResult": "pareto",
    "pareto_front": "pareto",
    "robust_optimize": "exchange",
    "RobustResult": "robust_result",
    "estimate_yield": "yields",
    "YieldResult": "yields",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
