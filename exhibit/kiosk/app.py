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
  failing does the kiosk exit (status FAILING_EXIT) for systemd to restart it: a fresh process
  (a new GL context, attract mode from the start) is the one remedy left, and a minute or more
  between restarts is no crash loop.
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

Why one module of this size: what each frame does, in order, reads best in one place; its parts
(content, start views, inset, languages, warm-up, frame errors) are modules of their own."""

from __future__ import annotations

import dataclasses
import functools
import gc
import logging
import math
import os
import time
from collections.abc import Callable
from pathlib import Path


from exhibit import scenes
from exhibit.errors import ExhibitError
from exhibit.operations import journal
from exhibit.kiosk.config import KioskConfig
from exhibit.kiosk.content import nearest_level
from exhibit.kiosk.frame_errors import FrameErrors, FrameStats
from exhibit.kiosk.language import PREPARING
from exhibit.kiosk.assembly import KioskParts, assemble
from exhibit.kiosk.jobs import Framers
from exhibit.kiosk.preparing import Preparer
from exhibit.kiosk.state import ATTRACT, KioskState
from exhibit.kiosk.warm_up import WarmUp
from exhibit.geometry.view import ViewState
from exhibit.render.gpu import GpuMesh
from exhibit.render.options import RenderOptions
from exhibit.render.renderer import HudInfo
from exhibit.render.target import CloseRequest, Focus, Key, RenderTarget

log = logging.getLogger("exhibit.kiosk")

#: A run of failed frames this long, with none drawn, ends the process so systemd restarts it.
FAILING_EXIT_S = 60.0
FAILING_EXIT = 70  # EX_SOFTWARE
#: A whole frame longer than this after start-up is logged (the 1st, 2nd, 4th, 8th... of them).
SLOW_FRAME_MS = 100.0
#: Seconds of a crossfade between timelines and between scenes.
CROSSFADE_S = 1.0
#: While a visitor waits for a scene still being prepared, the picture on screen is held (it does
#: not change) and redrawn this often: on software GL a frame takes the CPU the preparing
#: needs.
HOLD_FRAME_S = 0.2
#: What the screen says when no scene could be prepared (the second line is for staff).
NOTICE = (
    "This exhibit is resting for a moment.",
    "(no scene could be prepared: see `exhibit status` and the journal)",
)


class Kiosk:
    """The running exhibit. ``window`` is a render target (exhibit.render.target: the GLFW
    Window on a museum's screen, HeadlessTarget in tests and benchmarks). ``state`` is None when
    no scene could be prepared: the window then shows NOTICE. ``preparer(framers)`` makes the
    preparer (exhibit.kiosk.preparing) of every scene but the first, while the kiosk runs;
    None: all of them here, before the first frame (reviews, most tests)."""

    def __init__(
        self,
        config: KioskConfig,
        window: RenderTarget,
        clock: Callable[[], float] = time.monotonic,
        notifier=None,
        health_path: Path | None = None,
        sessions=None,
        preparer: Callable[[Framers], Preparer] | None = None,
        parts: KioskParts | None = None,
    ) -> None:
        """``parts``: the kiosk's parts, built by the caller (exhibit.kiosk.assembly); without
        them they are assembled here from the other arguments."""
        if parts is None:
            parts = assemble(config, window, clock, notifier, health_path, preparer)
        self.config = config
        self.window = window
        self.clock = clock
        self.notifier = notifier
        #: The visitor-session recorder (exhibit.operations.sessions.SessionLog), or None.
        self.sessions = sessions
        #: For the health file: [{"scene", "reason"}] and one line per problem, for people.
        self.scenes_failed = parts.scenes_failed
        self.problems = parts.problems
        self.devices = parts.devices
        self.governor = parts.governor
        #: Text sizes for the HUD, and the framing that keeps the picture clear of it.
        self.text = parts.text
        #: The language on screen and its words (exhibit.kiosk.language), and when it changes.
        self.translate = parts.translate
        self.language = parts.language
        self.language.on_change = self._language_changed
        if sessions is not None:
            sessions.language = self.translate.language
        self.framer = parts.framer
        #: The time-slice inset, in a corner (a panel for timelines that slice).
        self.inset = parts.inset
        #: The scenes on the GPU: the first one now, the rest from the preparer.
        self.content = parts.content
        self.state: KioskState | None = parts.state
        self.reporter = parts.reporter
        self.started = parts.started
        #: "Listen": spoken descriptions and captions (exhibit.kiosk.narrator), and where
        #: attract mode was at the last frame (timeline path, time into it, when), for its holds.
        self.narrator = parts.narrator
        self._narrated_at: tuple[str, float, float] | None = None
        #: The crossfade: what was drawn last (to capture when a cut comes) and when it began.
        self._shown: tuple | None = None
        self._fade_start: float | None = None
        #: While a visitor waits for a scene being prepared: (scene, when the wait began).
        self._waiting: tuple[str, float] | None = None
        self._log_fields: dict[str, str | None] = {}
        self._update_log_fields()
        self.stats = FrameStats()
        self.errors = FrameErrors()
        self.frames = 0
        self._last_report = self.started
        self._quit = False
        self._install_input()
        #: Start-up work left for after the first frame, one piece per frame.
        self.warm = WarmUp(self._warm_up_chores())
        if self.content.preparer is None:
            self.warm.all()

    def _language_changed(self, language: str) -> None:
        """The session under way records the language its visitor reads."""
        if self.sessions is not None:
            self.sessions.language = language

    def _warm_up_chores(self) -> list:
        """exhibit.kiosk.warm_up's chores: every title and caption panel in every language,
        then a frame at every quality level the governor may choose."""
        if self.state is None:
            return []
        known = set(scenes.names())
        timelines = self.content.timelines
        names = (set(self.state.content) | {t.scene for t in timelines}) & known
        words = {(scenes.get(name).title, scenes.get(name).caption, name) for name in names}
        words |= {
            (scenes.get(t.scene).title, k.caption, t.scene)
            for t in timelines
            for k in t.keyframes
            if t.scene in known
        }
        chores: list = []
        if self.config.hud:
            chores += [
                functools.partial(self._warm_hud, self._hud(title, caption, scene, language))
                for language in self.translate.order
                for title, caption, scene in sorted(words)
            ]
        chores += [
            functools.partial(self._warm_quality, quality) for quality in self.governor.levels
        ]
        return chores

    def _warm_hud(self, hud: HudInfo) -> bool:
        self.window.warm_hud([hud], self.text)
        return True

    def _warm_quality(self, quality) -> bool:
        """A frame at ``quality`` through a crossfade into the back buffer (the next frame
        draws over it); waits while a crossfade is under way (its snapshot is in use)."""
        if self._fade_start is not None or self.state is None:
            return False
        frame = self.state.frame
        levels = self.content.levels((frame.scene, frame.params))
        if not levels:
            return False
        options = RenderOptions(hud=self.config.hud, quality=quality, text=self.text)
        gpu = nearest_level(levels, quality.mesh)
        hud = self._hud(frame.title, frame.caption, frame.scene, tags=frame.tags)
        self.window.capture(gpu, frame.view, options, hud)
        self.window.draw(gpu, frame.view, options, hud, fade=0.5)
        return True

    # ------------------------------------------------------------------ input from the window

    def _install_input(self) -> None:
        """Keys, focus and close requests from the window (exhibit.render.target's events):
        visitors cannot close the exhibit (Alt+F4, the compositor), staff quit with the
        maintenance combination, and a focus loss releases every held key."""
        self.window.hide_cursor()
        self.window.close_allowed = False
        self.window.set_input(self._on_input)

    def _on_input(self, event) -> None:
        keyboard = self.devices.keyboard
        if isinstance(event, Key):
            if keyboard is not None:
                keyboard.key(event.name, event.pressed, mods=event.mods)
            quit_combo = set(self.config.quit_keys)
            if event.pressed and quit_combo and quit_combo == event.mods | {event.name.lower()}:
                log.info("maintenance key combination: quitting")
                self._quit = True
        elif isinstance(event, Focus):
            log.info("the window %s the input focus", "has" if event.focused else "lost")
            if not event.focused and keyboard is not None:
                keyboard.release_all()
        elif isinstance(event, CloseRequest):
            log.info(
                "the window system asked to close: ignored (staff quit with %s)",
                "+".join(self.config.quit_keys),
            )

    # ------------------------------------------------------------------ the loop

    def step(self) -> None:
        """One frame: poll, update, draw, swap (run() adds the watchdog and the reports)."""
        start = self.clock()
        events = self.devices.poll()
        if self.state is None:
            self.window.notice(list(NOTICE), self.drift(start))
        else:
            mode, scene = self.state.mode, self.state.frame.scene
            if self.state.mapper.pressed(events, "listen"):
                self.narrator.press()
            events = self.state.mapper.without(events, "listen")  # no takeover
            self._hold_for_narration(start)
            frame = self.state.update(events, start)
            self.language.update(
                self.state.mapper.pressed(events, "language"), self.state.mode == ATTRACT, start
            )
            if self.sessions is not None:  # never raises, never blocks
                self.sessions.observe(frame.mode, frame.scene, events, start)
            if frame.mode == ATTRACT and mode != ATTRACT:  # after the session took its language
                self.language.walked_away(start)
                self.narrator.walked_away()
            self._narrate(frame, start)
            if frame.mode != mode or frame.scene != scene:
                fields = self._update_log_fields()
                if frame.mode != mode:
                    angles = ", ".join(f"{math.degrees(a):.1f}" for a in frame.view.angles)
                    log.info(
                        "mode %s: scene %s, angles (%s) degrees",
                        frame.mode,
                        frame.scene,
                        angles,
                        extra=fields,
                    )
                else:
                    log.info("scene %s (%s mode)", frame.scene, frame.mode, extra=fields)
            self._draw(frame, start)
        error = self.window.ctx.error
        if error != "GL_NO_ERROR":
            self.stats.gl_errors += 1
            n = self.stats.gl_errors
            if n & (n - 1) == 0:  # the 1st, 2nd, 4th, 8th...: a few lines, even over months
                log.error("GL error: %s (%d so far)", error, n)
        self.window.swap()
        end = self.clock()
        self.stats.times.append(end - start)
        self.governor.frame_done((end - start) * 1000.0, end)
        if self.governor.frame_ms_max_at is not None and (end - start) * 1000.0 > SLOW_FRAME_MS:
            self.stats.slow_frames += 1
            n = self.stats.slow_frames
            if n & (n - 1) == 0:
                shown = self.state.frame.scene if self.state is not None else None
                log.warning(
                    "slow frame: %.0f ms (scene %s; %d so far)", (end - start) * 1000.0, shown, n
                )

    def _hold_for_narration(self, now: float) -> None:
        """Attract mode waits at the end of a caption's window while its narration goes on:
        within a timeline, and at its end too (the next timeline, or the same one looping,
        would start its own words and cut these off)."""
        last, self._narrated_at = self._narrated_at, None
        if self.state is None or self.state.mode != ATTRACT or not self.narrator.on(True):
            return
        playlist = self.state.playlist
        if not playlist.timelines:
            return
        timeline, t = playlist.locate(now)
        until = self.narrator.speaking_until(self.translate.language)
        if until is not None:
            path, end = until
            if timeline.path == path and t > end and (last is None or last[1] <= t):
                playlist.hold(t - end)
            elif last is not None and last[0] == path and last[1] <= end + 1e-6:
                moved_on = timeline.path != path or t < last[1]
                if moved_on:  # past the end since the last frame: back to just before it
                    playlist.hold((now - last[2]) - (end - last[1]))
            timeline, t = playlist.locate(now)
        self._narrated_at = (timeline.path, t, now)

    def _narrate(self, frame, now: float) -> None:
        """What is on screen, spoken once, while narration is on."""
        attract = frame.mode == ATTRACT
        if self.state is None or not self.narrator.on(attract):
            return
        language = self.translate.language
        if attract and self.state.playlist.timelines:
            timeline, t = self.state.playlist.locate(now)
            self.narrator.speak_timeline(timeline, t, language, now)
        elif not attract:
            self.narrator.speak_scene(frame.scene, frame.title, frame.caption, language, now)

    def _update_log_fields(self) -> dict[str, str | None]:
        """The journal fields for what is on screen, set for every record from now on (errors
        included) and returned for the record about the change itself."""
        fields: dict[str, str | None]
        if self.state is None:
            fields = {"EXHIBIT_MODE": "notice", "EXHIBIT_SCENE": None}
        else:
            fields = {"EXHIBIT_MODE": self.state.mode, "EXHIBIT_SCENE": self.state.frame.scene}
        if fields != self._log_fields:
            journal.set_context(**fields)
            self._log_fields = fields
        return fields

    def drift(self, now: float) -> tuple[float, float]:
        """Where the text panels sit now: a slow Lissajous path within drift_px (burn-in care);
        still with reduced motion, where the crossfaded pose changes do that work."""
        if self.config.reduced_motion:
            return (0.0, 0.0)
        phase = 2 * math.pi * (now - self.started) / self.config.drift_period_s
        amplitude = self.config.drift_px / 2
        return (amplitude * (1 + math.sin(phase)), amplitude * (1 + math.sin(0.71 * phase + 1.3)))

    def _report(self, now: float) -> None:
        """The STATUS line and the health file (exhibit.kiosk.reporting), about once a second."""
        self.reporter.report(
            now,
            stats=self.stats,
            frames=self.frames,
            errors=self.errors,
            devices=self.devices.statuses(now),
            state=self.state,
            problems=self.problems,
            scenes_failed=self.scenes_failed,
            language=self.translate.language,
            sessions=self.sessions,
            governor=self.governor,
            narration=self.narrator.status(),
        )

    def run(
        self,
        duration: float | None = None,
        screenshot: Path | None = None,
        max_frames: int | None = None,
        until: Callable[[], bool] | None = None,
    ) -> int:
        """Run until the maintenance keys (or duration / max_frames, for tests and staff, or
        ``until()`` returning True after a frame, for benchmarks).

        Returns 0, or FAILING_EXIT after FAILING_EXIT_S in which every frame raised. READY goes
        to systemd after the first frame drawn; the watchdog is pinged after every frame, drawn
        or failed, as the loop is alive either way (a hung one is what the watchdog is for)."""
        frames = 0
        code = 0
        min_frame = 1.0 / self.config.fps_limit
        try:
            while not self._quit:
                start = self.clock()
                drawn = self._frame(start)
                if drawn and self.frames == 1:
                    # Start-up is over: everything built so far (configs, scenes, meshes,
                    # programs) lives as long as the process. Collect once and move it out of
                    # the collector's sight, so a full collection later walks only the few
                    # objects frames make, not start-up's hundreds of thousands (a pause of
                    # tens of ms in the middle of a visitor's session otherwise).
                    gc.collect()
                    gc.freeze()
                    if self.notifier is not None:
                        self.notifier.ready()
                failing = self.errors.failing_since  # set whenever a frame was not drawn
                if not drawn and failing is not None and start - failing >= FAILING_EXIT_S:
                    log.critical(
                        "no frame drawn for %.0f s (%d failed): exiting, for systemd "
                        "to restart the kiosk",
                        start - failing,
                        self.errors.total,
                    )
                    code = FAILING_EXIT
                    break
                frames += 1
                if duration is not None and start - self.started >= duration:
                    break
                if max_frames is not None and frames >= max_frames:
                    break
                if until is not None and until():
                    break
                # a failed frame did not wait for vsync: no busy loop; a held picture leaves
                # the CPU to the scene a visitor waits for
                spare = (HOLD_FRAME_S if self.waiting else min_frame) - (self.clock() - start)
                if spare > 0 and (not self.config.vsync or not drawn or self.waiting):
                    time.sleep(spare)
            if screenshot is not None:
                self._screenshot(screenshot)
        finally:
            if self.notifier is not None:
                self.notifier.stopping()
            self.content.close()
            self.devices.close()
            self.narrator.close()
            if self.sessions is not None:  # a visitor still there: their session ends now
                self.sessions.close(self.clock())
        return code

    def _frame(self, start: float) -> bool:
        """step(), the watchdog and, about once a second, the reports; whether a frame was drawn.
        Exceptions go to FrameErrors: a frame's bug must not end the exhibit."""
        try:
            if self.content.prepared_at is None and self.frames:  # after the first picture
                self.content.collect(start, self.started)
            self.step()
            self.frames += 1
            self.errors.drawn(start)
            drawn = True
            if self.warm and self.frames > 1:
                self.warm.step()
        except Exception as exc:  # noqa: BLE001
            self.errors.failed(exc, start)
            drawn = False
        if self.notifier is not None:
            self.notifier.watchdog()
        if start - self._last_report >= 1.0:
            self._last_report = start
            try:
                self._report(start)
            except Exception as exc:  # noqa: BLE001
                self.errors.failed(exc, start)
        return drawn

    def _hud(
        self,
        title: str,
        caption: str,
        scene: str,
        language: str | None = None,
        tags: tuple[tuple[str, str], ...] = (),
    ) -> HudInfo:
        """The HUD's words in the language on screen (or ``language``)."""
        tr = self.translate
        return HudInfo(
            title=tr(title, language),
            caption=tr(caption, language),
            axes=scenes.get(scene).axes,
            axes_label=tr("4D axes", language),
            words=tr.hud_words(language),
            tags=tuple((name, tr(words, language)) for name, words in tags),
        )

    @property
    def waiting(self) -> bool:
        """Whether a visitor waits for a scene still being prepared (the picture is held)."""
        return self._waiting is not None

    def _fade(self, now: float) -> float:
        """The outgoing picture's opacity in the crossfade under way (0: none)."""
        if self._fade_start is None:
            return 0.0
        u = (now - self._fade_start) / CROSSFADE_S
        if u >= 1.0:
            self._fade_start = None
            return 0.0
        return 1.0 - u * u * (3.0 - 2.0 * u)

    def _hold(self, frame, title: str, now: float) -> None:
        """A visitor chose a scene still being prepared: it is prepared first, and until it
        comes the picture on screen stays, with a notice in the caption panel (in the
        visitor's language) saying what comes. Only with nothing shown yet, the notice
        screen."""
        if self._waiting is None or self._waiting[0] != frame.scene:
            log.info("scene %s is being prepared: the picture on screen is held", frame.scene)
            self._waiting = (frame.scene, now)
        self.content.wanted((frame.scene, frame.params))
        words = self.translate(PREPARING).replace("{title}", title)
        if self._shown is None:
            self.window.notice([words], self.drift(now))
            self._fade_start = None
            return
        gpu, view, options, hud = self._shown
        options = dataclasses.replace(options, hud=True, hud_drift=self.drift(now))
        hud = dataclasses.replace(hud, note=words)
        self.window.draw(gpu, view, options, hud, fade=self._fade(now))
        self._shown = (gpu, view, options, hud)

    def _draw(self, frame, now: float) -> None:
        hud = self._hud(frame.title, frame.caption, frame.scene, tags=frame.tags)
        quality = self.governor.quality
        options = RenderOptions(
            hud=self.config.hud, hud_drift=self.drift(now), quality=quality, text=self.text
        )
        self.governor.observe(frame.mode, frame.scene, frame.view, now)
        levels = self.content.levels((frame.scene, frame.params))
        if not levels:
            self._hold(frame, hud.title, now)
            return
        gpu = nearest_level(levels, quality.mesh)
        arrived = self._waiting is not None
        if arrived:
            assert self._waiting is not None
            log.info(
                "scene %s shown after %.1f s of preparing",
                frame.scene,
                now - self._waiting[1],
            )
            self._waiting = None
        if (frame.cut or arrived) and self._shown is not None:
            # Crossfade: the outgoing picture (the held one, with its notice, when a visitor
            # waited), drawn once more offscreen, fades out over the new one (never a black
            # frame, never a hard cut).
            self.window.capture(*self._shown)
            self._fade_start = now
        fade = self._fade(now)
        inset = (
            self.inset.for_frame(frame, self.content.mesh(frame.scene, frame.params))
            if self.config.hud
            else None
        )
        self.window.draw(gpu, frame.view, options, hud, fade=fade, inset=inset)
        self._shown = (gpu, frame.view, options, hud)
        if self.governor.update(self.window.frame_ms, now):
            log.info(
                "quality %s (frames took %.1f ms, the target is %.1f ms)",
                self.governor.quality.describe(),
                self.governor.recent_ms or 0.0,
                self.governor.settings.target_ms,
            )

    @property
    def shown(self) -> tuple[GpuMesh, ViewState] | None:
        """The mesh and view of the picture drawn last, None before one (a review measures
        what it shows: exhibit.kiosk.claims)."""
        return None if self._shown is None else (self._shown[0], self._shown[1])

    def release(self) -> None:
        """Free the GPU meshes this kiosk uploaded (each level once) and the inset's. The
        museum's kiosk never needs it (its meshes live as long as the process); a review or a
        test that builds many kiosks on one GL context does, or the context fills up."""
        self.content.release()
        self.inset.release()
        self.narrator.close()
        self._shown = None
        # a shared headless pipeline's crossfade snapshot keeps the outgoing frame's mesh
        self.window.release_snapshot()

    def _screenshot(self, path: Path) -> None:
        from PIL import Image

        if self.state is None:
            self.window.notice(list(NOTICE), self.drift(self.clock()))
        else:
            self._draw(self.state.frame, self.clock())
        Image.fromarray(self.window.read()).save(path)


def open_window(config: KioskConfig, windowed: bool):
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
