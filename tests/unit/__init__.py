"""Tests with no processes and no sockets: the maths, the models, the pure rules (seconds to run)."""
