"""Follow Me through the real processes (docs/mavlink.md, "Follow Me"), lockstep, the default controller (MPC): a
ground station arms in Hold, chooses AUTO.FOLLOW_TARGET and sends FOLLOW_TARGET at 1 Hz (as QGroundControl and
MAVSDK do) for a target walking north at 3 m/s; the vehicle takes off, climbs to FLW_TGT_HT, then follows
FLW_TGT_DST behind with its nose on the target. Malformed FOLLOW_TARGETs are refused on the way. Then the messages
stop: after 3 s the vehicle says so and holds, still in Follow Me."""

from __future__ import annotations

import math

import pymap3d
import pytest

from tests.sitl.ground_station import HOLD, GroundStation, said
from tests.sitl.mavlink_sitl import start_sitl
from transport.geodesy import Home
from transport.mavlink import mavlink as M

HOME = Home()
FOLLOW = (4 << 16) | (8 << 24)  # AUTO.FOLLOW_TARGET
SPEED = 3.0  # m/s north
START_NORTH = 10.0  # m: where the target starts
DISTANCE, HEIGHT = 8.0, 8.0  # PX4's FLW_TGT_DST and FLW_TGT_HT defaults
LOST = "Follow Me: no FOLLOW_TARGET for 3 s"


def send_target(gs: GroundStation, north: float, east: float, velocity: tuple[float, float, float],
                lat_e7: int | None = None, alt: float | None = None) -> None:  # fmt: skip
    lat, lon, _ = pymap3d.ned2geodetic(north, east, 0.0, HOME.lat, HOME.lon, HOME.alt)
    gs.conn.mav.follow_target_send(gs.time_boot_ms, 1, round(lat * 1e7) if lat_e7 is None else lat_e7,
                                   round(lon * 1e7), HOME.alt if alt is None else alt, list(velocity),
                                   [math.nan] * 3, [1.0, math.nan, math.nan, math.nan], [math.nan] * 3,
                                   [math.nan] * 3, 0)  # fmt: skip


def target_north(t: float, t0: float) -> float:
    return START_NORTH + SPEED * (t - t0)


@pytest.mark.timeout(600)
def test_follow_me_follows_a_walking_target_behind_at_its_height_and_holds_when_it_is_lost(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        t0 = gs.sim_time
        next_send = [t0]
        last_sent = [t0]

        def feed() -> None:
            if gs.sim_time >= next_send[0]:
                send_target(gs, target_north(gs.sim_time, t0), 0.0, (SPEED, 0.0, 0.0))
                last_sent[0] = gs.sim_time
                next_send[0] += 1.0

        gs.wait(lambda: gs.mode == HOLD, "Hold", 30, every=feed)
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        assert gs.set_mode(FOLLOW).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == FOLLOW, "Follow Me in the HEARTBEAT", 30, every=feed)

        # Malformed targets on the way: refused with a reason, the flight goes on.
        since = len(gs.statustexts)
        send_target(gs, 0.0, 0.0, (0.0, 0.0, 0.0), lat_e7=910_000_000)
        assert "position not a place on Earth" in said(gs, "FOLLOW_TARGET dropped", since)
        send_target(gs, 0.0, 0.0, (0.0, 0.0, 0.0), alt=math.nan)
        assert "altitude not finite" in said(gs, "FOLLOW_TARGET dropped: altitude", since)

        # The climb comes first: no horizontal flight until within 3 m of the follow height.
        first_move: list[float] = []

        def climbing() -> bool:
            feed()
            local = gs.latest.get("LOCAL_POSITION_NED")
            if local is not None and not first_move and math.hypot(local.x, local.y) > 1.0:
                first_move.append(-local.z)
            return local is not None and -local.z > HEIGHT - 0.5

        gs.wait(climbing, "the climb to FLW_TGT_HT", 240)
        assert not first_move or first_move[0] > HEIGHT - 3.0 - 0.5, first_move

        gaps: list[float] = []
        heights: list[float] = []
        headings: list[float] = []
        settle_until = gs.sim_time + 30.0

        def sample() -> None:
            feed()
            local, attitude = gs.latest.get("LOCAL_POSITION_NED"), gs.latest.get("ATTITUDE")
            if gs.sim_time < settle_until or local is None or attitude is None:
                return
            target = target_north(gs.sim_time, t0)
            gaps.append(math.hypot(target - local.x, local.y))
            heights.append(-local.z)
            headings.append(math.degrees(attitude.yaw))

        window_end = settle_until + 20.0
        gs.wait(lambda: gs.sim_time >= window_end, "20 s of settled following", 400, every=sample)
        print(f"follow: distance {min(gaps):.2f} .. {max(gaps):.2f} m, height {min(heights):.2f} .. "
              f"{max(heights):.2f} m, heading {min(headings):.1f} .. {max(headings):.1f} deg")  # fmt: skip
        assert gs.mode == FOLLOW and len(gaps) > 50
        assert min(gaps) > DISTANCE - 1.5 and max(gaps) < DISTANCE + 1.5
        assert min(heights) > HEIGHT - 1.0 and max(heights) < HEIGHT + 1.0
        assert max(abs(h) for h in headings) < 15.0  # the nose north, at the target ahead

        # The target is lost: no more FOLLOW_TARGET. PX4's estimator goes on for 3 s after the last one, then stands
        # still (the telemetry's clock trails the vehicle's by a few ticks).
        lost_at = gs.sim_time
        since = len(gs.statustexts)
        said(gs, LOST, since, 60)
        assert gs.sim_time - last_sent[0] == pytest.approx(3.0, abs=1.0)
        gs.wait_sim(10.0, timeout_s=120)
        held = gs.latest["LOCAL_POSITION_NED"]
        gs.wait_sim(5.0, timeout_s=120)
        now = gs.latest["LOCAL_POSITION_NED"]
        drift = math.hypot(now.x - held.x, now.y - held.y)
        print(f"lost: held {drift:.2f} m over 5 s at {held.x:.1f} m north, target last at "
              f"{target_north(lost_at, t0):.1f} m")  # fmt: skip
        assert gs.mode == FOLLOW and drift < 0.5 and math.hypot(now.vx, now.vy) < 0.3
        assert -now.z == pytest.approx(HEIGHT, abs=1.0)
    finally:
        sitl.kill()
