"""Issue 4 "Done means": a real client no one here wrote. MAVSDK (`pip install mavsdk`, the 4.x native binding:
no mavsdk_server) connects on the API link, unmodified, and flies a whole flight: health and armable, parameters,
arm, takeoff, OFFBOARD velocity, the transition command, a servo failure injected and cleared, land."""

from __future__ import annotations

import time

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK-Python is a test extra: pip install '.[test]'")
if not hasattr(mavsdk, "Mavsdk"):  # 3.x is the gRPC wrapper that needs a mavsdk_server binary
    pytest.skip("needs mavsdk >= 4 (the native binding, no server binary)", allow_module_level=True)

from mavsdk import ComponentType, Configuration, LogLevel, Mavsdk, log_subscribe  # noqa: E402
from mavsdk.plugins.action import Action  # noqa: E402
from mavsdk.plugins.failure import Failure, FailureType, FailureUnit  # noqa: E402
from mavsdk.plugins.offboard import Offboard, VelocityNedYaw  # noqa: E402
from mavsdk.plugins.param import Param  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode, LandedState, Telemetry, VtolState  # noqa: E402

from tests.mavlink_sitl import start_sitl  # noqa: E402


def wait_for(predicate, what: str, timeout_s: float = 30.0, period_s: float = 0.05) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(period_s)


@pytest.fixture
def sitl(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=4.0, controller="pid",
                      ground_station=False)  # fmt: skip
    yield sitl
    sitl.kill()


def test_mavsdk_flies_the_vehicle_unmodified(sitl):
    messages: list[str] = []
    log_subscribe(lambda level, message, file, line: messages.append(message) or level < LogLevel.WARN)
    drone = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        drone.add_any_connection(f"udpin://127.0.0.1:{sitl.ports['api_remote']}")
        system = drone.first_autopilot(60.0)
        assert system is not None, "MAVSDK found no autopilot"
        telemetry, action, param, offboard = Telemetry(system), Action(system), Param(system), Offboard(system)

        wait_for(lambda: telemetry.health().is_armable and telemetry.health_all_ok(), "health and armable")
        health = telemetry.health()
        assert health.is_global_position_ok and health.is_local_position_ok and health.is_home_position_ok

        # Parameters (bytewise INT32, REAL32), through MAVSDK's own calls.
        param.set_param_int("SYS_FAILURE_EN", 1)
        assert param.get_param_int("SYS_FAILURE_EN") == 1
        action.set_takeoff_altitude(5.0)
        assert action.get_takeoff_altitude() == pytest.approx(5.0)
        param.set_param_float("MPC_TKO_SPEED", 2.5)
        assert param.get_param_float("MPC_TKO_SPEED") == pytest.approx(2.5)
        failure = Failure(system)  # after SYS_FAILURE_EN: MAVSDK reads it when the plugin starts

        action.arm()
        wait_for(telemetry.armed, "armed")
        action.takeoff()
        wait_for(lambda: telemetry.position().relative_altitude_m > 4.5, "the takeoff to 5 m")
        wait_for(lambda: telemetry.flight_mode() == FlightMode.HOLD, "Hold after the takeoff")
        wait_for(lambda: telemetry.landed_state() == LandedState.IN_AIR, "landed state IN_AIR")
        assert telemetry.in_air()
        assert telemetry.vtol_state() == VtolState.MC

        # OFFBOARD velocity: 2 m/s north.
        offboard.set_velocity_ned(VelocityNedYaw(2.0, 0.0, 0.0, 0.0))
        offboard.start()
        assert telemetry.flight_mode() in (FlightMode.OFFBOARD, FlightMode.HOLD)
        wait_for(lambda: telemetry.flight_mode() == FlightMode.OFFBOARD, "Offboard")
        wait_for(lambda: abs(telemetry.velocity_ned().north_m_s - 2.0) < 0.2, "2 m/s north", timeout_s=20)
        offboard.stop()
        wait_for(lambda: telemetry.flight_mode() == FlightMode.HOLD, "Hold after Offboard")

        # The transition command is acknowledged (Hold in FW circles; back to MC brakes to a hover).
        action.transition_to_fixedwing()
        action.transition_to_multicopter()

        # A servo failure injected and cleared.
        failure.inject(FailureUnit.SYSTEM_SERVO, FailureType.STUCK, 1)
        failure.inject(FailureUnit.SYSTEM_SERVO, FailureType.OK, 1)

        action.land()
        wait_for(lambda: not telemetry.armed(), "disarmed after landing", timeout_s=60)
        wait_for(lambda: telemetry.landed_state() == LandedState.ON_GROUND, "landed state ON_GROUND")
        assert telemetry.position().relative_altitude_m < 0.5
    finally:
        drone.destroy()
    autopilot, plant = sitl.stop()
    assert autopilot["failures_acknowledged"] == 2 and not autopilot["armed"]
    assert any("Failure injected: servo 1 STUCK" in line for line in sitl.stderr().splitlines())
    assert not [m for m in messages if "timeout" in m.lower()], messages
