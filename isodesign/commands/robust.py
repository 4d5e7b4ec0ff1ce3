"""``isodesign optimize`` of a study with ``[scenarios]``: the robust optimum (docs/robust.md).

Runs the nominal optimization (its outputs in ``OUTDIR/nominal/``), then the exchange
method; writes the robust design (``design.toml``), ``robust.json`` (worst case, rounds,
scenarios, nominal against robust, yields), ``scenarios.csv``, ``rounds.csv``,
``sensitivities.csv``, ``yield.csv`` and ``robustness.png``. Exit status 1 names the
scenario that no design can meet.
"""

from __future__ import annotations

import dataclasses
import sys

from isodesign.commands.optimize import (
    StartProgress,
    canonical_command,
    progress_enabled,
    write_outputs,
)
from isodesign.io.designfile import design_to_toml
from isodesign.io.record import command_line, environment, resolved_study_dict, study_toml
from isodesign.optimization.dispatch import optimize
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.sensitivity import design_sensitivities
from isodesign.optimization.yields import optimum_yields
from isodesign.plotting.robust import robustness_plot

#: Files written by a robust ``isodesign optimize`` run (besides ``nominal/``).
ROBUST_FILES = ("robust.json", "scenarios.csv", "rounds.csv", "sensitivities.csv",
                "yield.csv", "robustness.png", "design.toml", "record.json",
                "study_resolved.toml")


def _sens_frame(rows: dict):
    import pandas as pd

    out = []
    for design, sens in rows.items():
        out += [{"design": design, **s.row()} for s in sens]
    return pd.DataFrame(out)


def active_sensitivities(res) -> list:
    """Sensitivities where they shape the robust design: the objective in the worst
    scenario and each binding constraint in the scenario where it binds (design held)."""
    out = []
    for r in res.active_scenarios():
        k = r["index"]
        for s in res.sensitivities(scenario=k):
            keep = (s.quantity == "objective" and r["worst"]) or (
                s.quantity != "objective" and s.binding)
            if keep:
                out.append(dataclasses.replace(s, quantity=f"{s.quantity} (scenario {k})"))
    return out


def robust_summary(res, sens, yields) -> str:
    """Text summary of a robust run."""
    st = res.study
    o = OBJECTIVES[res.objective]
    sp = st.scenarios
    nv, rv = res.nominal.values, res.values

    def d(v):
        return (f"N {v['volume_ratio']:.4g}, V_t0 {v['top_volume_m3'] * 1e3:.4g} L, "
                f"L_c {v['capillary_length_m'] * 1e3:.4g} mm, D_c "
                f"{v['capillary_diameter_m'] * 1e3:.4g} mm")

    at_nom = res.nominal_at_robust()
    lines = [
        f"study {st.name!r}: robust {o.sense_word} {res.objective} over "
        + "; ".join(p.label() for p in sp.parameters),
        f"  exchange: {len(res.rounds)} rounds, {len(res.scenarios)} scenarios, "
        f"{'converged' if res.converged else 'NOT converged (max_rounds reached)'}; "
        f"{res.wall_s:.1f} s (nominal optimization included)",
        "",
        f"  nominal optimum: {d(nv)}",
        f"    {res.objective} nominal {o.format(res.nominal.objective_value)}, worst case in "
        f"the box {o.format(res.nominal_worst_case())} "
        f"(worst for {res.first_search['which']} at {sp.describe(res.first_search['theta'])})",
        f"  robust optimum:  {d(rv)}",
        f"    {res.objective} worst case {o.format(res.objective_value)}, nominal "
        f"{o.format(at_nom)} (price in nominal {o.label}: "
        f"{o.format(res.nominal.objective_value - at_nom).lstrip('+')})",
        "",
        "active scenarios (they shape the robust design):",
    ]
    for r in res.active_scenarios():
        why = ("worst objective" if r["worst"] else "") + (
            ("; " if r["worst"] and r["binding"] else "") + "binding: " + ", ".join(r["binding"])
            if r["binding"] else "")
        lines.append(f"  {r['description']}: {o.format(r['objective'])} ({why})")
    lines += ["", f"verdict: {res.verdict()}", "", *res.constraint_lines()]
    top = sorted((s for s in sens["robust"] if s.quantity == "objective"),
                 key=lambda s: -abs(s.effect))
    lines.append("")
    lines.append("sensitivities of the robust design's objective (nominal parameters, design "
                 "held; per unit and over the tolerance's half-width):")
    for s in top:
        lines.append(f"  {s.parameter:24s} {s.per_unit:+.4g} {s.unit}/{s.parameter_unit}"
                     f"   {s.effect:+.3f} {s.unit} over the half-width")
    act = [s for s in sens["active"] if s.unit == "dB"]
    if act:
        lines.append("in the active scenarios (objective where it is worst, constraints where "
                     "they bind):")
        for s in sorted(act, key=lambda s: -abs(s.effect)):
            lines.append(f"  {s.quantity:38s} {s.parameter:22s} {s.per_unit:+.4g} "
                         f"{s.unit}/{s.parameter_unit}   {s.effect:+.3f} {s.unit}")
    for y in yields:
        lo, hi = y.interval
        lines.append(f"yield of the {y.label}: {100 * y.fraction:.1f} % ({y.passed}/{y.samples}; "
                     f"{100 * y.confidence:g} % CI {100 * lo:.1f}-{100 * hi:.1f} %)")
    return "\n".join(lines)


def _answer(study, args):
    """The study's robust optimum through :func:`isodesign.optimize` (with the starts'
    progress bar of its nominal optimum)."""
    with StartProgress(progress_enabled(args), study.solver["starts"],
                       study.objective["kind"]) as bar:
        return optimize(study, progress=bar)


def execute_robust_table(study, run, args, result=None) -> int:
    """A table study with ``[scenarios]``: the robust table optimum (docs/robust.md,
    section 7); writes robust.json, scenarios.csv, rounds.csv, design.toml, robustness.png
    (unless ``--no-plots``) and the table
    yields of the nominal and robust optima (``--yield-samples N``, default
    :data:`isodesign.optimization.yields.DEFAULT_YIELD_SAMPLES` as for a vertical study;
    yield.csv), the design-held sensitivities of the worst margin (sensitivities.csv) and
    the constraint table with the sentence naming what stopped the design."""
    from isodesign.optimization.robust_table import table_sensitivities

    run.record.update({"kind": "isodesign optimize",
                       "command_line": command_line(canonical_command(args, "optimize")[1:]),
                       "environment": environment(), "study": resolved_study_dict(study),
                       "study_source": study.source, "robust": True, "table": True})
    res = optimize(study) if result is None else result
    yields = optimum_yields(study, res, getattr(args, "yield_samples", None))
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of a robust table isodesign optimize run. Replay: isodesign "
        f"optimize {run.final_path('study_resolved.toml')} -o NEWDIR")))
    rec = {**res.record(), "yields": [y.record() for y in yields]}
    sens = {}
    if res.feasible:
        sens = {"robust": res.sensitivities(),
                "nominal": table_sensitivities(study, res.nominal.values)}
        worst = next((r for r in res.scenarios if r["worst"]), None)
        if worst is not None:  # the objective where it is worst, as the vertical run's
            sens["active"] = [dataclasses.replace(x, quantity=f"{x.quantity} (scenario "
                                                  f"{worst['index']})")
                              for x in res.sensitivities(scenario=worst["index"])]
        rec["sensitivities"] = {k: [x.row() for x in v] for k, v in sens.items()}
    run.write_json("robust.json", rec)
    run.record["robust_result"] = {k: rec[k] for k in ("worst_case_objective", "values",
                                                         "rounds", "converged", "yields",
                                                         "table")}
    if not res.feasible:
        run.status = "infeasible"
        print(f"study {study.name!r}: NO ROBUST DESIGN")
        print(f"isodesign: error: {res.failure_message()}", file=sys.stderr)
        return 1
    run.write_csv("scenarios.csv", res.scenarios_frame())
    run.write_csv("rounds.csv", res.rounds_frame())
    run.write_text("design.toml", design_to_toml(study.design_at(res.values), header=(
        f"Robust table optimum of study {study.name!r} (isodesign optimize with [scenarios]).")))
    v, nv = res.values, res.nominal.values
    print(f"study {study.name!r} (table): robust {res.objective} over "
          + "; ".join(p.label() for p in study.scenarios.parameters))
    print(f"  exchange: {len(res.rounds)} rounds, {len(res.scenarios)} scenarios, "
          f"{'converged' if res.converged else 'NOT converged'}; {res.wall_s:.1f} s")
    for name, vals, obj in (("nominal", nv, res.nominal.objective_value),
                            ("robust", v, res.objective_value)):
        print(f"  {name:8s} N {vals['volume_ratio']:.4g}, V_t0 {vals['top_volume_m3'] * 1e3:.4g} "
              f"L, L_c {vals['capillary_length_m'] * 1e3:.4g} mm, D_c "
              f"{vals['capillary_diameter_m'] * 1e3:.4g} mm; "
              f"{'nominal' if name == 'nominal' else 'worst case'} {obj:+.4g}")
    for r in res.scenarios:
        print(f"  scenario {r['description']}: {r['objective']:+.4g}"
              + ("  (worst)" if r["worst"] else ""))
    print(f"verdict: {res.verdict()}")
    print("\n".join(["", *res.constraint_lines(), ""]))
    run.write_csv("sensitivities.csv", _sens_frame(sens))
    print("sensitivities of the robust design's worst margin (nominal parameters, design "
          "held; central differences of the table's analysis):")
    for x in sorted(sens["robust"], key=lambda x: -abs(x.effect)):
        print(f"  {x.parameter:24s} {x.per_unit:+.4g} {x.unit}/{x.parameter_unit}"
              f"   {x.effect:+.3f} {x.unit} over the half-width")
    if yields:
        run.write_csv("yield.csv", yields[1].to_frame())
    if not getattr(args, "no_plots", False):
        with run.writing("robustness.png") as tmp:
            robustness_plot(res, tmp, sens=sens.get("active") or sens["robust"], yields=yields)
    for y in yields:
        lo, hi = y.interval
        print(f"yield of the {y.label} (table analysis): {100 * y.fraction:.1f} % "
              f"({y.passed}/{y.samples}; {100 * y.confidence:g} % CI {100 * lo:.1f}-"
              f"{100 * hi:.1f} %)")
    return 0


def execute_robust(study, run, args, result=None) -> int:
    """Optimize ``study`` robustly into the run directory ``run``; the exit status.

    ``result``: the study's robust optimum when already computed (a sweep point), else
    computed here by :func:`isodesign.optimize`; either way the same files are written.
    """
    if getattr(study, "table", None) is not None:
        return execute_robust_table(study, run, args, result)
    run.record.update({"kind": "isodesign optimize",
                       "command_line": command_line(canonical_command(args, "optimize")[1:]),
                       "environment": environment(), "study": resolved_study_dict(study),
                       "study_source": study.source, "robust": True})
    res = _answer(study, args) if result is None else result
    nominal = res.nominal
    write_outputs(nominal, run, args, plots=not args.no_plots, prefix="nominal/")
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of a robust isodesign optimize run. Replay: isodesign optimize "
        f"{run.final_path('study_resolved.toml')} -o NEWDIR")))
    if not res.feasible:
        run.status = "infeasible"
        run.write_json("robust.json", res.record())
        run.record["robust_result"] = res.record()
        print(f"study {study.name!r}: NO ROBUST DESIGN")
        print(f"isodesign: error: {res.failure_message()}", file=sys.stderr)
        return 1
    sens = {"robust": res.sensitivities()}
    b = res.problem.block
    th = study.scenarios.nominal()
    b.select(th, b.base_slot_hz)
    sens["nominal"] = design_sensitivities(b, b.initial_guess(nominal.values), th)
    sens["active"] = active_sensitivities(res)
    yields = optimum_yields(study, res, getattr(args, "yield_samples", None))
    rec = res.record()
    rec["yields"] = [y.record() for y in yields]
    rec["sensitivities"] = {k: [s.row() for s in v] for k, v in sens.items()}
    rec["reoptimized_sensitivities"] = {str(k): v for k, v in
                                        res.reoptimized_sensitivities().items()}
    run.write_json("robust.json", rec)
    run.record["robust_result"] = {k: rec[k] for k in ("worst_case_objective", "values",
                                                         "rounds", "converged", "yields")}
    run.write_csv("scenarios.csv", res.scenarios_frame())
    run.write_csv("rounds.csv", res.rounds_frame())
    run.write_csv("sensitivities.csv", _sens_frame(sens))
    if yields:
        run.write_csv("yield.csv", yields[1].to_frame())
    models = resolved_study_dict(study).get("models")
    run.write_text("design.toml", design_to_toml(res.design, models=models, header=(
        f"Robust optimum of study {study.name!r} (isodesign optimize with [scenarios]); p0 "
        f"from the nominal payload ({study.payload.mass_kg:g} kg).")))
    if not args.no_plots:
        with run.writing("robustness.png") as tmp:
            robustness_plot(res, tmp, sens=sens["active"] or sens["robust"], yields=yields)
    if args.quiet:
        print(f"{study.name}: robust worst case {res.objective_value:+.3f}; "
              f"{len(res.rounds)} rounds, {len(res.scenarios)} scenarios")
    else:
        print(robust_summary(res, sens, yields))
        print(f"wrote robust.json, scenarios.csv, rounds.csv, sensitivities.csv, design.toml, "
              f"robustness.png, nominal/ to {run.target}")
    return 0
