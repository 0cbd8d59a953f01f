"""COMPONENT_METADATA (397), the Component Metadata service's entry point: answered to MAV_CMD_REQUEST_MESSAGE, as
PX4 answers it, with the MAVLink FTP URI and CRC32 of the general metadata file (autopilot/storage/
parameter_metadata.py), from which QGroundControl and MAVSDK find the parameter metadata.

pymavlink's generated dialect predates the message, so it is declared here from MAVLink's common.xml (its fields and
CRC extra) and registered with the dialect, which then packs and parses it like any other.
"""

from __future__ import annotations

import struct
from typing import Any

from autopilot.storage.parameter_metadata import ComponentMetadata
from autopilot.topics.vehicle_status import VehicleStatus
from transport.mavlink import mavlink as M

MAVLINK_MSG_ID_COMPONENT_METADATA = 397
URI_BYTES = 100


class ComponentMetadataMessage(M.MAVLink_message):
    id = MAVLINK_MSG_ID_COMPONENT_METADATA
    msgname = "COMPONENT_METADATA"
    fieldnames = ["time_boot_ms", "file_crc", "uri"]
    ordered_fieldnames = ["time_boot_ms", "file_crc", "uri"]
    fieldtypes = ["uint32_t", "uint32_t", "char"]
    fielddisplays_by_name: dict[str, str] = {}
    fieldenums_by_name: dict[str, str] = {}
    fieldunits_by_name: dict[str, str] = {"time_boot_ms": "ms"}
    native_format = bytearray(b"<IIc")
    orders = [0, 1, 2]
    lengths = [1, 1, 1]
    array_lengths = [0, 0, URI_BYTES]
    crc_extra = 182  # MAVLink's, from the message's fields in common.xml
    unpacker = struct.Struct("<II100s")
    instance_field = None
    instance_offset = -1

    def __init__(self, time_boot_ms: int, file_crc: int, uri: bytes) -> None:
        M.MAVLink_message.__init__(self, ComponentMetadataMessage.id, ComponentMetadataMessage.msgname)
        self._fieldnames = ComponentMetadataMessage.fieldnames
        self._instance_field = ComponentMetadataMessage.instance_field
        self._instance_offset = ComponentMetadataMessage.instance_offset
        self.time_boot_ms = time_boot_ms
        self.file_crc = file_crc
        self.uri = uri

    def pack(self, mav: Any, force_mavlink1: bool = False) -> bytes:
        return self._pack(mav, self.crc_extra, self.unpacker.pack(self.time_boot_ms, self.file_crc, self.uri),
                          force_mavlink1=force_mavlink1)  # fmt: skip


M.mavlink_map.setdefault(MAVLINK_MSG_ID_COMPONENT_METADATA, ComponentMetadataMessage)

METADATA = ComponentMetadata.of()


def component_metadata(mav: Any, status: VehicleStatus) -> ComponentMetadataMessage:
    """COMPONENT_METADATA now: the general metadata file's URI and CRC32."""
    return ComponentMetadataMessage(status.time_boot_ms, METADATA.general_crc, METADATA.general_uri.encode("ascii"))
