"""IPOPT's Hessian of the Lagrangian, chosen per NLP by one rule: :func:`hessian_choice`.

Every NLP of isodesign (the vertical one, the table one, and the robust scenario stacks of
both) has exact first derivatives (CasADi's automatic differentiation); its Hessian is
either the exact one (CasADi) or IPOPT's limited-memory quasi-Newton approximation
(L-BFGS, ``hessian_approximation = "limited-memory"``). The choice is made here, once, by
the rule the measurement of docs/optimization.md (section "The Hessian",
``studies/hessian_choice.py``) supports:

* the **table** NLP (the six-degree-of-freedom model: a complex 6x6 solve per frequency):
  limited-memory at every size measured (the built-in table and a six-isolator table:
  the whole optimization 2.8-2.9 times faster than with the exact Hessian, the same
  optimum);
* the **vertical** NLP: exact up to :data:`VERTICAL_EXACT_MAX_VARIABLES` variables,
  limited-memory above (209 variables, the built-in study's grid: the whole
  optimization 1.6 times and its solves twice as fast, the same optima; 89 variables:
  the solves no faster, and two of eight starts stopped at a worse point); its robust
  scenario stack keeps the exact Hessian (not measured).

The choice and its reason are stated in every result
(:meth:`~isodesign.optimization.result.StudyResult.hessian_choice`), in ``design.json``
and on the standard output of ``isodesign optimize``.
"""

from __future__ import annotations

__all__ = ["EXACT", "LIMITED_MEMORY", "VERTICAL_EXACT_MAX_VARIABLES", "hessian_choice"]

EXACT = "exact"
LIMITED_MEMORY = "limited-memory"
#: The most variables (of one scenario's block) of a vertical NLP solved with the exact
#: Hessian; a larger one uses IPOPT's limited-memory approximation.
VERTICAL_EXACT_MAX_VARIABLES = 150


def hessian_choice(study, n_variables: int | None = None, *, scenarios: int = 0) -> dict:
    """The Hessian of a study's NLP and the reason, by the measured rule (module docstring).

    Parameters
    ----------
    study : Study
        A vertical or table study (its ``[table]`` decides the model).
    n_variables : int, optional
        The vertical NLP's number of variables; ignored for a table. Default: the exact
        Hessian's side of the rule.
    scenarios : int
        The scenarios of a robust stack (0: a nominal NLP). The vertical robust stack
        keeps the exact Hessian: the measurement was of the nominal NLPs, and the
        exchange method's worked example (docs/robust.md) is computed with it.

    Returns
    -------
    dict
        ``hessian`` (``"exact"`` or ``"limited-memory"``, IPOPT's
        ``hessian_approximation``) and ``reason`` (one sentence).
    """
    if getattr(study, "table", None) is not None:
        return {"hessian": LIMITED_MEMORY,
                "reason": "the six-degree-of-freedom table NLP: IPOPT's quasi-Newton "
                          "approximation, measured 2.8-2.9x faster than the exact Hessian at "
                          "the same optimum (docs/optimization.md, 'The Hessian'); gradient "
                          "and Jacobian exact"}
    n = n_variables
    if scenarios:
        return {"hessian": EXACT,
                "reason": f"the vertical NLP stacked over {scenarios} scenarios: CasADi's "
                          "exact Hessian (the quasi-Newton approximation was measured on the "
                          "nominal NLPs only; docs/optimization.md, 'The Hessian')"}
    if n is None or n <= VERTICAL_EXACT_MAX_VARIABLES:
        size = "" if n is None else f"{n} "
        return {"hessian": EXACT,
                "reason": f"the vertical NLP with {size}variables (at most "
                          f"{VERTICAL_EXACT_MAX_VARIABLES}): CasADi's exact Hessian of the "
                          "Lagrangian, as fast as the quasi-Newton approximation there and "
                          "more reliable (docs/optimization.md, 'The Hessian')"}
    return {"hessian": LIMITED_MEMORY,
            "reason": f"the vertical NLP with {n} variables (more than "
                      f"{VERTICAL_EXACT_MAX_VARIABLES}): IPOPT's quasi-Newton approximation, "
                      "measured 1.6x faster than the exact Hessian at the same optima "
                      "(docs/optimization.md, 'The Hessian'); gradient and Jacobian exact"}
