"""The kiosk: a fullscreen window, the devices, attract mode and the watchdog, in one frame loop.

Everything slow happens before the first frame: meshes come from the cache (or are built once,
with progress), are uploaded to the GPU once, and devices are opened. Each frame then polls the
devices without blocking, steps the KioskState, draws, swaps (vsync paces the loop), pings the
systemd watchdog and, about once a second, writes the health file and the STATUS line.
"""

from __future__ import annotations

import logging
import math
import os
import resource
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from exhibit import scenes
from exhibit.devices.config import load_config
from exhibit.devices.hub import DeviceSet
from exhibit.devices.mapping import ActivityDetector, Mapper
from exhibit.errors import ExhibitError
from exhibit.kiosk.attract import Playlist, load_playlist
from exhibit.kiosk.config import KioskConfig
from exhibit.kiosk.state import KioskState
from exhibit.render.options import RenderOptions
from exhibit.render.renderer import HudInfo
from exhibit.scenes.cache import build_cached
from exhibit.surfaces import progress

log = logging.getLogger("exhibit.kiosk")

#: GLFW key names for keys that have none of their own (glfw.get_key_name gives None for them).
_SPECIAL_KEYS = {"SPACE": "space", "ESCAPE": "escape", "UP": "up", "DOWN": "down",
                 "LEFT": "left", "RIGHT": "right"}


@dataclass
class FrameStats:
    """Frame times since the last report, for the STATUS line and the health file."""

    times: list[float] = field(default_factory=list)
    gl_errors: int = 0


def _rss_kb() -> int:
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * (os.sysconf("SC_PAGE_SIZE") // 1024)
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def _fd_count() -> int:
    try:
        return len(os.listdir("/proc/self/fd"))
    except OSError:
        return -1


def mesh_keys(config: KioskConfig, playlist: list) -> list[tuple[str, tuple]]:
    """Every (scene, parameters) the kiosk can show: the content list and the timelines."""
    keys = []
    for name in config.scenes:
        params = tuple(sorted(scenes.get(name).resolve().items()))
        keys.append((name, params))
    for timeline in playlist:
        keys.append((timeline.scene, tuple(sorted(timeline.params.items()))))
    return list(dict.fromkeys(keys))


class Kiosk:
    """The running exhibit. ``window`` is an exhibit.render.window.Window (or any object with
    draw, read, swap, should_close, close, handle and _glfw)."""

    def __init__(self, config: KioskConfig, window, clock=time.monotonic, notifier=None,
                 health_path: Path | None = None):
        self.config = config
        self.window = window
        self.clock = clock
        self.notifier = notifier
        self.health_path = health_path
        timelines = load_playlist(config.attract_dir)
        device_config = load_config(config.devices_config)
        self.devices = DeviceSet(device_config, clock=clock).open()
        mapper = Mapper(device_config.mapping,
                        ActivityDetector(threshold=device_config.activity_threshold))
        self.gpu = {}
        keys = mesh_keys(config, timelines)
        with progress.on_terminal():
            for i, (name, params) in enumerate(keys, 1):
                progress.report(f"preparing scene {i}/{len(keys)}: {name}")
                if notifier is not None:
                    notifier.extend_timeout(60)  # a cold mesh build may take a while
                mesh, _ = build_cached(scenes.get(name), dict(params),
                                       config.resolution.get(name))
                self.gpu[(name, params)] = window.renderer.upload(mesh)
        now = clock()
        self.started = now
        self.state = KioskState(Playlist(timelines), mapper, config.scenes,
                                config.idle_timeout_s, config.blend_s, now)
        self.stats = FrameStats()
        self._last_report = now
        self._quit = False
        self._install_input()

    # ------------------------------------------------------------------ input from the window

    def _install_input(self) -> None:
        glfw = self.window._glfw
        handle = self.window.handle
        glfw.set_input_mode(handle, glfw.CURSOR, glfw.CURSOR_HIDDEN)
        keyboard = self.devices.keyboard
        names = {getattr(glfw, f"KEY_{k}"): v for k, v in _SPECIAL_KEYS.items()}
        quit_combo = set(self.config.quit_keys)

        def on_key(_window, key, _scancode, action, mods):
            name = glfw.get_key_name(key, 0) or names.get(key)
            if not name or action == glfw.REPEAT:
                return
            pressed = action == glfw.PRESS
            if keyboard is not None:
                keyboard.key(name, pressed)
            held = {m for m, bit in (("ctrl", glfw.MOD_CONTROL), ("alt", glfw.MOD_ALT),
                                     ("shift", glfw.MOD_SHIFT), ("super", glfw.MOD_SUPER))
                    if mods & bit}
            if pressed and quit_combo and quit_combo == held | {name.lower()}:
                log.info("maintenance key combination: quitting")
                self._quit = True

        def on_focus(_window, focused):
            if not focused and keyboard is not None:
                keyboard.release_all()

        def on_close(_window):
            # Visitors cannot close the exhibit (Alt+F4, the compositor's close request).
            glfw.set_window_should_close(handle, self._quit)

        self._callbacks = (on_key, on_focus, on_close)  # keep references alive
        glfw.set_key_callback(handle, on_key)
        glfw.set_window_focus_callback(handle, on_focus)
        glfw.set_window_close_callback(handle, on_close)

    # ------------------------------------------------------------------ the loop

    def step(self) -> None:
        """One frame: poll, update, draw, swap, watchdog."""
        start = self.clock()
        mode = self.state.mode
        frame = self.state.update(self.devices.poll(), start)
        if frame.mode != mode:
            angles = ", ".join(f"{math.degrees(a):.1f}" for a in frame.view.angles)
            log.info("mode %s: scene %s, angles (%s) degrees", frame.mode, frame.scene, angles)
        self._draw(frame, start)
        error = self.window.ctx.error
        if error != "GL_NO_ERROR":
            self.stats.gl_errors += 1
            log.error("GL error: %s", error)
        self.window.swap()
        if self.notifier is not None:
            self.notifier.watchdog()
        self.stats.times.append(self.clock() - start)
        if start - self._last_report >= 1.0:
            self._report(start)

    def drift(self, now: float) -> tuple[float, float]:
        """Where the text panels sit now: a slow Lissajous path within drift_px (burn-in care)."""
        phase = 2 * math.pi * (now - self.started) / self.config.drift_period_s
        amplitude = self.config.drift_px / 2
        return (amplitude * (1 + math.sin(phase)), amplitude * (1 + math.sin(0.71 * phase + 1.3)))

    def _report(self, now: float) -> None:
        frames = len(self.stats.times)
        elapsed = now - self._last_report
        fps = frames / elapsed if elapsed > 0 else 0.0
        p95 = float(np.percentile(self.stats.times, 95)) * 1000 if self.stats.times else 0.0
        self.stats.times.clear()
        self._last_report = now
        devices = [{"url": s.get("url", ""), "state": s.get("state", "")}
                   for s in self.devices.statuses()]
        if self.notifier is not None:
            states = ", ".join(f"{d['url']} {d['state']}" for d in devices)
            self.notifier.status(f"{fps:.0f} fps, {self.state.mode}, {self.state.frame.scene}; "
                                 f"{states}")
        if self.health_path is not None:
            from exhibit.kiosk.health import write_health
            try:
                write_health(self.health_path, {
                    "time": time.time(), "pid": os.getpid(), "fps": round(fps, 1),
                    "frame_ms_p95": round(p95, 2), "mode": self.state.mode,
                    "scene": self.state.frame.scene, "devices": devices,
                    "uptime_s": round(now - self.started, 1), "gl_errors": self.stats.gl_errors,
                    "rss_kb": _rss_kb(), "fds": _fd_count()})
            except OSError as exc:
                log.warning("cannot write the health file %s: %s", self.health_path, exc)

    def run(self, duration: float | None = None, screenshot: Path | None = None,
            max_frames: int | None = None) -> int:
        """Run until the maintenance keys (or duration / max_frames, for tests and staff)."""
        first = True
        frames = 0
        min_frame = 1.0 / self.config.fps_limit
        try:
            while not self._quit:
                start = self.clock()
                self.step()
                frames += 1
                if first:
                    first = False
                    if self.notifier is not None:
                        self.notifier.ready()
                if duration is not None and start - self.started >= duration:
                    break
                if max_frames is not None and frames >= max_frames:
                    break
                spare = min_frame - (self.clock() - start)
                if spare > 0 and not self.config.vsync:
                    time.sleep(spare)
            if screenshot is not None:
                self._screenshot(screenshot)
        finally:
            if self.notifier is not None:
                self.notifier.stopping()
            self.devices.close()
        return 0

    def _draw(self, frame, now: float) -> None:
        hud = HudInfo(title=frame.title, caption=frame.caption, axes=scenes.get(frame.scene).axes)
        options = RenderOptions(hud=self.config.hud, hud_drift=self.drift(now))
        self.window.draw(self.gpu[(frame.scene, frame.params)], frame.view, options, hud)

    def _screenshot(self, path: Path) -> None:
        from PIL import Image

        self._draw(self.state.frame, self.clock())
        Image.fromarray(self.window.read()).save(path)


def open_window(config: KioskConfig, windowed: bool):
    """The kiosk's window, or a clear ExhibitError when there is no display."""
    from exhibit.render.context import RenderUnavailable
    from exhibit.render.window import Window

    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ExhibitError("no display (neither DISPLAY nor WAYLAND_DISPLAY is set): the kiosk "
                           "needs a screen. Headless, render pictures instead: "
                           "`exhibit render --figure 8 --out figure-8.png`")
    try:
        return Window(size=config.size, title="exhibit",
                      fullscreen=config.fullscreen and not windowed, samples=config.samples,
                      vsync=config.vsync, monitor=config.monitor)
    except RenderUnavailable as exc:
        raise ExhibitError(f"{exc}. Headless, render pictures instead: "
                           "`exhibit render --figure 8 --out figure-8.png`") from None

