"""MAVLink 2 signing on the ground links (docs/mavlink.md#signing): SETUP_SIGNING, and which unsigned messages a
vehicle with a key still obeys.

pymavlink does the cryptography: each link's `mav.signing` holds the key, signs what goes out and checks what
comes in (a good signature makes `message.get_signed()` true; a bad one, a replayed timestamp or none at all
leave it false). The parser is told to keep unsigned frames (`allow_unsigned_callback`), so that this service,
not the parser, decides: a refused command gets a COMMAND_ACK DENIED and a STATUSTEXT instead of silence.
"""

from __future__ import annotations

import time
from typing import Any

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.router import GroundLink, Router
from autopilot.mavlink.statustext import Announcer
from autopilot.storage.parameters import ParameterStore
from autopilot.storage.signing_key import SigningKey, SigningRefused, key_from_setup
from transport.link_signing import timestamp_at
from transport.mavlink import MAV_RESULT_DENIED
from transport.mavlink import mavlink as M

# Read-only or link-keeping messages obeyed unsigned even when signing is required: a ground station without the
# key still sees the vehicle (telemetry goes to every client) and can read its parameters, never change anything.
UNSIGNED_ALLOWED = frozenset({
    "HEARTBEAT", "TIMESYNC", "PING", "SYSTEM_TIME", "RADIO_STATUS", "PARAM_REQUEST_LIST", "PARAM_REQUEST_READ",
    "MISSION_REQUEST_LIST",
})  # fmt: skip
COMMANDS_WITH_ACK = ("COMMAND_LONG", "COMMAND_INT")


def accept_every_frame(mav: Any, message_id: int) -> bool:
    """pymavlink's unsigned callback: keep the frame (unsigned); the service decides what it may do."""
    return True


class SigningService:
    def __init__(self, params: ParameterStore, router: Router, announcer: Announcer, *, system_id: int) -> None:
        self.params = params
        self.router = router
        self.announcer = announcer
        self.system_id = system_id
        self.refused = 0  # unsigned (or badly signed) messages refused
        self.keys_set = 0
        for link_id, link in enumerate(router.links):
            link.mav.signing.link_id = link_id
            link.mav.signing.allow_unsigned_callback = accept_every_frame
        self._apply(params.signing_key)

    @property
    def required(self) -> bool:
        return self.params.signing_key is not None and self.params.get_int("MAV_SIGN_REQ") == 1

    def _apply(self, key: SigningKey | None) -> None:
        """Every link signs with `key` (None: signing off), from a timestamp no older than now."""
        for link in self.router.links:
            signing = link.mav.signing
            signing.secret_key = None if key is None else key.secret
            signing.sign_outgoing = key is not None
            signing.timestamp = 0 if key is None else max(key.timestamp, timestamp_at(time.time()), signing.timestamp)
            signing.stream_timestamps.clear()

    def admits(self, link: GroundLink, message: Any) -> bool:
        """False (and the sender told, or the refusal counted) for an unsigned message signing forbids."""
        kind = message.get_type()
        if message.get_signed() or kind in UNSIGNED_ALLOWED or not self.required:
            return True
        self.refused += 1
        link.counters.ignored[f"unsigned:{kind}"] += 1
        if kind in COMMANDS_WITH_ACK:
            link.queue(link.mav.command_ack_encode(message.command, MAV_RESULT_DENIED, 0, 0,
                                                   message.get_srcSystem(), message.get_srcComponent()))  # fmt: skip
        self.announcer.say(M.MAV_SEVERITY_WARNING, f"{kind} refused: not signed (signing required)",
                           key="unsigned")  # fmt: skip
        return False

    def on_setup_signing(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            link.counters.ignored["setup_signing_for_other"] += 1
            return
        if self.params.signing_key is not None and not message.get_signed():
            # Changing or removing a key takes the current one, whatever MAV_SIGN_REQ says (PX4 does the same).
            self._refuse(link, "not signed with the current key")
            return
        try:
            key = key_from_setup(message.secret_key, message.initial_timestamp)
        except SigningRefused as refusal:
            self._refuse(link, str(refusal))
            return
        self.params.set_signing_key(key)
        self._apply(key)
        self.keys_set += 1
        self.announcer.say(M.MAV_SEVERITY_NOTICE, "signing: key removed, signing off" if key is None else
                           "signing: key set, outgoing messages signed")  # fmt: skip

    def _refuse(self, link: GroundLink, reason: str) -> None:
        self.refused += 1
        link.counters.ignored["setup_signing_refused"] += 1
        self.announcer.say(M.MAV_SEVERITY_WARNING, f"SETUP_SIGNING refused: {reason}")

    def summary(self) -> dict[str, Any]:
        return {"signing": self.params.signing_key is not None, "signing_required": self.required,
                "unsigned_refused": self.refused, "signing_keys_set": self.keys_set}  # fmt: skip
