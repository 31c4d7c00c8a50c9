"""Progress of a long command, for the person who runs it: one way, tqdm on stderr.

Two shapes of work:

- :class:`Progress` counts (frames rendered): a tqdm bar on a terminal, else a line every
  EVERY_S seconds ("rendering: 120/900 frames"); nothing for a job that ends sooner.
- :class:`on_terminal` shows uncounted work (a mesh build's stages, the scene being prepared):
  within the block, :func:`report` puts its text on one tqdm status line on a terminal, each
  text replacing the last (at most ten a second), the line cleared at the end; nothing
  elsewhere (a pipe, the service's journal), unless ``lines``: then each text is a line.

Code deep under a command (the mesh builder, exhibit.surfaces.implicit) calls :func:`report`
with no callback threaded to it: it reaches the innermost open status line through a context
variable, so a thread or a worker process that opened none stays silent. Callers that take a
``progress`` callback (the narration's preparation, a review's player) are handed
``report`` or a :class:`Progress`.
"""

from __future__ import annotations

import sys
import time
from contextvars import ContextVar, Token
from typing import Any, Literal

#: Counted work without a terminal: a line on stderr this often (seconds).
EVERY_S = 10.0
#: A status line changes at most this often (seconds).
STATUS_EVERY_S = 0.1


def _tqdm(**options: Any) -> Any:
    """A tqdm bar on stderr that leaves no line behind, or None in an environment from before
    tqdm was locked."""
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(leave=False, **options)


class Progress:
    """Counted work: call it with the count done since the last call; a context manager."""

    def __init__(self, total: int, what: str = "rendering", unit: str = "frames"):
        self.total, self.what, self.unit, self.done = total, what, unit, 0
        self._clock = time.monotonic
        self._next = self._clock() + EVERY_S
        self._stream = sys.stderr
        self._bar = _tqdm(total=total, desc=what, unit=unit[:-1]) if self._stream.isatty() else None

    def __call__(self, n: int = 1) -> None:
        self.done += n
        if self._bar is not None:
            self._bar.update(n)
            return
        now = self._clock()
        if now >= self._next:
            self._next = now + EVERY_S
            print(
                f"{self.what}: {self.done}/{self.total} {self.unit}",
                file=self._stream,
                flush=True,
            )

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()


class _Status:
    """One open status line (on_terminal)."""

    def __init__(self, lines: bool) -> None:
        self._stream = sys.stderr
        self._lines = lines
        self._last = -STATUS_EVERY_S
        self._bar = _tqdm(bar_format="{desc}") if self._stream.isatty() else None

    def report(self, text: str) -> None:
        if self._bar is not None:
            now = time.monotonic()
            if now - self._last < STATUS_EVERY_S:
                return
            self._last = now
            self._bar.set_description_str(text)
        elif self._lines:
            print(text, file=self._stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


_status: ContextVar[_Status | None] = ContextVar("exhibit_progress_status", default=None)


class on_terminal:
    """Context manager: a status line for :func:`report` while the block runs, if stderr is a
    terminal (``lines``: else each report as a line of its own)."""

    def __init__(self, lines: bool = False) -> None:
        self.lines = lines
        self._token: Token[_Status | None] | None = None
        self._line: _Status | None = None

    def __enter__(self) -> on_terminal:
        self._line = _Status(self.lines)
        self._token = _status.set(self._line)
        return self

    def __exit__(self, *exc: object) -> Literal[False]:
        if self._token is not None:
            _status.reset(self._token)
        if self._line is not None:
            self._line.close()
        return False


def report(text: str) -> None:
    """Show ``text`` on the innermost open status line (on_terminal); nothing without one."""
    line = _status.get()
    if line is not None:
        line.report(text)
