"""Failure injection on the plant link: forward MAV_CMD_INJECT_FAILURE to the plant, match its acknowledgements,
and say when the controllers learn of a failure (at once, or SYS_FAILURE_DLY later).

An injection asked for by a ground station carries a ticket; its outcome (the plant's answer, or FAILED when
the plant does not answer within INJECTION_TIMEOUT_USEC) is reported for the ground station's COMMAND_ACK.
Failures scheduled on the command line (`--failure`) carry none.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from aircraft.failures import Failure
from autopilot.topics.vehicle_status import InjectionOutcome, drain
from transport.mavlink import MAV_RESULT_ACCEPTED, MAV_RESULT_FAILED

INJECTION_TIMEOUT_USEC = 1_000_000  # a forwarded failure the plant has not acknowledged by then has failed


@dataclass(frozen=True)
class ScheduledFailure:
    """A failure to inject at a simulation time (s since the flight's start), from `--failure`."""

    time_s: float
    failure: Failure


@dataclass(frozen=True)
class PendingInjection:
    failure: Failure
    sent_usec: int
    ticket: int | None  # the ground station's request, or None for a scheduled failure


@dataclass
class InjectionCounters:
    acknowledged: int = 0
    refused: int = 0


@dataclass
class FailureInjection:
    """The injections on their way to the plant and the failures the controllers know."""

    send: Callable[[Failure], bool]  # MAV_CMD_INJECT_FAILURE to the plant; False: no plant to send it to
    note: Callable[[str], None]  # a line for the terminal
    scheduled: list[ScheduledFailure] = field(default_factory=list)
    known: list[Failure] = field(default_factory=list)  # in the order the controllers learnt them
    counters: InjectionCounters = field(default_factory=InjectionCounters)
    _awaiting: list[PendingInjection] = field(default_factory=list)
    _learning: list[tuple[int, Failure]] = field(default_factory=list)  # (when, failure): SYS_FAILURE_DLY
    _outcomes: list[InjectionOutcome] = field(default_factory=list)
    _next_scheduled: int = 0

    def __post_init__(self) -> None:
        self.scheduled = sorted(self.scheduled, key=lambda item: item.time_s)

    def request(self, failure: Failure, now_usec: int, ticket: int | None = None) -> None:
        pending = PendingInjection(failure, now_usec, ticket)
        if not self.send(failure):
            self.counters.refused += 1
            text = failure.describe()
            self.note(f"failure {text} not sent: no plant has completed the handshake")
            self._outcome(pending, MAV_RESULT_FAILED, f"Failure {text}: no plant on the plant link")
            return
        self._awaiting.append(pending)

    def acknowledged(self, result: int, now_usec: int, delay_s: float, oracle: bool = True) -> list[Failure]:
        """The plant's COMMAND_ACK for the oldest injection; the failures the controllers learn now. `oracle` False:
        an actuator failure is not told (the failure detector has to find it); a sensor failure always is."""
        if not self._awaiting:
            return []
        pending = self._awaiting.pop(0)
        text = pending.failure.describe()
        if result != MAV_RESULT_ACCEPTED:
            self.counters.refused += 1
            self.note(f"plant refused failure {text} (result {result})")
            self._outcome(pending, result, f"Failure refused by the plant: {text}")
            return []
        self.counters.acknowledged += 1
        if not oracle and not pending.failure.sensor:
            self._outcome(pending, result, f"Failure injected: {text}")
            return []
        delay_usec = int(round(delay_s * 1e6))
        when = f", controllers told in {delay_usec / 1e6:g} s" if delay_usec > 0 else ""
        self._outcome(pending, result, f"Failure injected: {text}{when}")
        if delay_usec > 0:
            self._learning.append((now_usec + delay_usec, pending.failure))
            return []
        self.known.append(pending.failure)
        return [pending.failure]

    def inject_scheduled(self, t_s: float, now_usec: int) -> None:
        """Send the `--failure` injections whose time has come."""
        while self._next_scheduled < len(self.scheduled) and self.scheduled[self._next_scheduled].time_s <= t_s:
            self.request(self.scheduled[self._next_scheduled].failure, now_usec)
            self._next_scheduled += 1

    def tick(self, now_usec: int) -> list[Failure]:
        """The failures the controllers learn now (their delay is over); injections the plant never answered."""
        learnt = []
        if self._learning:
            learnt = [failure for due, failure in self._learning if due <= now_usec]
            self._learning = [(due, failure) for due, failure in self._learning if due > now_usec]
            self.known += learnt
        while self._awaiting and now_usec - self._awaiting[0].sent_usec > INJECTION_TIMEOUT_USEC:
            pending = self._awaiting.pop(0)
            self.counters.refused += 1
            text = pending.failure.describe()
            self.note(f"the plant did not acknowledge failure {text}")
            self._outcome(pending, MAV_RESULT_FAILED, f"Failure {text}: the plant did not answer")
        return learnt

    def restart(self) -> None:
        """A new plant run: the scheduled failures start again; nothing is awaited any more."""
        self._next_scheduled = 0
        self._awaiting.clear()

    @property
    def has_outcomes(self) -> bool:
        """Answers for the ground stations are waiting (the next status snapshot takes them)."""
        return bool(self._outcomes)

    def drain_outcomes(self) -> tuple[InjectionOutcome, ...]:
        return drain(self._outcomes)

    def _outcome(self, pending: PendingInjection, result: int, text: str) -> None:
        if pending.ticket is not None:
            self._outcomes.append(InjectionOutcome(pending.ticket, result, text))
