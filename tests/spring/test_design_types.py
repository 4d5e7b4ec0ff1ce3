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
