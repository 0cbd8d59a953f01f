"""The exit statuses of the `vtol` commands, written once; each command's --help says what its own mean."""

from __future__ import annotations

OK = 0
FAILED = 1  # the command could not do its job: a flight failed to fly, nothing was recorded
USAGE = 2  # bad arguments or input, refused in one line on stderr before anything runs (transport/cli.py)
CHECK_FAILED = 3  # everything flew, but a check of the result failed (an acceptance check, a waypoint missed)
INTERRUPTED = 130  # Ctrl-C (the shell's status for a command stopped by SIGINT)


def epilog(ok: str, failed: str | None = None, check_failed: str | None = None) -> str:
    """The --help's closing paragraph: each status the command can end with, and what it means for it."""
    statuses = [(OK, ok), (FAILED, failed), (USAGE, "bad arguments or input, refused in one line before anything "
                "runs"), (CHECK_FAILED, check_failed), (INTERRUPTED, "interrupted (Ctrl-C)")]  # fmt: skip
    return "exit status: " + "; ".join(f"{code} {meaning}" for code, meaning in statuses if meaning) + "."
