"""The plant link's start-up handshake (docs/plant-link.md, "The handshake"): which sender the plant belongs to.

Three messages, standard MAVLink (HEARTBEAT and the PING protocol), over the plant's UDP port:

    autopilot -> plant   HELLO      HEARTBEAT (an autopilot: compid 1, autopilot != INVALID, type != GCS)
                                    + PING request (target 0/0, seq = the client's nonce) in one datagram
    plant -> autopilot   CHALLENGE  PING answer (target = the client's ids, seq = its nonce, time_usec = the plant's
                                    nonce)
    autopilot -> plant   CONFIRM    PING (target = the plant's ids, seq = the client's nonce, time_usec = the
                                    plant's nonce), from the same address

The plant fixes its peer on the first CONFIRM that matches a challenge it sent to that address; from then on it
ignores (and counts) every datagram from anyone else. The functions here are pure: they build messages and
recognise them, nothing more.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass
from typing import Any

from transport.mavlink import mavlink

AUTOPILOT_COMPONENT = mavlink.MAV_COMP_ID_AUTOPILOT1  # 1
NONCE_BITS = 32  # the client's nonce travels in PING.seq (uint32)
PLANT_NONCE_BITS = 63  # the plant's nonce travels in PING.time_usec (uint64)


@dataclass(frozen=True)
class Hello:
    """An autopilot's HELLO: who it is and its nonce."""

    system_id: int
    component_id: int
    nonce: int


@dataclass(frozen=True)
class Challenge:
    """What the plant sent to a candidate: both nonces."""

    client_nonce: int
    plant_nonce: int


def new_client_nonce() -> int:
    return secrets.randbits(NONCE_BITS)


def new_plant_nonce() -> int:
    return secrets.randbits(PLANT_NONCE_BITS)


def is_autopilot_heartbeat(message: Any) -> bool:
    """A HEARTBEAT from an autopilot component (not a ground station, not a plant, not a generic sender)."""
    return (
        message.get_type() == "HEARTBEAT"
        and message.get_srcComponent() == AUTOPILOT_COMPONENT
        and message.autopilot != mavlink.MAV_AUTOPILOT_INVALID
        and message.type != mavlink.MAV_TYPE_GCS
    )


def is_ping_request(message: Any) -> bool:
    return message.get_type() == "PING" and message.target_system == 0 and message.target_component == 0


def find_hello(messages: list[Any]) -> Hello | None:
    """The HELLO in one datagram's messages: an autopilot HEARTBEAT and a PING request from the same ids."""
    for heartbeat in messages:
        if not is_autopilot_heartbeat(heartbeat):
            continue
        ids = (heartbeat.get_srcSystem(), heartbeat.get_srcComponent())
        for ping in messages:
            if is_ping_request(ping) and (ping.get_srcSystem(), ping.get_srcComponent()) == ids:
                return Hello(ids[0], ids[1], ping.seq)
    return None


def is_confirmation(message: Any, challenge: Challenge, plant_ids: tuple[int, int]) -> bool:
    """The CONFIRM of `challenge`, addressed to the plant."""
    return (
        message.get_type() == "PING"
        and (message.target_system, message.target_component) == plant_ids
        and message.seq == challenge.client_nonce
        and message.time_usec == challenge.plant_nonce
    )


def hello_messages(mav: Any, nonce: int) -> list[Any]:
    """The autopilot's HELLO (HEARTBEAT + PING request), to be sent in one datagram."""
    heartbeat = mav.heartbeat_encode(
        mavlink.MAV_TYPE_VTOL_TILTROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, mavlink.MAV_STATE_ACTIVE
    )
    return [heartbeat, mav.ping_encode(0, nonce, 0, 0)]


def challenge_message(mav: Any, hello: Hello, challenge: Challenge) -> Any:
    """The plant's CHALLENGE to a HELLO."""
    return mav.ping_encode(challenge.plant_nonce, challenge.client_nonce, hello.system_id, hello.component_id)


def is_challenge_for(message: Any, nonce: int, client_ids: tuple[int, int]) -> bool:
    """A CHALLENGE answering our HELLO (our nonce, addressed to us)."""
    return (
        message.get_type() == "PING"
        and (message.target_system, message.target_component) == client_ids
        and message.seq == nonce
    )


def confirm_message(mav: Any, challenge_ping: Any) -> Any:
    """The autopilot's CONFIRM of a CHALLENGE: both nonces back, addressed to the plant that sent it."""
    return mav.ping_encode(
        challenge_ping.time_usec, challenge_ping.seq, challenge_ping.get_srcSystem(), challenge_ping.get_srcComponent()
    )
