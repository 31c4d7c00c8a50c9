"""The one interface every input backend implements, and the events they produce.

A backend is polled by the render loop, so ``poll()`` must never block: it returns whatever
arrived since the last call (possibly nothing) as timestamped :class:`Event` values. Faults never
escape as exceptions from ``poll()``: a backend that loses its device goes to ``LOST``, emits
release events (so a held stick does not keep spinning the view), and tries to come back by
itself; ``state`` and ``detail`` say what is going on for ``exhibit devices`` and the kiosk's
status line.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, field
from typing import Callable

from exhibit.errors import ExhibitError

__all__ = ["DeviceError", "State", "Kind", "Event", "Capabilities", "Backend", "Clock",
           "release_events"]

Clock = Callable[[], float]


class DeviceError(ExhibitError):
    """A device problem a person can fix: a bad URL, a bad layout or config, a missing port."""


class State(str, enum.Enum):
    """Where a backend stands. ``CONNECTING``: port open, handshake not done yet."""

    CLOSED = "closed"
    CONNECTING = "connecting"
    CONNECTED = "connected"
    LOST = "lost"
    RECONNECTING = "reconnecting"


class Kind(str, enum.Enum):
    """What an event's value means.

    - ``REL``: a relative step (knob detents, mouse pixels); the mapping adds it once.
    - ``ABS``: an absolute deflection in [-1, 1] that holds until the next ABS event of the same
      channel; the mapping integrates it over time as a rate.
    - ``BUTTON``: 1.0 pressed, 0.0 released.
    """

    REL = "rel"
    ABS = "abs"
    BUTTON = "button"


@dataclass(frozen=True, slots=True)
class Event:
    """One input change. ``t`` is on the host's monotonic clock (seconds); a backend whose device
    has its own clock (the controller's t_ms) maps it onto that timeline so rates integrate with
    the device's sampling instants, not with USB arrival jitter."""

    t: float
    device: str
    kind: Kind
    index: int
    value: float

    def to_dict(self) -> dict:
        return {"t": round(self.t, 6), "device": self.device, "kind": self.kind.value,
                "index": self.index, "value": self.value}

    @classmethod
    def from_dict(cls, d: dict) -> "Event":
        return cls(float(d["t"]), str(d["device"]), Kind(d["kind"]), int(d["index"]),
                   float(d["value"]))


@dataclass(frozen=True)
class Capabilities:
    """What a backend can deliver: the number of channels of each kind."""

    axes: int = 0
    deltas: int = 0
    buttons: int = 0

    def to_dict(self) -> dict:
        return {"axes": self.axes, "deltas": self.deltas, "buttons": self.buttons}

    def count(self, kind: Kind) -> int:
        return {Kind.ABS: self.axes, Kind.REL: self.deltas, Kind.BUTTON: self.buttons}[kind]


def release_events(t: float, device: str, axes: dict[int, float], buttons: dict[int, float]
                   ) -> list[Event]:
    """Zero every deflected axis and release every pressed button: sent when a device is lost,
    so nothing it held keeps acting on the view."""
    out = [Event(t, device, Kind.ABS, i, 0.0) for i, v in sorted(axes.items()) if v]
    out += [Event(t, device, Kind.BUTTON, i, 0.0) for i, v in sorted(buttons.items()) if v]
    return out


@dataclass
class Backend:
    """Base of all backends. Subclasses implement ``_open``, ``_close`` and ``_poll``; the public
    methods add the bookkeeping every backend shares.

    ``name`` tags the events (the mapping binds to it); ``clock`` is injectable so tests and
    replays run on simulated time instead of sleeping.
    """

    name: str = "device"
    clock: Clock = field(default=time.monotonic, repr=False)
    state: State = field(default=State.CLOSED, init=False)
    #: one line on the last problem or the device's identity, for people
    detail: str = field(default="", init=False)
    url: str = field(default="", init=False)

    capabilities: Capabilities = field(default_factory=Capabilities, init=False)

    def open(self) -> "Backend":
        """Start using the device. A device that is absent is not an error for a backend that
        can wait for it (state LOST, retried by ``poll``); a bad configuration is."""
        self._open()
        return self

    def close(self) -> None:
        """Release every resource (ports, file descriptors, threads); safe to call twice."""
        if self.state is not State.CLOSED:
            self._close()
        self.state = State.CLOSED

    def poll(self) -> list[Event]:
        """Events since the last call; never blocks, never raises for device faults."""
        if self.state is State.CLOSED:
            return []
        return self._poll()

    def status(self) -> dict:
        return {"name": self.name, "url": self.url, "state": self.state.value,
                "detail": self.detail, "capabilities": self.capabilities.to_dict()}

    def __enter__(self) -> "Backend":
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    # -- for subclasses
    def _open(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _close(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _poll(self) -> list[Event]:  # pragma: no cover - abstract
        raise NotImplementedError
