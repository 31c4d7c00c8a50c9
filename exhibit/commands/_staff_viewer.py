"""The staff viewer's controls (`exhibit render SCENE --window`): the keys of the kiosk's
``keyboard://`` device, through the same mapping, so what staff try at a desk is what a visitor
gets at the exhibit (q/a w/s e/d r/f t/g y/h turn θ1..θ6, u/j move the sensor, space = home).

Home returns to the view the viewer opened with (the scene's start view, or the figure's). The
viewer shows one scene, so the next-scene key does nothing here. Two keys are the viewer's own and
are not bound in the shipped mapping: c toggles colouring by 4D depth, Escape closes the window.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterable

from exhibit.devices.base import Clock
from exhibit.devices.config import DeviceConfig
from exhibit.devices.keyboard import KeyboardBackend
from exhibit.devices.mapping import Mapper
from exhibit.devices.url import parse_url
from exhibit.geometry.view import ViewState
from exhibit.render.frame_request import FrameRequest
from exhibit.render.target import Focus, Key

#: The viewer's own keys (the shipped keyboard mapping leaves them free).
DEPTH_KEY, QUIT_KEY = "c", "escape"


class StaffControls:
    """Keys in, views out: every ``keyboard://`` device of ``config`` and its bindings, read from
    one keyboard."""

    def __init__(
        self, config: DeviceConfig, home: ViewState, clock: Clock = time.monotonic
    ) -> None:
        names = [n for n, url in config.devices.items() if parse_url(url)[0] == "keyboard"]
        name = names[0] if names else "keyboard"
        binds = tuple(
            dataclasses.replace(b, device=name)
            for b in config.mapping.bindings
            if b.device in names
        )
        self.mapper = Mapper(dataclasses.replace(config.mapping, bindings=binds))
        self.keyboard = KeyboardBackend(name=name, clock=clock).open()
        self.home = home
        self.depth_colour = False
        self.quit = False

    def key(self, name: str, pressed: bool, mods: Iterable[str] = frozenset()) -> None:
        """A key went down or up (auto-repeats are the caller's to drop); a view key with
        Ctrl, Alt or Super held does nothing, as in the kiosk."""
        name = name.lower()
        if name == QUIT_KEY:
            self.quit = self.quit or pressed
        elif name == DEPTH_KEY:
            self.depth_colour ^= pressed
        else:
            self.keyboard.key(name, pressed, mods=mods)

    def step(self, view: ViewState, now: float) -> ViewState:
        """The view after the keys since the last step, at time ``now``."""
        events = self.keyboard.poll()
        view = self.mapper.apply(view, events, now)
        return self.home if self.mapper.pressed(events, "home") else view


def run(window, gpu, view, hud, config: DeviceConfig, options) -> None:
    """Draw ``view`` in ``window`` and let the keys drive it until the window is closed or
    Escape is pressed."""
    controls = StaffControls(config, view)

    def on_input(event) -> None:
        if isinstance(event, Key):
            controls.key(event.name, event.pressed, event.mods)
        elif isinstance(event, Focus) and not event.focused:
            controls.keyboard.release_all()

    window.set_input(on_input)
    while not window.should_close and not controls.quit:
        view = controls.step(view, time.monotonic())
        shown = dataclasses.replace(options, depth_colour=controls.depth_colour)
        window.draw(FrameRequest(gpu, view, shown, hud))
        window.swap()
