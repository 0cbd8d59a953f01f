"""Issue 4 "Done means": a real client no one here wrote. MAVSDK (`pip install mavsdk`, the 4.x native binding:
no mavsdk_server) connects on the API link, unmodified, and flies a whole flight: health and armable, parameters,
arm, takeoff, OFFBOARD velocity, the transition commands (to FW and back to MC, seen in the VTOL state), a servo
failure injected and cleared, land."""

from __future__ import annotations

import math
import time

import pytest

# 3.x is the gRPC wrapper that needs a mavsdk_server binary; 4 is the native binding.
pytest.importorskip("mavsdk", minversion="4", reason="MAVSDK-Python 4 is a test extra: pip install '.[test]'")

from mavsdk import LogLevel, log_subscribe  # noqa: E402
from mavsdk.plugins.action import Action  # noqa: E402
from mavsdk.plugins.failure import Failure, FailureType, FailureUnit  # noqa: E402
from mavsdk.plugins.offboard import Offboard, VelocityNedYaw  # noqa: E402
from mavsdk.plugins.param import Param  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode, LandedState, Telemetry, VtolState  # noqa: E402

from tests.sitl.mavlink_sitl import start_sitl  # noqa: E402
from tests.sitl.mavsdk_client import mavsdk_autopilot  # noqa: E402


def wait_for(predicate, what: str, timeout_s: float = 30.0, period_s: float = 0.05) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(period_s)


def watch(value, until, what: str, timeout_s: float = 30.0, period_s: float = 0.05, also=None) -> list:
    """Poll value() until until(value) holds; the values seen, each change once, in order. `also` runs at each
    poll (e.g. to sample other telemetry on the way)."""
    seen: list = []
    deadline = time.monotonic() + timeout_s
    while True:
        current = value()
        if not seen or seen[-1] != current:
            seen.append(current)
        if also is not None:
            also()
        if until(current):
            return seen
        assert time.monotonic() < deadline, f"timed out waiting for {what}; seen {seen}"
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
    with mavsdk_autopilot(f"udpin://127.0.0.1:{sitl.ports['api_remote']}") as system:
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
        # Straight from Hold to Offboard (the ACK can come before the HEARTBEAT that shows the new mode).
        modes = watch(telemetry.flight_mode, lambda mode: mode == FlightMode.OFFBOARD, "Offboard")
        assert modes in ([FlightMode.HOLD, FlightMode.OFFBOARD], [FlightMode.OFFBOARD]), modes
        wait_for(lambda: abs(telemetry.velocity_ned().north_m_s - 2.0) < 0.2, "2 m/s north", timeout_s=20)
        offboard.stop()
        wait_for(lambda: telemetry.flight_mode() == FlightMode.HOLD, "Hold after Offboard")

        # The transition command in Hold (autopilot/navigator/modes/hold.py, HoldMode.transition): to FW the vehicle circles
        # at FW_AIRSPD_TRIM, tilting its rotors forward as it speeds up, through TRANSITION_TO_FW (mean tilt 5 ...
        # 85 deg, autopilot/vehicle_status.py) to FW; back to MC it brakes to a hover, through TRANSITION_TO_MC.
        assert telemetry.vtol_state() == VtolState.MC
        lowest = [telemetry.position().relative_altitude_m]

        def note_altitude() -> None:
            lowest[0] = min(lowest[0], telemetry.position().relative_altitude_m)

        action.transition_to_fixedwing()
        to_fw = watch(telemetry.vtol_state, lambda state: state == VtolState.FW, "fixed wing", timeout_s=90,
                      also=note_altitude)  # fmt: skip
        fw_speed = math.hypot(telemetry.velocity_ned().north_m_s, telemetry.velocity_ned().east_m_s)
        assert to_fw == [VtolState.MC, VtolState.TRANSITION_TO_FW, VtolState.FW], to_fw
        assert fw_speed > 20.0  # in forward flight at about FW_AIRSPD_TRIM (26 m/s)
        assert telemetry.flight_mode() == FlightMode.HOLD
        action.transition_to_multicopter()
        to_mc = watch(telemetry.vtol_state, lambda state: state == VtolState.MC, "multicopter", timeout_s=90,
                      also=note_altitude)  # fmt: skip
        print(f"to FW {to_fw} at {fw_speed:.1f} m/s, back {to_mc}, lowest {lowest[0]:.2f} m")
        assert to_mc == [VtolState.FW, VtolState.TRANSITION_TO_MC, VtolState.MC], to_mc
        assert lowest[0] > 3.0  # both ways at the altitude it held (5 m)
        assert telemetry.flight_mode() == FlightMode.HOLD
        wait_for(lambda: math.hypot(telemetry.velocity_ned().north_m_s, telemetry.velocity_ned().east_m_s) < 0.5,
                 "the brake to a hover", timeout_s=60)  # fmt: skip

        # A servo failure injected and cleared.
        failure.inject(FailureUnit.SYSTEM_SERVO, FailureType.STUCK, 1)
        failure.inject(FailureUnit.SYSTEM_SERVO, FailureType.OK, 1)

        action.land()
        wait_for(lambda: not telemetry.armed(), "disarmed after landing", timeout_s=60)
        wait_for(lambda: telemetry.landed_state() == LandedState.ON_GROUND, "landed state ON_GROUND")
        assert telemetry.position().relative_altitude_m < 0.5
    autopilot, plant = sitl.stop()
    assert autopilot["failures_acknowledged"] == 2 and not autopilot["armed"]
    assert any("Failure injected: servo 1 STUCK" in line for line in sitl.stderr().splitlines())
    assert not [m for m in messages if "timeout" in m.lower()], messages
