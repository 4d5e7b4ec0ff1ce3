"""Design files: schema, round trip, and one precise error per mistake."""

from __future__ import annotations

import math
import tomllib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from isodesign import Gas, InputError, SpringDesign, piston_area_from_diaphragm, pressure_from_load
from isodesign.io.designfile import (
    DESIGN_KEYS,
    design_from_dict,
    design_to_toml,
    load_design,
    reference_design_path,
    save_design,
)


def base() -> dict:
    """A minimal valid design dictionary."""
    return {
        "volume_ratio": 2.0,
        "top_volume_m3": 1e-3,
        "capillary_length_m": 0.02,
        "capillary_diameter_m": 1e-3,
        "piston_area_m2": 5e-3,
        "pressure_pa": 4e5,
    }


def roundtrip(design: SpringDesign) -> SpringDesign:
    return design_from_dict(tomllib.loads(design_to_toml(design)), source="rt")


# -- the shipped reference ---------------------------------------------------------------------
def test_reference_file_equals_reference_design():
    assert load_design(reference_design_path()) == SpringDesign.reference()


def test_reference_file_keeps_exact_volume_ratio_and_table1_viscosity():
    d = load_design(reference_design_path())
    assert d.volume_ratio == 1.5e-3 / 8.1e-4
    assert d.gas.viscosity_pa_s == 1.79e-5


# -- round trip --------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "design",
    [
        SpringDesign.reference(),
        SpringDesign.reference().replace(polytropic_index=1.2, roughness_m=1.5e-6),
        SpringDesign.reference().replace(gas=Gas()),
        SpringDesign.reference().replace(
            gas=Gas(
                name='nitrogen "N2" \\ test',
                gas_constant_j_per_kg_k=296.8,
                heat_capacity_ratio=1.4,
                sutherland_mu_ref_pa_s=1.663e-5,
                sutherland_t_ref_k=273.0,
                sutherland_s_k=107.0,
            )
        ),
        SpringDesign.reference().with_load(100.0, 4),
    ],
    ids=["reference", "polytropic", "sutherland", "custom-gas", "from-load"],
)
def test_toml_roundtrip_is_exact(design):
    assert roundtrip(design) == design


@settings(max_examples=60, deadline=None)
@given(
    n=st.floats(0.05, 20.0),
    v=st.floats(1e-6, 1e-1),
    length=st.floats(2e-3, 1.0),
    ratio=st.floats(1e-3, 0.5),
    area=st.floats(1e-5, 1.0),
    p=st.floats(1.02e5, 2e6),
    t=st.floats(200.0, 400.0),
    k=st.floats(0.0, 100.0),
)
def test_toml_roundtrip_property(n, v, length, ratio, area, p, t, k):
    d = SpringDesign(
        volume_ratio=n,
        top_volume_m3=v,
        capillary_length_m=length,
        capillary_diameter_m=length * ratio,
        piston_area_m2=area,
        pressure_pa=p,
        temperature_k=t,
        minor_loss=k,
    )
    assert roundtrip(d) == d


def test_save_and_load(tmp_path):
    path = save_design(SpringDesign.reference(), tmp_path / "d.toml", header="my spring\nv1")
    text = path.read_text()
    assert text.startswith("# my spring\n# v1\n")
    assert load_design(path) == SpringDesign.reference()


# -- alternatives ------------------------------------------------------------------------------
def test_piston_area_from_diaphragm_radii():
    d = base()
    del d["piston_area_m2"]
    d.update(diaphragm_r1_m=0.01, diaphragm_r2_m=0.035)
    assert design_from_dict(d).piston_area_m2 == pytest.approx(
        piston_area_from_diaphragm(0.01, 0.035)
    )


def test_pressure_from_load():
    d = base()
    del d["pressure_pa"]
    d["load"] = {"mass_kg": 400.0, "isolators": 4}
    design = design_from_dict(d)
    assert design.pressure_pa == pytest.approx(pressure_from_load(400.0, 4, 5e-3))
    assert design.load_n == pytest.approx(100.0 * 9.80665)


def test_gas_table_and_defaults():
    d = base()
    d["gas"] = {"viscosity_pa_s": 1.8e-5}
    design = design_from_dict(d)
    assert design.gas.viscosity_pa_s == 1.8e-5
    assert design.gas.gas_constant_j_per_kg_k == Gas().gas_constant_j_per_kg_k
    assert design.temperature_k == 288.15 and design.polytropic_index is None


def test_integers_are_accepted_as_numbers():
    d = base() | {"temperature_k": 293, "minor_loss": 1}
    design = design_from_dict(d)
    assert design.temperature_k == 293.0 and design.minor_loss == 1.0


# -- errors ------------------------------------------------------------------------------------
def error(d: dict, *fragments: str) -> str:
    with pytest.raises(InputError) as ei:
        design_from_dict(d, source="my.toml")
    msg = str(ei.value)
    assert msg.startswith("my.toml: "), msg
    assert "\n" not in msg
    for f in fragments:
        assert f in msg, (f, msg)
    return msg


def test_unknown_top_level_key_lists_valid_keys():
    msg = error(base() | {"volume_ration": 2.0}, "'volume_ration'", "valid keys")
    for key in DESIGN_KEYS:
        assert key in msg


def test_unknown_key_in_gas_names_table():
    error(base() | {"gas": {"visc": 1e-5}}, "'visc'", "[gas]", "viscosity_pa_s")


def test_unknown_key_in_load_names_table():
    d = base()
    del d["pressure_pa"]
    d["load"] = {"mass_kg": 10.0, "isolators": 1, "g": 9.8}
    error(d, "'g'", "[load]", "mass_kg", "isolators")


def test_missing_required_key():
    d = base()
    del d["top_volume_m3"]
    error(d, "missing", "top_volume_m3")


@pytest.mark.parametrize(
    ("key", "value", "fragment"),
    [
        ("volume_ratio", "two", "a string"),
        ("top_volume_m3", True, "a boolean"),
        ("capillary_length_m", [1.0], "an array"),
        ("pressure_pa", {"x": 1}, "a table"),
        ("temperature_k", math.nan, "finite"),
    ],
)
def test_wrong_type_names_key(key, value, fragment):
    error(base() | {key: value}, key, fragment)


@pytest.mark.parametrize(
    ("key", "value", "fragment"),
    [
        ("volume_ratio", -1.0, "> 0"),
        ("top_volume_m3", 0.0, "> 0"),
        ("piston_area_m2", -5e-3, "> 0"),
        ("pressure_pa", 9e4, "(101325, inf]"),
        ("minor_loss", 200.0, "[0, 100]"),
        ("polytropic_index", 1.6, "[1, 1.4]"),
        ("roughness_m", -1e-6, "[0, inf]"),
        ("capillary_diameter_m", 0.05, "capillary_length_m"),
    ],
)
def test_bad_value_names_key_and_range(key, value, fragment):
    error(base() | {key: value}, key, fragment)


def test_bad_gas_value_names_key():
    error(base() | {"gas": {"heat_capacity_ratio": 2.5}}, "gas.heat_capacity_ratio", "(1, 1.7]")
    error(base() | {"gas": {"name": 3}}, "gas.name", "string")
    error(base() | {"gas": 1.0}, "gas", "table")


def test_piston_area_and_radii_conflict():
    error(
        base() | {"diaphragm_r1_m": 0.01, "diaphragm_r2_m": 0.03},
        "piston_area_m2",
        "diaphragm_r1_m",
        "either",
    )


def test_single_radius_is_an_error():
    d = base()
    del d["piston_area_m2"]
    d["diaphragm_r2_m"] = 0.03
    error(d, "diaphragm_r2_m", "diaphragm_r1_m")


def test_missing_piston_area():
    d = base()
    del d["piston_area_m2"]
    error(d, "piston_area_m2")


def test_bad_radius_names_key():
    d = base()
    del d["piston_area_m2"]
    d.update(diaphragm_r1_m=-0.01, diaphragm_r2_m=0.03)
    error(d, "diaphragm_r1_m", "> 0")


def test_pressure_and_load_conflict():
    error(base() | {"load": {"mass_kg": 10.0, "isolators": 1}}, "pressure_pa", "[load]")


def test_missing_pressure():
    d = base()
    del d["pressure_pa"]
    error(d, "pressure_pa", "[load]")


@pytest.mark.parametrize(
    ("load", "fragments"),
    [
        ({"mass_kg": 10.0}, ("isolators",)),
        ({"mass_kg": -10.0, "isolators": 1}, ("load.mass_kg", "> 0")),
        ({"mass_kg": 10.0, "isolators": 2.5}, ("load.isolators", "integer in [1, 1000]")),
        ({"mass_kg": 10.0, "isolators": 0}, ("load.isolators", "integer in [1, 1000]")),
        ({"mass_kg": "ten", "isolators": 1}, ("load.mass_kg", "a string")),
    ],
)
def test_bad_load(load, fragments):
    d = base()
    del d["pressure_pa"]
    d["load"] = load
    error(d, *fragments)


def test_malformed_toml_is_input_error(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("volume_ratio = [\n")
    with pytest.raises(InputError, match=r"bad\.toml.*malformed TOML"):
        load_design(p)


def test_missing_file_is_input_error(tmp_path):
    with pytest.raises(InputError, match=r"nope\.toml"):
        load_design(tmp_path / "nope.toml")


def test_load_design_errors_name_the_file(tmp_path):
    p = tmp_path / "spring.toml"
    p.write_text("volume_ratio = 2.0\nbogus = 1\n")
    with pytest.raises(InputError, match=r"spring\.toml: unknown key 'bogus'"):
        load_design(p)


def test_design_file_diaphragm_table_is_the_recorded_diaphragm(tmp_path):
    """A [diaphragm] table is the diaphragm the commands use; given twice it is refused."""
    from isodesign.io.designfile import load_design_models, load_diaphragm

    base = reference_design_path().read_text()
    p = tmp_path / "d.toml"
    p.write_text(base + '\n[diaphragm]\nmodel = "none"\n')
    models = load_design_models(p)
    assert models["diaphragm"] == str(p)
    assert load_diaphragm(p) is not None
    both = tmp_path / "both.toml"
    both.write_text(base + '\n[models]\ndiaphragm = "none"\n\n[diaphragm]\nmodel = "none"\n')
    with pytest.raises(InputError, match="given twice"):
        load_design_models(both)
    with pytest.raises(InputError, match="given twice"):
        load_design(both)


def test_acoustic_keys_round_trip(tmp_path):
    """A design with the lumped acoustics, a chamber shape and wall heat exchange is written
    with those keys and read back the same (before, the file dropped them and the design came
    back with the distributed default)."""
    from isodesign.io.designfile import design_to_toml, load_design
    from isodesign.spring.design import SpringDesign

    d = SpringDesign.reference().replace(acoustics="lumped", chamber_aspect_ratio=2.5,
                                         chamber_heat_exchange=True)
    p = tmp_path / "d.toml"
    p.write_text(design_to_toml(d))
    text = p.read_text()
    assert 'acoustics = "lumped"' in text and "chamber_heat_exchange = true" in text
    back = load_design(p)
    assert (back.acoustics, back.chamber_aspect_ratio, back.chamber_heat_exchange) == (
        "lumped", 2.5, True)
    assert back == d
    # the defaults are not written and read back as defaults
    p.write_text(design_to_toml(SpringDesign.reference()))
    assert "acoustics" not in p.read_text()
    assert load_design(p).acoustics == "distributed"


@pytest.mark.parametrize(("line", "words"), [
    ('acoustics = "wave"', ["acoustics", "distributed, lumped"]),
    ("acoustics = 1", ["acoustics", "expected a string"]),
    ("chamber_aspect_ratio = 0", ["chamber_aspect_ratio", "0.05"]),
    ('chamber_heat_exchange = "yes"', ["chamber_heat_exchange", "true or false"]),
])
def test_acoustic_keys_bad_values_are_named(tmp_path, line, words):
    from isodesign.errors import InputError
    from isodesign.io.designfile import design_to_toml, load_design
    from isodesign.spring.design import SpringDesign

    p = tmp_path / "d.toml"
    p.write_text(line + "\n" + design_to_toml(SpringDesign.reference()))
    with pytest.raises(InputError) as exc:
        load_design(p)
    msg = str(exc.value)
    assert str(p) in msg and all(w in msg for w in words), msg
