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

from isodesign.optimization.explain import limiting_summary

#: Files written by a table optimization (feasible run, plots on).
TABLE_OUTPUT_FILES = ("design.json", "design.toml", "bands.csv", "modes.csv", "starts.csv",
                      "record.json", "study_resolved.toml", "response.png", "layout.png")


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
        f"{result.n_reached_best} reached the best design; {result.wall_s:.1f} s",
        "  Hessian: {hessian} ({reason})".format(**result.hessian_choice()),
        f"  {'':<24}{'start':>10}{'optimum':>10}",
        f"  {'N = V_b0/V_t0':<24}{v0['volume_ratio']:>10.4g}{v1['volume_ratio']:>10.4g}",
        f"  {'V_t0 (L)':<24}{v0['top_volume_m3'] * 1e3:>10.4g}{v1['top_volume_m3'] * 1e3:>10.4g}",
        f"  {'L_c (mm)':<24}{v0['capillary_length_m'] * 1e3:>10.4g}"
        f"{v1['capillary_length_m'] * 1e3:>10.4g}",
        f"  {'D_c (mm)':<24}{v0['capillary_diameter_m'] * 1e3:>10.4g}"
        f"{v1['capillary_diameter_m'] * 1e3:>10.4g}",
    ]
    lines += lever_lines(result)
    for i, ax in enumerate(AXES):
        lines.append(f"  {'worst margin ' + ax + ' (dB)':<24}{a0.axis_margin_db()[i]:>+10.2f}"
                     f"{a1.axis_margin_db()[i]:>+10.2f}")
    lines.append(peak_text(result))
    rc = getattr(result, "recheck_rows", None)  # the one row re-check (recheck.recheck_rows)
    rows = ""
    if rc is not None:
        worst = max((d for _, _, d, _ in rc.rows), default=0.0)
        rows = f", {len(rc.rows)} constraint rows to {worst:.2g}"
    lines.append(f"  re-check: NumPy closure = NLP to {result.recheck_sigma_rel:.2g} (sigma), "
                 f"{result.recheck_margin_db:.2g} dB (worst margin){rows}; mode refreshes "
                 f"{result.mode_rounds}")
    lines.append("  modes of the optimum (springs at its closure):")
    lines.append(modes_text(result.modes))
    lines.append(stability_text(result.stability))
    if result.leveling is not None:  # the valves' loop (docs/table.md, section 12)
        from isodesign.table.leveling import valve_gain_bounds

        gb = valve_gain_bounds(st)
        if gb is not None:
            lines.append(f"  valve gain: a design variable within {gb[0]:.4g} to {gb[1]:.4g} "
                         f"kg/s/m; chosen {result.leveling.gain_kg_s_per_m:.4g} kg/s/m (the "
                         "largest whose loop meets the margin bounds on the optimum's springs)")
        lines.append(result.leveling.text())
        broken = [(n, v) for n, v in result.violations if n.startswith("leveling_")]
        if broken:
            lines.append("  WARNING: the leveling loop's " + ", ".join(
                f"{n} is {v:.3g} {'dB' if n.endswith('gain_margin') else 'deg'} below its bound"
                for n, v in broken) + ": not a design that meets the study")
            g = result.leveling_gain_hint_kg_s_per_m
            lines.append("  the valves meet both bounds on these springs " + (
                f"at gains up to {g:.4g} kg/s/m (table.leveling.gain_kg_s_per_m)"
                if g is not None else "at no gain down to a thousandth of the study's"))
    lines.append("")
    lines += result.constraint_lines()
    lines.append("")
    lines.append(f"start:   {a0.verdict()}")
    lines.append(f"optimum: {result.verdict()}")
    lines += [f"  note: {n}" for n in a1.notes]
    return "\n".join(lines)


#: Short names of the spring's variables (a per-group lever's label).
_SHORT = {"volume_ratio": "N", "top_volume_m3": "V_t0", "capillary_length_m": "L_c",
          "capillary_diameter_m": "D_c"}


def lever_lines(result) -> list[str]:
    """The table's free levers, start and optimum (none with every lever fixed)."""
    from isodesign.optimization.variables import (
        GROUP_SPRING_LEVERS,
        TABLE_LEVER_UNITS,
        group_lever,
    )

    out = []
    notes = result.lever_notes()
    for v in result.study.levers:
        if v.fixed:
            continue
        unit = TABLE_LEVER_UNITS[v.name]
        label = f"{v.name.removesuffix('_n_per_m').removesuffix('_m').removesuffix('_kg')} ({unit})"
        if v.name in GROUP_SPRING_LEVERS:  # N group 2 (-), D_c group 3 (m)
            g, base = group_lever(v.name)
            label = f"{_SHORT[base]} group {g + 1} ({unit})"
        out.append(f"  {label:<24}{v.start:>10.4g}{result.values[v.name]:>10.4g}"
                   + (f"  {notes[v.name]}" if v.name in notes else ""))
    out += [f"  {k}: {note}" for k, note in notes.items()  # free positions' binding rows
            if k not in result.values]
    from isodesign.table.inertia_base import base_summary

    slab = base_summary(result.study.table_at(result.values)) if out else ""
    return out + ([f"  {slab}"] if slab else [])


def peak_text(result) -> str:
    """The continuous peak of |T| per axis, its search band and the refinement rounds."""
    pk = result.peak or {}
    tp = pk.get("peaks")
    if tp is None:
        return "  continuous peak of |T|: not measured"
    lim = pk.get("limit_db")
    text = ("  peak |T| per axis (every point, continuous from "
            f"{tp.f_low_hz:.3g} Hz = half the lowest mode to {tp.f_high_hz:.3g} Hz): "
            + ", ".join(f"{ax} {v:+.2f} dB" for ax, v in zip("xyz", tp.axis_peak_db(),
                                                            strict=True)))
    if lim is None:
        return text + " (no limit)"
    rounds = pk.get("rounds", 0)
    text += (f" (limit {lim:g} dB; {rounds} refinement round(s)"
             + (f", {len(pk['added_frequencies_hz'])} frequencies added to the NLP"
                if rounds else "") + ")")
    if pk.get("met") is False:
        p, a, v, f = tp.worst()
        text += (f"\n  WARNING: the continuous peak {v:.2f} dB ({p} {a}, {f:.3g} Hz) is above "
                 f"its limit {lim:g} dB by {v - lim:.2f} dB between the NLP's grid points "
                 "after the last refinement round: not a design that meets the study")
    return text


def failure_text(result) -> str:
    """An infeasible table run: IPOPT's status, the violations and the best point found."""
    v = result.values
    lines = [f"table study {result.study.name!r}: NO FEASIBLE DESIGN",
             f"  {len(result.starts)} starts, none feasible; IPOPT status of the best point "
             f"found: {result.status}",
             "  violated constraints (worst violation, NLP units: ln of the quantity, or "
             "ln |T|^2):"]
    lines += [f"    {n}: {a:.3g}" for n, a in result.violations]
    lines.append(f"  best point found (not a design): N = {v['volume_ratio']:.4g}, V_t0 = "
                 f"{v['top_volume_m3'] * 1e3:.4g} L, L_c = {v['capillary_length_m'] * 1e3:.4g}"
                 f" mm, D_c = {v['capillary_diameter_m'] * 1e3:.4g} mm")
    lines.append("")
    lines += result.constraint_lines()
    lines.append("  relax the violated constraints or widen the variables' bounds "
                 "(docs/optimization.md, 'When no design is feasible')")
    return "\n".join(lines)


def execute_table(study, run, args, result=None, *, prefix: str = "") -> int:
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
        :func:`isodesign.optimize` (with the progress bar of ``args``).
    prefix : str
        A subdirectory of ``run`` for the files (``"optimize/"`` for ``isodesign demo``): the
        run record's fields then go into ``run.record["parts"]`` and into the subdirectory's
        own ``record.json``.
    """
    from isodesign.io.designfile import design_to_toml
    from isodesign.io.record import (
        command_line,
        constraint_rows,
        environment,
        resolved_study_dict,
        study_toml,
    )
    from isodesign.optimization.dispatch import optimize
    from isodesign.optimization.table_problem import PEAK_ROWS_MAX_HZ
    from isodesign.plotting.style import save_figure
    from isodesign.table.modes import rocking_stability
    from isodesign.table.peaks import continuous_peaks, peak_search_band
    from isodesign.table.plots import layout_figure

    rec = run.record.setdefault("parts", {}).setdefault(prefix.rstrip("/"), {}) if prefix \
        else run.record
    rec.update({"kind": "isodesign optimize", "table": True,
                "command_line": command_line(), "environment": environment(),
                "study": resolved_study_dict(study), "study_source": study.source})
    if result is None:
        from isodesign.commands.optimize import StartProgress, progress_enabled

        n = study.solver["starts"]
        n = 2 * n - 1 if any(v.free for v in study.levers) else n
        with StartProgress(progress_enabled(args), n, study.objective["kind"]) as bar:
            result = optimize(study, progress=bar)
    res = result
    start = {v.name: v.start for v in study.variables}
    rec.update({"feasible": res.feasible, "status": res.status,
                "design": res.values, "start_design": start,
                "objective": res.objective, "objective_value": res.objective_value,
                "start_objective_value": res.start_objective, "wall_s": res.wall_s,
                "n_reached_best": res.n_reached_best,
                "starts": [{"start": i, "status": stt, "feasible": bool(f),
                            "iterations": it, "wall_s": w}
                           for i, stt, f, it, w, _ in res.starts],
                "hessian": res.hessian, "mode_rounds": res.mode_rounds,
                "distortion_outer_rounds": res.distortion_outer_rounds,
                "recheck_max_rel_diff": res.recheck_sigma_rel,
                "recheck_sigma_rel": res.recheck_sigma_rel,
                "recheck_margin_db": res.recheck_margin_db,
                "recheck_rows": [[k, kind, d, v] for k, kind, d, v in res.recheck_rows.rows]
                if getattr(res, "recheck_rows", None) is not None else [],
                "violations": [[n, v] for n, v in res.violations],
                "nlp_violations": [[n, v] for n, v in res.nlp_violations],
                "constraints": constraint_rows(res),
                "limited_by": res.limited_by if res.feasible else [],
                "success": res.success, "verdict": res.verdict(),
                "peak_refinement": _peak_record(res)})
    run.write_csv(prefix + "starts.csv", res.starts_frame())
    run.write_text(prefix + "study_resolved.toml", study_toml(study, header=(
        "Resolved study of an isodesign optimize run (a table study).\n"
        f"Replay: isodesign optimize {run.final_path(prefix + 'study_resolved.toml')} -o NEWDIR")))
    if not res.feasible:
        run.status = "infeasible"
        _part_record(run, rec, prefix, "infeasible")
        print(failure_text(res))
        sys.stdout.flush()
        print(f"isodesign: error: no feasible design ({res.status}); violations: "
              + ", ".join(f"{n} ({v:.3g})" for n, v in res.violations)
              + f"; wrote {run.final_path(prefix + 'record.json')} (run_status infeasible)",
              file=sys.stderr)
        return 1
    models = resolved_study_dict(study).get("models")
    run.write_text(prefix + "design.toml", design_to_toml(res.design, models=models, header=(
        f"Optimized spring of the table study {study.name!r} (isodesign optimize); each "
        "isolator's p0 comes from the table's leveling (docs/table.md).")))
    variables = {}
    for v in study.variables:
        val = res.values[v.name]
        at = ("lower" if abs(val / v.lower - 1) < 1e-6 else
              "upper" if abs(val / v.upper - 1) < 1e-6 else None) if not v.fixed else None
        variables[v.name] = {"value": val, "lower": v.lower, "upper": v.upper,
                             "fixed": v.fixed, "at_bound": at}
    for v in study.levers:  # a table's free levers (docs/table.md, "Co-design levers")
        if v.fixed:
            continue
        val, tol = res.values[v.name], 1e-6 * (v.upper - v.lower)
        at = "lower" if val - v.lower < tol else "upper" if v.upper - val < tol else None
        sens = next((x for x in res.lever_sensitivity if x["name"] == v.name), None)
        variables[v.name] = {"value": val, "lower": v.lower, "upper": v.upper,
                             "fixed": False, "at_bound": at,
                             "margin_db_per_unit_of_bound": None if sens is None
                             else sens["db_per_unit"]}
    def derived(analysis, modes, values):
        # the vertical mode: the one with the most kinetic energy in z (an off-centre CG
        # couples it, so its name need not be "z")
        j = int(np.nanargmax(np.where(np.isfinite(modes.frequency_hz),
                                      modes.energy_fraction[:, 2], -1.0)))
        fz = float(modes.frequency_hz[j])
        pk = continuous_peaks(analysis.model, analysis.stroke_rms_m,
                              analysis.closure_tube_velocity_m_s,
                              *peak_search_band(modes, PEAK_ROWS_MAX_HZ))
        return {"worst_band_margin_db": analysis.worst_margin_db,
                "natural_frequency_hz": fz if np.isfinite(fz) else None,
                "natural_frequencies_hz": dict(zip(modes.names,
                                                   map(float, modes.frequency_hz), strict=True)),
                "peak_transmissibility_db": pk.max_db,
                "peak_frequency_hz": pk.worst()[3],
                "tilt_margin": float(rocking_stability(analysis.model).margin[0]),
                "total_volume_m3": values["top_volume_m3"] * (1 + values["volume_ratio"])}

    run.write_json(prefix + "design.json", {
        "derived": derived(res.analysis, res.modes, res.values),
        "start_derived": derived(res.start_analysis, res.start_modes, start),
        "variables": variables, "objective": {"kind": res.objective,
                                              "value": res.objective_value},
        "verdict": res.verdict(), "start_verdict": res.start_analysis.verdict(),
        "success": res.success, "violations": [[n, v] for n, v in res.violations],
        "constraints": constraint_rows(res),
        "limited_by": res.limited_by, "limiting_summary": limiting_summary(res),
        "continuous_peak_db": (None if res.peak["peaks"] is None
                               else res.peak["peaks"].max_db),
        "hessian": res.hessian, "hessian_reason": res.hessian_choice()["reason"],
        "valve_gain_kg_s_per_m": (None if res.leveling is None
                                  else res.leveling.gain_kg_s_per_m),
        "worst_margin_per_axis_db": dict(zip("xyz", res.analysis.axis_margin_db().tolist(),
                                             strict=True)),
        "rocking_margin": res.stability.margin.tolist(),
        "modes": res.modes.to_frame()[["mode", "name", "frequency_hz",
                                       "damping_ratio"]].to_dict("records"),
        "notes": list(res.analysis.notes)})
    run.write_csv(prefix + "bands.csv", _bands_frame(res))
    run.write_csv(prefix + "modes.csv", res.modes.to_frame())
    if not args.no_plots:
        with run.writing(prefix + "response.png") as tmp:
            save_figure(res.analysis.plot(), tmp)
        with run.writing(prefix + "layout.png") as tmp:
            from isodesign.table.study import study_footprint

            fp, dmin = study_footprint(study)  # the footprint and spacing (free positions)
            save_figure(layout_figure(study.table_at(res.values), res.analysis.model.leveling,
                                      footprint=fp, min_distance_m=dmin), tmp)
    if args.quiet:
        print(f"{study.name}: worst margin {res.objective_value:+.2f} dB (NLP grid); "
              f"{res.verdict()}")
    else:
        print(table_summary_text(res))
        print(f"wrote {run.final_path(prefix) if prefix else run.target}")
    _part_record(run, rec, prefix, "infeasible" if res.violations else "complete")
    if res.violations:  # a design that breaks a constraint is not a success
        run.status = "infeasible"
        sys.stdout.flush()
        print("isodesign: error: the design breaks a constraint: " + ", ".join(
            f"{n} ({v:.3g})" for n, v in res.violations)
            + f"; wrote {run.final_path(prefix + 'record.json')} (run_status infeasible)",
            file=sys.stderr)
        return 1
    return 0


def _part_record(run, rec: dict, prefix: str, status: str) -> None:
    """A part's own ``record.json`` (a run inside ``isodesign demo``'s directory)."""
    if prefix:
        run.write_json(prefix + "record.json", {**rec, "run_status": status})


def _peak_record(res) -> dict:
    pk = dict(res.peak or {})
    tp = pk.pop("peaks", None)
    if tp is not None:
        pk.update(search_band_hz=[tp.f_low_hz, tp.f_high_hz], peak_db=tp.max_db,
                  per_point_axis=tp.to_frame().to_dict("records"))
    return pk
