"""Recording and replay of input sessions (``exhibit record``, ``replay://FILE``).

The file is JSON lines: a header ``{"exhibit_recording": 1, "devices": {name: url}}``, then one
event per line, ``t`` in seconds from the start of the recording. Events keep their device names,
so a replayed session drives the same bindings as the live one, and replaying it on a fixed clock
gives the same ViewStates every time (the tests check this).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass

from pathlib import Path

from exhibit.devices.base import (
    Backend,
    Capabilities,
    DeviceError,
    Event,
    Kind,
    State,
    release_events,
)
from exhibit.errors import ConfigError
from exhibit.schema import read_text

__all__ = ["Recorder", "ReplayBackend", "read_recording", "FORMAT"]

FORMAT = 1
#: A recording is read whole; an hour of busy input is a few megabytes.
MAX_RECORDING_BYTES = 64 << 20
#: An axis is in [-1, 1], a detent count small: anything larger is corrupt.
MAX_EVENT_VALUE = 1e4


class Recorder:
    """Writes events as they are polled; ``t`` relative to the first ``start``."""

    def __init__(self, path: str | Path, devices: dict[str, str], t0: float):
        self.path = Path(path)
        try:
            self._f = open(self.path, "w")  # noqa: SIM115 - open while recording; close()
        except OSError as exc:
            raise DeviceError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        self.t0 = t0
        self.count = 0
        self._f.write(json.dumps({"exhibit_recording": FORMAT, "devices": devices}) + "\n")

    def write(self, events: Iterable[Event]) -> None:
        for e in events:
            d = e.to_dict()
            d["t"] = round(e.t - self.t0, 6)
            self._f.write(json.dumps(d) + "\n")
            self.count += 1

    def close(self) -> None:
        self._f.close()


def read_recording(path: Path) -> tuple[dict, list[Event]]:
    """(header, events sorted by time); DeviceError names the file and line of a bad entry."""
    try:
        lines = read_text(path, MAX_RECORDING_BYTES).splitlines()
    except ConfigError as exc:
        raise DeviceError(f"recording {exc}") from None
    try:
        header = json.loads(lines[0]) if lines else None
    except (ValueError, RecursionError):
        header = None
    if not isinstance(header, dict) or header.get("exhibit_recording") != FORMAT:
        raise DeviceError(
            f"{path} line 1: not an exhibit recording (expected the header "
            f'{{"exhibit_recording": {FORMAT}, ...}})'
        )
    events = []
    for n, line in enumerate(lines[1:], 2):
        if not line.strip():
            continue
        try:
            e = Event.from_dict(json.loads(line))
            if not 0 <= e.t <= 1e7:
                raise ValueError(f"time {e.t} is not in [0, 1e7] s")
            if not (math.isfinite(e.value) and abs(e.value) <= MAX_EVENT_VALUE):
                raise ValueError(
                    f"value {e.value} is not a finite number within ±{MAX_EVENT_VALUE:g}"
                )
            if not 0 <= e.index < 256:
                raise ValueError(f"index {e.index} is not in 0..255")
        except (ValueError, KeyError, TypeError, OverflowError, RecursionError) as exc:
            raise DeviceError(f"{path} line {n}: bad event ({exc})") from None
        events.append(e)
    events.sort(key=lambda e: e.t)
    return header, events


@dataclass
class ReplayBackend(Backend):
    """``replay://FILE[?speed=X&loop=1]``: the recorded events, re-timed from ``open``."""

    file: Path = Path()
    speed: float = 1.0
    loop: bool = False

    def __post_init__(self) -> None:
        self.url = self.url or f"replay://{self.file}"
        self.events: list[Event] = []
        self._i = 0
        self._t0 = 0.0
        self._axes: dict[tuple[str, int], float] = {}
        self._buttons: dict[tuple[str, int], float] = {}
        self._finished = False

    def _open(self) -> None:
        header, self.events = read_recording(self.file)
        n = {k: 1 + max((e.index for e in self.events if e.kind is k), default=-1) for k in Kind}
        self.capabilities = Capabilities(n[Kind.ABS], n[Kind.REL], n[Kind.BUTTON])
        self._i, self._t0 = 0, self.clock()
        self._finished = False
        self.state = State.CONNECTED
        self.detail = f"{len(self.events)} events from {self.file}"

    def _close(self) -> None:
        self.events = []

    def _poll(self) -> list[Event]:
        now = self.clock()
        out = []
        while self.events:
            if self._i >= len(self.events):
                if not self.loop:
                    break
                out += self._release(self._t0 + self.events[-1].t / self.speed)
                self._t0 += self.events[-1].t / self.speed + 0.001
                self._i = 0
            e = self.events[self._i]
            t = self._t0 + e.t / self.speed
            if t > now:
                break
            self._i += 1
            key = (e.device, e.index)
            if e.kind is Kind.ABS:
                self._axes[key] = e.value
            elif e.kind is Kind.BUTTON:
                self._buttons[key] = e.value
            out.append(Event(t, e.device, e.kind, e.index, e.value))
        if self._i >= len(self.events) and not self.loop and not self._finished:
            self._finished = True
            out += self._release(now)
            self.detail = f"finished {self.file}"
        return out

    def _release(self, t: float) -> list[Event]:
        out = []
        for (dev, i), v in sorted(self._axes.items()):
            if v:
                out += release_events(t, dev, {i: v}, {})
        for (dev, i), v in sorted(self._buttons.items()):
            if v:
                out += release_events(t, dev, {}, {i: v})
        self._axes.clear()
        self._buttons.clear()
        return out
