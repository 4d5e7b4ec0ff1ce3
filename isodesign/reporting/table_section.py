"""The report's table section: a study with a ``[table]`` in six degrees of freedom."""

from __future__ import annotations

import warnings

import numpy as np

from isodesign.plotting.style import figure_svg

__all__ = ["table_design_rows", "table_job_rows", "table_section", "table_verdict"]

_AXES = ("x", "y", "z")


def table_section(case) -> dict | None:
    """The template's table block of a case whose study has a table (None otherwise).

    The layout's top view, the verdict over points, axes and bands, the band table per
    point and axis, |T| per axis, the modes (nonlinear eigenproblem, springs at the
    closure) and the rocking stability with gravity (docs/table.md).

    Parameters
    ----------
    case : Case

    Returns
    -------
    dict or None
    """
    st = case.study
    if getattr(st, "table", None) is None:
        return None
    from isodesign.optimization.table_driver import band_response_and_modes
    from isodesign.optimization.table_problem import PEAK_ROWS_MAX_HZ
    from isodesign.table.peaks import continuous_peaks, peak_search_band
    from isodesign.table.plots import (
        layout_figure,
        table_bands_figure,
        table_transmissibility_figure,
    )

    # a co-designed run's table: the levers at the optimum's values (record.json)
    res, modes = band_response_and_modes(st, case.design, (case.record or {}).get("design"),
                                         case.models)
    model = res.model
    from isodesign.table.leveling import leveling_of_study
    from isodesign.table.stability_report import stability_section

    # the static verdict and the loop as ``isodesign stability`` computes them (the linear
    # regime's modes, a statically unstable one makes the verdict unstable)
    stability = stability_section(model, leveling_of_study(st))
    stability["source"] = ("the study's [table.leveling]" if
                           ((getattr(st, "raw", None) or {}).get("table") or {}).get("leveling")
                           else "the default valves (the study has no [table.leveling])")
    stab = stability["static"][0]
    from isodesign.table.study import study_footprint

    footprint = study_footprint(st)  # the layout's footprint and spacing (section 15)
    head = ["band (Hz)", "limit (um/s)"] + [f"{n} {a}" for n in res.point_names for a in _AXES]
    rows = []
    for b, lab in enumerate(res.bands.labels):
        cells, classes = [lab, f"{res.limit_velocity_rms_m_s[b] * 1e6:.4g}"], ["", ""]
        for p in range(len(res.point_names)):
            for a in range(3):
                mg = res.margin_db[p, a, b]
                cells.append(f"{res.velocity_rms_m_s[p, a, b] * 1e6:.3g} ({mg:+.1f} dB)")
                classes.append("fail" if mg < 0 else "")
        rows.append({"cells": cells, "classes": classes})
    mode_rows = [[str(j + 1), modes.names[j],
                  "unstable" if np.isnan(modes.frequency_hz[j]) else
                  f"{modes.frequency_hz[j]:.3f}",
                  "" if np.isnan(modes.damping_ratio[j]) else f"{modes.damping_ratio[j]:.3f}",
                  *[f"{100 * e:.0f}" for e in modes.energy_fraction[j]]] for j in range(6)]
    stab_rows = [[name, f"{stab.directions[0, j]:+.2f} rx, {stab.directions[1, j]:+.2f} ry",
                  f"{stab.margin[j]:.3g}", "> 1" if stab.margin[j] > 1 else "<= 1: tips"]
                 for j, name in enumerate(("weakest", "strongest"))]
    lev = model.leveling
    lev_rows = [[str(i + 1), str(lev.group_of[i] + 1), f"{lev.load_n[i]:.1f}",
                 f"{lev.pressure_pa[i] / 1e5:.4g}", f"{res.stroke_rms_m[i] * 1e6:.3g}"]
                for i in range(lev.load_n.size)]
    p, a, b, w = res.worst
    opt_svg = _start_vs_optimum_svg(case, res)
    peaks = continuous_peaks(model, res.stroke_rms_m, res.closure_tube_velocity_m_s,
                             *peak_search_band(modes, PEAK_ROWS_MAX_HZ))
    lim = st.constraints.get("max_peak_transmissibility_db")
    peak_line = (f"Peak |T| per axis over every point, continuous from {peaks.f_low_hz:.3g} Hz "
                 f"(half the lowest mode) to {peaks.f_high_hz:.3g} Hz: " + ", ".join(
                     f"{ax} {peaks.peak_db[:, i].max():+.2f} dB at "
                     f"{peaks.frequency_hz[int(np.argmax(peaks.peak_db[:, i])), i]:.3g} Hz"
                     for i, ax in enumerate(_AXES))
                 + ("" if lim is None or lim is False else
                    f"; limit {lim:g} dB" + (" (ABOVE it)" if peaks.max_db > lim + 0.01
                                             else "")))
    return {
        "response": res,
        "modes": modes,
        "optimization_svg": opt_svg,
        "peak_line": peak_line,
        "label": case.label,
        "passes": res.passes,
        "verdict": res.verdict(),
        "worst": f"{p}, {a} axis, {b} Hz: {w:+.2f} dB",
        "axis_margins": ", ".join(f"{ax} {v:+.2f} dB" for ax, v in
                                  zip(_AXES, res.axis_margin_db(), strict=True)),
        "notes": list(res.notes),
        "layout_svg": figure_svg(layout_figure(model.table, lev, footprint=footprint[0],
                                               min_distance_m=footprint[1])),
        "bands_svg": figure_svg(table_bands_figure(res)),
        "transmissibility_svg": figure_svg(table_transmissibility_figure(res)),
        "band_head": head,
        "band_rows": rows,
        "mode_rows": mode_rows,
        "stability_rows": stab_rows,
        "stability": stability,
        "leveling_rows": lev_rows,
    }


def _fmt_xy(v) -> str:
    return "(" + ", ".join(f"{x:g}" for x in v) + ")"


def table_job_rows(case, t: dict) -> list[tuple[str, str]]:
    """The job of a table case: the table, its layout, loads and p0 per isolator and group.

    Parameters
    ----------
    case : Case
    t : dict
        :func:`table_section` of the case.

    Returns
    -------
    list of (str, str)
        Rows replacing the ``[payload]`` rows of the report's job section.
    """
    tab = case.study.table
    lev = t["response"].model.leveling
    inert = np.asarray(tab.inertia_kg_m2, float)
    off = [inert[0, 1], inert[0, 2], inert[1, 2]]
    inertia = (f"Ixx {inert[0, 0]:.4g}, Iyy {inert[1, 1]:.4g}, Izz {inert[2, 2]:.4g} kg m^2 "
               "about the CG" + ("" if not np.any(off) else
                                 f" (products Ixy {off[0]:.4g}, Ixz {off[1]:.4g}, Iyz "
                                 f"{off[2]:.4g})"))
    groups = []
    for g, members in enumerate(tab.leveling_groups):
        members = list(members)
        groups.append(f"valve {g + 1}: isolator(s) {', '.join(str(i + 1) for i in members)}, "
                      f"p0 {lev.group_pressure_pa[g] / 1e5:.4g} bar abs, load "
                      + ", ".join(f"{lev.load_n[i]:.1f}" for i in members) + " N")
    per = "; ".join(f"{i + 1}: {lev.load_n[i]:.1f} N, {lev.pressure_pa[i] / 1e5:.4g} bar"
                    for i in range(lev.load_n.size))
    pts = "; ".join(f"{n} {_fmt_xy(x)} m" for n, x in zip(tab.point_names,
                                                        tab.instrument_points_m, strict=True))
    h = tab.horizontal
    rows = []
    if any(tab.group_springs):  # docs/table.md section 15: a leveling group's own spring
        rows.append(("spring per leveling group", "; ".join(
            f"valve {g + 1}: " + (", ".join(_group_field(k, v) for k, v in own.items())
                                  + (" (the others the shared spring's)"
                                     if len(own) < 4 else "") if own else
                                  "the shared spring (the design section's)")
            for g, own in enumerate(tab.group_springs))))
    return [
        ("table", f"{tab.mass_kg:g} kg on {tab.n_isolators} isolators; centre of gravity "
                  f"{_fmt_xy(tab.cg_m)} m (x, y from the isolators' origin, z above their "
                  f"support plane); {inertia}"),
        ("layout", "isolators at (x, y) m: " + "; ".join(
            f"{i + 1}: {_fmt_xy(xy)}" for i, xy in enumerate(tab.isolators_m))),
        ("leveling groups", "; ".join(groups) + f" (supply {tab.supply_pressure_pa / 1e5:.4g}"
                                                " bar abs)"),
        ("load and p0 per isolator", per),
        ("instrument points", pts),
        ("horizontal element", f"pendulum {h.pendulum_length_m:g} m, lateral stiffness "
                               f"{h.lateral_stiffness_n_per_m:g} N/m, loss factor "
                               f"{h.lateral_loss_factor:g}, elastic centre "
                               f"{h.elastic_centre_height_m:g} m above the support plane"),
        *rows,
    ]


def _group_field(name: str, value: float) -> str:
    """One field of a leveling group's own spring, as the design section prints it."""
    scale, label = {"volume_ratio": (1.0, "N = {:.4g}"), "top_volume_m3": (1e3, "V_t0 {:.4g} L"),
                    "capillary_length_m": (1e3, "L_c {:.4g} mm"),
                    "capillary_diameter_m": (1e3, "D_c {:.4g} mm")}.get(name, (1.0, name + " {:g}"))
    return label.format(value * scale)


def table_verdict(case, t: dict) -> dict:
    """The report's one verdict card of a table case: over every point, axis and band, and
    the run's constraints (a design that breaks one is a FAIL, whatever its margins).

    Parameters
    ----------
    case : Case
    t : dict
        :func:`table_section` of the case.

    Returns
    -------
    dict
        The template's verdict card (``table`` True).
    """
    res = t["response"]
    rec = case.record or {}
    broken = [(n, v) for n, v in rec.get("violations") or []] \
        if rec.get("table") and rec.get("feasible") else []
    p, a, b, w = res.worst
    passes = bool(res.passes and not broken)
    line = res.verdict()
    if broken:
        line = ("constraint broken: " + ", ".join(f"{n} ({v:.3g})" for n, v in broken)
                + "; bands: " + line)
    m = res.margin_db
    return {"label": case.label, "passes": passes, "word": "PASS" if passes else "FAIL",
            "table": True, "line": line, "worst_band": f"{p} {a} {b}",
            "worst_margin": f"{w:+.2f} dB", "failing": int(np.sum(m < 0)), "bands": m.size,
            "target": res.target_name, "axis_margins": t["axis_margins"], "outside": "",
            "scope": "a rigid table in six degrees of freedom, floor in x, y and z, every "
                     "instrument point", "invalid": "", "broken": broken,
            "stability": t["stability"]}


def table_design_rows(t: dict) -> dict:
    """Design-table cells of a table case that replace the payload's.

    Parameters
    ----------
    t : dict
        :func:`table_section` of the case.

    Returns
    -------
    dict
        Row name -> cell: p0 (absolute and gauge) per leveling valve and the six modes'
        frequencies with their names.
    """
    lev = t["response"].model.leveling
    modes = t["modes"]
    freqs = ", ".join(("unstable" if np.isnan(f) else f"{f:.3g}") + f" ({n})"
                      for f, n in zip(modes.frequency_hz, modes.names, strict=True))
    return {
        "p0 absolute (bar)": " / ".join(f"{p / 1e5:.4g}" for p in lev.group_pressure_pa)
                             + " (per valve)",
        "p0 gauge (bar)": " / ".join(f"{(p - 101325.0) / 1e5:.4g}"
                                     for p in lev.group_pressure_pa) + " (per valve)",
        "natural frequency f_n (Hz)": freqs,
    }


def _start_vs_optimum_svg(case, res) -> str | None:
    """An optimize run's start against its optimum, per axis (worst over the points): the
    panel titles give the same margins as the table's band table."""
    rec = case.record
    if case.kind != "optimize" or not rec or "start_design" not in rec:
        return None
    from isodesign.plotting.style import band_axis, new_figure
    from isodesign.table.response import table_band_response

    st = case.study
    m = case.models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = table_band_response(st.design_at(rec["start_design"]), st.table, st.floor_axes,
                                    st.target, bands=st.bands, flow=m["flow"],
                                    amplitude_mode=m["amplitude_mode"],
                                    diaphragm=m["diaphragm"], warn=False,
                                    distortion=bool(m.get("distortion", False)))  # fmt: skip
    fig = new_figure(11.0, 3.6)
    axes = fig.subplots(1, 3, sharey=True)
    x = np.asarray(res.bands.centre_hz, float)
    for a, ax in enumerate(axes):
        band_axis(ax, res.bands)
        lim = res.limit_velocity_rms_m_s * 1e6
        ax.plot(x, lim, color="k", ls="--", lw=1.2, label=res.target_name)
        worst_s = start.velocity_rms_m_s[:, a].max(axis=0) * 1e6
        worst_o = res.velocity_rms_m_s[:, a].max(axis=0) * 1e6
        ax.plot(x, worst_s, color="#c0392b", ls="--", marker="o", ms=3, label="start")
        ax.plot(x, worst_o, color="#1f5fa8", marker="o", ms=3, label="optimum")
        ax.set_yscale("log")
        ax.set_title(f"{_AXES[a]} axis: start {start.margin_db[:, a].min():+.1f} dB, optimum "
                     f"{res.margin_db[:, a].min():+.1f} dB", fontsize=10)
        ax.grid(True, which="major", lw=0.4, alpha=0.6)
    axes[0].set_ylabel("band RMS velocity, worst point (um/s)")
    axes[0].legend(fontsize=7, loc="lower left")
    return figure_svg(fig)
