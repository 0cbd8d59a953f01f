"""Parameters (docs/mavlink.md): PX4 bytewise encoding, list/read/set over MAVLink with refusals, a parameter file that
survives a restart and is never broken by a kill -9 in the middle of a write."""

from __future__ import annotations

import json
import math
import struct

import pytest

from autopilot.storage.parameters import (
    BY_NAME,
    DEFINITIONS,
    ParameterFileError,
    ParameterRejected,
    ParameterStore,
    decode_value,
    encode_value,
)


def as_int32_bytes(value: int) -> float:
    return struct.unpack("<f", struct.pack("<i", value))[0]


def test_int32_travels_bytewise_and_real32_as_is():
    failure_en = BY_NAME["SYS_FAILURE_EN"]
    assert encode_value(failure_en, 1) == as_int32_bytes(1) != 1.0
    assert decode_value(failure_en, as_int32_bytes(1)) == 1
    assert decode_value(failure_en, 1.0) == 1065353216  # a C-cast 1.0 is not 1 in PX4's encoding
    takeoff = BY_NAME["MIS_TAKEOFF_ALT"]
    assert encode_value(takeoff, 12.5) == 12.5 and decode_value(takeoff, 12.5) == 12.5
    assert len({d.name for d in DEFINITIONS}) == len(DEFINITIONS)
    assert all(len(d.name) <= 16 for d in DEFINITIONS)


@pytest.mark.parametrize(
    "name, value, why",
    [
        ("NO_SUCH_PARAM", 1.0, "unknown"),
        ("COM_OF_LOSS_T", math.nan, "finite"),
        ("COM_OF_LOSS_T", math.inf, "finite"),
        ("SYS_FAILURE_EN", 0.5, "integer"),
        ("SYS_FAILURE_EN", 1065353216, "outside"),
        ("MIS_TAKEOFF_ALT", -5.0, "outside"),
        ("VT_ARSP_BLEND", 30.0, "below VT_ARSP_TRANS"),
    ],
)
def test_bad_values_are_refused_with_a_reason(name, value, why):
    store = ParameterStore(None)
    with pytest.raises(ParameterRejected, match=why):
        store.set(name, value)
    assert store.non_default() == {}


def test_the_file_holds_changed_values_and_is_read_back(tmp_path):
    path = tmp_path / "state" / "params.json"
    store = ParameterStore(path)
    assert store.set("MIS_TAKEOFF_ALT", 20.0) and store.set("SYS_FAILURE_EN", 1)
    assert not store.set("SYS_FAILURE_EN", 1)  # unchanged
    assert store.flush() is None
    document = json.loads(path.read_text())
    assert document["parameters"] == {"MIS_TAKEOFF_ALT": 20.0, "SYS_FAILURE_EN": 1}
    again = ParameterStore(path)
    again.load()
    assert again["MIS_TAKEOFF_ALT"] == 20.0 and again.get_int("SYS_FAILURE_EN") == 1
    assert not list(path.parent.glob(".*.tmp"))


BROKEN_FILES = {
    "not_json": "{ this is not json",
    "truncated": '{"format": "tiltrotor-sitl parameters", "version": 1, "parameters": {"MIS_TAKE',
    "wrong_format": '{"format": "something else", "version": 1, "parameters": {}}',
    "wrong_version": '{"format": "tiltrotor-sitl parameters", "version": 7, "parameters": {}}',
    "not_an_object": '{"format": "tiltrotor-sitl parameters", "version": 1, "parameters": [1, 2]}',
    "string_value": '{"format": "tiltrotor-sitl parameters", "version": 1, "parameters": {"MIS_TAKEOFF_ALT": "20"}}',
    "out_of_range": '{"format": "tiltrotor-sitl parameters", "version": 1, "parameters": {"SYS_FAILURE_EN": 7}}',
    "binary": "\x00\xff\xfe garbage",
}


@pytest.mark.parametrize("case", sorted(BROKEN_FILES))
def test_a_broken_parameter_file_is_refused(tmp_path, case):
    path = tmp_path / "params.json"
    path.write_text(BROKEN_FILES[case], encoding="latin-1")
    with pytest.raises(ParameterFileError):
        ParameterStore(path).load()
