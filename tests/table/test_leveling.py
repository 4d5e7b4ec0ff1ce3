"""The leveling system: plant against the spring model and the 6x6 assembly, python-control's
margins against an independent frequency response, and the nonlinear valves in the time
domain against the linear loop (onset, load step, limit cycle)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.optimization.study import table_study
from isodesign.spring.equations import air_stiffness
from isodesign.table.assembly import dynamic_stiffness
from isodesign.table.layout import HorizontalElement, Table
from isodesign.table.leveling import (
    LevelingSystem,
    leveling_from_dict,
    leveling_plant,
    orifice_flux,
    simulate_leveling,
    valve_flow,
)
from isodesign.table.leveling_loop import (
    describing_function,
    leveling_loop,
    limit_cycle,
    load_step,
    step_load,
    step_metrics,
)
from isodesign.table.model import table_model


def _builtin(h):
    st = table_study()
    t = st.table
    tt = Table(mass_kg=t.mass_kg, isolators_m=t.isolators_m, cg_m=(0.0, 0.0, h),
               inertia_kg_m2=t.inertia_kg_m2, leveling_groups=t.leveling_groups,
               horizontal=t.horizontal)
    return table_model(st.start_design(), tt)


def _three(ref, h=0.5):
    t = Table(mass_kg=400.0, isolators_m=[(-0.6, -0.35), (0.6, -0.3), (0.05, 0.45)],
              cg_m=(0.05, -0.02, h), inertia_kg_m2=[60.0, 90.0, 120.0],
              horizontal=HorizontalElement(0.2, 8.0e3, 0.15, elastic_centre_height_m=0.03))
    return table_model(ref, t, flow="poiseuille")


def _independent_p(model, plant, f):
    """P(jw) (3x3, valve flows to sensor heights) from the 6x6 assembly and Eq. 38.

    Each valve's flow into its isolator's top chamber, with the table held, raises the
    chamber pressure by ``a_t (a_b + jwC) / (jw (a_b + jwC + a_t))`` per kg/s (the two
    chambers and the capillary); the table's own motion acts through each spring's
    stiffness, Eq. 38 (``air_stiffness`` of the lumped design) plus the diaphragm's.
    """
    d = plant.data
    w = 2 * math.pi * f
    kv, pblk = [], []
    for i, des in enumerate(model.designs):
        lump = des.replace(acoustics="lumped")
        ka = air_stiffness(lump, w, Cx(d["c"][i], 0.0))
        kv.append(Cx(np.array([float(np.asarray(ka.re)) + d["kd"][i]]),
                     np.array([float(np.asarray(ka.im)) + w * d["cd"][i]])))
        at, ab = d["n"][i] * d["p0"][i] / d["mt0"][i], d["n"][i] * d["p0"][i] / d["mb0"][i]
        z = ab + 1j * w * d["c"][i]
        pblk.append(at * z / (1j * w * (z + at)))
    w_ref = 2 * math.pi
    kh = [Cx(np.array([float(np.asarray(k.re).ravel()[0])]),
             np.array([w * float(np.asarray(k.im).ravel()[0]) / w_ref]))
          for k in model.horizontal_stiffness(np.array([w_ref]))]
    dd, _ = dynamic_stiffness(model.geometry, kv, kh, np.array([w]))
    dm = (np.asarray(dd.re) + 1j * np.asarray(dd.im)).reshape(6, 6)
    gz = model.geometry.gz
    cs = plant.c[:, :6]
    p = np.zeros((3, 3), complex)
    for g, i in enumerate(plant.fed):
        q = np.linalg.solve(dm, gz[i] * d["ap"][i] * pblk[i])
        p[:, g] = cs @ q
    return p


def test_margins_against_an_independent_frequency_response(ref):
    model = _three(ref)
    loop = leveling_loop(model, LevelingSystem(gain_kg_s_per_m=0.01))
    assert loop.stable
    gain = loop.gain_kg_s_per_m

    def lg(f, g):
        p = _independent_p(model, loop.plant, f)
        o = [k for k in range(3) if k != g]
        inner = np.linalg.solve(np.eye(2) + gain * p[np.ix_(o, o)], p[np.ix_(o, [g])])
        return gain * (p[g, g] - gain * (p[np.ix_([g], o)] @ inner)[0, 0])

    for g in range(3):
        f0 = loop.gain_crossover_hz[g]
        fg = brentq(lambda lf, g=g: abs(lg(math.exp(lf), g)) - 1.0, math.log(0.5 * f0),
                    math.log(2 * f0), xtol=1e-14)
        pm = 180.0 + math.degrees(np.angle(lg(math.exp(fg), g)))
        assert math.exp(fg) == pytest.approx(loop.gain_crossover_hz[g], rel=1e-6)
        assert pm == pytest.approx(loop.phase_margin_deg[g], rel=1e-6)
        assert loop.delay_margin_s[g] == pytest.approx(
            math.radians(pm) / (2 * math.pi * math.exp(fg)), rel=1e-6)
        # phase crossover: the imaginary part changes sign where the phase passes -180
        fp = brentq(lambda ff, g=g: lg(ff, g).imag, 0.98 * loop.phase_crossover_hz[g],
                    1.02 * loop.phase_crossover_hz[g], xtol=1e-14)
        gm = -20 * math.log10(abs(lg(fp, g)))
        assert fp == pytest.approx(loop.phase_crossover_hz[g], rel=1e-6)
        assert gm == pytest.approx(loop.gain_margin_db[g], rel=1e-6)


def test_sealed_plant_is_the_spring_model_and_the_assembly(ref):
    model = _three(ref)
    plant = leveling_plant(model)
    f = 0.7
    w = 2 * math.pi * f
    n = plant.n_states
    # a vertical force at the CG: the plant's body response against D(w)^-1
    x = np.linalg.solve(1j * w * np.eye(n) - plant.a, plant.e[:, 2])
    p_ind = _independent_p(model, plant, f)  # builds D(w) with Eq. 38 inside
    assert np.all(np.isfinite(p_ind))
    d = plant.data
    kv = []
    for i, des in enumerate(model.designs):
        ka = air_stiffness(des.replace(acoustics="lumped"), w, Cx(d["c"][i], 0.0))
        kv.append(Cx(np.array([float(np.asarray(ka.re)) + d["kd"][i]]),
                     np.array([float(np.asarray(ka.im)) + w * d["cd"][i]])))
    kh = [Cx(np.array([float(np.asarray(k.re).ravel()[0])]),
             np.array([w * float(np.asarray(k.im).ravel()[0]) / (2 * math.pi)]))
          for k in model.horizontal_stiffness(np.array([2 * math.pi]))]
    dd, _ = dynamic_stiffness(model.geometry, kv, kh, np.array([w]))
    q = np.linalg.solve((np.asarray(dd.re) + 1j * np.asarray(dd.im)).reshape(6, 6),
                        np.eye(6)[2])
    np.testing.assert_allclose(x[:6], q, rtol=1e-9, atol=1e-12 * np.abs(q).max())


def test_orifice_flow_law():
    kappa, r, t = 1.4, 286.9, 288.15
    r_c = (2 / 2.4) ** 3.5
    up = 7e5
    choked = float(orifice_flux(up, 1e5, kappa, r, t))
    assert float(orifice_flux(up, up * r_c, kappa, r, t)) == pytest.approx(choked, rel=1e-12)
    assert float(orifice_flux(up, up * 0.3, kappa, r, t)) == pytest.approx(choked, rel=1e-12)
    assert float(orifice_flux(up, up * 0.9, kappa, r, t)) < choked
    assert float(orifice_flux(up, up, kappa, r, t)) == 0.0
    s = LevelingSystem(gain_kg_s_per_m=0.02, dead_band_m=1e-5, saturation_flow_kg_s=1e-3)
    a_f = 1e-3 / float(orifice_flux(7e5, 3.8e5, kappa, r, t))
    a_e = 1e-3 / float(orifice_flux(3.8e5, 101325.0, kappa, r, t))
    args = (a_f, a_e, s, 3.8e5, 7e5, kappa, r, t)
    assert valve_flow(0.5e-5, *args) == 0.0 and valve_flow(-0.9e-5, *args) == 0.0
    assert valve_flow(1e-5 + 1e-3, *args) == pytest.approx(0.02 * 1e-3, rel=1e-12)
    assert valve_flow(-1e-5 - 1e-3, *args) == pytest.approx(-0.02 * 1e-3, rel=1e-12)
    assert valve_flow(1.0, *args) == pytest.approx(1e-3, rel=1e-12)  # saturated
    dfun = describing_function(np.array([0.5e-5, 1e-5 + 1e-9, 1e-3, 10.0]), s)
    assert dfun[0] == 0.0 and dfun[1] < 1e-6
    assert dfun[3] == pytest.approx(4 * 1e-3 / (math.pi * 10.0), rel=1e-4)  # the relay


def test_leveling_keys_are_validated():
    st = table_study()
    lv = leveling_from_dict({"gain_kg_s_per_m": 0.03, "sensor_positions_m": [[0, -0.4],
                            [0.6, 0.4], [-0.6, 0.4]]}, st.table, "s.toml")
    assert lv.gain_kg_s_per_m == 0.03 and lv.sensors(st.table).shape == (3, 2)
    for bad, key in (({"gain_kg_s_per_m": -1.0}, "table.leveling.gain_kg_s_per_m"),
                     ({"dead_band_m": "x"}, "table.leveling.dead_band_m"),
                     ({"fed_chamber": "side"}, "table.leveling.fed_chamber"),
                     ({"sensor_positions_m": [[0, 0]]}, "table.leveling.sensor_positions_m"),
                     ({"sensor_positions_m": [[0, 0], [9, 0], [0, 1]]},
                      "table.leveling.sensor_positions_m"),
                     ({"valve_gain": 1.0}, "valve_gain")):
        with pytest.raises(InputError, match=key):
            leveling_from_dict(bad, st.table, "s.toml")


def test_the_study_s_valves():
    from isodesign.table.leveling import leveling_of_study

    st = table_study()
    assert leveling_of_study(st) == LevelingSystem()


def test_study_file_accepts_the_leveling_table():
    from isodesign.table.study import table_from_dict

    st = table_study()
    d = dict(st.raw["table"])
    d["leveling"] = {"gain_kg_s_per_m": 0.03}
    t = table_from_dict(d, st.table.mass_kg, st.table.g_m_s2, "s.toml")
    assert t.n_isolators == 4
    d["leveling"] = {"dead_band_m": -1.0}
    with pytest.raises(InputError, match=r"^s.toml: table.leveling.dead_band_m: must be"):
        table_from_dict(d, st.table.mass_kg, st.table.g_m_s2, "s.toml")


def test_high_cg_loses_the_loop_before_the_statics():
    from isodesign.table.modes import rocking_stability

    low, high = _builtin(0.35), _builtin(0.8)
    sysm = LevelingSystem(gain_kg_s_per_m=0.02)
    lo, hi = leveling_loop(low, sysm), leveling_loop(high, sysm)
    assert lo.stable and not hi.stable
    # python-control's closed MIMO loop has the poles of A - G B C
    for lp in (lo, hi):
        ev = np.linalg.eigvals(lp.plant.closed_loop())
        assert lp.closed_loop_poles.size == ev.size
        gap = np.abs(lp.closed_loop_poles[:, None] - ev[None, :]).min(axis=1)
        assert np.all(gap <= 1e-7 * np.abs(ev).max())  # each pole matched (order-free)
    assert rocking_stability(high).stable  # statically the high table still stands
    assert hi.oscillation_frequency_hz == pytest.approx(
        abs(hi.closed_loop_poles[np.argmax(hi.closed_loop_poles.real)].imag) / (2 * math.pi),
        rel=0.2)
    assert hi.critical_gain_kg_s_per_m < 0.02 < lo.critical_gain_kg_s_per_m


def _growth_rate(sim, f_hz):
    """The envelope's growth rate (1/s) of sensor 1 between two late windows."""
    t, h = sim.time_s, sim.heights_m[:, 0]
    span = 5.0 / f_hz
    w1 = (t > t[-1] - 3 * span) & (t <= t[-1] - 2 * span)
    w2 = t > t[-1] - span
    return math.log(np.abs(h[w2]).max() / np.abs(h[w1]).max()) / (2 * span)


@pytest.mark.slow
def test_onset_of_the_leveling_oscillation_in_the_time_domain():
    """The nonlinear valves (orifice law, no dead band) decay at 0.95 G_c and grow at
    1.05 G_c, at the linear loop's rates: the onset within 5 % of the linear prediction."""
    model = _builtin(0.8)
    loop = leveling_loop(model, LevelingSystem(gain_kg_s_per_m=0.01, dead_band_m=0.0))
    g_c = loop.critical_gain_kg_s_per_m
    x0 = np.zeros(loop.plant.n_states)
    x0[3] = 1e-5
    for fac in (0.95, 1.05):
        sim = simulate_leveling(loop.plant, 80.0, x0=x0, gain_kg_s_per_m=fac * g_c,
                                samples=8000)
        sigma = _growth_rate(sim, loop.oscillation_frequency_hz)
        ev = np.linalg.eigvals(loop.plant.closed_loop(fac * g_c))
        assert np.sign(sigma) == np.sign(fac - 1.0)
        assert sigma == pytest.approx(ev.real.max(), rel=0.2)


@pytest.mark.slow
def test_load_step_against_the_nonlinear_valves():
    """A 5 kg mass placed off-centre: settling time and overshoot of the nonlinear valves
    (orifice law, 10 um dead band, saturation) within 10 % of the linear loop's."""
    model = _builtin(0.35)
    loop = leveling_loop(model, LevelingSystem(gain_kg_s_per_m=0.045, dead_band_m=10e-6,
                                               saturation_flow_kg_s=1e-3))
    pos = (0.5, 0.3, 0.7)
    lin = load_step(loop, 5.0, pos, 40.0, samples=4000)
    assert lin.overshoot_percent > 5.0  # an overshoot worth comparing
    sim = simulate_leveling(loop.plant, 40.0, force=step_load(model.table, 5.0, pos),
                            samples=4000)
    peak, t_s, over, tilt = step_metrics(sim.time_s, sim.heights_m, sim.body, 0.05)
    assert peak == pytest.approx(lin.peak_deviation_m, rel=0.1)
    assert t_s == pytest.approx(lin.settling_time_s, rel=0.1)
    assert over == pytest.approx(lin.overshoot_percent, rel=0.1)
    # the residual: every sensor within the dead band, the tilt within its bound
    assert np.all(np.abs(sim.heights_m[-1]) <= 10e-6 * 1.05)
    assert lin.residual_tilt_rad < 1e-6 and tilt <= 2 * 10e-6 / 0.8 * 1.05


@pytest.mark.slow
def test_limit_cycle_amplitude_against_the_describing_function():
    """A high-CG table whose linear loop is unstable at the valves' slope: the nonlinear
    valves (dead band, saturation, orifice law) settle on a cycle within 20 % of the
    describing function's amplitude (measured 1 %), every valve saturating."""
    model = _builtin(0.8)
    sysm = LevelingSystem(gain_kg_s_per_m=0.03, dead_band_m=20e-6, saturation_flow_kg_s=2e-5)
    loop = leveling_loop(model, sysm)
    lc = limit_cycle(loop)
    assert lc.amplitude_m is not None and lc.amplitude_ratio > 0.9
    x0 = np.zeros(loop.plant.n_states)
    x0[3] = 3e-3  # 1.2 mm at the sensors: the cycle is reached from above in ~40 s
    sim = simulate_leveling(loop.plant, 80.0, x0=x0, samples=8000)
    last = sim.time_s > 60.0
    amp = np.abs(sim.heights_m[last]).max(axis=0)
    assert amp.max() == pytest.approx(lc.amplitude_m, rel=0.2)
    assert np.abs(sim.valve_flow_kg_s[last]).max() == pytest.approx(2e-5, rel=0.01)


def test_stability_command(tmp_path, capsys):
    from importlib import resources

    from isodesign.cli import main

    out = tmp_path / "s"
    assert main(["stability", "--builtin", "table", "-o", str(out), "--plot"]) == 0
    text = capsys.readouterr().out
    assert "critical CG height 1.497 m -> stable" in text
    assert "leveling loop: valve gain 0.02 kg/s/m; closed loop stable" in text
    assert text.count("phase margin") == 3 and "delay margin" in text
    for name in ("stability.csv", "loop.csv", "loop.png", "record.json"):
        assert (out / name).is_file(), name
    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(src.replace("[table.horizontal]",
                               "[table.leveling]\ngain_kg_s_per_m = 0.0\n\n[table.horizontal]"))
    assert main(["stability", str(bad), "-o", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "table.leveling.gain_kg_s_per_m: must be a number > 0" in err
    assert len(err.strip().splitlines()) == 1


def test_the_valves_low_frequency_transmissibility():
    from isodesign.table.leveling_loop import leveling_transmissibility

    loop = leveling_loop(_builtin(0.35), LevelingSystem())
    f = np.geomspace(1e-3, 20.0, 4000)
    tv, ts = leveling_transmissibility(loop, f)
    # the table follows the floor far below the loop
    np.testing.assert_allclose(np.abs(tv[f < 0.01]), 1.0, atol=1e-4)
    r = np.abs(tv) / np.abs(ts)
    assert np.all(np.abs(r[f < 1.0] - 1.0) < 2e-3)  # docs/table.md, section 12: < 0.2 %
    # the loop's lag takes damping from the vertical resonance: its peak rises 1.6 dB
    gain_db = 20 * np.log10(np.abs(tv).max() / np.abs(ts).max())
    assert f"{gain_db:.1f}" == "1.6" and 1.5 < f[np.argmax(np.abs(tv))] < 1.7
    # in the study's bands (4 to 80 Hz, edges 3.5 to 90 Hz) the valves change |T| < 0.05 dB
    fb = np.geomspace(3.5, 90.0, 400)
    tvb, tsb = leveling_transmissibility(loop, fb)
    assert np.max(np.abs(20 * np.log10(np.abs(tvb) / np.abs(tsb)))) < 0.05
    # the sealed answer is the table model's own vertical transmissibility at low frequency
    assert abs(ts[0]) == pytest.approx(1.0, abs=1e-6)


def test_the_figures_docs_table_section_12_quotes():
    from pathlib import Path

    page = " ".join((Path(__file__).parents[2] / "docs" / "table.md").read_text(
        encoding="utf-8").split())
    lo = leveling_loop(_builtin(0.35), LevelingSystem())
    assert (f"MIMO gain margin {lo.mimo_gain_margin_db:+.1f} dB, onset at `G_c` = "
            f"{lo.critical_gain_kg_s_per_m:.3g} kg/s/m rocking at "
            f"{lo.oscillation_frequency_hz:.3g} Hz") in page
    assert f"delay margins {lo.delay_margin_s.min():.2g} to {lo.delay_margin_s.max():.2g} s" \
        in page
    step = load_step(leveling_loop(_builtin(0.35), LevelingSystem(
        gain_kg_s_per_m=0.045, dead_band_m=10e-6, saturation_flow_kg_s=1e-3)), 5.0,
        (0.5, 0.3, 0.7), 40.0, samples=4000)
    assert (f"sags {step.peak_deviation_m * 1e3:.3g} mm at the worst sensor, overshoots "
            f"{step.overshoot_percent:.2g} % and settles within 5 % of the sag in "
            f"{step.settling_time_s:.2g} s") in page
    hi = leveling_loop(_builtin(0.8), LevelingSystem(gain_kg_s_per_m=0.03, dead_band_m=20e-6,
                                                     saturation_flow_kg_s=2e-5))
    assert f"`G_c` is {hi.critical_gain_kg_s_per_m:.4g} kg/s/m" in page
    assert f"predicts {limit_cycle(hi).amplitude_m * 1e3:.3g} mm" in page
    # where the loop gives way as the CG rises (the study's figure)
    h0 = brentq(lambda h: leveling_loop(_builtin(h), LevelingSystem()).mimo_gain_margin_db,
                0.5, 0.8, xtol=1e-4)
    assert f"The leveling loop gives way at `h` = {h0:.2g} m" in page


def test_report_section_of_the_stability():
    from isodesign.table.stability_report import stability_section

    sec = stability_section(_builtin(0.35))
    assert len(sec["static_rows"]) == 2 and sec["static_rows"][0][1] == "1.497"
    assert sec["static_rows"][0][4] == "stable" and "quasi-static" in sec["static_rows"][0][0]
    assert len(sec["loop_rows"]) == 3 and sec["loop_summary"].startswith("stable")
    assert sec["loop_svg"].lstrip().startswith("<svg") or "<svg" in sec["loop_svg"][:500]
    assert "self-consistent solutions" in sec["solutions"]


def test_stability_command_on_a_table_that_tips(tmp_path, capsys):
    from importlib import resources

    from isodesign.cli import main

    src = (resources.files("isodesign") / "data" / "table_study.toml").read_text()
    src = src.replace("cg_m = [0.0, 0.0, 0.35]", "cg_m = [0.0, 0.0, 1.7]")
    src = src.replace("cg_height_m = 0.35", "cg_height_m = 1.7")
    study = tmp_path / "high.toml"
    study.write_text(src)
    assert main(["stability", str(study), "-o", str(tmp_path / "s")]) == 0
    text = capsys.readouterr().out
    verdicts = [ln for ln in text.splitlines() if "static stability" in ln]
    assert verdicts and all("-> UNSTABLE" in ln for ln in verdicts)
    assert "UNSTABLE from the smallest valve gain" in text
    assert "limit cycle (describing function): none" in text
