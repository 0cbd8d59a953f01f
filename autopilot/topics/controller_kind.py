"""The velocity controllers a vehicle can fly: the unified MPC (with the PID baseline as its back-up) or the PID
baseline alone; `--controller`, the VT_CTRL parameter and the Python API name them so."""

from __future__ import annotations

from typing import Literal

ControllerKind = Literal["mpc", "pid"]
MPC: ControllerKind = "mpc"
PID: ControllerKind = "pid"
