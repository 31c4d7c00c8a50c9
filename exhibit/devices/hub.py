"""All configured devices at once: open them, poll them all without blocking, merge events.

One faulty backend never stops the others: a device that is absent waits (WAITING if it was
never connected, LOST if it went away), and an unexpected exception from a backend (a bug, a
driver surprise) is caught, shown in its status and the backend is reopened later, because on
a museum floor a frozen exhibit is worse than a missing knob.
The traceback of such an exception is logged once per backend and kind of exception, not at
every poll or reopen (every 2 s for as long as the bug lasts, which on an unattended kiosk can be
months); later ones only count up in the backend's status detail.
"""

from __future__ import annotations

import contextlib
import logging
import time

from exhibit.devices.base import Backend, Clock, DeviceError, Event, State

from exhibit.devices.config import DeviceConfig
from exhibit.devices.keyboard import KeyboardBackend
from exhibit.devices.url import backend_for_url

__all__ = ["DeviceSet"]

log = logging.getLogger("exhibit.devices")
#: Seconds before a backend that raised is reopened.
RETRY_S = 2.0


class DeviceSet:
    def __init__(
        self, config: DeviceConfig, clock: Clock = time.monotonic, hid_api: object | None = None
    ) -> None:
        self.config = config
        self.clock = clock
        # construct every backend first: a bad URL or layout fails before anything is opened
        self.backends: list[Backend] = [
            backend_for_url(url, name, clock=clock, layout_dirs=config.layout_dirs, hid_api=hid_api)
            for name, url in config.devices.items()
        ]
        self._broken: dict[int, float] = {}
        self._errors: dict[int, int] = {}  # backend index -> exceptions so far
        self._logged: set[tuple[int, str]] = set()  # (index, exception type) with a traceback

    def open(self) -> DeviceSet:
        for i, b in enumerate(self.backends):
            self._guard(i, b.open)
        return self

    def _guard(self, i: int, fn):
        try:
            return fn()
        except Exception as exc:  # noqa: BLE001 - one device's bug must not stop the exhibit
            b = self.backends[i]
            with contextlib.suppress(Exception):  # a closing device's own error changes nothing
                b.close()
            count = self._errors[i] = self._errors.get(i, 0) + 1
            known = isinstance(exc, DeviceError)  # a problem a person fixes: no traceback
            if (i, type(exc).__name__) not in self._logged:
                self._logged.add((i, type(exc).__name__))
                log.error(
                    "device %s (%s): %s, retried every %g s (logged once; the count is "
                    "in its status)",
                    b.name,
                    b.url,
                    exc if known else "backend error",
                    RETRY_S,
                    exc_info=None if known else exc,
                )
            b.state = State.LOST  # WAITING if never connected; the absence runs on across reopens
            b.detail = (f"{exc}" if known else f"backend error: {type(exc).__name__}: {exc}") + (
                f" ({count} so far)" if count > 1 else ""
            )
            self._broken[i] = self.clock() + RETRY_S
            return None

    def poll(self) -> list[Event]:
        out: list[Event] = []
        for i, b in enumerate(self.backends):
            if i in self._broken:
                if self.clock() < self._broken[i]:
                    continue
                del self._broken[i]
                self._guard(i, b.open)
                continue
            events = self._guard(i, b.poll)
            if events:
                out += events
        return out

    def close(self) -> None:
        for b in self.backends:
            with contextlib.suppress(Exception):  # a closing device's own error changes nothing
                b.close()

    def statuses(self, now: float | None = None) -> list[dict]:
        """Every backend's status(); ``now`` (on ``clock``) if the caller has read it."""
        now = self.clock() if now is None else now
        return [b.status(now) for b in self.backends]

    @property
    def keyboard(self) -> KeyboardBackend | None:
        """The keyboard backend, for the window owner to feed."""
        return next((b for b in self.backends if isinstance(b, KeyboardBackend)), None)

    def __enter__(self) -> DeviceSet:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()
