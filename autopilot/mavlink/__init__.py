"""The autopilot's MAVLink services for ground stations: links, streams, commands, parameters, offboard, missions,
statustext. They read only the VehicleStatus snapshot and turn what clients ask into typed requests."""
