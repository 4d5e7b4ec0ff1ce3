"""The report's robustness section: nominal against robust, scenarios, sensitivities, yield."""

from __future__ import annotations

from isodesign.optimization.objectives import OBJECTIVES
from isodesign.plotting.style import figure_svg

__all__ = ["robustness_section"]


def _fmt_design(v: dict) -> list[str]:
    return [f"{v['volume_ratio']:.4g}", f"{v['top_volume_m3'] * 1e3:.4g}",
            f"{v['capillary_length_m'] * 1e3:.4g}", f"{v['capillary_diameter_m'] * 1e3:.4g}"]


def robustness_section(case) -> dict | None:
    """The template's robustness block of a robust optimize run (None for other inputs).

    Parameters
    ----------
    case : Case
        With ``robust`` (the run's ``robust.json``).

    Returns
    -------
    dict or None
    """
    rob = case.robust
    if not rob:
        return None
    from isodesign.optimization.sensitivity import Sensitivity
    from isodesign.plotting.robust import scenario_bars, sensitivity_bars

    obj = OBJECTIVES[rob["objective"]]
    nom = rob["nominal_optimum"]
    nd, rd = _fmt_design(nom["values"]), _fmt_design(rob["values"])
    ys = {y["label"]: y for y in rob.get("yields", [])}

    def yld(label):
        y = ys.get(label)
        if y is None:
            return "n/a"
        lo, hi = y["clopper_pearson"]
        return f"{100 * y['fraction']:.1f} % (CI {100 * lo:.1f}-{100 * hi:.1f} %)"

    price = nom["objective"] - rob["robust_at_nominal_scenario"]
    comparison = [
        ["N", nd[0], rd[0]], ["V_t0 (L)", nd[1], rd[1]], ["L_c (mm)", nd[2], rd[2]],
        ["D_c (mm)", nd[3], rd[3]],
        [f"{obj.label}, nominal scenario", obj.format(nom["objective"]),
         obj.format(rob["robust_at_nominal_scenario"])],
        [f"{obj.label}, worst case in the box", obj.format(nom["worst_case_in_box"])
         + ("" if nom["worst_case_quantity"] == "objective"
            else f" (and {nom['worst_case_quantity']} exceeded)"),
         obj.format(rob["worst_case_objective"])],
        ["yield", yld("nominal optimum"), yld("robust optimum")],
    ]
    rows = []
    for r in rob["scenarios"]:
        why = ", ".join((["worst objective"] if r["worst"] else [])
                        + ([f"binding: {', '.join(r['binding'])}"] if r["binding"] else []))
        rows.append({"active": r["active"], "cells": [
            r["description"], obj.format(r["objective"]),
            obj.format(r.get("nominal_objective")), why or "-"]})
    allsens = rob.get("sensitivities", {})
    sens = [Sensitivity(**s) for s in (allsens.get("active") or allsens.get("robust", []))]
    nom_sens = [Sensitivity(**s) for s in allsens.get("robust", [])]
    shown = [s for s in nom_sens if s.quantity == "objective"] + [
        s for s in sens if s.unit == "dB"]
    srows = [[s.quantity, s.parameter, f"{s.per_unit:+.4g} {s.unit}/{s.parameter_unit}",
              f"{s.effect:+.3f} {s.unit}"] for s in sorted(
                  shown, key=lambda s: (s.quantity != "objective", s.quantity, -abs(s.effect)))]
    yrows = []
    for y in rob.get("yields", []):
        yrows.append([y["label"], str(y["samples"]), str(y["passed"]),
                      f"{100 * y['fraction']:.1f} %",
                      f"{100 * y['clopper_pearson'][0]:.2f}-{100 * y['clopper_pearson'][1]:.2f} %",
                      f"{100 * y['wilson'][0]:.2f}-{100 * y['wilson'][1]:.2f} %",
                      f"{y['worst_margin_db']:+.2f} dB",
                      ", ".join(f"{k} {v}" for k, v in y["failures"].items()) or "none"])
    rounds = rob["rounds"]
    return {
        "label": case.label,
        "parameters": "; ".join(rob["parameters"]),
        "method": (f"Exchange method: {len(rounds)} rounds, {len(rob['scenarios'])} scenarios in "
                   f"the final set, {'converged' if rob['converged'] else 'NOT converged'} "
                   f"(last search: largest excess {rob['last_search_score']:.3g} of its "
                   "tolerance); every constraint holds in every scenario of the set, and a "
                   "search of the box found nothing beyond the tolerances."),
        "comparison": comparison,
        "comparison_note": (f"Price of robustness in the nominal scenario: "
                            f"{obj.format(price).lstrip('+')}. The nominal optimum's worst case "
                            f"occurs at {nom['worst_case_scenario']}."),
        "scenarios": rows,
        "scenario_svg": figure_svg(scenario_bars(rob)),
        "sensitivity_svg": figure_svg(sensitivity_bars(sens)) if sens else "",
        "sensitivity_caption": ("Change of the robust design's objective in its worst scenario "
                                "and of each constraint where it binds (dB) over each "
                                "tolerance's half-width, the design held; the table also gives "
                                "the objective at the nominal parameters. "
                                + ("Central differences of the table's NumPy band response "
                                   "(the yield's analysis), checked against the table NLP's "
                                   "margin in the tests." if rob.get("table") else
                                   "Exact derivatives of the NLP (implicit function theorem), "
                                   "checked against finite differences of the NumPy analysis "
                                   "in the tests.")),
        "sensitivities": srows,
        "yields": yrows,
        "yield_note": ("Draws from the tolerance laws judged with the NumPy analysis: the "
                       "criterion in every band, every constraint, the continuous peak of |T|. "
                       "Intervals at 95 %."),
    }
