"""zenoh sessions for telemetry (docs/telemetry.md): loopback endpoints, multicast scouting off, optional.

No traffic leaves the machine unless a user gives non-loopback endpoints. When zenoh cannot start (port in
use, library missing), `open_session` says why on stderr and returns None: the flight goes on without it.
"""

from __future__ import annotations

import json
import sys
from typing import Any


def session_config(listen: list[str], connect: list[str]) -> Any:
    """A zenoh peer configuration with multicast scouting disabled and explicit endpoints."""
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps(listen))
    config.insert_json5("connect/endpoints", json.dumps(connect))
    return config


def open_session(listen: list[str], connect: list[str], who: str) -> Any | None:
    """Open a zenoh session or return None (with a one-line warning) if it cannot be opened."""
    try:
        import zenoh

        return zenoh.open(session_config(listen, connect))
    except Exception as exc:  # zenoh raises its own error types; telemetry is optional by design
        print(f"{who}: zenoh telemetry disabled: {exc}", file=sys.stderr)
        return None
