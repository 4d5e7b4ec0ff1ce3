"""Strict types at the Python API's edge, the same as in design files: a SpringDesign and the
functions that take one refuse what a design file refuses, with an InputError naming the
parameter (never a TypeError, AttributeError or OverflowError)."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.spring.design import SpringDesign
from isodesign.spring.gas import pressure_from_load
from isodesign.spring.stiffness import complex_stiffness

FIELDS = ("volume_ratio", "top_volume_m3", "capillary_length_m", "capillary_diameter_m",
          "piston_area_m2", "pressure_pa", "temperature_k", "minor_loss", "roughness_m",
          "polytropic_index")
BAD = [("2", "str"), (True, "bool"), (False, "bool"), (None, "NoneType"), ([1.0], "list"),
       ({"v": 1}, "dict"), (1 + 2j, "complex"), (np.bool_(True), "bool")]


@pytest.mark.parametrize("field", FIELDS)
@pytest.mark.parametrize(("value", "type_name"), BAD)
def test_a_field_of_the_wrong_type_is_refused_naming_it(ref, field, value, type_name):
    if field == "polytropic_index" and value is None:
        pytest.skip("None means adiabatic")
    with pytest.raises(InputError, match=rf"^{field}: expected a number, got {type_name}"):
        ref.replace(**{field: value})


@pytest.mark.parametrize("field", FIELDS[:6])
def test_a_400_digit_integer_is_refused_naming_the_field(ref, field):
    with pytest.raises(InputError, match=rf"^{field}: .*401 digits"):
        ref.replace(**{field: 10**400})


def test_numpy_numbers_and_ints_are_numbers(ref):
    d = ref.replace(volume_ratio=np.float64(2.0), top_volume_m3=np.float32(8e-4),
                    temperature_k=np.int64(290), minor_loss=1)
    assert d.volume_ratio == 2.0 and d.temperature_k == 290.0
    assert SpringDesign(**{**ref.to_dict(), "gas": ref.gas}).volume_ratio == ref.volume_ratio


@pytest.mark.parametrize("design", ["not a design", None, 3.0, {"volume_ratio": 2}])
def test_complex_stiffness_checks_its_design(design):
    with pytest.raises(InputError, match=r"^design: expected a SpringDesign"):
        complex_stiffness(design, [1.0], [1e-4])


@pytest.mark.parametrize(("mass", "n", "match"), [
    (1e308, 4, r"^mass_kg: .*beyond floating point"),
    (10**400, 4, r"^mass_kg: .*401 digits"),
    (600.0, 10**400, r"^n_isolators: "),
    (600.0, 2.5, r"^n_isolators: "),
])
def test_pressure_from_load_names_the_payload(mass, n, match):
    with pytest.raises(InputError, match=match):
        pressure_from_load(mass, n, 5.3e-3)


@pytest.mark.parametrize("g", [-9.80665, 0.0, float("nan"), 1e300])
def test_a_bad_gravity_is_named_as_g_m_s2(g):
    # issue 14: a negative g_m_s2 was reported as pressure_pa
    from isodesign.errors import InputError
    from isodesign.spring.gas import pressure_from_load

    with pytest.raises(InputError, match=r"^g_m_s2: must be in \(0, 100\] m/s\^2"):
        SpringDesign.reference().with_load(600.0, 4, g_m_s2=g)
    with pytest.raises(InputError, match=r"^g_m_s2"):
        pressure_from_load(600.0, 4, 5.3e-3, g_m_s2=g)


@pytest.mark.parametrize(("field", "value"), [
    ("volume_ratio", 1e10), ("volume_ratio", 1e-10), ("top_volume_m3", 1e20),
    ("pressure_pa", 1e300), ("temperature_k", 1e-300), ("capillary_length_m", 1e5),
])
def test_a_design_outside_the_models_domain_is_a_range_error(field, value):
    import re

    from isodesign.domain import DESIGN_DOMAIN
    from isodesign.errors import InputError

    lo, hi, _ = DESIGN_DOMAIN[field]
    with pytest.raises(InputError, match="^" + re.escape(f"{field}: must be in [{lo:g}, {hi:g}]")):
        SpringDesign.reference().replace(**{field: value})


def test_the_corners_of_the_models_domain_give_finite_stiffness():
    import numpy as np

    from isodesign.domain import FREQUENCY_DOMAIN_HZ, MODEL_AMPLITUDE_DOMAIN_M
    from isodesign.spring.stiffness import complex_stiffness

    for change in ({}, {"volume_ratio": 1e-3}, {"volume_ratio": 1e3}, {"pressure_pa": 1e12},
                   {"temperature_k": 1.0}, {"temperature_k": 5000.0}):
        d = SpringDesign.reference().replace(**change)
        res = complex_stiffness(d, [*FREQUENCY_DOMAIN_HZ, 1.0],
                                [*MODEL_AMPLITUDE_DOMAIN_M, 1e-3], warn=False)
        assert np.isfinite(res.k).all(), change
