"""The PX4 version this vehicle behaves like (QGroundControl and the log tools check it) and this project's own
version tag, as AUTOPILOT_VERSION, the ULog's information messages and the component metadata state them."""

from __future__ import annotations

PX4_MAJOR, PX4_MINOR, PX4_PATCH = 1, 15, 0
RELEASE_TYPE = 255  # PX4's FIRMWARE_VERSION_TYPE_OFFICIAL: a release
PX4_RELEASE = (PX4_MAJOR << 24) | (PX4_MINOR << 16) | (PX4_PATCH << 8) | RELEASE_TYPE  # 0xAABBCCTT
PX4_VERSION_TEXT = f"{PX4_MAJOR}.{PX4_MINOR}.{PX4_PATCH}"
CUSTOM_VERSION = b"trsitl01"  # this project's own (AUTOPILOT_VERSION's flight_custom_version, ULog's ver_sw)
