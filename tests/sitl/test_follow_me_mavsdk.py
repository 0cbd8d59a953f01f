"""MAVSDK's follow_me plugin against the vehicle (docs/mavlink.md, "Follow Me"), the default controller (MPC): its
set_config writes the FLW_TGT_* parameters, start() chooses AUTO.FOLLOW_TARGET, set_target_location feeds
FOLLOW_TARGET, and the vehicle takes its place beside a standing target; stop() goes to Hold."""

from __future__ import annotations

import math

import pymap3d
import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK-Python is a test extra: pip install '.[test]'")
if not hasattr(mavsdk, "Mavsdk"):
    pytest.skip("needs mavsdk >= 4 (the native binding, no server binary)", allow_module_level=True)

from mavsdk.plugins.action import Action  # noqa: E402
from mavsdk.plugins.follow_me import Config, FollowMe, TargetLocation  # noqa: E402
from mavsdk.plugins.param import Param  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode, Telemetry  # noqa: E402

from tests.sitl.mavlink_sitl import start_sitl  # noqa: E402
from tests.sitl.mavsdk_client import mavsdk_autopilot  # noqa: E402
from tests.sitl.test_mavlink_mavsdk import wait_for  # noqa: E402
from transport.geodesy import Home  # noqa: E402

HOME = Home()


@pytest.mark.timeout(600)
def test_mavsdks_follow_me_plugin_sets_the_parameters_starts_the_mode_and_the_vehicle_takes_its_place(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=2.0, ground_station=False)
    try:
        with mavsdk_autopilot(f"udpin://127.0.0.1:{sitl.ports['api_remote']}") as system:
            telemetry, action, param, follow_me = Telemetry(system), Action(system), Param(system), FollowMe(system)
            wait_for(lambda: telemetry.health().is_armable, "armable")

            follow_me.set_config(Config(follow_height_m=10.0, follow_distance_m=5.0, responsiveness=0.2,
                                        altitude_mode=Config.FollowAltitudeMode.CONSTANT, max_tangential_vel_m_s=4.0,
                                        follow_angle_deg=90.0))  # fmt: skip
            assert [param.get_param_float(name) for name in ("FLW_TGT_HT", "FLW_TGT_DST", "FLW_TGT_RS", "FLW_TGT_FA",
                                                             "FLW_TGT_MAX_VEL")] == pytest.approx([10, 5, 0.2, 90, 4])  # fmt: skip
            assert param.get_param_int("FLW_TGT_ALT_M") == 0

            action.arm()
            follow_me.start()
            wait_for(lambda: telemetry.flight_mode() == FlightMode.FOLLOW_ME, "Follow Me")
            # A target standing 20 m north: the vehicle comes from the south and circles to FLW_TGT_FA 90, its right
            # (the course is the vehicle's bearing to it while it stands), 5 m from it at 10 m.
            lat, lon, _ = pymap3d.ned2geodetic(20.0, 0.0, 0.0, HOME.lat, HOME.lon, HOME.alt)
            target = TargetLocation(lat, lon, HOME.alt, 0.0, 0.0, 0.0)

            def in_place() -> bool:
                follow_me.set_target_location(target)
                position = telemetry.position_velocity_ned().position
                return (math.hypot(position.north_m - 20.0, position.east_m - 5.0) < 1.5
                        and abs(-position.down_m - 10.0) < 1.0)  # fmt: skip

            wait_for(in_place, "the place 5 m right of the target at 10 m", timeout_s=240, period_s=0.25)
            assert telemetry.flight_mode() == FlightMode.FOLLOW_ME and follow_me.is_active()
            follow_me.stop()
            wait_for(lambda: telemetry.flight_mode() == FlightMode.HOLD, "Hold after stop()")
    finally:
        sitl.kill()
