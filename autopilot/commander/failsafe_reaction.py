"""What the commander does when a failsafe has decided (failsafe.py), as PX4's commander carries out a failsafe
action: a warning only; Descend (Land with no horizontal position control); flight termination (motors off); or
the action's mode. Not Return while landing, and the same mode again only for Hold, which stops a Go-to where it is
(PX4). A pure function makes the plan; the commander applies it in its order: the texts before, the motors cut or
the mode entered, the texts after.
"""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.commander.failsafe import DESCEND, DISARM, TERMINATE, WARN, Decision
from autopilot.navigator.modes.hold import HOLD
from autopilot.navigator.modes.land import LAND
from autopilot.navigator.modes.rtl import RETURN
from transport.mavlink import mavlink

Said = tuple[tuple[int, str], ...]  # (MAV_SEVERITY, STATUSTEXT)
WARNING, CRITICAL = mavlink.MAV_SEVERITY_WARNING, mavlink.MAV_SEVERITY_CRITICAL


@dataclass(frozen=True)
class Reaction:
    before: Said = ()
    mode: str | None = None  # the mode to enter (again)
    mode_reason: str | None = None  # said when the mode changes
    descend: bool = False  # the Land entered is PX4's Descend
    cut_motors: str | None = None  # disarm, saying this
    terminate: bool = False  # the motors stay off until the termination is cleared (flight termination)
    after: Said = ()


def reaction(decision: Decision, mode: str, flying: bool) -> Reaction:
    """The plan for `decision` in `mode` (flying: the flight controller runs)."""
    action, cause = decision.action, decision.cause
    if action == WARN or (action == mode != HOLD) or (action == RETURN and mode == LAND):
        return Reaction(before=((WARNING, cause),))
    if action == DESCEND:
        return Reaction(mode=LAND, mode_reason=f"{cause}, Descend", descend=True,
                        after=((CRITICAL, "Failsafe activated: Descend"),))  # fmt: skip
    if action == TERMINATE:
        return Reaction(before=((CRITICAL, f"{cause}: flight termination"),),
                        cut_motors="Failsafe activated: flight termination, motors off", terminate=True)  # fmt: skip
    if action == DISARM:
        return Reaction(before=((CRITICAL, f"{cause}: disarm"),), cut_motors="Failsafe activated: disarm, motors off")
    return Reaction(before=((WARNING, f"{cause}, {action}"),) if action == mode else (), mode=action,
                    mode_reason=f"{cause}, {action}",
                    after=((CRITICAL, f"Failsafe activated: {action}"),) if flying else ())  # fmt: skip
