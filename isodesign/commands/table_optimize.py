"""``isodesign optimize`` on a study with a ``[table]``: the three-axis optimizer's outputs.

Not a command of its own: :mod:`isodesign.commands.optimize` calls :func:`execute_table`
when the study has a table (docs/table.md, section 11). Writes design.toml, design.json,
bands.csv (one row per point, axis and band, with the start's columns), modes.csv,
starts.csv, study_resolved.toml, record.json and, unless --no-plots, response.png and
layout.png.
"""

from __future__ import annotations

import sys

import numpy as np

#: Files written by a table optimization (feasible run, plots on).
TABLE_OUTPUT_FILES = ("design.json", "design.toml", "bands.csv", "modes.csv", "starts.csv",
                      "record.json", "study_resolved.toml", "response.png", "layout.png")


def _starts_frame(result):
    import pandas as pd

    return pd.DataFrame(list(result.starts), columns=["start", "status", "feasible",
                                                      "iterations", "wall_s", "objective_nlp"])


def _bands_frame(result):
    df = result.analysis.to_frame()
    s = result.start_analysis
    df["start_velocity_rms_m_s"] = s.to_frame()["velocity_rms_m_s"].to_numpy()
    df["start_margin_db"] = s.to_frame()["margin_db"].to_numpy()
    return df


def table_summary_text(result) -> str:
    """Start against optimum, constraints, modes, rocking stability and verdicts.

    Parameters
    ----------
    result : TableOptimizationResult
    """
    from isodesign.table.assembly import AXES
    from isodesign.table.summary import modes_text, stability_text

    st = result.study
    v0 = {v.name: v.start for v in st.variables}
    v1 = result.values
    a0, a1 = result.start_analysis, result.analysis
    lines = [
        f"table study {st.name!r} ({st.source}): maximize the worst margin over "
        f"{len(st.table.point_names)} point(s) x 3 axes x {len(st.bands)} bands",
        f"  {len(result.starts)} starts: {sum(1 for s in result.starts if s[2])} feasible, "
        f"{result.n_reached_best} reached the best design; {result.wall_s:.1f} s; Hessian "
        f"{result.hessian} (exact gradients and Jacobian)",
        f"  {'':<24}{'start':>10}{'optimum':>10}",
        f"  {'N = V_b0/V_t0':<24}{v0['volume_ratio']:>10.4g}{v1['volume_ratio']:>10.4g}",
        f"  {'V_t0 (L)':<24}{v0['top_volume_m3'] * 1e3:>10.4g}{v1['top_volume_m3'] * 1e3:>10.4g}",
        f"  {'L_c (mm)':<24}{v0['capillary_length_m'] * 1e3:>10.4g}"
        f"{v1['capillary_length_m'] * 1e3:>10.4g}",
        f"  {'D_c (mm)':<24}{v0['capillary_diameter_m'] * 1e3:>10.4g}"
        f"{v1['capillary_diameter_m'] * 1e3:>10.4g}",
    ]
    for i, ax in enumerate(AXES):
        lines.append(f"  {'worst margin ' + ax + ' (dB)':<24}{a0.axis_margin_db()[i]:>+10.2f}"
                     f"{a1.axis_margin_db()[i]:>+10.2f}")
    pk = a1.peak_transmissibility_db().max(axis=0)
    lim = st.constraints.get("max_peak_transmissibility_db")
    over = lim is not None and lim is not False and bool(np.any(pk > lim + 0.01))
    lines.append("  peak |T| per axis on the analysis grid (every point): " + ", ".join(
        f"{ax} {v:+.2f} dB" for ax, v in zip("xyz", pk, strict=True))
        + ("" if lim in (None, False) else f" (limit {lim:g} dB"
           + ("; ABOVE it between the NLP's grid points)" if over else ")")))
    lines.append("  constraints (worst violation, NLP units): " + ", ".join(
        f"{n} {v:.2g}" for n, v in result.constraints))
    lines.append(f"  re-check: NumPy closure = NLP to {result.recheck_sigma_rel:.2g} (sigma), "
                 f"{result.recheck_margin_db:.2g} dB (worst margin); mode refreshes "
                 f"{result.mode_rounds}")
    lines.append("  modes of the optimum (springs at its closure):")
    lines.append(modes_text(result.modes))
    lines.append(stability_text(result.stability))
    lines.append(f"start:   {a0.verdict()}")
    lines.append(f"optimum: {a1.verdict()}")
    lines += [f"  note: {n}" for n in a1.notes]
    return "\n".join(lines)


def execute_table(study, run, args, result=None) -> int:
    """Optimize a table study into the run directory ``run``; print the report; the status.

    Parameters
    ----------
    study : Study
        With a ``[table]``.
    run : RunDirectory
    args : argparse.Namespace
        The optimize command's options.
    result : TableOptimizationResult, optional
        The study's optimum when already computed (a sweep point); else computed here by
        :func:`isodesign.optimize`.
    """
    from isodesign.io.designfile import design_to_toml
    from isodesign.io.record import command_line, environment, resolved_study_dict, study_toml
    from isodesign.optimization.dispatch import optimize
    from isodesign.plotting.style import save_figure
    from isodesign.table.modes import rocking_stability
    from isodesign.table.plots import layout_figure

    run.record.update({"kind": "isodesign optimize", "table": True,
                       "command_line": command_line(), "environment": environment(),
                       "study": resolved_study_dict(study), "study_source": study.source})
    res = optimize(study) if result is None else result
    start = {v.name: v.start for v in study.variables}
    run.record.update({"feasible": res.feasible, "status": res.status,
                       "design": res.values, "start_design": start,
                       "objective": res.objective, "objective_value": res.objective_value,
                       "start_objective_value": res.start_objective, "wall_s": res.wall_s,
                       "n_reached_best": res.n_reached_best,
                       "starts": [{"start": i, "status": stt, "feasible": bool(f),
                                   "iterations": it, "wall_s": w}
                                  for i, stt, f, it, w, _ in res.starts],
                       "hessian": res.hessian, "mode_rounds": res.mode_rounds,
                       "recheck_max_rel_diff": res.recheck_sigma_rel,
                       "recheck_sigma_rel": res.recheck_sigma_rel,
                       "recheck_margin_db": res.recheck_margin_db,
                       "violations": [[n, v] for n, v in res.constraints]})
    run.write_csv("starts.csv", _starts_frame(res))
    run.write_text("study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign optimize run (a table study).\n"
        f"Replay: isodesign optimize {run.final_path('study_resolved.toml')} -o NEWDIR")))
    if not res.feasible:
        run.status = "infeasible"
        print(f"isodesign: error: no feasible design ({res.status}); violations: "
              + ", ".join(f"{n} ({v:.3g})" for n, v in res.constraints if v > 1e-6),
              file=sys.stderr)
        return 1
    models = resolved_study_dict(study).get("models")
    run.write_text("design.toml", design_to_toml(res.design, models=models, header=(
        f"Optimized spring of the table study {study.name!r} (isodesign optimize); each "
        "isolator's p0 comes from the table's leveling (docs/table.md).")))
    variables = {}
    for v in study.variables:
        val = res.values[v.name]
        at = ("lower" if abs(val / v.lower - 1) < 1e-6 else
              "upper" if abs(val / v.upper - 1) < 1e-6 else None) if not v.fixed else None
        variables[v.name] = {"value": val, "lower": v.lower, "upper": v.upper,
                             "fixed": v.fixed, "at_bound": at}
    def derived(analysis, modes, values):
        z = [f for f, n in zip(modes.frequency_hz, modes.names, strict=True) if n == "z"]
        return {"worst_band_margin_db": analysis.worst_margin_db,
                "natural_frequency_hz": z[0] if z else None,
                "peak_transmissibility_db": float(analysis.peak_transmissibility_db().max()),
                "tilt_margin": float(rocking_stability(analysis.model).margin[0]),
                "total_volume_m3": values["top_volume_m3"] * (1 + values["volume_ratio"])}

    run.write_json("design.json", {
        "derived": derived(res.analysis, res.modes, res.values),
        "start_derived": derived(res.start_analysis, res.start_modes, start),
        "variables": variables, "objective": {"kind": res.objective,
                                              "value": res.objective_value},
        "verdict": res.analysis.verdict(), "start_verdict": res.start_analysis.verdict(),
        "worst_margin_per_axis_db": dict(zip("xyz", res.analysis.axis_margin_db().tolist(),
                                             strict=True)),
        "rocking_margin": res.stability.margin.tolist(),
        "modes": res.modes.to_frame()[["mode", "name", "frequency_hz",
                                       "damping_ratio"]].to_dict("records"),
        "notes": list(res.analysis.notes)})
    run.write_csv("bands.csv", _bands_frame(res))
    run.write_csv("modes.csv", res.modes.to_frame())
    if not args.no_plots:
        with run.writing("response.png") as tmp:
            save_figure(res.analysis.plot(), tmp)
        with run.writing("layout.png") as tmp:
            save_figure(layout_figure(study.table, res.analysis.model.leveling), tmp)
    if args.quiet:
        print(f"{study.name}: worst margin {res.objective_value:+.2f} dB (NLP grid); "
              f"{res.analysis.verdict()}")
    else:
        print(table_summary_text(res))
        print(f"wrote {run.target}")
    return 0
