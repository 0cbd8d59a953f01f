"""MAVLink 2 signing of a whole link with a key both ends were given (docs/plant-link.md#signing): the signing
timestamp, the key file, and a parser that keeps only frames signed with the key.

pymavlink does the cryptography (SHA-256 signatures, per-stream timestamps that must increase). A link given a
key signs everything it sends and refuses every frame that is unsigned, signed with another key or replayed: the
parser reports it as bad data with the reason "Invalid signature", which `transport.mavlink.Link` counts as
`bad_signature`.
"""

from __future__ import annotations

import calendar
import time
from pathlib import Path
from typing import Any

KEY_BYTES = 32
EPOCH_2015 = calendar.timegm((2015, 1, 1, 0, 0, 0, 0, 0, 0))  # MAVLink signing timestamps count from here
TICKS_PER_S = 100_000  # in units of 10 us


class KeyFileRefused(ValueError):
    """A key file that cannot be read or holds no key, with the reason."""


def timestamp_at(unix_s: float) -> int:
    """The MAVLink signing timestamp of a wall-clock time."""
    return max(0, int((unix_s - EPOCH_2015) * TICKS_PER_S))


def parse_key(text: str) -> bytes:
    """A key file's text: 64 hexadecimal digits (surrounding white space allowed)."""
    digits = text.strip()
    if len(digits) != 2 * KEY_BYTES:
        raise KeyFileRefused(f"{len(digits)} characters, {2 * KEY_BYTES} hexadecimal digits expected")
    try:
        key = bytes.fromhex(digits)
    except ValueError:
        raise KeyFileRefused("not hexadecimal") from None
    if not any(key):
        raise KeyFileRefused("an all-zero key")
    return key


def read_key_file(path: str | Path) -> bytes:
    try:
        text = Path(path).read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        raise KeyFileRefused(f"{path}: cannot be read ({exc})") from None
    try:
        return parse_key(text)
    except KeyFileRefused as exc:
        raise KeyFileRefused(f"{path}: {exc}") from None


def sign_everything(mav: Any, key: bytes) -> None:
    """Make pymavlink's `mav` sign what it sends with `key`, from now, and refuse every frame not signed with it
    (no unsigned callback: an unsigned frame raises inside the parser, which robust parsing turns into bad data)."""
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = True
    mav.signing.timestamp = max(mav.signing.timestamp, timestamp_at(time.time()))
    mav.signing.allow_unsigned_callback = None
