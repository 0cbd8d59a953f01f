"""The plant's handshake gate (sim_bridge/peer.py) on messages built as the autopilot builds them: no sockets."""

from __future__ import annotations

from typing import Any

from sim_bridge.peer import Address, PeerGate
from transport.mavlink import Link
from transport.plant_handshake import confirm_message, hello_messages

AUTOPILOT: Address = ("127.0.0.1", 40001)
PLANT_IDS = (1, 200)


def parsed(link: Link, messages: list[Any]) -> list[Any]:
    return link.parse(b"".join(link.pack(message) for message in messages))


def gate_and_autopilot() -> tuple[PeerGate, Link, list[bytes]]:
    sent: list[bytes] = []
    gate = PeerGate(Link(*PLANT_IDS), lambda data, _address: sent.append(data))
    return gate, Link(1, 1), sent


def test_a_hello_said_twice_before_the_plant_answered_gets_one_challenge_and_either_confirm_binds():
    gate, autopilot, sent = gate_and_autopilot()
    hello = hello_messages(autopilot.mav, 4242)
    gate.admit(parsed(autopilot, hello), AUTOPILOT)
    gate.admit(parsed(autopilot, hello), AUTOPILOT)  # repeated: the first was not answered in time
    first, second = (autopilot.parse(data)[0] for data in sent)
    assert (first.seq, first.time_usec) == (second.seq, second.time_usec) == (4242, first.time_usec)
    assert gate.admit(parsed(autopilot, [confirm_message(autopilot.mav, first)]), AUTOPILOT) == []
    assert gate.peer == AUTOPILOT and gate.handshakes == 1 and not gate.foreign
    # the second CONFIRM, from the peer now: a PING the plant has nothing to do with, not a stranger's datagram
    assert [
        m.get_type() for m in gate.admit(parsed(autopilot, [confirm_message(autopilot.mav, second)]), AUTOPILOT)
    ] == ["PING"]
    assert not gate.foreign


def test_a_new_nonce_gets_a_new_challenge_and_the_old_confirm_binds_nothing():
    gate, autopilot, sent = gate_and_autopilot()
    gate.admit(parsed(autopilot, hello_messages(autopilot.mav, 1)), AUTOPILOT)
    gate.admit(parsed(autopilot, hello_messages(autopilot.mav, 2)), AUTOPILOT)  # a restarted autopilot
    old, new = (autopilot.parse(data)[0] for data in sent)
    assert new.seq == 2 and new.time_usec != old.time_usec
    gate.admit(parsed(autopilot, [confirm_message(autopilot.mav, old)]), AUTOPILOT)
    assert gate.peer is None and gate.foreign["PING"] == 1
    gate.admit(parsed(autopilot, [confirm_message(autopilot.mav, new)]), AUTOPILOT)
    assert gate.peer == AUTOPILOT
