"""IPOPT's Hessian of the Lagrangian, chosen per study by one rule: :func:`hessian_choice`.

Every NLP of isodesign (the vertical one, the table one, and the robust scenario stacks of
both) has exact first derivatives (CasADi's automatic differentiation); its Hessian is
either the exact one (CasADi) or IPOPT's limited-memory quasi-Newton approximation
(L-BFGS). The choice is made here, once, from the size of the study's analysis, and it is
stated in every result (:meth:`~isodesign.optimization.result.StudyResult.hessian_choice`),
in ``design.json`` and on the standard output of ``isodesign optimize``. The measurement
behind the rule is in docs/optimization.md (section "The Hessian").
"""

from __future__ import annotations

__all__ = ["EXACT", "LIMITED_MEMORY", "hessian_choice"]

EXACT = "exact"
LIMITED_MEMORY = "limited-memory"


def hessian_choice(study) -> dict:
    """The Hessian of a study's NLP and the reason, by the measured rule.

    Parameters
    ----------
    study : Study
        A vertical or table study (its ``[table]`` decides the model's size).

    Returns
    -------
    dict
        ``hessian`` (``"exact"`` or ``"limited-memory"``, IPOPT's
        ``hessian_approximation``) and ``reason`` (one sentence).
    """
    if getattr(study, "table", None) is not None:
        return {"hessian": LIMITED_MEMORY,
                "reason": "IPOPT's quasi-Newton approximation; the exact Hessian through the "
                          "six-degree-of-freedom solve gives the same optimum at several times "
                          "the cost (docs/optimization.md); gradient and Jacobian exact"}
    return {"hessian": EXACT,
            "reason": "CasADi's exact Hessian of the Lagrangian: the one-degree-of-freedom "
                      "NLP is small (docs/optimization.md)"}
