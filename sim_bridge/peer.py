"""The plant's peer: the one autopilot it belongs to (docs/plant-link.md, "The handshake").

The gate sits between the socket and the plant. Datagrams from the peer go through; from anyone else they are
counted and dropped, except the handshake (transport/plant_handshake.py) while the plant has no peer. With a named
autopilot (`vtol-sim --autopilot-port P`) only 127.0.0.1:P may complete the handshake.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from transport.mavlink import Link
from transport.plant_handshake import (
    Challenge,
    challenge_message,
    find_hello,
    is_confirmation,
    new_plant_nonce,
)

Address = tuple[str, int]
MAX_CANDIDATES = 16  # challenges outstanding at once; the oldest is forgotten beyond this


class PeerGate:
    """Who the plant listens to, and what it did with everyone else."""

    def __init__(self, link: Link, send: Callable[[bytes, Address], None], named: Address | None = None) -> None:
        self.link = link
        self.send = send
        self.named = named
        self.peer: Address | None = None
        self.candidates: dict[Address, Challenge] = {}
        self.foreign: Counter[str] = Counter()  # per message type (and "datagrams") from senders other than the peer
        self.handshakes = 0  # peers bound
        self.challenges = 0  # HELLOs answered
        self.last_heard = 0.0  # monotonic time of the peer's latest datagram

    @property
    def plant_ids(self) -> tuple[int, int]:
        return (self.link.mav.srcSystem, self.link.mav.srcComponent)

    def release(self) -> None:
        """The peer is gone (silent for too long): the next autopilot to complete the handshake gets the plant."""
        self.peer = None
        self.candidates.clear()

    def admit(self, messages: list[Any], sender: Address) -> list[Any]:
        """The messages of one datagram the plant should act on: all of them from the peer, none from anyone else
        (a handshake step is answered here; everything else is counted in `foreign`)."""
        hello = find_hello(messages)
        if hello is not None and self._may_bind(sender):
            self._challenge(hello, sender)
            return [] if sender != self.peer else [m for m in messages if m.get_type() not in ("HEARTBEAT", "PING")]
        if sender == self.peer:
            self.last_heard = time.monotonic()
            return messages
        if self.peer is None and sender in self.candidates:
            challenge = self.candidates[sender]
            if any(is_confirmation(m, challenge, self.plant_ids) for m in messages):
                self.peer = sender
                self.last_heard = time.monotonic()
                self.candidates.clear()
                self.handshakes += 1
                return []
        self.foreign["datagrams"] += 1
        for message in messages:
            self.foreign[message.get_type()] += 1
        return []

    def _may_bind(self, sender: Address) -> bool:
        """A HELLO is answered from the peer itself (a restarted client on the same port), or from anyone allowed
        while the plant has no peer."""
        if sender == self.peer:
            return True
        return self.peer is None and (self.named is None or sender == self.named)

    def _challenge(self, hello: Any, sender: Address) -> None:
        """CHALLENGE a HELLO; a HELLO repeated before it was confirmed (same sender, same nonce) gets the same
        challenge, so that either CONFIRM binds."""
        pending = self.candidates.get(sender)
        repeated = pending is not None and pending.client_nonce == hello.nonce
        challenge = pending if repeated else Challenge(hello.nonce, new_plant_nonce())
        if sender != self.peer:
            self.candidates.pop(sender, None)
            self.candidates[sender] = challenge
            while len(self.candidates) > MAX_CANDIDATES:
                del self.candidates[next(iter(self.candidates))]
        self.challenges += 1
        self.send(self.link.pack(challenge_message(self.link.mav, hello, challenge)), sender)

    def summary(self) -> dict[str, Any]:
        return {
            "peer": None if self.peer is None else f"{self.peer[0]}:{self.peer[1]}",
            "handshakes": self.handshakes,
            "foreign": dict(self.foreign),
        }
