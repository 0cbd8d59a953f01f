"""PX4's commander: arming and its checks, the mode choice and its switches, failsafes and their reactions, home, the ground state, the output tests, failure injection."""
