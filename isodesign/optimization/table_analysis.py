"""The fine-grid analysis of a table design: its band response, its modes at the closure's
springs and its rocking stability (what the table optimizer reports of its optimum and its
start, :mod:`isodesign.optimization.table_driver`)."""

from __future__ import annotations

from isodesign.table.peaks import closure_springs

__all__ = ["band_response_and_modes"]


def _analyze(study, d, values=None):
    """Fine-grid band response, modes at its closure and rocking stability of a design."""
    from isodesign.table.modes import rocking_stability

    res, modes = band_response_and_modes(study, d, values)
    return res, modes, rocking_stability(res.model)


def band_response_and_modes(study, d, values=None, models=None):
    """A design's fine-grid band response and the table's modes at its closure springs.

    Parameters
    ----------
    study : Study
        A study with a ``[table]``.
    d : Design
    values : dict, optional
        Design values setting the study's levers (``study.table_at``); None: the study's table.
    models : dict, optional
        The response models (flow, amplitude_mode, diaphragm, distortion); None: the study's.

    Returns
    -------
    (TableBandResponse, TableModes)
        The band response (warnings silenced: the caller flags validity from its
        diagnostics) and the modes with the vertical springs at the response's closure.
    """
    import warnings

    from isodesign.table.modes import table_modes
    from isodesign.table.response import table_band_response

    m = study.models if models is None else models
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = table_band_response(d, study.table_at(values), study.floor_axes, study.target,
                                  bands=study.bands, flow=m["flow"],
                                  amplitude_mode=m["amplitude_mode"],
                                  diaphragm=m["diaphragm"], warn=False,
                                  distortion=bool(m.get("distortion", False)))  # fmt: skip
    model = res.model
    modes = table_modes(model, vertical=closure_springs(model, res.stroke_rms_m,
                                                        res.closure_tube_velocity_m_s))
    return res, modes
