"""Airframe files: the default loads, every kind of broken file is refused with one line (and exit 2 on the CLI)."""

from __future__ import annotations

from importlib import resources

import pytest

from aircraft.airframe import AirframeError, load_airframe

DEFAULT_TEXT = resources.files("aircraft.airframes").joinpath("chen2024_tiltrotor.toml").read_text()


def test_default_airframe_has_the_papers_numbers(airframe):
    assert airframe.mass == 7.427
    assert airframe.inertia_diag == (0.844, 1.347, 1.598)
    assert airframe.wing_area == 0.44 and airframe.wing_span == 2.0 and airframe.mean_chord == 0.22
    assert (airframe.tilt_min_deg, airframe.tilt_max_deg) == (-7.0, 95.0)
    assert airframe.spin_directions == (1.0, -1.0, 1.0, -1.0)


BROKEN = {
    "not toml": ("mass = = 3", "not valid TOML"),
    "missing key": (DEFAULT_TEXT.replace('mass = { value = 7.427, source = "paper Table 1 (kg)" }\n', ""),
                    "mass_properties.mass: missing"),
    "unknown key": (DEFAULT_TEXT.replace("[environment]", "[environment]\nwind_speed = { value = 3, source = \"x\" }"),
                    "unknown key 'environment.wind_speed'"),
    "negative mass": (DEFAULT_TEXT.replace("value = 7.427", "value = -7.427"), "must be > 0"),
    "nan": (DEFAULT_TEXT.replace("value = 7.427", "value = nan"), "must be finite"),
    "string number": (DEFAULT_TEXT.replace("value = 7.427", 'value = "7.4"'), "expected a number"),
    "wrong shape": (DEFAULT_TEXT.replace("[0.844, 1.347, 1.598]", "[0.844, 1.347]"), "list of 3"),
    "no source": (DEFAULT_TEXT.replace('source = "paper Table 1 (kg)"', 'source = ""'), "needs a non-empty 'source'"),
    "bad spin": (DEFAULT_TEXT.replace("[1.0, -1.0, 1.0, -1.0]", "[1.0, -1.0, 2.0, -1.0]"), "must be +1 or -1"),
    "tilt range": (DEFAULT_TEXT.replace("value = 95.0", "value = -10.0"), "tilt_min_deg must be below"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_broken_airframe_is_refused_with_a_specific_message(tmp_path, case):
    text, expected = BROKEN[case]
    path = tmp_path / "broken.toml"
    path.write_text(text)
    with pytest.raises(AirframeError) as refusal:
        load_airframe(path)
    message = str(refusal.value)
    assert expected in message and str(path) in message and "\n" not in message


def test_missing_file_is_refused(tmp_path):
    with pytest.raises(AirframeError, match="cannot read"):
        load_airframe(tmp_path / "nope.toml")
