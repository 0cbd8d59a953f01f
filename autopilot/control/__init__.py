"""The control stack under the flight modes: the velocity-controller protocol, the PID baseline, the attitude loop, the control allocation and what it knows of actuator health."""
