"""``keyboard://``: keys and mouse as an input device, for development and as a fallback.

Devices know nothing of windows: whoever owns the window (the kiosk's GLFW loop, a test) feeds
key and mouse events in with :meth:`KeyboardBackend.key`, :meth:`drag` and :meth:`scroll`, and
the backend turns them into the same events a controller would produce, so the mapping and the
idle logic treat them alike. Key names are lower-case (GLFW's key names: "q", "space", "up").

Default keys: seven axes, each a pair of keys (+ / -), held keys give full deflection:
``q/a w/s e/d r/f t/g y/h`` -> axes 1..6, ``u/j`` -> axis 7; mouse drag -> delta 1 (x) and
delta 2 (y) in pixels; scroll wheel -> delta 3 in clicks; space -> button 1, n -> button 2, l ->
button 3, v -> button 4 (the shipped mapping: home, next scene, next language, listen).

:func:`key_name` is the window side's half: a GLFW key code to the name used here, so the kiosk
and the staff viewer (`exhibit render --window`) read the same keys the same way.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from types import ModuleType


from exhibit.devices.base import Backend, Capabilities, Event, Kind, State

__all__ = ["KeyboardBackend", "DEFAULT_KEYS", "BUTTON_KEYS", "key_name"]

#: key -> (axis, direction)
DEFAULT_KEYS = {
    k: (i, d)
    for i, pair in enumerate(("qa", "ws", "ed", "rf", "tg", "yh", "uj"))
    for k, d in zip(pair, (1.0, -1.0))
}
BUTTON_KEYS = {"space": 0, "n": 1, "l": 2, "v": 3}
#: GLFW key names for keys that have none of their own (glfw.get_key_name gives None for them).
SPECIAL_KEYS = {
    "SPACE": "space",
    "ESCAPE": "escape",
    "UP": "up",
    "DOWN": "down",
    "LEFT": "left",
    "RIGHT": "right",
}


def key_name(glfw: ModuleType, key: int) -> str | None:
    """The name of GLFW key code ``key`` as :meth:`KeyboardBackend.key` takes it (the
    layout's printable name, else a special key's), or None for a key with neither. ``glfw``
    is the module, passed in: devices do not import the window system."""
    name = glfw.get_key_name(key, 0)
    if name:
        return name.lower()
    for special, text in SPECIAL_KEYS.items():
        if key == getattr(glfw, f"KEY_{special}", None):
            return text
    return None


@dataclass
class KeyboardBackend(Backend):
    keys: dict[str, tuple[int, float]] = field(default_factory=lambda: dict(DEFAULT_KEYS))

    def __post_init__(self) -> None:
        self.url = self.url or "keyboard://"
        n = max((i for i, _ in self.keys.values()), default=-1) + 1
        self.capabilities = Capabilities(axes=n, deltas=3, buttons=len(BUTTON_KEYS))
        self._queue: deque[Event] = deque(maxlen=4096)  # a stalled consumer cannot grow it
        self._down: set[str] = set()
        self._axes: dict[int, float] = {}

    def _open(self) -> None:
        self.state = State.CONNECTED
        self.detail = "keys and mouse from the window"

    def _close(self) -> None:
        self._queue.clear()
        self._down.clear()
        self._axes.clear()

    def _poll(self) -> list[Event]:
        out = list(self._queue)
        self._queue.clear()
        return out

    def _t(self, t: float | None) -> float:
        return self.clock() if t is None else t

    def key(
        self, name: str, pressed: bool, t: float | None = None, mods: Iterable[str] = ()
    ) -> None:
        """A key went down or up (repeats of a held key are harmless); ``mods``: the modifiers
        held ("ctrl", "alt", "shift", "super"). A press with any modifier but Shift is a
        shortcut meant for someone else (Ctrl+Q, Alt+Tab, the staff's quit combination), not
        a visitor at the knobs: it is dropped. A release always counts, so a key pressed
        before the modifier never sticks."""
        if pressed and set(mods) - {"shift"}:
            return
        name = name.lower()
        if name in BUTTON_KEYS and pressed != (name in self._down):
            self._queue.append(
                Event(
                    self._t(t),
                    self.name,
                    Kind.BUTTON,
                    BUTTON_KEYS[name],
                    1.0 if pressed else 0.0,
                )
            )
        (self._down.add if pressed else self._down.discard)(name)
        if name not in self.keys:
            return
        axis = self.keys[name][0]
        v = sum(d for k, (i, d) in self.keys.items() if i == axis and k in self._down)
        if self._axes.get(axis, 0.0) != v:
            self._axes[axis] = v
            self._queue.append(Event(self._t(t), self.name, Kind.ABS, axis, v))

    def release_all(self, t: float | None = None) -> None:
        """The window lost focus: nothing stays held."""
        for name in sorted(self._down):
            self.key(name, False, t)

    def drag(self, dx: float, dy: float, t: float | None = None) -> None:
        for i, v in ((0, dx), (1, dy)):
            if v:
                self._queue.append(Event(self._t(t), self.name, Kind.REL, i, float(v)))

    def scroll(self, clicks: float, t: float | None = None) -> None:
        if clicks:
            self._queue.append(Event(self._t(t), self.name, Kind.REL, 2, float(clicks)))
