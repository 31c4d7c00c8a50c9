"""The running kiosk (exhibit.kiosk.app.Kiosk, unchanged) drawing into the headless EGL pipeline
on a clock the test sets, so a kiosk frame at a given moment of attract mode, of a visit or of
the idle glide is the same picture every run.

The kiosk draws into exhibit.render.target.HeadlessTarget: its own FramePipeline draws each frame
into an offscreen target the size of the screen, and the frame is read back as the screenshot
would be.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from exhibit.kiosk import app
from exhibit.kiosk.config import load_kiosk_config
from exhibit.review.setup import keyboard_only
from exhibit.render.layout import HudLayout
from exhibit.render.target import HeadlessTarget

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "configs"


class FakeClock:
    def __init__(self, t: float = 0.0):
        self.t = t

    def __call__(self) -> float:
        return self.t


def keyboard_devices(path: Path) -> Path:
    """The shipped device config with its keyboard only (no serial port or HID device is
    opened), the keyboard's bindings as shipped: the review player's own."""
    return keyboard_only(None, path)


@dataclass
class Shot:
    """One kiosk frame and what the checks need of it."""

    image: np.ndarray
    surfaces: np.ndarray  # the same view, surfaces alone on black
    layout: HudLayout
    labels: list
    drift: tuple[float, float]
    caption: str
    mode: str
    scene: str
    params: dict


class KioskRun:
    """A Kiosk on a headless window at ``size``, one shipped attract ``timeline`` (a file name in
    configs/attract) as its attract mode and its scene as the content, the shipped keyboard
    mapping as its only device, the shipped mesh resolutions, quality pinned (the governor would
    step on llvmpipe's timing, which no two runs share)."""

    def __init__(
        self, headless, tmp: Path, size: tuple[int, int], timeline: str, idle_timeout_s: float = 5.0
    ):
        attract = tmp / "attract"
        attract.mkdir()
        (attract / timeline).write_text((SHIPPED / "attract" / timeline).read_text())
        scene = tomllib.loads((attract / timeline).read_text())["scene"]
        keyboard_devices(tmp / "devices.toml")
        site = tmp / "kiosk.toml"
        site.write_text(f"""
[display]
size = [{size[0]}, {size[1]}]
[content]
scenes = ["{scene}"]
start_scene = "{scene}"
[devices]
config = "devices.toml"
[attract]
timelines = "attract"
idle_timeout_s = {idle_timeout_s}
blend_s = 2.0
[quality]
level = "fxaa"
""")
        self.config = load_kiosk_config(site)
        self.clock = FakeClock(0.0)
        self.window = HeadlessTarget(headless, size)
        self.kiosk = app.Kiosk(self.config, self.window, clock=self.clock)
        self.headless = headless

    def run_until(self, t: float, step: float = 0.1) -> None:
        """Frames every ``step`` seconds up to time ``t`` (as a kiosk at 10 fps would draw)."""
        while self.clock.t + step <= t + 1e-9:
            self.clock.t = round(self.clock.t + step, 6)
            self.kiosk.step()

    def key(self, name: str, pressed: bool) -> None:
        self.kiosk.devices.keyboard.key(name, pressed, t=self.clock())

    def shot(self) -> Shot:
        """The latest frame, with the surfaces drawn alone for the panel check."""
        from tests.golden.images import SURFACES_ONLY

        gpu, view, options, hud = self.window.drawn
        hud_state = self.headless.renderer.hud
        layout, labels = hud_state.layout, list(hud_state.labels)
        frame = self.kiosk.state.frame
        surfaces = self.headless.frame(
            gpu, view, self.window.size, SURFACES_ONLY, quality=options.quality
        )
        return Shot(
            self.window.image.copy(),
            surfaces,
            layout,
            labels,
            options.hud_drift,
            hud.caption,
            frame.mode,
            frame.scene,
            dict(frame.params),
        )

    def close(self) -> None:
        self.kiosk.devices.close()
        self.kiosk.release()
