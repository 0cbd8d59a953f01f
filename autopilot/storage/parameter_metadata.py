"""The component metadata of the MAVLink Component Metadata service, generated from the parameter table: the
parameter metadata file (PX4's JSON: name, type, default, min, max, units, short and long description, group,
reboot required, decimal places, the values of an enumeration) and the general metadata file that points at it, with their CRC32s (QGroundControl
caches them by CRC). Both are served by MAVLink FTP from etc/extras/, where PX4 keeps them.

Format version 1 of each file: the version QGroundControl reads (it ignores other versions) and PX4 writes; the
files validate against MAVLink's published schemas of that version.
"""

from __future__ import annotations

import json
import zlib
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from autopilot.storage.kept_file import write_atomically
from autopilot.storage.parameters import DEFINITIONS, INT32, ParameterDefinition
from autopilot.topics.software_version import PX4_VERSION_TEXT

COMP_METADATA_TYPE_PARAMETER = 1
GENERAL_NAME = "component_general.json"
PARAMETERS_NAME = "parameters.json"
EXTRAS_URI = "mftp://etc/extras/"  # the FTP path of the vehicle's etc/extras folder
VENDOR, MODEL = "tiltrotor-sitl", "tilt-rotor VTOL (Chen et al., SciTech 2024)"

# Parameter groups by name prefix, PX4's group names; the first matching prefix wins.
GROUPS = (
    ("SDLOG_", "SD Logging"), ("MAV_", "MAVLink"), ("SYS_", "System"), ("COM_", "Commander"),
    ("NAV_DLL", "Data Link Loss"), ("NAV_RCL", "Commander"), ("NAV_", "Mission"), ("MIS_", "Mission"),
    ("GF_", "Geofence"), ("RTL_", "Return Mode"), ("MPC_", "Multicopter Position Control"),
    ("VT_ARSP", "VTOL Attitude Control"), ("VT_", "Tiltrotor SITL"), ("FW_", "FW TECS"),
)  # fmt: skip


def group_of(name: str) -> str:
    return next((group for prefix, group in GROUPS if name.startswith(prefix)), "Miscellaneous")


def short_description(description: str) -> str:
    """The description's first clause (up to a colon or a parenthesis), capitalised."""
    short = description
    for mark in (": ", " ("):
        short = short.split(mark, 1)[0]
    short = short.strip() or description
    return short[0].upper() + short[1:]


def decimal_places(definition: ParameterDefinition) -> int:
    """As many decimals as the default and the range are written with (0 for integers)."""
    if definition.kind == INT32:
        return 0
    places = [max(0, -Decimal(repr(float(v))).normalize().as_tuple().exponent)
              for v in (definition.default, definition.minimum, definition.maximum)]  # fmt: skip
    return max(1, *places)


def _top_level_items(text: str) -> list[str]:
    """`text` split at the commas outside parentheses."""
    items, depth, current = [], 0, []
    for char in text:
        depth += (char == "(") - (char == ")")
        if char == "," and depth == 0:
            items.append("".join(current).strip())
            current = []
        else:
            current.append(char)
    items.append("".join(current).strip())
    return items


def enum_values(definition: ParameterDefinition) -> list[dict] | None:
    """The values an INT32 parameter's description lists after its colon ("0 Position, 1 Altitude (...), ..."), each
    with its label (remarks in parentheses left out); None unless they are every value of its range (a ground
    station offers only the values listed)."""
    if definition.kind != INT32 or definition.maximum - definition.minimum > 16 or ": " not in definition.description:
        return None
    values: dict[int, str] = {}
    for item in _top_level_items(definition.description.split(": ", 1)[1]):
        number, _, label = item.partition(" ")
        label = label.split(" (", 1)[0].strip()
        if not number.isdigit() or not label:
            break
        values[int(number)] = label
    if set(values) != set(range(int(definition.minimum), int(definition.maximum) + 1)):
        return None
    return [{"value": value, "description": values[value]} for value in sorted(values)]


def _number(definition: ParameterDefinition, value: float) -> int | float:
    return int(value) if definition.kind == INT32 else float(value)


def parameter_entry(definition: ParameterDefinition) -> dict:
    entry = {
        "name": definition.name,
        "type": "Int32" if definition.kind == INT32 else "Float",
        "default": _number(definition, definition.default),
        "min": _number(definition, definition.minimum),
        "max": _number(definition, definition.maximum),
        "shortDesc": short_description(definition.description),
        "longDesc": definition.description[0].upper() + definition.description[1:],
        "group": group_of(definition.name),
        "decimalPlaces": decimal_places(definition),
        "rebootRequired": definition.reboot_required,
    }
    if definition.unit:
        entry["units"] = definition.unit
    values = enum_values(definition)
    if values is not None:
        entry["values"] = values
    return entry


def parameter_metadata(definitions: tuple[ParameterDefinition, ...] = DEFINITIONS) -> bytes:
    """The parameter metadata file (COMP_METADATA_TYPE_PARAMETER, version 1)."""
    document = {"version": 1, "parameters": [parameter_entry(d) for d in definitions]}
    return json.dumps(document, indent=1).encode("utf-8")


def general_metadata(parameters: bytes) -> bytes:
    """The general metadata file (COMP_METADATA_TYPE_GENERAL, version 1): where the parameter metadata is, its CRC."""
    document = {
        "version": 1,
        "vendorName": VENDOR,
        "modelName": MODEL,
        "firmwareVersion": PX4_VERSION_TEXT,
        "metadataTypes": [
            {
                "type": COMP_METADATA_TYPE_PARAMETER,
                "uri": EXTRAS_URI + PARAMETERS_NAME,
                "fileCrc": zlib.crc32(parameters),
            }
        ],  # fmt: skip
    }
    return json.dumps(document, indent=1).encode("utf-8")


@dataclass(frozen=True)
class ComponentMetadata:
    """The two files and the general one's URI and CRC32 (what COMPONENT_METADATA carries)."""

    general: bytes
    parameters: bytes

    @classmethod
    def of(cls, definitions: tuple[ParameterDefinition, ...] = DEFINITIONS) -> ComponentMetadata:
        parameters = parameter_metadata(definitions)
        return cls(general_metadata(parameters), parameters)

    @property
    def general_uri(self) -> str:
        return EXTRAS_URI + GENERAL_NAME

    @property
    def general_crc(self) -> int:
        return zlib.crc32(self.general)

    def write(self, extras: Path) -> list[Path]:
        """Write both files into `extras` (the vehicle's etc/extras), atomically; their paths."""
        paths = [extras / GENERAL_NAME, extras / PARAMETERS_NAME]
        for path, content in zip(paths, (self.general, self.parameters)):
            write_atomically(path, content.decode("utf-8"))
        return paths
