"""The component metadata generated from the parameter table: valid against MAVLink's published schemas (kept in
tests/data/component_metadata with their licence), every parameter described, the general file pointing at the
parameter file with its CRC, and COMPONENT_METADATA (397) packed and parsed as MAVLink defines it."""

from __future__ import annotations

import json
import zlib
from pathlib import Path

import pytest

from autopilot.mavlink.component_metadata import METADATA, ComponentMetadataMessage
from autopilot.storage.parameter_metadata import (
    ComponentMetadata,
    decimal_places,
    enum_values,
    group_of,
    short_description,
)
from autopilot.storage.parameters import DEFINITIONS, INT32, ParameterDefinition
from transport.mavlink import Link

jsonschema = pytest.importorskip("jsonschema", reason="jsonschema is a test extra: pip install '.[test]'")
SCHEMAS = Path(__file__).parents[1] / "data" / "component_metadata"


def schema(name: str) -> dict:
    return json.loads((SCHEMAS / name).read_text())


def test_the_parameter_metadata_validates_and_covers_every_parameter():
    document = json.loads(METADATA.parameters)
    jsonschema.validate(document, schema("parameter.schema.json"))
    assert [entry["name"] for entry in document["parameters"]] == [d.name for d in DEFINITIONS]
    by_name = {entry["name"]: entry for entry in document["parameters"]}
    for definition in DEFINITIONS:
        entry = by_name[definition.name]
        assert entry["type"] == ("Int32" if definition.kind == INT32 else "Float")
        assert (entry["default"], entry["min"], entry["max"]) == (definition.default, definition.minimum,
                                                                  definition.maximum)  # fmt: skip
        assert entry["shortDesc"] and entry["longDesc"].lower() == definition.description.lower()
        assert entry.get("units", "") == definition.unit and entry["group"]
    assert by_name["SDLOG_MODE"]["rebootRequired"] is True and by_name["MPC_XY_P"]["rebootRequired"] is False
    assert by_name["RTL_RETURN_ALT"]["group"] == "Return Mode" and by_name["SDLOG_MODE"]["group"] == "SD Logging"


def test_against_the_current_schema_only_the_version_differs():
    """The schema as published now asks for format version 3, which QGroundControl does not read yet."""
    validator = jsonschema.Draft7Validator(schema("parameter.current.schema.json"))
    errors = list(validator.iter_errors(json.loads(METADATA.parameters)))
    assert [list(error.path) for error in errors] == [["version"]]


def test_the_general_metadata_points_at_the_parameter_file_with_its_crc():
    general = json.loads(METADATA.general)
    jsonschema.validate(general, schema("general.schema.json"))
    (parameters,) = general["metadataTypes"]
    assert parameters == {
        "type": 1,
        "uri": "mftp://etc/extras/parameters.json",
        "fileCrc": zlib.crc32(METADATA.parameters),
    }
    assert METADATA.general_uri == "mftp://etc/extras/component_general.json"
    assert METADATA.general_crc == zlib.crc32(METADATA.general)


def test_the_files_are_written_to_etc_extras(tmp_path):
    paths = METADATA.write(tmp_path / "etc" / "extras")
    assert [p.read_bytes() for p in paths] == [METADATA.general, METADATA.parameters]


def test_descriptions_groups_and_decimals():
    assert short_description("offboard loss failsafe: 0 Position, 1 Altitude") == "Offboard loss failsafe"
    assert (
        short_description("MAVLink system id of the vehicle (at the next start)") == "MAVLink system id of the vehicle"
    )
    assert group_of("COM_DL_LOSS_T") == "Commander" and group_of("NAV_DLL_ACT") == "Data Link Loss"
    assert group_of("XYZ") == "Miscellaneous"
    real = ParameterDefinition("X", "REAL32", 0.95, 0.0, 2.0, "", "x")
    assert decimal_places(real) == 2
    assert decimal_places(ParameterDefinition("Y", "INT32", 1, 0, 5, "", "y")) == 0
    table = ComponentMetadata.of((real,))
    assert json.loads(table.parameters)["parameters"][0]["decimalPlaces"] == 2


def test_component_metadata_is_packed_and_parsed_as_mavlink_defines_it():
    vehicle, client = Link(1, 1), Link(255, 190)
    frame = vehicle.pack(ComponentMetadataMessage(1234, METADATA.general_crc, METADATA.general_uri.encode()))
    assert frame[7:10] == (397).to_bytes(3, "little")  # MAVLink 2: the message id
    (message,) = client.parse(frame)
    assert (message.get_type(), message.time_boot_ms, message.file_crc) == ("COMPONENT_METADATA", 1234,
                                                                            METADATA.general_crc)  # fmt: skip
    assert message.uri.rstrip(b"\0") == METADATA.general_uri.encode()


def test_an_enumeration_is_listed_only_when_it_names_every_value_of_the_range():
    by_name = {d.name: d for d in DEFINITIONS}
    assert enum_values(by_name["NAV_DLL_ACT"]) == [{"value": 0, "description": "disabled"}, {"value": 1, "description": "Hold"},
                                                   {"value": 2, "description": "Return"}, {"value": 3, "description": "Land"}]  # fmt: skip
    labels = [v["description"] for v in enum_values(by_name["COM_OBL_RC_ACT"])]
    assert labels == ["Position", "Altitude", "Stabilized", "Return", "Land", "Hold"]  # remarks in parentheses left out
    assert enum_values(by_name["COM_RC_IN_MODE"]) is None  # "5-8 priorities": not every value named
    assert enum_values(by_name["NAV_RCL_ACT"]) is None  # 4 is in the range but not listed
    assert enum_values(by_name["MPC_XY_P"]) is None and enum_values(by_name["MAV_SYS_ID"]) is None
