"""The autopilot process: velocity controller (MPC or PID), attitude loop and control allocation."""
