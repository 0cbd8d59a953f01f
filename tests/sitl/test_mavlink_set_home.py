"""MAV_CMD_DO_SET_HOME through MAVLink (docs/mavlink.md, "Commands" (DO_SET_HOME)): param1 = 1 sets home where the vehicle is, else
at params 5-7; HOME_POSITION says the new home at once (with its x, y, z in the local frame, whose origin stays);
GF_MAX_HOR_DIST is measured from it and Return lands there; bad coordinates are DENIED as PX4 denies them.
Lockstep, the default controller."""

from __future__ import annotations

import math

import pymap3d

from tests.sitl.mavlink_sitl import start_sitl
from transport.geodesy import Home
from transport.mavlink import mavlink as M

HOME = Home()
NEW_HOME_NED = (40.0, 10.0)  # m from the origin, on the ground


def new_home_position(gs, after_ms: int):
    """The first HOME_POSITION sent after `after_ms` (time_usec from the vehicle's simulation clock)."""
    gs.wait(lambda: "HOME_POSITION" in gs.latest and gs.latest["HOME_POSITION"].time_usec > after_ms * 1000,
            "a new HOME_POSITION")  # fmt: skip
    return gs.latest["HOME_POSITION"]


def test_set_home_moves_home_position_the_fence_distance_and_return(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", spawn_alt=20.0, speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        gs.wait(lambda: "HOME_POSITION" in gs.latest, "HOME_POSITION")
        # Refused as PX4 refuses them: non-finite coordinates; and out of range ones; home stays.
        nan = gs.command(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, math.nan, HOME.lon, HOME.alt)
        assert nan.result == M.MAV_RESULT_DENIED
        far = gs.command(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, 95.0, HOME.lon, HOME.alt)
        assert far.result == M.MAV_RESULT_DENIED
        gs.wait(lambda: any("Set home denied" in text and "out of range" in text for text in gs.statustexts),
                "the reason")  # fmt: skip
        unchanged = new_home_position(gs, gs.time_boot_ms)
        assert (unchanged.latitude, unchanged.longitude) == (int(round(HOME.lat * 1e7)), int(round(HOME.lon * 1e7)))
        # param1 = 1: here (20 m up).
        position = gs.latest["GLOBAL_POSITION_INT"]
        before = gs.time_boot_ms
        assert gs.command(M.MAV_CMD_DO_SET_HOME, 1, 0, 0, math.nan, 0, 0, 0).result == M.MAV_RESULT_ACCEPTED
        here = new_home_position(gs, before)
        assert math.hypot(here.latitude - position.lat, here.longitude - position.lon) < 100  # ~1 m
        assert abs(here.altitude - position.alt) < 1000 and abs(here.z + 20.0) < 1.5
        # Coordinates: 40 m north and 10 m east of the origin, on the ground.
        lat, lon, _ = pymap3d.ned2geodetic(*NEW_HOME_NED, 0.0, HOME.lat, HOME.lon, HOME.alt)
        before = gs.time_boot_ms
        assert gs.command(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, lat, lon, HOME.alt).result == M.MAV_RESULT_ACCEPTED
        home = new_home_position(gs, before)
        # (COMMAND_LONG's params are float32: a degree in them is good to ~1e-6, 10 cm)
        assert abs(home.latitude - lat * 1e7) < 20 and abs(home.longitude - lon * 1e7) < 20
        assert home.altitude == int(round(HOME.alt * 1000))
        assert math.hypot(home.x - NEW_HOME_NED[0], home.y - NEW_HOME_NED[1]) < 0.3 and abs(home.z) < 0.1
        assert any(text.startswith("Home position:") for text in gs.statustexts)
        # The vehicle, over the origin, is 41 m from the new home: beyond a 30 m GF_MAX_HOR_DIST.
        gs.param_set("GF_MAX_HOR_DIST", 30.0, M.MAV_PARAM_TYPE_REAL32)
        gs.wait(lambda: any("Geofence violated: 41 m from home" in text for text in gs.statustexts), "the breach")
        gs.param_set("GF_MAX_HOR_DIST", 0.0, M.MAV_PARAM_TYPE_REAL32)
        # Return lands at the new home and disarms.
        gs.param_set("RTL_RETURN_ALT", 25.0, M.MAV_PARAM_TYPE_REAL32)
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: not gs.armed, "the landing at the new home", 300)
        final = gs.latest["LOCAL_POSITION_NED"]
        print(f"Return: landed {math.hypot(final.x - NEW_HOME_NED[0], final.y - NEW_HOME_NED[1]):.2f} m from home")
        assert math.hypot(final.x - NEW_HOME_NED[0], final.y - NEW_HOME_NED[1]) <= 2.0
    finally:
        sitl.kill()
