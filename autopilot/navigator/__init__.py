"""PX4's navigator: the flight modes and the position logic they fly (missions, Return, geofence, region of interest, Offboard set-points, manual sticks)."""
