"""Keys, focus and close requests from the kiosk's window (exhibit.render.target's events):
visitors cannot close the exhibit (Alt+F4, the compositor), staff quit with the maintenance
combination, and a focus loss releases every held key."""

from __future__ import annotations

import logging

from exhibit.devices.hub import DeviceSet
from exhibit.render.target import CloseRequest, Focus, InputEvent, Key, RenderTarget

log = logging.getLogger("exhibit.kiosk")


class WindowInput:
    """Installed on ``window`` at once; ``quit`` turns True at the maintenance combination
    ``quit_keys``. Keys go to the keyboard among ``devices`` (if one is configured)."""

    def __init__(
        self, window: RenderTarget, devices: DeviceSet, quit_keys: tuple[str, ...]
    ) -> None:
        self.devices = devices
        self.quit_keys = quit_keys
        self.quit = False
        window.hide_cursor()
        window.close_allowed = False
        window.set_input(self)

    def __call__(self, event: InputEvent) -> None:
        keyboard = self.devices.keyboard
        if isinstance(event, Key):
            if keyboard is not None:
                keyboard.key(event.name, event.pressed, mods=event.mods)
            quit_combo = set(self.quit_keys)
            if event.pressed and quit_combo and quit_combo == event.mods | {event.name.lower()}:
                log.info("maintenance key combination: quitting")
                self.quit = True
        elif isinstance(event, Focus):
            log.info("the window %s the input focus", "has" if event.focused else "lost")
            if not event.focused and keyboard is not None:
                keyboard.release_all()
        elif isinstance(event, CloseRequest):
            log.info(
                "the window system asked to close: ignored (staff quit with %s)",
                "+".join(self.quit_keys),
            )
