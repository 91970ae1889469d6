"""SensorSpec: validation (one line per bad field), serialisation, presets, --sensor text."""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

from analysis.camera.sensor import PRESETS, SensorSpec, sensor_spec
from analysis.camera.sensor.spec import FIELDS, NOISE_FIELDS, T2CAM_2020_NOISE_MM
from analysis.errors import ParameterError


def test_defaults_are_a_t2cam_like_window_without_noise():
    spec = SensorSpec()
    assert (spec.window_deg, spec.width_mm, spec.spacing_mm) == (40.0, 200.0, 10.0)
    assert spec.noise_free() == spec and not spec.is_ideal


@pytest.mark.parametrize(("field", "value"), [
    ("name", ""), ("window_deg", 0.0), ("window_deg", 400.0), ("window_deg", -5.0),
    ("window_deg", math.nan), ("window_deg", "40"), ("width_mm", 0.0), ("width_mm", -1.0),
    ("spacing_mm", 0.0), ("spacing_mm", math.inf), ("noise_mm", -0.1),
    ("correlated_mm", -1.0), ("correlation_mm", 0.0), ("correlation_mm", None),
    ("rotation_deg", -0.5), ("scale", -0.01), ("drop_fraction", 0.5),
    ("drop_fraction", -0.1), ("noise_mm", True),
])
def test_each_bad_field_is_refused_in_one_line_naming_it(field, value):
    with pytest.raises(ParameterError) as info:
        SensorSpec(**{field: value})
    message = str(info.value)
    assert field.split("_")[0] in message and "\n" not in message


def test_numbers_become_floats_and_round_trip_through_json():
    spec = SensorSpec(window_deg=90, noise_mm=1, width_mm=None)
    assert isinstance(spec.window_deg, float) and spec.width_mm is None
    d = json.loads(json.dumps(spec.to_dict()))
    assert list(d) == list(FIELDS)
    assert SensorSpec.from_dict(d) == spec
    assert SensorSpec.from_dict({"noise_mm": 0.5}) == SensorSpec(noise_mm=0.5)


def test_from_dict_refuses_unknown_keys_naming_the_fields():
    with pytest.raises(ParameterError, match=r"window_deg.*drop_fraction") as info:
        SensorSpec.from_dict({"window": 40.0})
    assert "window" in str(info.value)


def test_noise_free_zeroes_every_noise_field_and_nothing_else():
    spec = SensorSpec("x", 90.0, 150.0, 5.0, 1.0, 2.0, 30.0, 0.5, 0.01, 0.1)
    quiet = spec.noise_free()
    assert all(getattr(quiet, f) == 0.0 for f in NOISE_FIELDS)
    kept = set(FIELDS) - set(NOISE_FIELDS)
    assert all(getattr(quiet, f) == getattr(spec, f) for f in kept)
    assert quiet != spec and quiet.noise_free() == quiet


def test_presets():
    assert set(PRESETS) == {"t2cam-2017", "t2cam-2020", "ideal-full"}
    p17, p20, ideal = PRESETS["t2cam-2017"], PRESETS["t2cam-2020"], PRESETS["ideal-full"]
    assert (p17.window_deg, p17.width_mm, p17.spacing_mm, p17.noise_mm) == (40, 200, 10, 2.0)
    assert dataclasses.replace(p20, noise_mm=2.0, name=p17.name) == p17
    assert p20.noise_mm == T2CAM_2020_NOISE_MM == pytest.approx(0.025)
    assert ideal.is_ideal and not p17.is_ideal and not p20.is_ideal
    assert all(spec.name == name for name, spec in PRESETS.items())
    with pytest.raises(TypeError):
        PRESETS["mine"] = p17  # type: ignore[index]


@pytest.mark.parametrize(("text", "expected"), [
    ("t2cam-2017", PRESETS["t2cam-2017"]),
    (" ideal-full ", PRESETS["ideal-full"]),
    ("t2cam-2017,window_deg=90,noise_mm=0.5",
     dataclasses.replace(PRESETS["t2cam-2017"], window_deg=90.0, noise_mm=0.5,
                         name="t2cam-2017,window_deg=90,noise_mm=0.5")),
    ("window_deg=20,spacing_mm=5",
     SensorSpec("window_deg=20,spacing_mm=5", window_deg=20.0, spacing_mm=5.0)),
    ("t2cam-2020,spacing_mm=none,width_mm=None,name=mine",
     dataclasses.replace(PRESETS["t2cam-2020"], spacing_mm=None, width_mm=None, name="mine")),
])
def test_sensor_text_parses(text, expected):
    assert sensor_spec(text) == expected


@pytest.mark.parametrize(("text", "needles"), [
    ("t2cam-1999", ("t2cam-1999", "t2cam-2017", "ideal-full")),
    ("", ("preset",)),
    ("t2cam-2017,foo=1", ("foo", "window_deg", "drop_fraction")),
    ("t2cam-2017,noise", ("noise", "field=value")),
    ("window_deg=abc", ("window_deg", "abc")),
    ("window_deg=500", ("window_deg", "500")),
    ("t2cam-2017,noise_mm=none", ("noise_mm",)),
])
def test_bad_sensor_text_is_one_line_listing_what_is_allowed(text, needles):
    with pytest.raises(ParameterError) as info:
        sensor_spec(text)
    message = str(info.value)
    assert "\n" not in message
    for needle in needles:
        assert needle in message


@pytest.mark.parametrize("field", ["noise_mm", "correlated_mm", "rotation_deg", "scale",
                                   "drop_fraction"])
def test_noisy_is_any_noise_field_and_agrees_with_noise_free(field):
    spec = SensorSpec(**{field: 0.1})
    assert spec.noisy and spec.noise_free() != spec
    assert not spec.noise_free().noisy
