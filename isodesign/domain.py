"""The models' numeric domain: values outside these ranges are refused, naming the input.

Every input is checked for its type, finiteness and sign where it enters. Beyond that, a
value can be finite and positive yet so far outside anything physical that the solvers
cannot give an answer (a frequency of 1e-320 Hz, an amplitude of 1e300 m, a volume ratio of
1e300): without a range they end in "did not converge" or an overflow. The ranges below are
orders of magnitude wider than any air spring of an isolation table (so no real design is
refused) and narrow enough that the numerics stay finite; an input outside one is an
:class:`~isodesign.errors.InputError` naming the parameter (the CLI: the option or key) and
the range. Implausible values inside them get a unit-slip warning instead
(:mod:`isodesign.io.plausible`). Standard library only (the CLI imports it for ``--help``).
"""

from __future__ import annotations

__all__ = [
           "AMPLITUDE_DOMAIN_M",
           "CONSTRAINT_DOMAIN",
           "DESIGN_DOMAIN",
           "FREQUENCY_DOMAIN_HZ",
           "GAS_DOMAIN",
           "LAYOUT_DOMAIN",
           "MODEL_AMPLITUDE_DOMAIN_M",
           "SAMPLE_RATE_DOMAIN_HZ",
]

#: Frequencies of the spring and response models, Hz.
FREQUENCY_DOMAIN_HZ = (1e-6, 1e6)
#: Sample rates of a survey record, Hz.
SAMPLE_RATE_DOMAIN_HZ = (1e-3, 1e7)
#: Stroke and floor displacement amplitudes a user gives (options, arguments), m.
AMPLITUDE_DOMAIN_M = (1e-30, 10.0)
#: Amplitudes the spring model accepts, m: wider than :data:`AMPLITUDE_DOMAIN_M`, for the
#: strokes the closures reach from it (a 1e-30 m floor motion at 1e-6 Hz moves the
#: spring by ~1e-43 m), still refusing what no float arithmetic can carry (1e-320).
MODEL_AMPLITUDE_DOMAIN_M = (1e-200, 1e4)
#: Fields of a spring design: (lowest, highest, unit); the pressure's lower bound is the
#: atmosphere (open: a spring must carry load).
DESIGN_DOMAIN = {
    "volume_ratio": (1e-3, 1e3, ""),
    "top_volume_m3": (1e-9, 10.0, "m^3"),
    "capillary_length_m": (1e-7, 100.0, "m"),
    "capillary_diameter_m": (1e-8, 1.0, "m"),
    "piston_area_m2": (1e-8, 100.0, "m^2"),
    "pressure_pa": (101325.0, 1e12, "Pa"),
    "temperature_k": (1.0, 5000.0, "K"),
}
#: Layout of a payload: (lowest, highest, unit).
LAYOUT_DOMAIN = {
    "spacing_m": (1e-3, 1e3, "m"),
    "cg_height_m": (1e-6, 1e3, "m"),
}
#: A study's numeric constraints: (lowest, highest, unit); ``false`` switches one off.
CONSTRAINT_DOMAIN = {
    "max_total_volume_m3": (1e-9, 1e4, "m^3"),
    "min_capillary_diameter_m": (1e-8, 1.0, "m"),
    "min_tilt_margin": (1e-6, 1e6, ""),
    "min_natural_frequency_hz": (1e-6, 1e6, "Hz"),
    "max_natural_frequency_hz": (1e-6, 1e6, "Hz"),
    "max_peak_transmissibility_db": (0.0, 200.0, "dB"),
    "min_damping_ratio": (1e-6, 100.0, ""),
    "max_mach": (1e-6, 10.0, ""),
    "max_pressure_pa": (101325.0, 1e12, "Pa"),
    "min_rocking_frequency_hz": (1e-6, 1e6, "Hz"),
    "max_rocking_frequency_hz": (1e-6, 1e6, "Hz"),
    "min_leveling_gain_margin_db": (1e-6, 100.0, "dB"),
    "min_leveling_phase_margin_deg": (1e-6, 180.0, "deg"),
    "max_stroke_m": (1e-9, 10.0, "m"),
    "min_isolator_distance_m": (1e-4, 100.0, "m"),
    "min_isolator_load_n": (1e-3, 1e8, "N"),
    "max_isolator_load_n": (1e-3, 1e8, "N"),
    "supply_margin_pa": (1.0, 1e8, "Pa"),
}
#: Fields of a gas: (lowest, highest, unit).
GAS_DOMAIN = {
    "gas_constant_j_per_kg_k": (1.0, 1e5, "J/(kg K)"),
    "viscosity_pa_s": (1e-8, 1e-2, "Pa s"),
}
