"""Tests through the real processes and sockets: plant, autopilot, ground stations, the tools (minutes to run)."""
