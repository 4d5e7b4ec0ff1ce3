"""The Gaussian distortion power against the simulated tube's own residual
(docs/random-response.md, section 3a, "Why it overshoots on 4x VC-A").

The reference spring (4 x 100 kg, no diaphragm, quasi-steady tube) on 4x VC-A is simulated
in the time domain (the product's 1-DOF Monte Carlo, random-phase floor). From the simulated
tube velocity ``u(t)`` (RMS ``s``, ``x = u/s``) it measures:

* the marginal: ``kurtosis = E x^4``, the equivalent gain ``E|x|^3`` (Gaussian ``sqrt(8/pi)``)
  and the residual's variance ``E x^4 - (E|x|^3)^2`` (per ``s^4``; Gaussian ``3 - 8/pi``);
* the residual's spectrum: the periodogram of ``e = s^2 (|x| x - E|x|^3 x)`` in the
  one-third-octave bands, against the Hermite prediction the product makes from the same
  simulated ``u``'s own spectrum (:func:`isodesign.response.distortion.normalized_convolutions`,
  orders 3 and 5), so that only the Gaussian assumption differs;
* the order-5 term's share of the payload's distortion bands (the closure run with orders 3
  and 5, and with order 3 alone);
* the closure's own first-order estimate of the tube velocity's kurtosis (on VC-A and 4x
  VC-A): ``u = u_L + u_e`` with ``u_L`` Gaussian and ``u_e`` the response to the residual,
  ``kurtosis ~ 3 + 4 E[u_L^3 u_e] / s^4 = 3 + (24 A / s) sum_f Re H_ue(f) P_3(f)`` (``A = (K
  rho/2) s^2 c_3``, ``H_ue`` the tube velocity per unit source, ``P_3`` the normalized
  spectrum of ``rho_u^3``), against the simulated kurtosis.

* the closures against the Monte Carlo (4 seeds x ``--duration`` s, VC-A and 4x VC-A): the
  plain closure, the Gaussian residual (section 3a) and the non-Gaussian distortion (section
  3c: the residual's power and the minor loss's gain at the generalized Gaussian of the
  resummed first-order kurtosis), with the kurtosis each predicts.

Usage::

    python studies/distortion_residual_check.py [--seeds 2] [--duration 160]

Prints Markdown tables.
"""

from __future__ import annotations

import argparse
import math
import warnings

import numpy as np

from isodesign.floor import FloorSpectrum
from isodesign.response import Payload, band_response
from isodesign.response import distortion as dmod
from isodesign.simulation import monte_carlo as mcm
from isodesign.spring.design import SpringDesign


def _ctx(design, payload, floor, bands, duration_s, warmup_s=20.0):
    """The context of :func:`isodesign.simulation.simulate_random_response` (no diaphragm)."""
    from isodesign.response.model import spring_model
    from isodesign.spring.diaphragm import diaphragm_model

    model = spring_model(design, payload, "quasi_steady", "self_consistent", "none", True)
    duration, warm, n, dt = mcm._timing(duration_s, warmup_s, None, bands, floor.f_max_hz,
                                        "quasi_steady")  # fmt: skip
    return {"model": model, "flow": "quasi_steady", "floor": floor, "duration": duration,
            "amplitudes": "random_phase", "norm_bands": mcm._norm_bands(floor, "random_phase"),
            "bands": bands, "n": n, "n_skip": round(warm / dt), "dt": dt,
            "dia": diaphragm_model("none"),
            "f_fit": np.geomspace(floor.f_min_hz, floor.f_max_hz, 60)}  # fmt: skip


def first_order_kurtosis(design, payload, floor):
    """The closure's first-order estimate of the tube velocity's kurtosis (module doc)."""
    from isodesign.response import random_input as ri

    model = ri.spring_model(design, payload, "quasi_steady", "self_consistent", "none", True)
    grid = ri.response_grid(floor, None, target=ri.resolve_target("VC-E"), points_per_band=50)
    st = ri._Statistical(model, grid)
    s2, su2, _ = st.variances(1e-6 / 1.880, 1e-9)
    x, y, _, _, _ = ri._statistical_closure(st, 0.5 * math.log(s2), 0.5 * math.log(su2), 1e-10,
                                            100)  # fmt: skip
    sigma, sigma_u = math.exp(x), math.exp(y)
    k, _, _, c = st.stiffness(grid.omega, sigma, sigma_u, st.c_of)
    rel = ri.relative_transmissibility(k, model.mass, grid.omega)
    lines = np.asarray(grid.stroke_weight * rel.abs2()
                       * ri.tube_velocity_gain2(model.design, grid.omega, c, model.flow))
    s = math.sqrt(float(lines.sum()))
    saved = dict(dmod._WEIGHTS)
    try:
        dmod._WEIGHTS.clear()
        dmod._WEIGHTS[3] = 1.0
        fb, p3 = dmod.normalized_convolutions(grid.frequency_hz[lines > 0],
                                              lines[lines > 0] / s**2)  # fmt: skip
    finally:
        dmod._WEIGHTS.clear()
        dmod._WEIGHTS.update(saved)
    top = fb <= dmod.DISTORTION_RANGE_FACTOR * grid.frequency_hz.max()
    fb, p3 = fb[top], p3[top]
    w = 2 * math.pi * fb
    kk, _, _, cc = st.stiffness(w, sigma, sigma_u)
    kk = kk.to_complex()
    force, u_x, u_dp, _ = dmod.source_network(model.design, w, cc.to_complex(), model.flow)
    h_ue = u_x * (-force / (kk - model.mass * w * w)) + u_dp
    a = (0.5 * model.design.minor_loss * model.design.density_kg_m3 * s * s
         * dmod.abs_square_hermite_coefficient(3))
    return 3.0 + 24.0 * a / s * float(np.sum(h_ue.real * p3))


def measure(seeds=2, duration_s=160.0):
    """The measured figures: ``(marginal dict, bands, simulated / Gaussian residual in dB per
    band, order-5 share in dB per band)``."""
    ref = SpringDesign.reference()
    payload = Payload(400.0, 4)
    vca = FloorSpectrum.from_criterion("VC-A")
    floor = FloorSpectrum.from_band_rms(vca.bands, 4.0 * vca.band_rms_velocity(), name="4x VC-A")
    bands = mcm.default_bands(floor, mcm.resolve_target("VC-E"))
    ctx = _ctx(ref, payload, floor, bands, duration_s)
    e_sim = np.zeros(len(bands))
    e_gauss = np.zeros(len(bands))
    k4 = g = r = 0.0
    for seed in range(seeds):
        u = mcm._run(ctx, seed, None)[3]
        s = float(np.sqrt(np.mean(u**2)))
        x = u / s
        gain = float(np.mean(np.abs(x) ** 3))
        k4 += float(np.mean(x**4)) / seeds
        g += gain / seeds
        r += (float(np.mean(x**4)) - gain**2) / seeds
        e = s * s * (np.abs(x) * x - gain * x)
        e_sim += mcm._band_mean_square(e, ctx["duration"], bands) / seeds
        n = u.size
        pu = 2.0 * np.abs(np.fft.rfft(u)) ** 2 / n**2
        f = np.arange(pu.size) / ctx["duration"]
        keep = (f > 0) & (pu > 1e-12 * pu.max())
        fb, pb = dmod.normalized_convolutions(f[keep], pu[keep] / s**2, 1.0 / ctx["duration"])
        edges = np.append(bands.lower_hz, bands.upper_hz[-1])
        pos = np.searchsorted(edges, fb, side="right") - 1
        ok = (pos >= 0) & (pos < len(bands))
        eg = np.zeros(len(bands))
        np.add.at(eg, pos[ok], s**4 * pb[ok])
        e_gauss += eg / seeds
    marginal = {"kurtosis": k4, "gain": g, "gain_gaussian": math.sqrt(8 / math.pi),
                "residual": r, "residual_gaussian": 3 - 8 / math.pi,
                "kurtosis_estimate": first_order_kurtosis(ref, payload, floor),
                "kurtosis_estimate_vca": first_order_kurtosis(ref, payload, vca)}
    # the generalized Gaussian at the resummed first-order kurtosis (section 3c)
    kr = dmod.resummed_kurtosis(marginal["kurtosis_estimate"])
    _, gg_gain, gg_res = dmod.generalized_gaussian_moments(kr)
    marginal.update(kurtosis_gg=kr, gain_gg=gg_gain, residual_gg=gg_res)
    # the order-5 term's share of the payload's bands: orders (3, 5) against order 3 alone
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kw = {"flow": "quasi_steady", "diaphragm": "none"}
        plain = band_response(ref, payload, floor, "VC-E", **kw)
        both = band_response(ref, payload, floor, "VC-E", distortion=True, **kw)
        saved = dict(dmod._WEIGHTS)
        try:
            dmod._WEIGHTS.pop(5)
            only3 = band_response(ref, payload, floor, "VC-E", distortion=True, **kw)
        finally:
            dmod._WEIGHTS.clear()
            dmod._WEIGHTS.update(saved)
    db = lambda a, b: 20 * np.log10(a.payload_velocity_rms_m_s / b.payload_velocity_rms_m_s)  # noqa: E731
    return (marginal, bands, 10 * np.log10(e_sim / e_gauss), db(both, plain), db(both, only3),
            both.bands)


#: The payload's cases of :func:`variants`: (name, flow, vertical diaphragm).
CASES = (("quasi-steady tube, no diaphragm", "quasi_steady", "none"),
         ("Womersley tube, no diaphragm", "womersley", "none"),
         ("quasi-steady tube, diaphragm as a Prony series at A*", "quasi_steady", "prony"))


def variants(duration_s=160.0, seeds=4):
    """Rows ``(case, floor, closure, worst band (dB, label), stroke %, tube velocity %,
    kurtosis predicted, simulated, first order)`` of the plain closure, the Gaussian residual
    and the non-Gaussian distortion against the Monte Carlo on VC-A and 4x VC-A, for each
    case of :data:`CASES` (the diaphragm fitted at the plain closure's A*, the same element
    in the closure and the simulation)."""
    import functools

    from isodesign.response import random_input as ri
    from isodesign.simulation import simulate_random_response

    ref, payload = SpringDesign.reference(), Payload(400.0, 4)
    vca = FloorSpectrum.from_criterion("VC-A")
    rows = []
    for case, flow, dia in CASES:
        for scale in (1.0, 4.0):
            floor = FloorSpectrum.from_band_rms(vca.bands, scale * vca.band_rms_velocity(),
                                                name="VC-A" if scale == 1 else "4x VC-A")
            if dia == "prony":
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    a = band_response(ref, payload, floor, "VC-E",
                                      flow=flow).equivalent_amplitude_m
                dia_m, _ = mcm.prony_diaphragm(
                    "viscoelastic", np.geomspace(floor.f_min_hz, floor.f_max_hz, 60), a)
            else:
                dia_m = dia
            kw = {"flow": flow, "diaphragm": dia_m}
            mc = simulate_random_response(ref, payload, floor, target="VC-E", seeds=seeds,
                                          duration_s=duration_s, **kw)
            for label, dist, ng in (("plain closure", False, True),
                                    ("Gaussian residual (3a)", True, False),
                                    ("non-Gaussian distortion (3c)", True, True)):
                seen = []
                orig_at, orig_dp = ri._distortion_at, dmod.distortion_power

                def spy(*args, _o=orig_at, _s=seen):
                    _s.append(_o(*args))
                    return _s[-1]

                try:
                    ri._distortion_at = spy
                    dmod.distortion_power = functools.partial(orig_dp, non_gaussian=ng)
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        r = band_response(ref, payload, floor, "VC-E", distortion=dist, **kw)
                finally:
                    ri._distortion_at, dmod.distortion_power = orig_at, orig_dp
                e = mc.error_db(r)
                i = int(np.argmax(np.abs(e)))
                kurt = seen[-1].kurtosis if seen and ng else 3.0
                rows.append((case, floor.name, label, (float(e[i]), r.bands.labels[i]),
                             100 * (r.stroke_rms_m / mc.stroke_rms_m - 1),
                             100 * (r.tube_velocity_rms_m_s / mc.tube_velocity_rms_m_s - 1),
                             kurt, mc.tube_velocity_kurtosis,
                             seen[-1].kurtosis_first_order if seen else None))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--duration", type=float, default=160.0)
    a = ap.parse_args(argv)
    print(f"Closures against the Monte Carlo (4 seeds x {a.duration:g} s, reference spring, "
          "4 x 100 kg)\n")
    print("| case | floor | closure | worst band (dB) | stroke | tube velocity | kurtosis of u: "
          "closure (first order) / MC |\n|---|---|---|---|---|---|---|")
    for case, fl, lab, (eb, bl), es, eu, kp, km, k1 in variants(a.duration):
        k1s = f" ({k1:.2f})" if k1 is not None and lab.startswith("non") else ""
        kps = f"{kp:.2f}{k1s}" if lab.startswith("non") else "3 (Gaussian)"
        print(f"| {case} | {fl} | {lab} | {eb:+.2f} ({bl} Hz) | {es:+.1f} % | {eu:+.1f} % | "
              f"{kps} / {km:.2f} |")
    print()
    marginal, bands, ratio_db, dist_db, order5_db, pbands = measure(a.seeds, a.duration)
    print("| quantity | simulated | Gaussian | generalized Gaussian at the resummed kurtosis "
          "(3c) |\n|---|---|---|---|")
    print(f"| kurtosis of u | {marginal['kurtosis']:.2f} | 3 | {marginal['kurtosis_gg']:.2f} |")
    print(f"| gain E abs(x)^3 | {marginal['gain']:.3f} | {marginal['gain_gaussian']:.3f} | "
          f"{marginal['gain_gg']:.3f} |")
    print(f"| residual variance / s^4 | {marginal['residual']:.3f} | "
          f"{marginal['residual_gaussian']:.3f} | {marginal['residual_gg']:.3f} |")
    print(f"\nThe closure's first-order kurtosis estimate: {marginal['kurtosis_estimate']:.2f} "
          f"on 4x VC-A (simulated {marginal['kurtosis']:.2f}), "
          f"{marginal['kurtosis_estimate_vca']:.2f} on VC-A.")
    print("\n| band (Hz) | simulated residual / Gaussian (dB) | distortion's change (dB) | "
          "order 5's part (dB) |\n|---|---|---|---|")
    for i, lab in enumerate(bands.labels):
        j = list(pbands.labels).index(lab) if lab in pbands.labels else None
        rise = f"{dist_db[j]:+.3f}" if j is not None else ""
        o5 = f"{order5_db[j]:+.3f}" if j is not None else ""
        print(f"| {lab} | {ratio_db[i]:+.2f} | {rise} | {o5} |")


if __name__ == "__main__":
    main()
