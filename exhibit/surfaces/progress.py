"""Progress of long mesh builds, for people at a terminal; silent unless a command turns it on."""

from __future__ import annotations

import sys
import time
from typing import Literal

_enabled = False
_last = 0.0


def enable(on: bool = True) -> None:
    global _enabled
    _enabled = on


def report(message: str) -> None:
    """Show one line, overwritten by the next, at most ten times a second."""
    global _last
    if not _enabled:
        return
    now = time.monotonic()
    if now - _last < 0.1:
        return
    _last = now
    sys.stderr.write(f"\r\x1b[K{message}")
    sys.stderr.flush()


def done() -> None:
    if _enabled:
        sys.stderr.write("\r\x1b[K")
        sys.stderr.flush()


class on_terminal:
    """Context manager: show build progress while the block runs, if stderr is a terminal."""

    def __enter__(self) -> on_terminal:
        enable(sys.stderr.isatty())
        return self

    def __exit__(self, *exc: object) -> Literal[False]:
        done()
        enable(False)
        return False
