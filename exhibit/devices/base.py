"""The one interface every input backend implements, and the events they produce.

A backend is polled by the render loop, so ``poll()`` must never block: it returns whatever
arrived since the last call (possibly nothing) as timestamped :class:`Event` values. Faults never
escape as exceptions from ``poll()``: a backend that loses its device goes to ``LOST``, emits
release events (so a held stick does not keep spinning the view), and tries to come back by
itself; ``state`` and ``detail`` say what is going on for ``exhibit devices`` and the kiosk's
status line. A device that has not been seen since the backend was opened is ``WAITING``, not
``LOST``: the base class tells the two apart, and keeps the time of each change of state, so
the health file can say how long a device has been missing (``exhibit status --max-lost``).
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, field
from typing import Self
from collections.abc import Callable

from exhibit.errors import ConfigError, ExhibitError

__all__ = [
    "DeviceError",
    "State",
    "MISSING",
    "Kind",
    "Event",
    "Capabilities",
    "Backend",
    "Clock",
    "release_events",
]

Clock = Callable[[], float]


class DeviceError(ExhibitError):
    """A device problem a person can fix: a bad URL, a bad layout or config, a missing port."""


class DeviceConfigError(DeviceError, ConfigError):
    """Problems in a device config or HID layout file, each ``file: key: reason``."""


class State(str, enum.Enum):
    """Where a backend stands.

    - ``CLOSED``: not opened, or closed.
    - ``WAITING``: opened, and its device not connected once since: not plugged in, not found,
      no permission, or it never answered the handshake.
    - ``CONNECTING``: port open, first handshake not done yet.
    - ``CONNECTED``: delivering events.
    - ``LOST``: it was connected, then went away (unplugged, silent, a read error); retried.
    - ``RECONNECTING``: the port is back after a loss, handshake not done yet.

    A backend sets ``LOST`` whenever it does not have its device; :class:`Backend` reports that
    as ``WAITING`` until the device has been ``CONNECTED`` once.
    """

    CLOSED = "closed"
    WAITING = "waiting"
    CONNECTING = "connecting"
    CONNECTED = "connected"
    LOST = "lost"
    RECONNECTING = "reconnecting"


#: The states of an open backend whose device delivers nothing: it is missing.
MISSING = frozenset({State.WAITING, State.CONNECTING, State.LOST, State.RECONNECTING})


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
        return {
            "t": round(self.t, 6),
            "device": self.device,
            "kind": self.kind.value,
            "index": self.index,
            "value": self.value,
        }

    @classmethod
    def from_dict(cls, d: dict) -> Event:
        return cls(
            float(d["t"]), str(d["device"]), Kind(d["kind"]), int(d["index"]), float(d["value"])
        )


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


def release_events(
    t: float, device: str, axes: dict[int, float], buttons: dict[int, float]
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

    ``state`` is a property: setting it records when the state changed (``state_seconds``),
    since when the device has been missing (``missing_seconds``: since it was last connected,
    or since it was opened if it never was), and turns ``LOST`` into ``WAITING`` for a device
    never connected. Closing and reopening into the state it had before the close (DeviceSet
    does that after a backend raised) continues that state: a device that keeps failing does
    not look newly lost every two seconds.
    """

    name: str = "device"
    clock: Clock = field(default=time.monotonic, repr=False)
    #: True once the device has been CONNECTED (kept across close and reopen)
    ever_connected: bool = field(default=False, init=False)
    _state: State = field(default=State.CLOSED, init=False, repr=False)
    _state_since: float | None = field(default=None, init=False, repr=False)
    _missing_since: float | None = field(default=None, init=False, repr=False)
    _before_close: tuple = field(default=(State.CLOSED, None), init=False, repr=False)
    #: one line on the last problem or the device's identity, for people
    detail: str = field(default="", init=False)
    url: str = field(default="", init=False)

    capabilities: Capabilities = field(default_factory=Capabilities, init=False)

    @property
    def state(self) -> State:
        return self._state

    @state.setter
    def state(self, value: State) -> None:
        value = State(value)
        if value is State.LOST and not self.ever_connected:
            value = State.WAITING
        old = self._state
        if value is old:
            return
        now = self.clock()
        if value is State.CLOSED:
            self._before_close = (old, self._state_since)
            self._state_since = now
        elif old is State.CLOSED and self._before_close[0] is value:
            self._state_since = self._before_close[1]  # reopened into the same state
        else:
            self._state_since = now
        if value is State.CONNECTED:
            self.ever_connected = True
            self._missing_since = None
        elif value is not State.CLOSED and self._missing_since is None:
            self._missing_since = now  # CLOSED keeps it: a reopen continues the same absence
        self._state = value

    def state_seconds(self, now: float | None = None) -> float | None:
        """Seconds in the current state (on ``clock``); None before the first change."""
        if self._state_since is None:
            return None
        return max(0.0, (self.clock() if now is None else now) - self._state_since)

    def missing_seconds(self, now: float | None = None) -> float | None:
        """Seconds the device has been missing (a MISSING state): since it was last connected,
        or since the backend was opened if it never was. None when connected or closed."""
        if self._state not in MISSING or self._missing_since is None:
            return None
        return max(0.0, (self.clock() if now is None else now) - self._missing_since)

    def open(self) -> Self:
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

    def status(self, now: float | None = None) -> dict:
        """``state_s``: seconds in this state; ``missing_s``: seconds without the device (None
        when connected or closed); ``ever_connected``: whether it has been connected since it
        was first opened (``waiting`` or ``lost``). ``now``: the time on ``clock``, if the
        caller has read it already."""
        now = self.clock() if now is None else now
        state_s, missing_s = self.state_seconds(now), self.missing_seconds(now)
        return {
            "name": self.name,
            "url": self.url,
            "state": self.state.value,
            "detail": self.detail,
            "capabilities": self.capabilities.to_dict(),
            "state_s": None if state_s is None else round(state_s, 3),
            "missing_s": None if missing_s is None else round(missing_s, 3),
            "ever_connected": self.ever_connected,
        }

    def __enter__(self) -> Backend:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- for subclasses
    def _open(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _close(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _poll(self) -> list[Event]:  # pragma: no cover - abstract
        raise NotImplementedError
