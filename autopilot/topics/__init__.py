"""The topics every package of the autopilot may read (PX4's uORB messages): the vehicle's state and status, the requests ground stations make, mission items, home, set-points."""
