"""The vehicle's MAVLink 2 signing key (docs/mavlink.md#signing): what SETUP_SIGNING may set, and how it is kept in
the parameter file. Pure functions; the policy on the links is autopilot/mavlink/signing.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from transport.link_signing import KEY_BYTES

MAX_TIMESTAMP = (1 << 48) - 1  # the signature carries 48 bits


class SigningRefused(ValueError):
    """A SETUP_SIGNING (or a stored key) that cannot be used, with the reason."""


@dataclass(frozen=True)
class SigningKey:
    secret: bytes  # 32 bytes
    timestamp: int  # 10 us units since 2015-01-01 UTC: the first outgoing signature is at least this


def key_from_setup(secret_key: list[int] | bytes, initial_timestamp: int) -> SigningKey | None:
    """What a SETUP_SIGNING asks for: a key, or None to disable signing (all-zero key and timestamp, as MAVLink
    says). Raises SigningRefused for anything else that cannot be a key."""
    secret = bytes(secret_key)
    if len(secret) != KEY_BYTES:
        raise SigningRefused(f"key of {len(secret)} bytes, {KEY_BYTES} expected")
    blank = not any(secret)
    if blank and initial_timestamp == 0:
        return None
    if blank:
        raise SigningRefused("all-zero key with a timestamp (an all-zero key and timestamp 0 disable signing)")
    if initial_timestamp == 0:
        raise SigningRefused("initial timestamp 0 (10 us units since 2015-01-01 expected)")
    if initial_timestamp > MAX_TIMESTAMP:
        raise SigningRefused("initial timestamp beyond 48 bits")
    return SigningKey(secret, initial_timestamp)


def key_to_document(key: SigningKey) -> dict[str, Any]:
    """The parameter file's "signing" entry."""
    return {"key": key.secret.hex(), "timestamp": key.timestamp}


def key_from_document(entry: Any) -> SigningKey:
    """The parameter file's "signing" entry back; SigningRefused if it is not one."""
    if not isinstance(entry, dict) or not isinstance(entry.get("key"), str):
        raise SigningRefused('"signing" must be {"key": "<64 hex digits>", "timestamp": <int>}')
    try:
        secret = bytes.fromhex(entry["key"])
    except ValueError:
        raise SigningRefused('"signing" key is not hexadecimal') from None
    timestamp = entry.get("timestamp")
    if isinstance(timestamp, bool) or not isinstance(timestamp, int):
        raise SigningRefused('"signing" timestamp must be an integer')
    key = key_from_setup(secret, timestamp)
    if key is None:
        raise SigningRefused('"signing" key is all zero')
    return key
