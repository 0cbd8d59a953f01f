"""What the autopilot writes about its flight: the 100 Hz CSV log and the controller's internals on zenoh."""
