"""A Payload refuses what a study or design file refuses: strings, booleans, non-integer or
huge isolator counts; an overflowing payload is reported as the payload, not as a derived
pressure."""

from __future__ import annotations

import numpy as np
import pytest

from isodesign.errors import InputError
from isodesign.response import band_response
from isodesign.response.isolator import MAX_ISOLATORS, Payload, loaded_design


@pytest.mark.parametrize(("kw", "match"), [
    ({"mass_kg": "600"}, "^mass_kg: expected a number, got str"),
    ({"mass_kg": True}, "^mass_kg: expected a number, got bool"),
    ({"mass_kg": None}, "^mass_kg: expected a number"),
    ({"mass_kg": 10**400}, "^mass_kg: .*401 digits"),
    ({"mass_kg": float("nan")}, "^mass_kg: must be finite"),
    ({"mass_kg": 600, "isolators": 4.0}, r"^isolators: must be an integer in \[1, 1000\]"),
    ({"mass_kg": 600, "isolators": True}, "^isolators: "),
    ({"mass_kg": 600, "isolators": "4"}, "^isolators: "),
    ({"mass_kg": 600, "isolators": 0}, "^isolators: "),
    ({"mass_kg": 600, "isolators": 10**400}, "^isolators: .*a larger integer"),
    ({"mass_kg": 600, "spacing_m": "1.2"}, "^spacing_m: expected a number, got str"),
    ({"mass_kg": 600, "cg_height_m": False}, "^cg_height_m: expected a number, got bool"),
    ({"mass_kg": 600, "g_m_s2": "9.8"}, "^g_m_s2: expected a number"),
])
def test_payload_types(kw, match):
    with pytest.raises(InputError, match=match):
        Payload(**kw)


def test_payload_accepts_numpy_integers_and_floats():
    p = Payload(np.float64(600.0), np.int64(4))
    assert p.isolators == 4 and isinstance(p.isolators, int)
    assert Payload(600, MAX_ISOLATORS).isolators == MAX_ISOLATORS


def test_an_overflowing_payload_is_reported_as_the_payload(ref):
    heavy = Payload(1e308, 4)
    with pytest.raises(InputError, match=r"^mass_kg: ") as ei:
        loaded_design(ref, heavy)
    assert "pressure_pa" not in str(ei.value)
    with pytest.raises(InputError, match=r"^mass_kg: "):
        band_response(ref, heavy, "VC-A", "VC-E", points_per_band=4, warn=False)


@pytest.mark.parametrize("design", ["not a design", None])
def test_band_response_checks_its_design(design):
    with pytest.raises(InputError, match=r"^design: expected a SpringDesign"):
        band_response(design, Payload(600.0), "VC-A", "VC-E")
