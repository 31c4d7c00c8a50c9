"""The kiosk: a fullscreen window, the devices, attract mode and the watchdog, in one frame loop.

Everything slow happens before the first frame: meshes come from the cache (or are built once,
with progress), are uploaded to the GPU once, devices are opened, and the attract timelines and
scene start views are framed for the screen, clear of the text (exhibit.render.framer). Each
frame then polls the devices without blocking, steps the KioskState, draws (crossfading for
CROSSFADE_S into a frame the state marks as a cut), swaps (vsync paces the loop), pings the
systemd watchdog and, about once a second, writes the health file and the STATUS line.

It survives what it can, because a crash is a black screen until someone comes:

* A frame that raises is logged (the first of each kind with its traceback, then a count every
  ERROR_REPORT_S) and the next frame tries again. Only after FAILING_EXIT_S with every frame
  failing does the kiosk exit (status FAILING_EXIT, exhibit.kiosk.frame_loop) for systemd to
  restart it: a fresh process (a new GL context, attract mode from the start) is the one remedy
  left, and a minute or more between restarts is no crash loop.
* A scene whose mesh cannot be built or uploaded is skipped, with the timelines that show it,
  and named in the health file ("scenes_failed", "problems"). If no scene is left, the kiosk
  runs on with a notice on the screen instead of exiting: a restart would fail the same way,
  again and again, rebuilding meshes behind a black screen each time, whereas a running kiosk
  tells visitors and `exhibit status` what is wrong, and keeps the watchdog quiet.
* GLFW errors (exhibit.render.window) and device backends that raise (DeviceSet) are logged,
  never fatal; losing the input focus neither iconifies nor stops the fullscreen window.

Under systemd the log goes to the journal in its native protocol (exhibit.operations.journal), and
every record, the mode and scene changes and the errors among them, carries the mode and the
scene on screen as the fields EXHIBIT_MODE and EXHIBIT_SCENE (`journalctl -u exhibit
EXHIBIT_SCENE=hopf`); EXHIBIT_MODE is "notice" when no scene could be prepared.

What one frame does, in order, is here, and the picture's continuity (crossfades, a picture held
while a visitor waits); the rest are modules of their own: the parts built whole before the
first frame (assembly), the loop over time (frame_loop), the scenes (content, scene_meshes),
the window's input, visits (language and sessions), narration cues, the screen log, the HUD's
words and drift, warm-up, frame errors and the reports."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from exhibit.devices.base import Event
from exhibit.devices.hub import DeviceSet
from exhibit.errors import ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.kiosk.assembly import KioskParts, assemble
from exhibit.kiosk.config import KioskConfig
from exhibit.kiosk.content import Content, nearest_level
from exhibit.kiosk.frame_errors import FrameErrors, FrameStats
from exhibit.kiosk.frame_loop import run_frames
from exhibit.preparing.held import Held, on_screen
from exhibit.preparing.jobs import Framers
from exhibit.kiosk.language import PREPARING, Translator
from exhibit.kiosk.narrator import Narrator
from exhibit.framing.panel_drift import PanelDrift
from exhibit.preparing.preparing import Preparer
from exhibit.kiosk.screen_log import ScreenLog
from exhibit.kiosk.state import Frame, KioskState
from exhibit.kiosk.warm_up import Chores, WarmUp
from exhibit.kiosk.window_input import WindowInput
from exhibit.operations.notify import Notifier
from exhibit.operations.sessions import SessionLog
from exhibit.render.frame_request import FrameRequest
from exhibit.render.gpu import GpuMesh
from exhibit.render.options import RenderOptions
from exhibit.render.target import RenderTarget
from exhibit.timelines.model import Params

if TYPE_CHECKING:
    from exhibit.render.window import Window

log = logging.getLogger("exhibit.kiosk")

#: A whole frame longer than this after start-up is logged (the 1st, 2nd, 4th, 8th... of them).
SLOW_FRAME_MS = 100.0
#: Seconds of a crossfade between timelines and between scenes.
CROSSFADE_S = 1.0
#: What the screen says when no scene could be prepared (the second line is for staff).
NOTICE = (
    "This exhibit is resting for a moment.",
    "(no scene could be prepared: see `exhibit status` and the journal)",
)


class Kiosk:
    """The running exhibit. ``window`` is a render target (exhibit.render.target: the GLFW
    Window on a museum's screen, HeadlessTarget in tests and benchmarks). ``parts``: built whole
    by the caller (exhibit.kiosk.assembly), else assembled here from the other arguments;
    ``preparer(framers)`` makes the preparer (exhibit.preparing.preparing) of every scene but the
    first, while the kiosk runs; None: all of them before the first frame (reviews, tests).
    ``sessions``: the visitor-session recorder (exhibit.operations.sessions), or None."""

    def __init__(
        self,
        config: KioskConfig,
        window: RenderTarget,
        clock: Callable[[], float] = time.monotonic,
        notifier: Notifier | None = None,
        health_path: Path | None = None,
        sessions: SessionLog | None = None,
        preparer: Callable[[Framers], Preparer] | None = None,
        parts: KioskParts | None = None,
    ) -> None:
        self.config, self.window, self.clock = config, window, clock
        self.notifier, self.sessions = notifier, sessions
        self.parts = parts or assemble(config, window, clock, notifier, health_path, preparer)
        #: Where the text panels sit now (burn-in care): drift(now).
        self.drift = PanelDrift(config, self.parts.started)
        self.screen_log = ScreenLog(self.state)
        self.stats, self.errors = FrameStats(), FrameErrors()
        self.frames = 0
        #: The crossfade: what was drawn last (to capture when a cut comes) and when it began.
        self._shown: FrameRequest | None = None
        self._fade_start: float | None = None
        #: While a visitor waits for a scene being prepared: (scene, when the wait began).
        self._waiting: tuple[str, float] | None = None
        #: The scene of the picture drawn last, and that picture while held (preparing.held).
        self._shown_key: tuple[str, Params] | None = None
        self._held: Held | None = None
        self.input = WindowInput(window, self.devices, config.quit_keys)
        #: Start-up work left for after the first frame, one piece per frame.
        fading = lambda: self._fade_start is not None  # noqa: E731
        self.warm = WarmUp(Chores(self.parts, window, config.hud, fading).all())
        if self.content.preparer is None:
            self.warm.all()

    # The parts that readers of a running kiosk (reviews, benchmarks, tests) look at by name.
    @property
    def state(self) -> KioskState | None:
        """Attract/visitor state; None when no scene could be prepared (NOTICE is shown)."""
        return self.parts.state

    @property
    def content(self) -> Content:
        return self.parts.content

    @property
    def devices(self) -> DeviceSet:
        return self.parts.devices

    @property
    def translate(self) -> Translator:
        return self.parts.translate

    @property
    def narrator(self) -> Narrator:
        return self.parts.narrator

    def step(self) -> None:
        """One frame: poll, update, draw, swap (run() adds the watchdog and the reports)."""
        start = self.clock()
        events = self.devices.poll()
        if self.state is None:
            self.window.notice(list(NOTICE), self.drift(start))
        else:
            self._update(self.state, events, start)
        self.stats.gl_error(self.window.ctx.error)
        self.window.swap()
        end = self.clock()
        self.stats.times.append(end - start)
        governor = self.parts.governor
        governor.frame_done((end - start) * 1000.0, end)
        if governor.frame_ms_max_at is not None and (end - start) * 1000.0 > SLOW_FRAME_MS:
            shown = self.state.frame.scene if self.state is not None else None
            self.stats.slow((end - start) * 1000.0, shown)

    def _update(self, state: KioskState, events: list[Event], now: float) -> None:
        """The state stepped with the frame's events, what follows from it, and the frame
        drawn."""
        mode, scene, before = state.mode, state.frame.scene, state.frame
        events = self.parts.cues.listen(state, events, now)  # a listen press takes nothing over
        self.parts.cues.hold(state, now)
        frame = state.update(events, now)
        if self._held is not None:  # the visitor turns the picture held while they wait
            home = state.start_view(*self._held.key) if state.home_pressed(events) else None
            self._held.follow(before, frame, state.mapper.config, home)
        self.parts.visits.after(state, mode, frame, events, now, self.sessions)
        self.parts.cues.speak(state, frame, now)
        self.screen_log.changed(mode, scene, frame)
        self._draw(frame, now)

    def report(self, now: float) -> None:
        """The STATUS line and the health file (exhibit.kiosk.reporting)."""
        self.parts.reporter.report(
            now,
            stats=self.stats,
            frames=self.frames,
            errors=self.errors,
            state=self.state,
            sessions=self.sessions,
            screen=on_screen(self.state, self._waiting, self._held, self.content.preparer, now),
            **self.parts.health(now),
        )

    def run(
        self,
        duration: float | None = None,
        screenshot: Path | None = None,
        max_frames: int | None = None,
        until: Callable[[], bool] | None = None,
    ) -> int:
        """Run until the maintenance keys (or duration / max_frames, for tests and staff, or
        ``until()`` returning True after a frame, for benchmarks): exhibit.kiosk.frame_loop.
        Returns 0, or FAILING_EXIT after FAILING_EXIT_S in which every frame raised."""
        try:
            code = run_frames(self, self.parts.started, self.config, duration, max_frames, until)
            if screenshot is not None:
                self._screenshot(screenshot)
        finally:
            self._stop()
        return code

    def _stop(self) -> None:
        """systemd told, the preparer, devices and narration closed, and a visitor still there:
        their session ends now."""
        if self.notifier is not None:
            self.notifier.stopping()
        self.content.close()
        self.devices.close()
        self.narrator.close()
        if self.sessions is not None:
            self.sessions.close(self.clock())

    def tick(self, start: float) -> bool:
        """One frame (step(), and the scenes the preparer finished taken in); whether it was
        drawn. Exceptions go to FrameErrors: a frame's bug must not end the exhibit."""
        try:
            if self.content.prepared_at is None and self.frames:  # after the first picture
                self.content.collect(start, self.parts.started)
            self.step()
            self.frames += 1
            self.errors.drawn(start)
            if self.warm and self.frames > 1:
                self.warm.step()
            return True
        except Exception as exc:  # noqa: BLE001
            self.errors.failed(exc, start)
            return False

    @property
    def waiting(self) -> bool:
        """Whether a visitor waits for a scene still being prepared (the picture is held)."""
        return self._waiting is not None

    @property
    def holding_back(self) -> bool:
        """A visitor waits and the held picture stands still: the loop redraws it seldom."""
        return self.waiting and not (self._held is not None and self._held.moved)

    def _fade(self, now: float) -> float:
        """The outgoing picture's opacity in the crossfade under way (0: none)."""
        if self._fade_start is None:
            return 0.0
        u = (now - self._fade_start) / CROSSFADE_S
        if u >= 1.0:
            self._fade_start = None
            return 0.0
        return 1.0 - u * u * (3.0 - 2.0 * u)

    def _hold(self, frame: Frame, title: str, now: float) -> None:
        """A visitor chose a scene still being prepared: it goes first, and until it comes the
        picture on screen stays, turned by the visitor, its caption the notice saying what
        comes (exhibit.preparing.held). With nothing shown yet, the notice screen."""
        if self._waiting is None or self._waiting[0] != frame.scene:
            log.info("scene %s is being prepared: the picture on screen is held", frame.scene)
            self._waiting = (frame.scene, now)
        self.content.wanted((frame.scene, frame.params))
        words = self.translate(PREPARING).replace("{title}", title)
        if self._shown is None or self._shown_key is None:
            self.window.notice([words], self.drift(now))
            self._fade_start = None
            return
        self._held = self._held or Held(self._shown_key, self._shown)
        self._shown = self._held.picture(words, self.drift(now), self._fade(now))
        self.window.draw(self._shown)

    def _draw(self, frame: Frame, now: float) -> None:
        hud = self.parts.words(frame.title, frame.caption, frame.scene, tags=frame.tags)
        governor = self.parts.governor
        quality = governor.quality
        options = RenderOptions(
            hud=self.config.hud, hud_drift=self.drift(now), quality=quality, text=self.parts.text
        )
        governor.observe(frame.mode, frame.scene, frame.view, now)
        levels = self.content.levels((frame.scene, frame.params))
        if not levels:
            self._hold(frame, hud.title, now)
            return
        gpu = nearest_level(levels, quality.mesh)
        arrived, self._waiting = self._waiting, None
        if arrived is not None:
            log.info("scene %s shown after %.1f s of preparing", frame.scene, now - arrived[1])
        if (frame.cut or arrived) and self._shown is not None:
            # Crossfade: the outgoing picture (the held one, with its notice, when a visitor
            # waited), drawn once more offscreen, fades out over the new one (never a black
            # frame, never a hard cut).
            self.window.capture(self._shown)
            self._fade_start = now
        fade = self._fade(now)
        inset = (
            self.parts.inset.for_frame(frame, self.content.meshes.mesh(frame.scene, frame.params))
            if self.config.hud
            else None
        )
        request = FrameRequest(gpu, frame.view, options, hud, fade=fade, inset=inset)
        self.window.draw(request)
        self._shown, self._shown_key, self._held = request, (frame.scene, frame.params), None
        governor.adapt(self.window.frame_ms, now)

    @property
    def shown(self) -> tuple[GpuMesh, ViewState] | None:
        """The mesh and view of the picture drawn last, None before one (a review measures
        what it shows: exhibit.review.claims)."""
        return None if self._shown is None else (self._shown.gpu, self._shown.view)

    def release(self) -> None:
        """Free the GPU meshes this kiosk uploaded (each level once) and the inset's. The
        museum's kiosk never needs it (its meshes live as long as the process); a review or a
        test that builds many kiosks on one GL context does, or the context fills up."""
        self.content.release()
        self.parts.inset.release()
        self.narrator.close()
        self._shown = self._shown_key = self._held = None
        # a shared headless pipeline's crossfade snapshot keeps the outgoing frame's mesh
        self.window.release_snapshot()

    def _screenshot(self, path: Path) -> None:
        from PIL import Image

        if self.state is None:
            self.window.notice(list(NOTICE), self.drift(self.clock()))
        else:
            self._draw(self.state.frame, self.clock())
        Image.fromarray(self.window.read()).save(path)


def open_window(config: KioskConfig, windowed: bool) -> Window:
    """The kiosk's window, or a clear ExhibitError when there is no display."""
    from exhibit.render.context import RenderUnavailable
    from exhibit.render.window import Window

    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ExhibitError(
            "no display (neither DISPLAY nor WAYLAND_DISPLAY is set): the kiosk "
            "needs a screen. Headless, render pictures instead: "
            "`exhibit render --figure 8 --out figure-8.png`"
        )
    try:
        return Window(
            size=config.size,
            title="exhibit",
            fullscreen=config.fullscreen and not windowed,
            samples=0,
            msaa_samples=config.samples,
            vsync=config.vsync,
            monitor=config.monitor,
        )
    except RenderUnavailable as exc:
        raise ExhibitError(
            f"{exc}. Headless, render pictures instead: "
            "`exhibit render --figure 8 --out figure-8.png`"
        ) from None
