"""Stability figures of the isolated table: natural frequency, damping, peak |T|, tilt."""

from __future__ import annotations

from dataclasses import dataclass

from isodesign.errors import check_instance
from isodesign.response.control import (
    dominant_pole_pair,
    transfer_function_polynomials,
)
from isodesign.response.isolator import (
    Payload,
    tilt_margin,
    zener_damping_ratio,
    zener_optimum,
)
from isodesign.response.model import (
    LINEAR_REFERENCE_AMPLITUDE_M,
    TWO_PI,
    SpringModel,
    linear_natural_frequency,
    peak_of,
    spring_model,
)
from isodesign.results import ResultDisplay
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import flow_model

__all__ = [
    "StabilityFigures",
    "stability_figures",
    "stability_of_model",
]

# ---------------------------------------------------------------------------
# stability figures
# ---------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class StabilityFigures(ResultDisplay):
    """Natural frequency, damping, resonance peak and tilt margin of a loaded isolator.

    Attributes
    ----------
    natural_frequency_hz : float
        ``f_n = sqrt(K0 / (m/n)) / (2 pi)`` with ``K0 = k_s/(N+1) + Re k_D(X_ref, f_air)``
        (:func:`isodesign.response.isolator.static_stiffness`): the air spring's low-frequency limit
        plus the diaphragm's storage stiffness at the reference amplitude and at the air
        spring's own natural frequency; the optimizer's constraints use the same K0.
    static_stiffness_n_per_m : float
        ``K0`` per isolator, N/m.
    air_static_stiffness_n_per_m : float
        ``k_s/(N+1)``, N/m.
    reference_amplitude_m : float
        ``X_ref`` (:data:`LINEAR_REFERENCE_AMPLITUDE_M`).
    mass_per_isolator_kg, pressure_pa : float
        ``m/n`` and the chamber pressure p0 used.
    tilt_margin : float or None
        ``n K0 (s/2)^2 / (m g h)`` (> 1: statically stable in rocking); ``None`` without the
        payload's spacing and CG height.
    zener_damping_ratio, zener_optimal_damping_ratio : float
        ``c/(2 sqrt(k m))`` of the air spring's Zener form with ``C_u`` (diaphragm
        ignored), and the optimum ``N sqrt(2(N+2))/(4(N+1))`` for the same N.
    peak_transmissibility, peak_frequency_hz : float
        Maximum of ``|T(f)|`` at the reference amplitude, and where.
    pole_damping_ratio, pole_frequency_hz : float or None
        Damping ratio and natural frequency of the dominant (slowest-decaying) complex pole
        pair of the rational transfer function (python-control); ``None`` for models
        without one (womersley, zhao, any diaphragm but ``none``).
    excited_peak_transmissibility, excited_peak_frequency_hz : float or None
        Maximum of ``|T(f)|`` for the spring linearized at the self-consistent amplitude of
        a given excitation (:func:`band_response`); ``None`` otherwise.
    excitation_amplitude_m : float or None
        That amplitude (``A*`` of the random closure).
    flow, amplitude_mode, diaphragm : str
    """

    natural_frequency_hz: float
    static_stiffness_n_per_m: float
    air_static_stiffness_n_per_m: float
    reference_amplitude_m: float
    mass_per_isolator_kg: float
    pressure_pa: float
    tilt_margin: float | None
    zener_damping_ratio: float
    zener_optimal_damping_ratio: float
    peak_transmissibility: float
    peak_frequency_hz: float
    pole_damping_ratio: float | None
    pole_frequency_hz: float | None
    excited_peak_transmissibility: float | None = None
    excited_peak_frequency_hz: float | None = None
    excitation_amplitude_m: float | None = None
    flow: str = ""
    amplitude_mode: str = ""
    diaphragm: str = ""

    @property
    def tilt_stable(self) -> bool | None:
        """``tilt_margin > 1`` (None when not computed)."""
        return None if self.tilt_margin is None else bool(self.tilt_margin > 1.0)

    def _summary_items(self) -> list[tuple[str, str]]:
        """Natural frequency, damping, peak |T|, tilt margin (for repr and notebooks)."""
        import math

        items = [
            ("f_n", f"{self.natural_frequency_hz:.4g} Hz"),
            ("K0", f"{self.static_stiffness_n_per_m / 1e3:.4g} kN/m per isolator"),
            ("Zener damping ratio", f"{self.zener_damping_ratio:.3g} "
                                    f"(optimum {self.zener_optimal_damping_ratio:.3g})"),
            ("peak |T| linear", f"{20 * math.log10(self.peak_transmissibility):+.2f} dB at "
                                f"{self.peak_frequency_hz:.3g} Hz"),
        ]
        if self.excited_peak_transmissibility is not None:
            items.append(("peak |T| at A*",
                          f"{20 * math.log10(self.excited_peak_transmissibility):+.2f} dB"))
        if self.tilt_margin is not None:
            items.append(("tilt margin", f"{self.tilt_margin:.3g}"))
        return items

    def to_frame(self):
        """One row per figure: ``figure``, ``value``, ``unit``, ``definition``."""
        import pandas as pd

        rows = [
            ("natural_frequency_hz", self.natural_frequency_hz, "Hz",
             "sqrt(K0/(m/n))/(2 pi), K0 = k_s/(N+1) + Re k_D(X_ref, f_air)"),
            ("static_stiffness_n_per_m", self.static_stiffness_n_per_m, "N/m",
             "K0 per isolator"),
            ("air_static_stiffness_n_per_m", self.air_static_stiffness_n_per_m, "N/m",
             "k_s/(N+1)"),
            ("reference_amplitude_m", self.reference_amplitude_m, "m", "X_ref"),
            ("mass_per_isolator_kg", self.mass_per_isolator_kg, "kg", "m/n"),
            ("pressure_pa", self.pressure_pa, "Pa", "absolute chamber pressure p0"),
            ("tilt_margin", self.tilt_margin, "-",
             "n K0 (s/2)^2/(m g h); > 1 statically stable in rocking"),
            ("zener_damping_ratio", self.zener_damping_ratio, "-",
             "c/(2 sqrt(k m)), Zener form with C_u (air only)"),
            ("zener_optimal_damping_ratio", self.zener_optimal_damping_ratio, "-",
             "N sqrt(2(N+2))/(4(N+1))"),
            ("peak_transmissibility", self.peak_transmissibility, "-", "max |T| at X_ref"),
            ("peak_frequency_hz", self.peak_frequency_hz, "Hz", "frequency of max |T| at X_ref"),
            ("pole_damping_ratio", self.pole_damping_ratio, "-",
             "dominant complex pole pair of T(s) (rational models)"),
            ("pole_frequency_hz", self.pole_frequency_hz, "Hz",
             "|p|/(2 pi) of that pole pair"),
            ("excited_peak_transmissibility", self.excited_peak_transmissibility, "-",
             "max |T| at the self-consistent amplitude"),
            ("excited_peak_frequency_hz", self.excited_peak_frequency_hz, "Hz",
             "frequency of that maximum"),
            ("excitation_amplitude_m", self.excitation_amplitude_m, "m",
             "self-consistent spring amplitude A*"),
        ]  # fmt: skip
        df = pd.DataFrame(rows, columns=["figure", "value", "unit", "definition"])
        df.attrs.update(flow=self.flow, amplitude_mode=self.amplitude_mode,
                        diaphragm=self.diaphragm)  # fmt: skip
        return df


def stability_of_model(
    model: SpringModel, payload: Payload, *, excited=None, linear_coarse=None
) -> StabilityFigures:
    """Stability figures of a prepared model.

    ``excited = (t_of_f, amplitude, coarse)`` adds the excited peak; ``linear_coarse`` and
    ``coarse`` are ``(f, T)`` arrays already computed, to start the peak searches.

    Parameters
    ----------
    model : SpringModel
        The bound spring model.
    payload : Payload
        The payload (its spacing and CG height give the tilt margin).
    excited : tuple, optional
        ``(t_of_f, amplitude, coarse)``: adds the peak at an excitation amplitude.
    linear_coarse : tuple of ndarray, optional
        ``(f, T)`` of the linear transmissibility, to start the peak search.
    """
    check_instance("model", model, SpringModel, "a SpringModel (response.model.spring_model)")
    check_instance("payload", payload, Payload, "an isodesign.Payload")
    d = model.design
    x_ref = LINEAR_REFERENCE_AMPLITUDE_M
    fn, k0 = linear_natural_frequency(model, x_ref)
    tilt = None
    if payload.spacing_m is not None and payload.cg_height_m is not None:
        tilt = float(tilt_margin(k0, payload))

    def t_lin(f):
        return model.transmissibility(model.k(f, x_ref), f)

    f_pk, t_pk = peak_of(t_lin, fn, linear_coarse)
    pole_z = pole_f = None
    dia = diaphragm_model(model.diaphragm)
    if flow_model(model.flow).rational and dia.name == "none":
        import control


        num, den = transfer_function_polynomials(d, model.mass, model.flow)
        dom = dominant_pole_pair(control.TransferFunction(num, den))
        if dom is not None:
            pole_f, pole_z = dom[0] / TWO_PI, dom[1]
    ex_t = ex_f = ex_a = None
    if excited is not None:
        t_of_f, ex_a, coarse = excited
        ex_f, ex_t = peak_of(t_of_f, f_pk, coarse)
    return StabilityFigures(
        natural_frequency_hz=fn,
        static_stiffness_n_per_m=k0,
        air_static_stiffness_n_per_m=float(d.static_stiffness_n_per_m),
        reference_amplitude_m=x_ref,
        mass_per_isolator_kg=model.mass,
        pressure_pa=float(d.pressure_pa),
        tilt_margin=tilt,
        zener_damping_ratio=float(zener_damping_ratio(d, model.mass)),
        zener_optimal_damping_ratio=zener_optimum(float(d.volume_ratio))[2],
        peak_transmissibility=t_pk,
        peak_frequency_hz=f_pk,
        pole_damping_ratio=pole_z,
        pole_frequency_hz=pole_f,
        excited_peak_transmissibility=ex_t,
        excited_peak_frequency_hz=ex_f,
        excitation_amplitude_m=None if ex_a is None else float(ex_a),
        flow=model.flow,
        amplitude_mode=model.amplitude_mode,
        diaphragm=dia.name,
    )


def stability_figures(
    design,
    payload,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    derive_pressure: bool = True,
) -> StabilityFigures:
    """Natural frequency, damping ratios, linear resonance peak and tilt margin.

    Parameters
    ----------
    design : SpringDesign
    payload : Payload
        ``spacing_m`` and ``cg_height_m`` enable the tilt margin.
    flow, amplitude_mode, diaphragm : str
        Spring models.
    derive_pressure : bool

    Returns
    -------
    StabilityFigures
        Without the excitation-dependent figures (see :func:`band_response`).
    """
    model = spring_model(design, payload, flow, amplitude_mode, diaphragm, derive_pressure)
    return stability_of_model(model, payload)
