"""What the autopilot keeps across restarts (PX4's param and dataman): the parameters, the stored missions, the signing key, and the atomic file writer."""
