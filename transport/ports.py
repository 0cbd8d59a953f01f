"""Default ports and how `--instance I` shifts them (docs/plant-link.md, docs/mavlink.md, docs/telemetry.md). All on 127.0.0.1."""

from __future__ import annotations

from dataclasses import dataclass

LOOPBACK = "127.0.0.1"
MAX_SYSID = 250  # MAV_SYS_ID's range is 1 .. 250


@dataclass(frozen=True)
class Ports:
    """Every port of one vehicle instance."""

    instance: int = 0

    @property
    def plant(self) -> int:
        """Plant link: the plant binds it, the autopilot sends to it."""
        return 4560 + self.instance

    @property
    def gcs_bind(self) -> int:
        """GCS link: the autopilot binds it."""
        return 18570 + self.instance

    @property
    def gcs_remote(self) -> int:
        """GCS link: where the autopilot sends until a ground station speaks: 14550 for every instance, as in PX4's
        multi-vehicle SITL, so one ground station sees the whole fleet (the system ids tell the vehicles apart)."""
        return 14550

    @property
    def system_id(self) -> int:
        """The instance's default MAVLink system id (MAV_SYS_ID): instance + 1, as in PX4's multi-vehicle SITL, for
        instances 0 .. MAX_SYSID - 1; 1 above (a system id is at most MAX_SYSID: give those vehicles --sysid)."""
        return self.instance + 1 if self.instance < MAX_SYSID else 1

    @property
    def api_bind(self) -> int:
        """API (offboard) link: the autopilot binds it."""
        return 14580 + self.instance

    @property
    def api_remote(self) -> int:
        """API link: where MAVSDK listens."""
        return 14540 + self.instance

    @property
    def zenoh_plant(self) -> str:
        """zenoh endpoint the plant listens on."""
        return f"tcp/{LOOPBACK}:{7447 + self.instance}"

    @property
    def zenoh_autopilot(self) -> str:
        """zenoh endpoint the autopilot listens on."""
        return f"tcp/{LOOPBACK}:{7547 + self.instance}"
