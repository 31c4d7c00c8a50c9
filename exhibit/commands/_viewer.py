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

from exhibit.devices.config import DeviceConfig
from exhibit.devices.keyboard import KeyboardBackend, key_name
from exhibit.devices.mapping import Mapper
from exhibit.devices.url import parse_url

#: The viewer's own keys (the shipped keyboard mapping leaves them free).
DEPTH_KEY, QUIT_KEY = "c", "escape"


class StaffControls:
    """Keys in, views out: every ``keyboard://`` device of ``config`` and its bindings, read from
    one keyboard."""

    def __init__(self, config: DeviceConfig, home, clock=time.monotonic):
        names = [n for n, url in config.devices.items() if parse_url(url)[0] == "keyboard"]
        name = names[0] if names else "keyboard"
        binds = tuple(dataclasses.replace(b, device=name) for b in config.mapping.bindings
                      if b.device in names)
        self.mapper = Mapper(dataclasses.replace(config.mapping, bindings=binds))
        self.keyboard = KeyboardBackend(name=name, clock=clock).open()
        self.home = home
        self.depth_colour = False
        self.quit = False

    def key(self, name: str, pressed: bool) -> None:
        """A key went down or up (auto-repeats are the caller's to drop)."""
        name = name.lower()
        if name == QUIT_KEY:
            self.quit = self.quit or pressed
        elif name == DEPTH_KEY:
            self.depth_colour ^= pressed
        else:
            self.keyboard.key(name, pressed)

    def step(self, view, now: float):
        """The view after the keys since the last step, at time ``now``."""
        events = self.keyboard.poll()
        view = self.mapper.apply(view, events, now)
        return self.home if self.mapper.pressed(events, "home") else view


def run(window, gpu, view, hud, config: DeviceConfig, options) -> None:
    """Draw ``view`` in ``window`` and let the keys drive it until the window is closed or
    Escape is pressed."""
    glfw = window._glfw
    controls = StaffControls(config, view)

    def on_key(_window, key, _scancode, action, _mods):
        name = key_name(glfw, key)
        if name and action != glfw.REPEAT:
            controls.key(name, action == glfw.PRESS)

    def on_focus(_window, focused):
        if not focused:
            controls.keyboard.release_all()

    window.callbacks = (on_key, on_focus)  # pyGLFW keeps no reference of its own
    glfw.set_key_callback(window.handle, on_key)
    glfw.set_window_focus_callback(window.handle, on_focus)
    while not window.should_close and not controls.quit:
        view = controls.step(view, time.monotonic())
        window.draw(gpu, view, dataclasses.replace(options, depth_colour=controls.depth_colour),
                    hud)
        window.swap()
