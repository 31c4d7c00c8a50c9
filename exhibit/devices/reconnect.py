"""The reconnecting backend: what every device that can be unplugged shares.

The serial controller and the HID devices differ only in their I/O (a port and a handshake; a
hidapi handle and report layouts). Everything around it is one piece of logic, here:

- the state: WAITING until the device is first seen, then CONNECTED (or the subclass's own
  handshake states), LOST when it goes away (Backend.state keeps the times);
- the retry: a missing device is looked for again every ``retry_s`` from ``poll()``, never by
  blocking, and each success after a loss counts in ``reconnects``;
- the release: when a device is lost, every axis it deflected is zeroed and every button it
  held released, so nothing it held keeps turning the view;
- the event queue the subclass appends to between polls.

A subclass implements ``_connect(now)`` (try to open; None on success, else why not, for people),
``_disconnect()`` (release the handle; safe when there is none), ``_connected()`` (is there a
handle?) and ``_read(now)`` (what arrived, appended to ``_pending``; call ``_lost`` on a fault).
"""

from __future__ import annotations

from dataclasses import dataclass

from exhibit.devices.base import Backend, Event, State, release_events

__all__ = ["ReconnectingBackend"]


@dataclass
class ReconnectingBackend(Backend):
    #: Seconds between two attempts to find a missing device.
    retry_s: float = 0.5

    def __post_init__(self) -> None:
        self.reconnects = 0
        self._axes: dict[int, float] = {}
        self._buttons: dict[int, float] = {}
        self._pending: list[Event] = []
        self._next_retry = 0.0

    # ---- Backend

    def _open(self) -> None:
        self._attempt(self.clock())

    def _close(self) -> None:
        self._disconnect()
        self._pending.clear()

    def _poll(self) -> list[Event]:
        now = self.clock()
        if not self._connected():
            if now >= self._next_retry:
                self._attempt(now)
            if not self._connected():
                return self._take()
        self._read(now)
        return self._take()

    # ---- shared

    def _attempt(self, now: float) -> None:
        """Try to open the device; on failure LOST (WAITING if never connected) with why."""
        self._next_retry = now + self.retry_s
        was_connected = self.ever_connected
        problem = self._connect(now)
        if problem is not None:
            self.state = State.LOST
            self.detail = problem
            return
        if was_connected:
            self.reconnects += 1

    def _lost(self, now: float, why: str) -> None:
        """The device went away: drop the handle, release what it held, look for it again."""
        self._disconnect()
        self.state = State.LOST
        self.detail = why
        self._next_retry = now + self.retry_s
        self._release(now)

    def _release(self, now: float) -> None:
        """Zero every deflected axis and release every held button (events at ``now``)."""
        self._pending += release_events(now, self.name, self._axes, self._buttons)
        self._axes.clear()
        self._buttons.clear()

    def _take(self) -> list[Event]:
        out, self._pending = self._pending, []
        return out

    # ---- for subclasses

    def _connect(self, now: float) -> str | None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _disconnect(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _connected(self) -> bool:  # pragma: no cover - abstract
        raise NotImplementedError

    def _read(self, now: float) -> None:  # pragma: no cover - abstract
        raise NotImplementedError
