"""Why an optimum stopped where it did, in words.

A constraint is *binding* when its margin, in the NLP's units, is below
:data:`~isodesign.optimization.constraints.BINDING_TOL` (the log of the ratio to the
bound for most constraints, i.e. within 0.5 % of the bound; ``ln |T|^2`` for the peak
transmissibility, i.e. within 0.022 dB). :func:`limiting_factors` turns the binding
constraints and the variables on a bound into sentences that say which limit stopped
the design and whether it is a requirement of the study or a validity limit of the
model (a model-validity limit is not physics: a better model moves it).
"""

from __future__ import annotations

import math

from isodesign.optimization.constraint_registry import model_validity_names, study_keys

__all__ = ["BINDING_NOTE", "MODEL_VALIDITY_CONSTRAINTS", "STUDY_KEYS", "constraint_table_rows",
           "limiting_factors", "limiting_summary", "variables_at_bounds"]

#: Constraints that keep the design inside a model's validity, not user requirements.
MODEL_VALIDITY_CONSTRAINTS = model_validity_names()  # the registry's (constraint_registry)

#: For the lumped-model limits: the design quantity each caps, how it scales with the
#: constrained value (w l / c grows as V^(1/3) for a chamber, as L_c for the tube), unit.
_LUMPED_CAPS = {
    "lumped_tube": ("L_c", "capillary_length_m", 1, 1e3, "mm"),
    "lumped_top_chamber": ("V_t0", "top_volume_m3", 3, 1e3, "L"),
    "lumped_bottom_chamber": ("V_b0", None, 3, 1e3, "L"),
}


def variables_at_bounds(result, rtol: float = 1e-4) -> dict:
    """Free design variables that ended on a bound: name -> ``"lower"`` or ``"upper"``.

    The lower bound of D_c is the larger of its ``lower`` and
    ``constraints.min_capillary_diameter_m`` (as in the NLP). Bounds are not
    constraints of the NLP, so they are not in ``result.constraints``.

    Parameters
    ----------
    result : OptimizationResult
        Its study (variables, bounds, ``min_capillary_diameter_m``) and final
        ``values`` (SI).
    rtol : float
        A variable is on a bound when ``|ln(x / bound)| <= rtol``: a relative
        tolerance (default 1e-4, i.e. 0.01 %).

    Returns
    -------
    dict
        Name -> ``"lower"`` or ``"upper"`` for each free variable on a bound (the
        lower bound checked first); fixed variables are never listed.
    """
    st = result.study
    dmin = st.constraints.get("min_capillary_diameter_m")
    out = {}
    for v in st.variables:
        if v.fixed:
            continue
        lo = max(v.lower, dmin) if v.name == "capillary_diameter_m" and dmin else v.lower
        x = float(result.values[v.name])
        if abs(math.log(x / lo)) <= rtol:
            out[v.name] = "lower"
        elif abs(math.log(x / v.upper)) <= rtol:
            out[v.name] = "upper"
    return out


#: The study key that sets each constraint's bound (named in the sentences).
STUDY_KEYS = study_keys()  # the registry's (constraint_registry)


def _bounds(d: dict, fmt: str) -> list[str]:
    """``[">= lower", "<= upper"]`` of a constraint's display (the bounds it has), each
    number in format ``fmt``."""
    return [f"{op} {d[k]:{fmt}}" for op, k in ((">=", "lower"), ("<=", "upper"))
            if d[k] is not None]


def _bound_text(c) -> str:
    d = c.display()
    unit = "" if d["unit"] in ("-", "") else f" {d['unit']}"
    return f"{d['value']:.4g}{unit}, bound " + " and ".join(_bounds(d, ".4g")) + unit


def limiting_factors(result) -> list[str]:
    """Sentences naming what stopped the design: binding constraints and variable bounds.

    A constraint is binding when it is within
    :data:`~isodesign.optimization.constraints.BINDING_TOL` of its bound (0.5 %, or
    0.022 dB for the peak transmissibility). Values are in the command line's units
    (L, mm).

    Parameters
    ----------
    result : OptimizationResult
        Its ``constraints`` (with ``active``), ``values`` and study.

    Returns
    -------
    list of str
        One sentence per binding constraint (a requirement of the study with the key
        that sets it, or a model-validity limit with the design quantity it caps), one
        per variable on a bound, and, when the total-volume envelope is not binding,
        how much of it is used and why. Empty for a design that no limit stopped (an
        interior optimum).
    """
    st = result.study
    v = result.values
    out = []
    cons = {c.name: c for c in result.constraints}
    validity_binding = []
    for c in result.constraints:
        if not c.active:
            continue
        if c.name in MODEL_VALIDITY_CONSTRAINTS:
            validity_binding.append(c.name)
            text = (f"{c.name} ({_bound_text(c)}): a model-validity limit, not a requirement "
                    f"of the study ({c.description or 'validity of the model'}; "
                    "constraints.model_validity)")
            cap = _LUMPED_CAPS.get(c.name)
            if cap is not None and c.upper and c.value > 0:
                label, key, power, scale, unit = cap
                now = (v["top_volume_m3"] * v["volume_ratio"] if key is None else v[key])
                limit = now * (c.upper / c.value) ** power
                text += (f"; it caps {label} at {limit * scale:.3g} {unit} "
                         f"(now {now * scale:.3g} {unit}); the distributed acoustics "
                         "(models.acoustics = \"distributed\", docs/acoustics.md) lifts it")
            out.append(text)
        else:
            key = STUDY_KEYS.get(c.name)
            out.append(f"{c.name} ({_bound_text(c)}): a requirement of the study"
                       + (f" ({key})" if key else ""))
    for name, side in variables_at_bounds(result).items():
        var = st.variable(name)
        out.append(f"{name} at its {side} bound {getattr(var, side):g} "
                   f"(variables.{name}.{side}): a bound of the study's search space")
    tv = cons.get("total_volume")
    if tv is not None and not tv.active and tv.upper:
        why = (" because the model-validity limit " + " and ".join(validity_binding)
               + " binds" if validity_binding else "")
        out.append(f"total volume {tv.value * 1e3:.3g} L of the {tv.upper * 1e3:.3g} L "
                   f"envelope used{why}")
    return out


def limiting_summary(result) -> str:
    """One sentence: which limits stopped the design, by kind.

    Parameters
    ----------
    result : OptimizationResult

    Returns
    -------
    str
        ``"stopped by model-validity limit(s) ...; requirement(s) ...; bound(s) ..."``,
        or a sentence saying that no limit binds (an interior optimum).
    """
    validity = [c.name for c in result.constraints if c.active
                and c.name in MODEL_VALIDITY_CONSTRAINTS]
    req = [c.name for c in result.constraints if c.active
           and c.name not in MODEL_VALIDITY_CONSTRAINTS]
    bounds = [f"{n} ({side})" for n, side in variables_at_bounds(result).items()]
    parts = []
    if validity:
        parts.append("the model-validity limit" + ("s " if len(validity) > 1 else " ")
                     + ", ".join(validity))
    if req:
        parts.append("the requirement" + ("s " if len(req) > 1 else " ") + ", ".join(req))
    if bounds:
        parts.append("the variable bound" + ("s " if len(bounds) > 1 else " ")
                     + ", ".join(bounds))
    if not parts:
        return "no limit binds: an interior optimum of the objective"
    return "the design is stopped by " + "; ".join(parts)


#: The header line of a constraint table (the binding tolerance in words).
BINDING_NOTE = ("* binding: within 0.5 % of its bound (0.022 dB for the peak transmissibility); "
                "values and margins in the unit shown (L, mm)")


def constraint_table_lines(result, title: str) -> list[str]:
    """The constraint table as aligned text lines under ``title``, then (for a feasible
    result) the sentence naming what stopped the design and its limiting factors.

    Parameters
    ----------
    result : OptimizationResult or TableOptimizationResult
    title : str
        The heading (``"constraints"``, ``"constraints at the optimum"``).

    Returns
    -------
    list of str
    """
    lines = [f"{title} (" + BINDING_NOTE + "):"]
    rows = constraint_table_rows(result)
    head = ["", "constraint", "value", "bound", "margin", "unit"]
    w = [max(len(r[i]) for r in [head, *rows]) for i in range(6)]
    for r in [head, *rows]:
        lines.append("  " + "  ".join(f"{r[i]:{'>' if i in (2, 4) else '<'}{w[i]}}"
                                      for i in range(6)).rstrip())
    if result.feasible:
        lines += ["", limiting_summary(result) + ":"]
        lines += [f"  - {t}" for t in result.limited_by]
    return lines


def constraint_table_rows(result) -> list[list[str]]:
    """The constraints of ``result`` as text cells in display units (L, mm).

    Parameters
    ----------
    result : OptimizationResult

    Returns
    -------
    list of list of str
        ``["*" or "", name, value, bound, margin, unit]`` per constraint; the margin is
        the distance to the nearest bound in the unit shown (>= 0: met).
    """
    out = []
    for c in result.constraints:
        d = c.display()
        margin = "n/a" if d["margin"] is None else f"{d['margin']:.3g}"
        out.append(["*" if d["binding"] else "", d["name"], f"{d['value']:.5g}",
                    ", ".join(_bounds(d, ".5g")), margin, d["unit"]])
    return out
