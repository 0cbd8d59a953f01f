"""The one place flight controllers are built: the velocity controllers (the unified MPC with the PID baseline as
its back-up, or the PID alone), the allocator and the servo estimate they share, wired into a FlightController.

Which kind flies is the caller's choice: `--controller` when given, else the VT_CTRL parameter (controller_kind).
A flight controller is built afresh at start and at every takeoff from the ground. An MPC that cannot be built is
a bug: the error propagates, nothing falls back silently.
"""

from __future__ import annotations

import numpy as np

from aircraft.actuators import ALLOCATED_COUNT, ALLOCATED_ROTORS
from aircraft.airframe import Airframe
from autopilot.control.actuator_health import ServoEstimate
from autopilot.control.allocation import ControlAllocator
from autopilot.control.flight_controller import VELOCITY_PERIOD_USEC, FlightController
from autopilot.control.pid_baseline import PidVelocityController
from autopilot.mpc.controller import DEFAULT_HORIZON, MpcVelocityController
from autopilot.mpc.horizon import HORIZONS, LONG, PAPER, MpcHorizon
from autopilot.mpc.overlap import OverlappedMpc
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.controller_kind import MPC, PID, ControllerKind

KINDS: tuple[ControllerKind, ...] = (MPC, PID)
VT_CTRL_MPC = 1  # VT_CTRL: 0 the PID baseline, 1 the MPC
VT_MPC_HRZN = (PAPER, LONG)  # the MPC's horizon by VT_MPC_HRZN


def controller_kind(forced: str | None, vt_ctrl: int) -> ControllerKind:
    """The kind to build: `forced` (--controller) when given, else VT_CTRL's. Raises ValueError for another name."""
    if forced is None:
        return MPC if vt_ctrl == VT_CTRL_MPC else PID
    if forced not in KINDS:
        raise ValueError(f"controller must be one of {', '.join(KINDS)}, got {forced!r}")
    return MPC if forced == MPC else PID


def mpc_horizon(forced: str | None, vt_mpc_hrzn: int) -> MpcHorizon:
    """The MPC's horizon: `forced` (--mpc-horizon) when given, else VT_MPC_HRZN's. Raises ValueError for another."""
    if forced is None:
        if not 0 <= vt_mpc_hrzn < len(VT_MPC_HRZN):
            raise ValueError(f"VT_MPC_HRZN must be 0 .. {len(VT_MPC_HRZN) - 1}, got {vt_mpc_hrzn}")
        return VT_MPC_HRZN[vt_mpc_hrzn]
    if forced not in HORIZONS:
        raise ValueError(f"the MPC's horizon must be one of {', '.join(HORIZONS)}, got {forced!r}")
    return HORIZONS[forced]


def build_flight_controller(
    airframe: Airframe,
    kind: ControllerKind,
    params: ParameterStore | None = None,
    *,
    mpc_horizon: MpcHorizon = DEFAULT_HORIZON,
    mpc_overlap: bool = False,
) -> FlightController:
    """A fresh flight controller of `kind` ("mpc" or "pid"); params: its gains, weights and limits (None: the
    defaults; FlightController.retune applies later changes); mpc_horizon: the MPC's horizon (autopilot/mpc/horizon.py);
    mpc_overlap: solve one tick ahead on the solver's worker thread (autopilot/mpc/overlap.py, VT_MPC_OVERLAP)
    instead of the paper's synchronous solve. Raises ValueError for another kind."""
    if kind not in KINDS:
        raise ValueError(f"controller must be one of {', '.join(KINDS)}, got {kind!r}")
    u_initial = np.zeros(ALLOCATED_COUNT)
    u_initial[ALLOCATED_ROTORS] = airframe.hover_thrust_per_rotor / airframe.thrust_max  # hover trim
    allocator = ControlAllocator(airframe, u_initial=u_initial)
    servos = ServoEstimate(airframe)
    pid = PidVelocityController(airframe, dt=VELOCITY_PERIOD_USEC / 1e6)
    if kind != MPC:
        controller = FlightController(airframe, allocator, servos, pid)
    else:
        mpc = MpcVelocityController(airframe, allocator, servos, horizon=mpc_horizon)
        flying = OverlappedMpc(mpc, VELOCITY_PERIOD_USEC) if mpc_overlap else mpc
        controller = FlightController(airframe, allocator, servos, pid, flying)
    if params is not None:
        controller.retune(params)
    return controller
