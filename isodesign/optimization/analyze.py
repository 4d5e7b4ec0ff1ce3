"""One analysis for every study: the NumPy band response of a design, through the table.

Every study's physics is the table model (docs/table.md, section 14): a study with
``[table]`` is that table, a study without it the symmetric table of its ``[payload]``
(:func:`~isodesign.table.symmetric.study_table`). :func:`analyze` solves the closure of
either on the table model; for a study without ``[table]`` the symmetric table under its
vertical floor is z-reducible, so the closure solves the z DOF alone (exact), and the
answer is given in the vertical result type, :class:`~isodesign.response.band.BandResponse`
(:func:`~isodesign.response.random_input.band_response_at` at the table's closure state).
A payload on one or two isolators is no table (it has no rocking stiffness about their
line): its z DOF alone is the 1-DOF closure of
:func:`~isodesign.response.random_input.band_response`.
"""

from __future__ import annotations

import numpy as np

from isodesign.errors import InputError, SolverError
from isodesign.response.model import resolve_floor
from isodesign.response.random_input import band_response, band_response_at, solve_stroke_rms
from isodesign.spring.gas import P_ATM

__all__ = ["analyze", "vertical_band_response", "vertical_stroke_rms"]

#: Closure tolerance on ``ln sigma`` and iterations of the analysis (``band_response``'s).
ANALYSIS_RTOL = 1e-10
ANALYSIS_MAX_ITER = 50


def analyze(study, values: dict | None = None, scenario=None, *, bands="study",
            points_per_band: int = 50, warn: bool = False, strict: bool = True):
    """The NumPy analysis of a study's design at ``values``, through the table model.

    Parameters
    ----------
    study : Study
        Any study: with ``[table]`` (the table's answer over points, axes and bands) or
        without (its symmetric table's z DOF: the vertical answer).
    values : dict, optional
        Design-variable (and lever) values by name, SI; default the start values.
    scenario : sequence of float, optional
        A point of the study's ``[scenarios]`` (in ``study.scenarios.names`` order): the
        study under it (payload mass, temperature, ambient pressure, tolerances, CG
        offsets of a table).
    bands : Bands, (f_min_hz, f_max_hz), None or "study"
        The judged bands (default the study's); None: every band of the floor and target.
    points_per_band : int
        Trapezoid points per band.
    warn : bool
        Emit the validity flags as one warning.
    strict : bool
        Raise if the closure fails (else the linear-regime state, flagged).

    Returns
    -------
    TableBandResponse or BandResponse
        A ``[table]`` study's :class:`~isodesign.table.response.TableBandResponse`; a
        vertical study's :class:`~isodesign.response.band.BandResponse` (its symmetric
        table's z answer, to 1e-6 dB the 1-DOF's: ``tests/table/test_one_model.py``).
    """
    vals = _checked_values(study, values)
    for name, flag in (("warn", warn), ("strict", strict)):
        if not isinstance(flag, bool):
            raise InputError(f"{name}: expected True or False, got {flag!r:.40}")
    st, p_atm = _under(study, scenario)
    b = st.bands if isinstance(bands, str) and bands == "study" else bands
    if isinstance(b, tuple | list):  # (f_min_hz, f_max_hz): named as the caller typed it
        from isodesign.floor import third_octave_bands

        try:
            if len(b) != 2:
                raise InputError(f"{len(b)} numbers")
            third_octave_bands(*b)  # checked only: the response resolves them
        except InputError as exc:
            raise InputError(f"bands: expected (f_min_hz, f_max_hz) with f_min_hz < f_max_hz, "
                             f"got {bands!r:.60} ({exc})") from None
    m = st.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"], "diaphragm": m["diaphragm"],
          "random_method": m["random_method"]}
    d = st.design_at(vals)
    if study.table is not None:
        from isodesign.table.response import table_band_response

        return table_band_response(d, st.table_at(vals), st.floor_axes, st.target, bands=b,
                                   points_per_band=points_per_band, warn=warn, strict=strict,
                                   distortion=bool(m.get("distortion", False)), **kw)  # fmt: skip
    return vertical_band_response(d, st.payload, st.floor, st.target, bands=b,
                                  points_per_band=points_per_band, derive_pressure=False,
                                  warn=warn, strict=strict, p_atm_pa=p_atm,
                                  distortion=bool(m.get("distortion", False)), **kw)


def vertical_band_response(design, payload, floor, target, *, bands=None,
                           points_per_band: int = 50, flow: str = "quasi_steady",
                           amplitude_mode: str = "self_consistent", diaphragm="viscoelastic",
                           random_method: str = "statistical", derive_pressure: bool = True,
                           warn: bool = True, strict: bool = True, p_atm_pa: float = P_ATM,
                           distortion: bool = False):
    """The vertical band response of a payload, through its symmetric table.

    The payload's symmetric table (:func:`~isodesign.table.symmetric.payload_table`) is
    leveled and bound to ``design``; under the vertical floor it is z-reducible, so its
    closure is its z DOF alone (exact), and the answer is given as a
    :class:`~isodesign.response.band.BandResponse` at that closure state
    (:func:`~isodesign.response.random_input.band_response_at`). The same arguments as
    :func:`~isodesign.response.random_input.band_response`; the same answer to 1e-6 dB.
    A payload on one or two isolators (or more than a table takes) is no table, and a
    design whose own p0
    (``derive_pressure=False``) is not the payload's leveled p0 is no leveled table: both
    are the z DOF alone at that p0, :func:`~isodesign.response.random_input.band_response`.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    floor, target, bands, points_per_band, flow, amplitude_mode, diaphragm, random_method :
        As in :func:`~isodesign.response.random_input.band_response`.
    derive_pressure : bool
        p0 from the payload (Eq. 1, the leveling's) or the design's own.
    warn, strict : bool
        As in :func:`~isodesign.response.random_input.band_response`.
    p_atm_pa : float
        Ambient pressure of the leveling, Pa.
    distortion : bool
        The closure with the tubes' distortion power (``models.distortion``,
        docs/random-response.md 3a-3d): the z DOF's own
        :func:`~isodesign.response.random_input.band_response` with ``distortion=True``, at
        the design's p0 (the leveled table's z DOF, as without it).

    Returns
    -------
    BandResponse
    """
    from isodesign.spring.design import SpringDesign

    if not isinstance(design, SpringDesign):
        raise InputError(f"design: expected an isodesign SpringDesign, got "
                         f"{type(design).__name__} {design!r:.40}")
    kw = {"flow": flow, "amplitude_mode": amplitude_mode, "diaphragm": diaphragm,
          "random_method": random_method}
    if distortion:
        return band_response(design, payload, floor, target, bands=bands,
                             points_per_band=points_per_band, derive_pressure=derive_pressure,
                             warn=warn, strict=strict, distortion=True, **kw)  # fmt: skip
    if not _table_able(design, payload, derive_pressure, p_atm_pa):
        return band_response(design, payload, floor, target, bands=bands,
                             points_per_band=points_per_band, derive_pressure=derive_pressure,
                             warn=warn, strict=strict, **kw)  # fmt: skip
    try:
        sigma, sigma_u, n_it, info, grid = _z_closure(design, payload, floor, target, bands,
                                                      points_per_band, p_atm_pa, kw)
    except SolverError:
        if strict:
            raise
        # no closure: the z DOF's own flagged fallback (the linear-regime state)
        return band_response(design, payload, floor, target, bands=bands,
                             points_per_band=points_per_band, derive_pressure=derive_pressure,
                             warn=warn, strict=False, **kw)  # fmt: skip
    return band_response_at(design, payload, floor, target, sigma, sigma_u, bands=bands,
                            points_per_band=points_per_band, derive_pressure=derive_pressure,
                            iterations=n_it, closure_slope=info.get("closure_slope"),
                            warn=warn, grid=grid, linearization=info.get("linearization"),
                            **kw)


def _table_able(design, payload, derive_pressure: bool, p_atm_pa: float) -> bool:
    """The payload is a table (3 to 64 isolators) leveled at the design's p0."""
    from isodesign.response.isolator import Payload
    from isodesign.table.layout import MAX_TABLE_ISOLATORS

    if not isinstance(payload, Payload) or not 3 <= payload.isolators <= MAX_TABLE_ISOLATORS:
        return False
    if derive_pressure:
        return True
    p0 = p_atm_pa + payload.load_per_isolator_n / design.piston_area_m2
    return abs(design.pressure_pa - p0) <= 1e-9 * p0


def vertical_stroke_rms(design, payload, grid, *, flow: str = "quasi_steady",
                        amplitude_mode: str = "self_consistent", diaphragm="viscoelastic",
                        random_method: str = "equivalent_amplitude",
                        derive_pressure: bool = False, p_atm_pa: float = P_ATM,
                        rtol: float = 1e-12, max_iter: int = 50):
    """:func:`~isodesign.response.random_input.solve_stroke_rms` of a payload through its
    symmetric table: the table leveled and bound to ``design``, its closure the z DOF
    alone (exact; docs/table.md, section 14). The same arguments and answer.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
    grid : ResponseGrid
        The vertical floor's frequencies and quadrature weights.
    flow, amplitude_mode, diaphragm, random_method, derive_pressure, rtol, max_iter :
        As in :func:`~isodesign.response.random_input.solve_stroke_rms`.
    p_atm_pa : float
        Ambient pressure of the leveling, Pa (a scenario's ``ambient_pressure_pa``).

    Returns
    -------
    tuple
        ``(sigma, info)``.
    """
    if not _table_able(design, payload, derive_pressure, p_atm_pa):
        return solve_stroke_rms(design, payload, grid, flow=flow, amplitude_mode=amplitude_mode,
                                diaphragm=diaphragm, derive_pressure=derive_pressure,
                                rtol=rtol, max_iter=max_iter, random_method=random_method)
    from isodesign.table.closure import z_closure
    from isodesign.table.model import table_model
    from isodesign.table.symmetric import payload_table

    d = design.with_load(payload.mass_kg, payload.isolators, g_m_s2=payload.g_m_s2) \
        if derive_pressure else design
    model = table_model(d, payload_table(payload, piston_area_m2=d.piston_area_m2),
                        flow=flow, amplitude_mode=amplitude_mode, diaphragm=diaphragm,
                        p_atm_pa=p_atm_pa)  # fmt: skip
    sigma, _, _, info = z_closure(model, grid, random_method, rtol, max_iter, with_info=True)
    return float(sigma[0]), info


def _checked_values(study, values) -> dict:
    """``values`` checked against the study: a mapping of its design variables' and levers'
    names to finite numbers; a fixed one only at its fixed value (else the answer would be
    the fixed design's, not the one asked for)."""
    import math
    import numbers

    from isodesign.optimization.study import Study
    from isodesign.optimization.variables import LAYOUT_LEVERS, LAYOUT_PLAUSIBLE_M

    if not isinstance(study, Study):
        raise InputError(f"study: expected an isodesign Study (isodesign.load_study(path), "
                         f"table_study(), vertical_study()), got {type(study).__name__} "
                         f"{study!r:.40}")
    if values is None:
        return {v.name: v.start for v in study.variables}
    if not isinstance(values, dict):
        raise InputError(f"values: expected a dict of design-variable values by name (SI), "
                         f"got {type(values).__name__} {values!r:.40}")
    spec = {v.name: v for v in (*study.variables, *study.levers)}
    for k, v in values.items():
        if k not in spec:
            raise InputError(f"values: unknown name {k!r}; this study's design variables and "
                             f"levers: {', '.join(spec)}")
        try:
            finite = not isinstance(v, bool) and isinstance(v, numbers.Real) and \
                math.isfinite(float(v))
        except OverflowError:  # a 400-digit integer
            finite = False
        if not finite:
            raise InputError(f"values[{k!r}]: expected a finite number, got {str(v)[:40]!s}")
        if spec[k].fixed and not math.isclose(v, spec[k].start, rel_tol=1e-9, abs_tol=0.0):
            raise InputError(f"values[{k!r}] = {v:g}: variables.{k} is fixed at "
                             f"{spec[k].start:g} in this study; free it (fixed = false) or "
                             "leave it out")
        if k in LAYOUT_LEVERS and not 0 < v <= 2 * LAYOUT_PLAUSIBLE_M:
            raise InputError(f"values[{k!r}] = {v:g} m is outside the plausible extent of a "
                             f"table's isolators (0, {2 * LAYOUT_PLAUSIBLE_M:g}] m; a unit "
                             "slip? it is in m")
    return dict(values)


def _under(study, scenario):
    """The study under ``scenario`` and its ambient pressure."""
    if scenario is None:
        return study, P_ATM
    if study.scenarios is None:
        raise InputError("scenario: the study has no [scenarios]")
    sp = study.scenarios
    try:
        theta = np.asarray(scenario, dtype=float)
    except (TypeError, ValueError, OverflowError):
        theta = None
    if theta is None or isinstance(scenario, str | dict) or theta.shape != (sp.size,) or any(
            isinstance(v, str | bytes | bool) for v in np.ravel(np.asarray(scenario, object))):
        raise InputError(f"scenario: expected {sp.size} numbers ({', '.join(sp.names)}, in "
                         f"that order), got {scenario!r:.60}")
    lo, hi = sp.lower(), sp.upper()
    for name, v, a, b in zip(sp.names, theta, lo, hi, strict=True):
        if not a - 1e-12 * abs(a) <= v <= b + 1e-12 * abs(b):  # also NaN
            raise InputError(f"scenario: {name} = {v:g} is outside the study's [scenarios] "
                             f"range [{a:g}, {b:g}]")
    if study.table is not None:
        from isodesign.optimization.table_scenario import table_scenario

        return table_scenario(study, theta), P_ATM
    from isodesign.optimization.uncertainty import ScenarioStudy

    sc = ScenarioStudy(study, study.scenarios, theta)
    return sc, float(sc.theta.get("ambient_pressure_pa", P_ATM))


def _z_closure(design, payload, floor, target, bands, points_per_band, p_atm, kw):
    """The closure of a payload's symmetric table: ``(sigma, sigma_u, evaluations, info,
    z grid)`` of its isolators (one state: the table is z-reducible; ``info`` the z DOF's
    closure slope and linearization)."""
    from isodesign.table.closure import TableDescribing, solve_describing_closure, z_closure
    from isodesign.table.floor import table_floor, table_grid
    from isodesign.table.model import table_model
    from isodesign.table.symmetric import payload_table

    model = table_model(design, payload_table(payload, piston_area_m2=design.piston_area_m2),
                        flow=kw["flow"], amplitude_mode=kw["amplitude_mode"],
                        diaphragm=kw["diaphragm"], p_atm_pa=p_atm)  # fmt: skip
    if not model.z_reducible:  # the constructor's layout and leveling guarantee it
        raise SolverError("analyze: the symmetric table of the [payload] is not z-reducible")
    grid = table_grid(table_floor(resolve_floor(floor), x=False, y=False), bands,
                      target=target, points_per_band=points_per_band)
    method = kw["random_method"]
    if method == "rayleigh":  # no z-DOF closure of its own: the isolators' together
        sigma, n_it = solve_describing_closure(TableDescribing(model, grid, method),
                                               rtol=ANALYSIS_RTOL)
        return float(sigma[0]), None, n_it, {}, grid.axis_grids[2]
    # z-reducible under a vertical floor: the z DOF alone (exact)
    sigma, sigma_u, n_it, info = z_closure(model, grid, method, ANALYSIS_RTOL,
                                           ANALYSIS_MAX_ITER, with_info=True)
    su = float(sigma_u[0]) if method == "statistical" else None
    return float(sigma[0]), su, n_it, info, grid.axis_grids[2]
