"""``isodesign response STUDY --verify-monte-carlo SEEDS`` for a study with a [table].

The table's band response (every instrument point, x, y, z) against the six-degree-of-freedom
Monte Carlo verifier (:func:`isodesign.simulation.table_monte_carlo.simulate_table_response`):
the closure's error per band, point and axis, and each isolator's stroke RMS
(``docs/table-monte-carlo.md``).
"""

from __future__ import annotations

__all__ = ["table_monte_carlo_table", "verify_table"]


def verify_table(args, job, res, floor):
    """Simulate the study's table like ``res`` was computed; return the Monte Carlo result.

    Parameters
    ----------
    args : argparse.Namespace
        The response command's options (``verify_monte_carlo`` seeds, ``mc_duration_s``).
    job : types.SimpleNamespace
        The resolved job (its study has a table; ``job.models`` the spring models).
    res : TableBandResponse
        The closure (its bands are simulated).
    floor : TableFloor
        The floor per axis.

    Returns
    -------
    TableMonteCarloResult
    """
    from isodesign.errors import InputError
    from isodesign.simulation.table_monte_carlo import simulate_table_response

    m = job.models
    try:
        return simulate_table_response(
            job.design, job.study.table_at(None), floor, bands=res.bands,
            seeds=args.verify_monte_carlo,
            duration_s=args.mc_duration_s, flow=m["flow"], diaphragm=m["diaphragm"],
        )  # fmt: skip
    except InputError as exc:
        raise InputError(f"--verify-monte-carlo: {exc}") from None


def table_monte_carlo_table(res, mc, in_force=None) -> str:
    """The closure against the Monte Carlo verifier: dB per band, point and axis; strokes.

    Parameters
    ----------
    res : TableBandResponse
        The closure of the model the simulator integrates (the lumped acoustics).
    mc : TableMonteCarloResult
    in_force : TableBandResponse, optional
        The closure of the model in force when it is another one (the distributed
        acoustics): one more line gives their largest difference over the simulated bands.

    Returns
    -------
    str
    """
    import numpy as np

    from isodesign.simulation.table_monte_carlo import AXES

    err = mc.error_db(res.velocity_rms_m_s, res.bands)
    se = mc.standard_error_db()
    cols = [f"{p} {a}" for p in mc.point_names for a in AXES]
    width = max(7, *(len(c) for c in cols))
    lines = [
        f"Monte Carlo (6 DOF): {len(mc.seeds)} seeds x {mc.duration_s:g} s, dt = "
        f"{mc.time_step_s * 1e3:.3g} ms, flow={mc.flow}, diaphragm={mc.diaphragm}, lateral "
        f"element as a Prony series (fit error {mc.lateral_fit_error:.1%}; the closure uses the "
        f"hysteretic one unless the study gives a model) "
        f"({mc.seconds_per_realization:.2g} s per realization)",
        "  closure - simulation, dB (20 log10 of the band RMS ratio):",
        f"  {'band':>6}  " + "  ".join(f"{c:>{width}}" for c in cols),
    ]
    for j, lab in enumerate(mc.bands.labels):
        vals = err[:, :, j].reshape(-1)
        lines.append(f"  {lab:>6}  " + "  ".join(f"{v:>+{width}.2f}" for v in vals))
    worst = np.unravel_index(int(np.argmax(np.abs(err))), err.shape)
    lines.append(
        f"  worst: {mc.point_names[worst[0]]} {AXES[worst[1]]}, {mc.bands.labels[worst[2]]} Hz, "
        f"{err[worst]:+.2f} dB; largest Monte Carlo standard error {np.nanmax(se):.3f} dB"
        if len(mc.seeds) > 1 else
        f"  worst: {mc.point_names[worst[0]]} {AXES[worst[1]]}, {mc.bands.labels[worst[2]]} Hz, "
        f"{err[worst]:+.2f} dB (one seed: no standard error)"
    )
    lines.append("  isolator  stroke RMS closure (um)  simulation (um)  error")
    for i, (a, b) in enumerate(zip(res.stroke_rms_m, mc.stroke_rms_m, strict=True)):
        lines.append(f"  {i + 1:>8}  {a * 1e6:>23.4g}  {b * 1e6:>15.4g}  "
                     f"{100 * (a / b - 1):>+5.1f} %")
    if in_force is not None:  # in force minus the simulated model, on the simulated bands
        diff = mc.error_db(in_force.velocity_rms_m_s, in_force.bands) - err
        k = np.unravel_index(int(np.argmax(np.abs(diff))), diff.shape)
        lines.append(
            "  the simulator integrates the lumped acoustics (uniform chamber pressures, a slug "
            "in the tube), so the closure above is the lumped model's; the "
            f"{in_force.model.design.acoustics} acoustics in force differ from it by at most "
            f"{diff[k]:+.3f} dB ({mc.point_names[k[0]]} {AXES[k[1]]}, {mc.bands.labels[k[2]]} "
            "Hz; docs/acoustics.md)")
    return "\n".join(lines)
