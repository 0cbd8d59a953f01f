"""Home (docs/mavlink.md, "Commands" (DO_SET_HOME)): PX4 SITL's default, PX4_HOME_LAT/LON/ALT from the environment as PX4 reads them, or
--home; one choice for plant and autopilot; a bad one refused."""

from __future__ import annotations

import numpy as np
import pytest

from autopilot.commander.home import HomeKeeper
from autopilot.topics.home_position import home_at
from transport.geodesy import Home, HomeRefused, home_from


def test_px4s_home_is_the_default_and_each_environment_variable_replaces_its_part():
    assert home_from(None, {}) == Home(47.397742, 8.545594, 488.0)
    assert home_from(None, {"PX4_HOME_ALT": "100"}) == Home(47.397742, 8.545594, 100.0)
    assert home_from(None, {"PX4_HOME_LAT": "-33.8688", "PX4_HOME_LON": " 151.2093 "}) == Home(
        -33.8688, 151.2093, 488.0
    )
    assert home_from((1.0, 2.0, 3.0), {"PX4_HOME_LAT": "10"}) == Home(1.0, 2.0, 3.0)  # --home wins


@pytest.mark.parametrize("given, environ, message", [
    (None, {"PX4_HOME_LAT": "north"}, "PX4_HOME_LAT='north' is not a number"),
    (None, {"PX4_HOME_LON": "nan"}, "not finite"),
    (None, {"PX4_HOME_LAT": "91"}, "out of range"),
    ((0.0, 0.0, 20_000.0), {}, "altitude"),
])  # fmt: skip
def test_a_home_that_cannot_be_one_is_refused(given, environ, message):
    with pytest.raises(HomeRefused, match=message):
        home_from(given, environ)


def test_home_follows_a_moved_vehicle_as_px4s_does_but_never_over_a_manual_home():
    keeper = HomeKeeper(Home())
    assert keeper.set_here(np.array([0.0, 0.0, -0.25])) and keeper.position.down == -0.25
    assert not keeper.follow(np.array([0.9, 0.0, -0.25]))  # within 1 m: stays
    assert not keeper.follow(np.array([0.0, 0.0, -1.7]))  # within 1.5 m vertically: stays
    assert keeper.follow(np.array([0.0, 1.1, -0.25])) and keeper.position.east == 1.1 and not keeper.position.manual
    keeper.position = home_at(Home(), Home().lat, Home().lon, Home().alt + 3.0)  # DO_SET_HOME's coordinates
    assert keeper.position.manual and abs(keeper.position.down + 3.0) < 1e-6
    assert not keeper.set_here(np.zeros(3)) and not keeper.follow(np.array([50.0, 0.0, 0.0]))
    assert abs(keeper.position.down + 3.0) < 1e-6 and abs(keeper.position.north) < 1e-6
