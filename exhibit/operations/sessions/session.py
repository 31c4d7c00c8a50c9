"""One visitor session as stored, and which events count as a visitor using a control: the row
format the recorder fills, the writer stores and `exhibit stats` reads back."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from exhibit.devices.base import Event, Kind

#: An ABS control counts as used past this deflection (a real push, never noise or drift).
STICK_USED = 0.5
#: What a kind of control is called in the inputs list.
KIND_NAMES = {Kind.REL: "knob", Kind.ABS: "stick", Kind.BUTTON: "button"}
#: Lists longer than this are cut (a fuzzing device with a thousand names must not bloat rows).
MAX_ITEMS = 64


@dataclass
class Session:
    """One visitor session, as stored."""

    start: float
    end: float
    duration_s: float
    active_s: float
    utc_offset_s: int
    language: str = "en"
    scenes: list[str] = field(default_factory=list)
    inputs: list[str] = field(default_factory=list)

    def row(self) -> tuple:
        return (
            self.start,
            self.end,
            self.duration_s,
            self.active_s,
            self.utc_offset_s,
            self.language,
            json.dumps(self.scenes[:MAX_ITEMS]),
            json.dumps(self.inputs[:MAX_ITEMS]),
        )

    @property
    def local_start(self) -> float:
        """Seconds since 1970-01-01 00:00 in the kiosk's local time: day and hour buckets."""
        return self.start + self.utc_offset_s


def input_name(event: Event) -> str | None:
    """What an event says was used ("controller.stick"), or None if it is no real use: a knob
    that did not move, a button released, a stick within STICK_USED of rest."""
    if event.kind is Kind.ABS:
        if abs(event.value) < STICK_USED:
            return None
    elif not event.value or (event.kind is Kind.BUTTON and event.value < 0):
        return None
    return f"{event.device}.{KIND_NAMES.get(event.kind, str(event.kind.value))}"
