"""The report's table section: a study with a ``[table]`` in six degrees of freedom."""

from __future__ import annotations

import warnings

import numpy as np

from isodesign.plotting.style import figure_svg

__all__ = ["table_section"]

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
    from isodesign.table.modes import rocking_stability, table_modes
    from isodesign.table.optimize import closure_springs
    from isodesign.table.plots import (
        layout_figure,
        table_bands_figure,
        table_transmissibility_figure,
    )
    from isodesign.table.response import table_band_response

    m = case.models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = table_band_response(case.design, st.table, st.floor_axes, st.target,
                                  bands=st.bands, flow=m["flow"],
                                  amplitude_mode=m["amplitude_mode"],
                                  diaphragm=m["diaphragm"], warn=False)  # fmt: skip
    model = res.model
    modes = table_modes(model, vertical=closure_springs(model, res.stroke_rms_m,
                                                        res.tube_velocity_rms_m_s))
    stab = rocking_stability(model)
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
                  f"{stab.margin[j]:.3g}", "stable" if stab.margin[j] > 1 else "UNSTABLE"]
                 for j, name in enumerate(("weakest", "strongest"))]
    lev = model.leveling
    lev_rows = [[str(i + 1), str(lev.group_of[i] + 1), f"{lev.load_n[i]:.1f}",
                 f"{lev.pressure_pa[i] / 1e5:.4g}", f"{res.stroke_rms_m[i] * 1e6:.3g}"]
                for i in range(lev.load_n.size)]
    p, a, b, w = res.worst
    return {
        "label": case.label,
        "passes": res.passes,
        "verdict": res.verdict(),
        "worst": f"{p}, {a} axis, {b} Hz: {w:+.2f} dB",
        "axis_margins": ", ".join(f"{ax} {v:+.2f} dB" for ax, v in
                                  zip(_AXES, res.axis_margin_db(), strict=True)),
        "notes": list(res.notes),
        "layout_svg": figure_svg(layout_figure(st.table, lev)),
        "bands_svg": figure_svg(table_bands_figure(res)),
        "transmissibility_svg": figure_svg(table_transmissibility_figure(res)),
        "band_head": head,
        "band_rows": rows,
        "mode_rows": mode_rows,
        "stability_rows": stab_rows,
        "leveling_rows": lev_rows,
    }
