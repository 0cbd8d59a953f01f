"""Default ports and how `--instance I` shifts them (docs/plant-link.md, docs/mavlink.md, docs/telemetry.md). All on 127.0.0.1.

Every instance 0 .. MAX_INSTANCE has its own ports, disjoint from every other instance's (except the GCS remote
port 14550, shared on purpose): instances 0 .. 9 and 0 .. 99 keep PX4's offsets, the API remote port from instance
10 on and the zenoh endpoints from instance 100 on move to ranges of their own.
"""

from __future__ import annotations

from dataclasses import dataclass

LOOPBACK = "127.0.0.1"
MAX_SYSID = 250  # MAV_SYS_ID's range is 1 .. 250
MAX_INSTANCE = 999
API_REMOTE_SHARED_FROM = 10  # 14540 + 10 would be the GCS remote port 14550
ZENOH_SHARED_FROM = 100  # 7447 + 100 would be instance 0's autopilot endpoint


def zenoh_endpoint(port: int) -> str:
    """The zenoh endpoint of loopback TCP `port`: "tcp/127.0.0.1:PORT"."""
    return f"tcp/{LOOPBACK}:{port}"


def endpoint_port(endpoint: str) -> int:
    """The port of a zenoh endpoint "tcp/HOST:PORT" (ValueError if it has none)."""
    return int(endpoint.rsplit(":", 1)[1])


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
        """API link: where MAVSDK listens: 14540 + I for I < 10, as in PX4; 15570 + I from 10 on (PX4 sends every
        instance from 10 on to 14549, so two of them could not each have a ground station listening)."""
        return 14540 + self.instance if self.instance < API_REMOTE_SHARED_FROM else 15570 + self.instance

    @property
    def zenoh_plant(self) -> str:
        """zenoh endpoint the plant listens on: 7447 + I for I < 100, 7547 + I from 100 on."""
        return zenoh_endpoint((7447 if self.instance < ZENOH_SHARED_FROM else 7547) + self.instance)

    @property
    def zenoh_autopilot(self) -> str:
        """zenoh endpoint the autopilot listens on: 7547 + I for I < 100, 8447 + I from 100 on."""
        return zenoh_endpoint((7547 if self.instance < ZENOH_SHARED_FROM else 8447) + self.instance)
