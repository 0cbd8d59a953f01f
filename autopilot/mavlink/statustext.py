"""STATUSTEXT: events and refusals said to every ground-station link (and on stderr and zenoh), as PX4 says them.

A text of up to 50 bytes goes in one STATUSTEXT (id 0); longer ones in 50-byte chunks that share an id (the
last chunk shorter than 50 bytes, empty if need be). A refusal said with a key is said at most once per
simulated second, and at most NOTICES_PER_PERIOD keyed notices in all per second, so a flood of varied junk
cannot flood the links.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from autopilot.mavlink.router import Router
from transport.telemetry import encode_event

NOTICE_PERIOD_USEC = 1_000_000
NOTICES_PER_PERIOD = 20
CHUNK_BYTES = 50
MAX_CHUNKS = 20


StatustextSink = Callable[[int, int, str], None]  # (simulation time us, MAV_SEVERITY, text)


class Announcer:
    def __init__(self, router: Router, clock: Callable[[], int], events_publisher: Any | None, quiet: bool,
                 sink: StatustextSink | None = None) -> None:  # fmt: skip
        """clock: the simulation time (us); events_publisher: zenoh's vtol/<sysid>/autopilot/events (None: none);
        sink: told every text said (the logger's logged messages)."""
        self.router = router
        self.sink = sink
        self.clock = clock
        self.events_publisher = events_publisher
        self.quiet = quiet
        self.suppressed = 0
        self._last_notice: dict[str, int] = {}
        self._window_usec = 0
        self._in_window = 0
        self._text_id = 0

    def restart(self) -> None:
        self._last_notice.clear()

    def say(self, severity: int, text: str, key: str | None = None) -> None:
        if key is not None and not self._may_say(key):
            self.suppressed += 1
            return
        if not self.quiet:
            print(f"vtol-autopilot: {text}", file=sys.stderr, flush=True)
        chunks = self._chunks(text)
        for link in self.router.links:
            for chunk, text_id, sequence in chunks:
                link.queue(link.mav.statustext_encode(severity, chunk, text_id, sequence))
        if self.events_publisher is not None:
            self.events_publisher.put(encode_event(self.clock() / 1e6, "statustext", text, severity=severity))
        if self.sink is not None:
            self.sink(self.clock(), severity, text)

    def _may_say(self, key: str) -> bool:
        now = self.clock()
        last = self._last_notice.get(key)
        if last is not None and 0 <= now - last < NOTICE_PERIOD_USEC:
            return False
        if not 0 <= now - self._window_usec < NOTICE_PERIOD_USEC:
            self._window_usec, self._in_window = now, 0
            if len(self._last_notice) > 256:
                self._last_notice.clear()
        if self._in_window >= NOTICES_PER_PERIOD:
            return False
        self._in_window += 1
        self._last_notice[key] = now
        return True

    def _chunks(self, text: str) -> list[tuple[bytes, int, int]]:
        encoded = text.encode("utf-8", "replace")[: CHUNK_BYTES * MAX_CHUNKS]
        if len(encoded) <= CHUNK_BYTES:
            return [(encoded, 0, 0)]
        self._text_id = self._text_id % 65535 + 1
        chunks = [encoded[i : i + CHUNK_BYTES] for i in range(0, len(encoded), CHUNK_BYTES)]
        if len(chunks[-1]) == CHUNK_BYTES:
            chunks.append(b"")
        return [(chunk, self._text_id, sequence) for sequence, chunk in enumerate(chunks)]
