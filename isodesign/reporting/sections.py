"""The content of a report: every section's tables and texts, and the figures as SVG.

:func:`build_context` turns analysed cases (:func:`isodesign.reporting.analysis.analyse`)
into the variables of the report's template: numbers formatted with their units, one
column per candidate in every table, figures drawn in the visual language of
:mod:`isodesign.plotting` and inlined as SVG. :mod:`isodesign.reporting.render` renders it.
"""

from __future__ import annotations

import datetime as _dt
import math
from types import SimpleNamespace

import numpy as np

from isodesign import __version__
from isodesign.io.record import PEAK_EXCESS_DB, dumps_toml, environment, resolved_study_dict
from isodesign.optimization.analyze import vertical_band_response
from isodesign.optimization.constraints import DISPLAY_UNITS
from isodesign.plotting.optimization import (
    objective_display,
    optimization_figure,
    pareto_figure,
)
from isodesign.plotting.response import (
    UM_PER_UIN,
    band_response_figure,
    bands_figure,
    floor_label,
    harmonic_figure,
    transmissibility_figure,
)
from isodesign.plotting.stiffness import stiffness_figure
from isodesign.plotting.style import LINEAR, candidate_style, figure_svg, new_figure
from isodesign.reporting.analysis import (
    HARMONIC_AMPLITUDES_M,
    STIFFNESS_AMPLITUDES_M,
    CaseAnalysis,
    db,
    model_caveats,
)
from isodesign.reporting.inputs import Case
from isodesign.reporting.robustness import robustness_section
from isodesign.reporting.table_section import (
    table_design_rows,
    table_job_rows,
    table_section,
    table_verdict,
)

__all__ = ["SECTIONS", "build_context"]

#: Section ids of a report, in reading order (optimization and pareto only when present).
SECTIONS = ("verdict", "job", "design", "bands", "transmissibility", "stiffness", "stability",
            "optimization", "pareto", "flags", "provenance")

def _f(x, fmt=".4g", scale=1.0, none="n/a") -> str:
    if x is None:
        return none
    try:
        v = float(x) * scale
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return none
    return f"{v:{fmt}}"


def _svg(fig) -> str:
    return figure_svg(fig)


# ---------------------------------------------------------------------------
# sections
# ---------------------------------------------------------------------------
def _verdict(a: CaseAnalysis) -> dict:
    r = a.judged
    nfail = int(np.sum(~r.band_passes))
    return {
        "label": a.case.label,
        "passes": bool(r.passes),
        "word": "PASS" if r.passes else "FAIL",
        "worst_band": r.worst_band_label,
        "worst_margin": f"{r.worst_margin_db:+.2f} dB",
        "line": r.verdict(),
        "failing": nfail,
        "bands": len(r.bands),
        "target": r.target_name,
        "outside": _outside_note(a),
        "scope": r.scope.short(),
        "invalid": "; ".join(r.outside_validity),
    }


def _outside_note(a: CaseAnalysis) -> str:
    """Bands outside the judged range where the payload exceeds the limit (not judged)."""
    r, mask = a.all_bands, a.judged_mask
    bad = ~mask & ~np.asarray(r.band_passes, bool)
    if not bad.any():
        return ""
    i = int(np.argmin(np.where(bad, r.margin_db, np.inf)))
    return (f"outside the judged range, {int(bad.sum())} band(s) exceed the limit (not "
            f"judged); the worst is {r.bands.labels[i]} Hz at {r.margin_db[i]:+.1f} dB, "
            f"where |T| amplifies the floor")


def _job(c: Case, a: CaseAnalysis, tsec: dict | None = None) -> dict:
    st = c.study
    p = st.payload
    floor, target = st.floor, st.target
    lim = np.asarray(a.judged.limit_velocity_rms_m_s, float)
    lo, hi = c.judged_hz
    rows = [
        ("payload", f"{p.mass_kg:g} kg on {p.isolators} isolators "
                    f"({p.mass_kg / p.isolators:.4g} kg per isolator)"),
        ("layout", (f"narrowest isolator spacing {p.spacing_m:g} m, centre of gravity "
                    f"{p.cg_height_m:g} m above the diaphragms")
         if p.spacing_m and p.cg_height_m else "isolator spacing and CG height not given "
                                               "(no tilt margin)"),
        ("floor", _floor_text(st)),
        ("floor source", floor.source or "(none given)"),
        ("criterion", f"{target.name}: {target.description}"),
        ("criterion limit in the judged bands", _limit_text(lim)),
        ("criterion source", target.source),
        ("judged bands", f"{lo:g}-{hi:g} Hz ({len(a.judged.bands)} one-third-octave bands; "
                         f"{len(a.all_bands.bands)} shown)"),
        ("job from", c.job_source),
    ]
    if tsec is not None:  # the table's own job, not the [payload] it reduces to
        rows[:2] = table_job_rows(c, tsec)
    sc = a.judged.scope
    if getattr(st, "table", None) is not None:  # docs/table.md
        t = st.table
        rows += [("scope", f"a rigid table in six degrees of freedom on {t.n_isolators} "
                           "isolators with three leveling valves, floor in x, y and z, every "
                           "instrument point (section 1); the vertical-only sections below "
                           "show the symmetric payload it reduces to"),
                 ("not modelled", "floor rotation; differential floor motion between "
                                  "isolators; leveling-valve dynamics in the band response "
                                  "(taken closed; their loop is analysed in section 1); table "
                                  "flexibility")]
    else:
        rows += [("scope", sc.covers), ("not modelled", "; ".join(sc.leaves_out))]
    if sc.illustrative_share is not None:
        rows.append(("illustrative parameters",
                     f"{sc.illustrative_what} supplies {100 * sc.illustrative_share:.0f} % of "
                     "the static stiffness K0; calibrate it from rig data "
                     "(isodesign fit diaphragm)"))
    return {"label": c.label, "rows": rows}


def _limit_text(lim) -> str:
    lo, hi = float(lim.min()) * 1e6, float(lim.max()) * 1e6
    if math.isclose(lo, hi, rel_tol=1e-9):
        return f"{lo:.4g} um/s ({lo / UM_PER_UIN:.4g} uin/s) band RMS velocity in every band"
    return (f"{lo:.4g}-{hi:.4g} um/s ({lo / UM_PER_UIN:.4g}-{hi / UM_PER_UIN:.4g} uin/s) "
            "band RMS velocity")


def _floor_text(st) -> str:
    fl = st.floor
    spec = st.raw.get("floor", {})
    rng = f"defined {fl.f_min_hz:.3g}-{fl.f_max_hz:.3g} Hz"
    if "criterion" in spec:
        return (f"{fl.name}: a floor exactly on the {spec['criterion']} curve in every "
                f"one-third-octave band (band-constant velocity PSD), {rng}")
    kind = "band RMS velocity per one-third octave" if fl.bands is not None else \
        "velocity PSD, interpolated log-log"
    return f"{fl.name}: measured spectrum from {spec.get('csv', '?')} ({kind}), {rng}"


def _design_rows(cases: list[CaseAnalysis]) -> list[list[str]]:
    def row(name, fn):
        return [name, *[fn(a) for a in cases]]

    def d(a):
        return a.case.design

    def s(a):
        return a.judged.stability

    return [
        row("volume ratio N = V_b0/V_t0", lambda a: _f(d(a).volume_ratio)),
        row("top chamber V_t0 (L, per isolator)", lambda a: _f(d(a).top_volume_m3, scale=1e3)),
        row("bottom chamber V_b0 (L, per isolator)",
            lambda a: _f(d(a).bottom_volume_m3, scale=1e3)),
        row("total volume (L, per isolator)", lambda a: _f(d(a).total_volume_m3, scale=1e3)),
        row("capillary length L_c (mm)", lambda a: _f(d(a).capillary_length_m, scale=1e3)),
        row("capillary diameter D_c (mm)", lambda a: _f(d(a).capillary_diameter_m, scale=1e3)),
        row("piston area A_p (cm^2)", lambda a: _f(d(a).piston_area_m2, scale=1e4)),
        row("p0 absolute (bar)", lambda a: _f(d(a).pressure_pa, scale=1e-5)),
        row("p0 gauge (bar)", lambda a: _f(d(a).pressure_pa - 101325.0, scale=1e-5)),
        row("static stiffness K0 (kN/m, per isolator)",
            lambda a: _f(s(a).static_stiffness_n_per_m, scale=1e-3)),
        row("air static stiffness k_s/(N+1) (kN/m)",
            lambda a: _f(s(a).air_static_stiffness_n_per_m, scale=1e-3)),
        row("natural frequency f_n (Hz)", lambda a: _f(s(a).natural_frequency_hz)),
        row("operating stroke A* (um, per isolator)",
            lambda a: _f(a.judged.equivalent_amplitude_m, scale=1e6)),
    ]


def _band_table(cases: list[CaseAnalysis]) -> dict:
    a0 = cases[0]
    r0 = a0.all_bands
    head = ["band (Hz)", "judged", "floor (um/s)", "limit (um/s)", "limit (uin/s)"]
    for a in cases:
        pre = f"{a.case.label}: " if len(cases) > 1 else ""
        head += [f"{pre}payload (um/s)", f"{pre}margin (dB)"]
    rows = []
    for i, lab in enumerate(r0.bands.labels):
        judged = bool(a0.judged_mask[i])
        cells = [lab, "yes" if judged else "no (shown)",
                 _f(r0.floor_velocity_rms_m_s[i], scale=1e6),
                 _f(r0.limit_velocity_rms_m_s[i], scale=1e6),
                 _f(r0.limit_velocity_rms_m_s[i] * 1e6 / UM_PER_UIN)]
        classes = []
        for a in cases:
            r = a.all_bands
            m = float(r.margin_db[i])
            cells += [_f(r.payload_velocity_rms_m_s[i], scale=1e6), f"{m:+.2f}"]
            classes.append("fail" if m < 0 and judged else ("warn" if m < 0 else ""))
        rows.append({"cells": cells, "judged": judged, "classes": classes})
    return {"head": head, "rows": rows, "ncase": len(cases)}


def _stability_rows(cases: list[CaseAnalysis]) -> list[list[str]]:
    def lim(a, key, fmt="{:g}"):
        v = a.case.study.constraints.get(key)
        return fmt.format(v) if isinstance(v, int | float) and not isinstance(v, bool) else "-"

    rows = []
    for a in cases:
        s = a.judged.stability
        peak_db = db(s.excited_peak_transmissibility)
        pk_lim = a.case.study.constraints.get("max_peak_transmissibility_db")
        pk_ok = "" if not isinstance(pk_lim, int | float) or isinstance(pk_lim, bool) \
            else (" (within)" if peak_db <= pk_lim + PEAK_EXCESS_DB else " (ABOVE)")
        tm_lim = a.case.study.constraints.get("min_tilt_margin")
        tilt = "-" if s.tilt_margin is None else f"{s.tilt_margin:.3g}"
        if s.tilt_margin is not None and isinstance(tm_lim, int | float):
            tilt += " (ok)" if s.tilt_margin >= tm_lim else " (BELOW)"
        rows.append([
            a.case.label,
            f"{s.natural_frequency_hz:.4g} Hz",
            f"{lim(a, 'min_natural_frequency_hz')}-{lim(a, 'max_natural_frequency_hz')} Hz",
            tilt, lim(a, "min_tilt_margin"),
            f"{s.zener_damping_ratio:.3g} (optimum {s.zener_optimal_damping_ratio:.3g})",
            lim(a, "min_damping_ratio"),
            "-" if s.pole_damping_ratio is None else f"{s.pole_damping_ratio:.3g}",
            f"{peak_db:+.2f} dB at {_f(s.excited_peak_frequency_hz, '.3g')} Hz{pk_ok}",
            f"{db(s.peak_transmissibility):+.2f} dB",
            lim(a, "max_peak_transmissibility_db", "{:g} dB"),
        ])
    head = ["design", "f_n", "f_n limits", "tilt margin", "min tilt margin",
            "Zener damping ratio", "min damping ratio", "pole damping ratio",
            "peak |T| at A*", "peak |T| linear (1 um)", "peak |T| limit"]
    return [head, *rows]


def _harmonic_rows(cases: list[CaseAnalysis]) -> list[list[str]]:
    head = ["design", "operating amplitude (random floor)"] + [
        f"floor {x * 1e6:g} um harmonic" for x in HARMONIC_AMPLITUDES_M]
    rows = [head]
    for a in cases:
        s = a.judged.stability
        cells = [a.case.label, f"peak {db(s.excited_peak_transmissibility):+.2f} dB at "
                               f"{_f(s.excited_peak_frequency_hz, '.3g')} Hz"]
        h = a.harmonic
        for j in range(len(h.floor_amplitude_m)):
            cells.append(f"peak {db(h.peak_transmissibility[j]):+.2f} dB at "
                         f"{h.peak_frequency_hz[j]:.3g} Hz")
        rows.append(cells)
    return rows


def _optimization(a: CaseAnalysis, t: dict | None = None) -> dict | None:
    c = a.case
    rec = c.record
    if c.kind != "optimize" or rec is None:
        return None
    cons = []
    for r in rec.get("constraints", []):
        sc, unit = DISPLAY_UNITS.get(r.get("unit", ""), (1.0, r.get("unit", "")))
        bound = []
        if r.get("lower") is not None:
            bound.append(f">= {r['lower'] * sc:.5g}")
        if r.get("upper") is not None:
            bound.append(f"<= {r['upper'] * sc:.5g}")
        cons.append({"binding": bool(r.get("binding")), "cells": [
            "binding" if r.get("binding") else "", r["name"], _f(r.get("value"), ".5g", sc),
            ", ".join(bound), _f(r.get("margin"), ".3g", sc), unit,
            r.get("description", "")]})
    names = (("volume_ratio", "N", 1.0, ""), ("top_volume_m3", "V_t0", 1e3, "L"),
             ("capillary_length_m", "L_c", 1e3, "mm"), ("capillary_diameter_m", "D_c", 1e3, "mm"))
    dj = c.design_json or {}
    var = dj.get("variables", {})
    sv = []
    for key, sym, scale, unit in names:
        v = var.get(key, {})
        sv.append([f"{sym} ({unit})" if unit else sym,
                   _f(rec["start_design"].get(key), scale=scale),
                   _f(rec["design"].get(key), scale=scale),
                   f"{_f(v.get('lower'), '.3g', scale)}-{_f(v.get('upper'), '.3g', scale)}"
                   + (" (fixed)" if v.get("fixed") else ""),
                   v.get("at_bound") or ""])
    f0, f1 = dj.get("start_derived", {}), dj.get("derived", rec.get("figures", {}))
    for label, key, fmt, scale in (("worst-band margin (dB)", "worst_band_margin_db", "+.2f", 1),
                                   ("natural frequency (Hz)", "natural_frequency_hz", ".4g", 1),
                                   ("peak |T| at A* (dB)", "peak_transmissibility_db", "+.2f", 1),
                                   ("tilt margin", "tilt_margin", ".3g", 1),
                                   ("total volume (L)", "total_volume_m3", ".4g", 1e3)):
        sv.append([label, _f(f0.get(key), fmt, scale), _f(f1.get(key), fmt, scale), "", ""])
    obj = rec.get("objective", "")
    sc, unit, name, maximized = objective_display(obj)
    sense = "maximize" if maximized else "minimize"
    ofmt = "+.2f" if unit == "dB" else ".4g"
    fd = rec.get("flat_direction")
    flat = None
    if fd:
        d0, d1 = fd["capillary_diameter_range_m"]
        l0, l1 = fd["capillary_length_range_m"]
        flat = {
            "pair": fd.get("pair", ""),
            "tolerance": fd.get("objective_tolerance"),
            "d_range": f"{min(d0, d1) * 1e3:.4g}-{max(d0, d1) * 1e3:.4g} mm",
            "l_range": f"{min(l0, l1) * 1e3:.4g}-{max(l0, l1) * 1e3:.4g} mm",
            "flat": bool(fd.get("flat")),
            "tie_break": fd.get("tie_break", ""),
            "chosen": _f(fd.get("chosen_capillary_diameter_m"), ".4g", 1e3),
        }
    starts = rec.get("starts", [])
    return {
        "svg": t["optimization_svg"] if t and t.get("optimization_svg") else
        _start_vs_optimum_svg(a),
        "label": c.label,
        "objective": f"{sense} {name}: start {_f(rec.get('start_objective_value'), ofmt, sc)} "
                     f"{unit}, optimum {_f(rec.get('objective_value'), ofmt, sc)} {unit} (on the "
                     "optimizer's grid)",
        "constraints": cons,
        "start_vs_optimum": sv,
        "flat": flat,
        "starts": f"{len(starts)} starts, {sum(1 for s in starts if s.get('feasible'))} feasible, "
                  f"{rec.get('n_reached_best', '?')} reached the best design; "
                  f"{_f(rec.get('wall_s'), '.1f')} s",
        "recheck": _f(rec.get("recheck_max_rel_diff"), ".2g"),
        "notes": dj.get("notes", []),
        "limited_by": dj.get("limited_by", []),
    }


def _start_vs_optimum_svg(a: CaseAnalysis) -> str:
    """Start design against optimum (bands and |T|), as optimize's response.png."""
    c = a.case
    st = c.study
    start_design = st.design_at(c.record["start_design"])
    m = c.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"], "diaphragm": m["diaphragm"],
          "random_method": m["random_method"], "derive_pressure": False, "warn": False,
          "distortion": bool(m.get("distortion", False))}
    start = vertical_band_response(start_design, st.payload, st.floor, st.target,
                                   bands=st.bands, **kw)
    start_all = vertical_band_response(start_design, st.payload, st.floor, st.target,
                                       bands=None, **kw)
    run = SimpleNamespace(analysis=a.judged, start_analysis=start, study=st, design=c.design,
                          start_values=c.record["start_design"])
    return _svg(optimization_figure(run, start_all=start_all, optimum_all=a.all_bands))


def _pareto(a: CaseAnalysis) -> dict | None:
    c = a.case
    rec = c.record
    if c.kind != "pareto" or rec is None:
        return None
    oa, ob = rec["objectives"]
    pts = rec["points"]
    vals = np.array([[np.nan if p.get(oa) is None else p[oa],
                      np.nan if p.get(ob) is None else p[ob]] for p in pts], float)
    res = SimpleNamespace(objectives=(oa, ob), values=vals,
                          designs=tuple(p["design"] for p in pts),
                          front=np.array([bool(p.get("nondominated")) for p in pts]),
                          hypervolume=float(rec.get("hypervolume") or float("nan")),
                          binding=tuple(tuple(p.get("binding") or ()) for p in pts),
                          settings=rec.get("settings") or {})
    fig = pareto_figure(res)
    sa, ua, na, _ = objective_display(oa)
    sb, ub, nb, _ = objective_display(ob)
    rows = []
    order = np.argsort(np.where(np.isfinite(vals[:, 1]), vals[:, 1], np.inf), kind="stable")
    chosen = (c.pareto or {}).get("chosen_point")
    for i in order:
        p = pts[i]
        d = p["design"]
        ok = np.isfinite(vals[i]).all()
        passes = ""
        if oa == "worst_band_margin" and ok:
            passes = "PASS" if vals[i, 0] >= 0 else "FAIL"
        rows.append({"chosen": int(i) == chosen, "cells": [
            str(i), _f(vals[i, 0], ".4g", sa) if ok else "not solved",
            _f(vals[i, 1], ".4g", sb) if ok else "", passes,
            _f(d["volume_ratio"]), _f(d["top_volume_m3"], ".4g", 1e3),
            _f(d["capillary_length_m"], ".4g", 1e3), _f(d["capillary_diameter_m"], ".4g", 1e3),
            "yes" if p.get("nondominated") else "no", p.get("status", "")]})
    return {"label": c.label, "svg": _svg(fig),
            "head": ["#", f"{na} ({ua})", f"{nb} ({ub})", "verdict", "N", "V_t0 (L)",
                     "L_c (mm)", "D_c (mm)", "non-dominated", "solver status"],
            "rows": rows, "hypervolume": _f(rec.get("hypervolume"), ".4f"),
            "chosen": chosen}


def _flags(cases: list[CaseAnalysis]) -> dict:
    rows = []
    for a in cases:
        for where, name, n, tot, meaning in a.flags:
            rows.append([a.case.label, where, name,
                         f"{n} of {tot}" if n >= 0 else f"of {tot}", meaning])
    return {"rows": rows, "count": len(rows)}


def _provenance(cases: list[CaseAnalysis], command: list[str] | None) -> dict:
    env = environment()
    inputs = []
    for a in cases:
        c = a.case
        rec = c.record or {}
        inputs.append({
            "label": c.label, "kind": c.kind, "source": c.source,
            "run_command": " ".join(rec.get("command_line", [])) if rec else "",
            "run_date": (rec.get("environment") or {}).get("date_utc", ""),
            "run_version": rec.get("isodesign_version", ""),
            "study_toml": dumps_toml(resolved_study_dict(c.study)),
        })
    return {
        "version": __version__,
        "packages": [(k, v or "not installed") for k, v in env["packages"].items()],
        "python": env["python"], "platform": env["platform"],
        "date": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "command": " ".join(command) if command else "",
        "inputs": inputs,
    }


# ---------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------
def _figures(cases: list[CaseAnalysis]) -> dict:
    a0 = cases[0]
    st = a0.case.study
    peak = st.constraints.get("max_peak_transmissibility_db")
    peak = peak if isinstance(peak, int | float) and not isinstance(peak, bool) else None
    out = {}
    if len(cases) == 1:
        r = a0.all_bands
        fig_k = new_figure(12.0, 4.6)
        axes_k = fig_k.subplots(1, 2)
        out["bands"] = _svg(band_response_figure(
            r, judged=a0.judged_mask, peak_limit_db=peak,
            title=f"{a0.case.label}: payload {st.payload.mass_kg:g} kg on "
                  f"{st.payload.isolators} isolators, {floor_label(r.floor_name)}, "
                  f"limit {r.target_name}"))
        out["harmonic"] = _svg(harmonic_figure(a0.harmonic, peak_limit_db=peak))
        out["stiffness"] = _svg(stiffness_figure(
            [a0.stiffness], axes=axes_k,
            title=f"{a0.case.label}: complex stiffness per isolator "
                  f"({a0.case.models['flow']} flow, {a0.case.models['diaphragm']} diaphragm)"))
        return out
    entries = [(f"{a.case.label} ({a.judged.worst_margin_db:+.2f} dB, "
                f"{'PASS' if a.passes else 'FAIL'})", a.all_bands, candidate_style(i))
               for i, a in enumerate(cases)]
    out["bands"] = _svg(bands_figure(
        entries, judged=a0.judged_mask,
        title=f"payload {st.payload.mass_kg:g} kg on {st.payload.isolators} isolators; "
              f"{floor_label(a0.all_bands.floor_name)}; limit {a0.all_bands.target_name}"))
    curves = []
    for i, a in enumerate(cases):
        r = a.judged
        v = np.asarray(r.spring_diagnostics.valid).reshape(-1)
        curves.append((f"{a.case.label} at its operating stroke "
                       f"{r.equivalent_amplitude_m * 1e6:.3g} um", r.grid.frequency_hz,
                       r.transmissibility, candidate_style(i),
                       v if v.size == r.grid.frequency_hz.size else None))
    curves.append(("linear regime (1 um stroke), " + a0.case.label, a0.judged.grid.frequency_hz,
                   a0.judged.transmissibility_linear, LINEAR, None))
    out["harmonic"] = _svg(transmissibility_figure(
        curves, peak_limit_db=peak, title="transmissibility floor -> payload"))
    fig_k = new_figure(12.0, 5.4)
    out["stiffness"] = _svg(stiffness_figure(
        [a.stiffness for a in cases], labels=[a.case.label for a in cases],
        title="complex stiffness per isolator at the smallest and largest stroke amplitudes",
        axes=fig_k.subplots(1, 2), colour_by="result",
        amplitudes_m=(min(STIFFNESS_AMPLITUDES_M), max(STIFFNESS_AMPLITUDES_M))))
    return out


# ---------------------------------------------------------------------------
# the report
# ---------------------------------------------------------------------------
def build_context(analyses: list[CaseAnalysis], *, command=None, title=None) -> dict:
    """The template's variables for analysed cases (one: a design report; more: comparison).

    Parameters
    ----------
    analyses : list of CaseAnalysis
    command : sequence of str, optional
        Recorded in the provenance.
    title : str, optional

    Returns
    -------
    dict
    """
    cases = analyses
    tsec = [table_section(a.case) for a in cases]  # None for a case without a table
    jobs = [_job(a.case, a, t) for a, t in zip(cases, tsec, strict=True)]
    design_rows = _design_rows(cases)
    for j, t in enumerate(tsec):  # a table: p0 per valve, the six modes' frequencies
        if t is not None:
            cells = table_design_rows(t)
            for r in design_rows:
                if r[0] in cells:
                    r[j + 1] = cells[r[0]]
    same_job = all(j["rows"][:8] == jobs[0]["rows"][:8] for j in jobs)
    designs = [a.case.label for a in cases]
    if title is None:
        title = (f"Isolation report: {designs[0]}" if len(cases) == 1
                 else "Isolation comparison: " + ", ".join(designs))
    return {
        "title": title,
        "comparison": len(cases) > 1,
        "labels": designs,
        "verdicts": [table_verdict(a.case, t) if t is not None else _verdict(a)
                     for a, t in zip(cases, tsec, strict=True)],
        "jobs": jobs if not same_job else jobs[:1],
        "same_job": same_job,
        "design_head": ["", *designs],
        "design_rows": design_rows,
        "models": [{"label": a.case.label, "source": a.case.models_source,
                    "rows": model_caveats(a.case.models,
                                         getattr(a.case.design, "acoustics", None)),
                    "notes": list(a.case.notes)}
                   for a in cases],
        "band_table": _band_table(cases),
        "harmonic_rows": _harmonic_rows(cases),
        "stability_rows": _stability_rows(cases),
        "optimizations": [o for o in (_optimization(a, t) for a, t in
                                      zip(cases, tsec, strict=True)) if o],
        "robustness": [r for r in (robustness_section(a.case) for a in cases) if r],
        "tables": [t for t in tsec if t],
        "paretos": [p for p in (_pareto(a) for a in cases) if p],
        "flags": _flags(cases),
        "figures": _figures(cases),
        "provenance": _provenance(cases, command),
        "um_per_uin": UM_PER_UIN,
    }
