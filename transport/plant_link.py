"""The autopilot's end of the plant link: receive each step's state, answer with SERVO_OUTPUT_RAW.

Used by the autopilot process, by the test peers and by the benchmarks, so every one of them speaks the
lockstep protocol the same way (docs/plant-link.md).
"""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass, field
from typing import Any

from transport.mavlink import Link
from transport.mavlink_frames import HIL_GPS, HIL_SENSOR, PLANT_STEP_FORMATS, SERVO_OUTPUT_RAW
from transport.plant_handshake import confirm_message, hello_messages, is_challenge_for, new_client_nonce
from transport.ports import LOOPBACK
from transport.udp import SPIN_WINDOW_S, receive

USEC_WRAP = 1 << 32


@dataclass
class PlantSample:
    """What the plant sent for one step."""

    time_usec: int
    state: Any  # HIL_STATE_QUATERNION
    sensor: Any | None = None  # HIL_SENSOR (None when the client does not decode the sensors)
    gps: Any | None = None  # HIL_GPS, at 10 Hz (likewise)
    others: list[Any] = field(default_factory=list)  # COMMAND_ACK, STATUSTEXT, HEARTBEAT...


class PlantLinkClient:
    """UDP client of a plant listening on 127.0.0.1:port."""

    def __init__(
        self,
        port: int,
        system_id: int = 1,
        component_id: int = 1,
        host: str = LOOPBACK,
        local_port: int = 0,
        signing_key: bytes | None = None,
        sensors: bool = True,
    ) -> None:
        """`local_port` 0: an ephemeral port; a plant started with `--autopilot-port P` accepts only local_port P.
        `signing_key`: sign the link, as a plant given the same key does (docs/plant-link.md#signing).
        `sensors` False: HIL_SENSOR and HIL_GPS are checked (CRC) but not decoded, and samples carry none; the
        autopilot flies on HIL_STATE_QUATERNION alone, and decoding them cost it about 4 us a step: it decodes the
        last HIL_SENSOR (`latest_sensor`) only when it reports or calibrates the sensors."""
        self.address = (host, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((LOOPBACK, local_port))
        except OSError:
            self.sock.close()
            raise
        self.sock.setblocking(False)
        self.local_port: int = self.sock.getsockname()[1]
        self.link = Link(system_id, component_id, signing_key, fast=PLANT_STEP_FORMATS,
                         checked=() if sensors else (HIL_SENSOR, HIL_GPS))  # fmt: skip
        self.sensors = sensors
        self.received_other: list[Any] = []
        self.confirmed = 0  # handshake challenges answered (docs/plant-link.md, "The handshake")
        self.plant_ids: tuple[int, int] | None = None  # (system, component) of the plant that challenged us last
        self.foreign = 0  # datagrams from anyone but the plant's address, ignored
        self._nonce = new_client_nonce()
        self._spin_s = SPIN_WINDOW_S

    def close(self) -> None:
        self.sock.close()

    def send(self, message: Any) -> None:
        self.sock.sendto(self.link.pack(message), self.address)

    def send_raw(self, data: bytes) -> None:
        self.sock.sendto(data, self.address)

    def hello(self) -> None:
        """The handshake's HELLO (HEARTBEAT + PING with our nonce, one datagram); `receive_step` answers the plant's
        CHALLENGE, after which the plant belongs to us and starts (or resumes) stepping."""
        self.send_raw(b"".join(self.link.pack(message) for message in hello_messages(self.link.mav, self._nonce)))

    def _answer_challenge(self, message: Any) -> bool:
        """CONFIRM a CHALLENGE to our HELLO; True if `message` was one."""
        if not is_challenge_for(message, self._nonce, (self.link.mav.srcSystem, self.link.mav.srcComponent)):
            return False
        self.send(confirm_message(self.link.mav, message))
        self.confirmed += 1
        self.plant_ids = (message.get_srcSystem(), message.get_srcComponent())
        return True

    def receive_step(self, timeout_s: float = 2.0) -> PlantSample | None:
        """The next step's state (messages in between are collected in `received_other`); None on timeout."""
        started = time.monotonic()
        deadline = started + timeout_s
        while True:
            received = receive(self.sock, deadline, spin_s=self._spin_s)
            if received is None:
                if time.monotonic() >= deadline:
                    return None
                continue
            data, sender = received
            if sender != self.address:
                self.foreign += 1  # only the plant speaks for the plant (a forged state would fly the vehicle)
                continue
            sample = None
            for message in self.link.parse(data):
                kind = message.get_type()
                if kind == "HIL_STATE_QUATERNION":
                    sample = PlantSample(message.time_usec, message)
                elif kind in ("HIL_SENSOR", "HIL_GPS") and not self.sensors:
                    # checked, decoded only when asked for (pymavlink's parser, unlike the fast path, decodes them)
                    if kind == "HIL_SENSOR":
                        fields = [getattr(message, name) for name in message.fieldnames]
                        self.link.frames.kept[HIL_SENSOR.msgid] = HIL_SENSOR.payload(fields)
                elif kind == "HIL_SENSOR" and sample is not None:
                    sample.sensor = message
                elif kind == "HIL_GPS" and sample is not None:
                    sample.gps = message
                elif not (kind == "PING" and self._answer_challenge(message)):
                    self.received_other.append(message)
            if sample is not None:
                # Spin for the next state only while states come quickly (lockstep, ~100 us apart); a plant
                # paced to the wall clock (states milliseconds apart) is waited for without burning a core.
                self._spin_s = SPIN_WINDOW_S if time.monotonic() - started < SPIN_WINDOW_S / 2 else 0.0
                return sample

    def latest_sensor(self) -> Any | None:
        """The last HIL_SENSOR received, decoded now (with `sensors` False the link only keeps its bytes); None
        before the first."""
        payload = self.link.frames.kept.get(HIL_SENSOR.msgid)
        if payload is None:
            return None
        size = HIL_SENSOR.payload_struct.size
        padded = payload[:size] + bytes(max(0, size - len(payload)))  # MAVLink 2 drops trailing zeros
        return HIL_SENSOR.message_class(*HIL_SENSOR.fields(padded))

    @property
    def states_come_quickly(self) -> bool:
        """Whether the plant's states arrive in quick succession (lockstep faster than real time), not paced to
        the wall clock: the last one came within half the spin window of the wait for it."""
        return self._spin_s > 0.0

    def send_pwm(self, time_usec: int, pwm: list[int]) -> None:
        """SERVO_OUTPUT_RAW for step time_usec with 12 channels (port 0)."""
        self.send_raw(self.link.pack_fields(SERVO_OUTPUT_RAW, time_usec % USEC_WRAP, 0, *pwm))

    def send_command_long(self, command: int, params: tuple[float, ...], target: tuple[int, int]) -> None:
        """COMMAND_LONG to `target` (system, component)."""
        p = list(params) + [0.0] * (7 - len(params))
        self.send(self.link.mav.command_long_encode(target[0], target[1], command, 0, *p))

    def request_plant_parameters(self) -> bool:
        """PARAM_REQUEST_LIST to the plant this client shook hands with (its parameters, the wind:
        transport/plant_parameters.py); False (nothing sent) before any handshake."""
        if self.plant_ids is None:
            return False
        self.send(self.link.mav.param_request_list_encode(*self.plant_ids))
        return True

    def set_plant_parameter(self, name: str, param_value: float, param_type: int) -> bool:
        """PARAM_SET to the plant (the value in its wire encoding); False (nothing sent) before any handshake."""
        if self.plant_ids is None:
            return False
        self.send(self.link.mav.param_set_encode(*self.plant_ids, name.encode(), param_value, param_type))
        return True

    def command_plant(self, command: int, params: tuple[float, ...]) -> bool:
        """COMMAND_LONG to the plant this client shook hands with, addressed by the ids it challenged us with;
        False (nothing sent) before any handshake."""
        if self.plant_ids is None:
            return False
        self.send_command_long(command, params, self.plant_ids)
        return True
