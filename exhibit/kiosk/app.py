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

Under systemd the log goes to the journal in its native protocol (exhibit.kiosk.journal), and
every record, the mode and scene changes and the errors among them, carries the mode and the
scene on screen as the fields EXHIBIT_MODE and EXHIBIT_SCENE (`journalctl -u exhibit
EXHIBIT_SCENE=hopf`); EXHIBIT_MODE is "notice" when no scene could be prepared.
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import logging
import math
import os
import resource
import time
import traceback
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from exhibit import scenes
from exhibit.devices.config import load_config
from exhibit.devices.hub import DeviceSet
from exhibit.devices.mapping import ActivityDetector, Mapper
from exhibit.errors import ConfigError, ExhibitError
from exhibit.kiosk import journal
from exhibit.kiosk.attract import Playlist, load_playlist
from exhibit.kiosk.config import KioskConfig
from exhibit.kiosk.framing import FILL_LIMIT
from exhibit.kiosk.governor import for_kiosk, mesh_levels
from exhibit.kiosk.language import (PREPARING, SOURCE, Catalogue, Translator,
                                    in_every_language, load_catalogues)
from exhibit.kiosk.preparing import Framers, Job, Prepared, run_job, scene_jobs
from exhibit.kiosk.state import ATTRACT, KioskState
from exhibit.render.options import RenderOptions
from exhibit.render.framer import Framer
from exhibit.render.frame import Inset
from exhibit.geometry.framing import mesh_points, mesh_sample
from exhibit.render.inset import inset_label, inset_rect, inset_view
from exhibit.render.layout import TextSizes, hud_layout
from exhibit.render.renderer import HudInfo
from exhibit.render.target import CloseRequest, Focus, Key
from exhibit.surfaces import progress
from exhibit.surfaces.mesh import Mesh4D

log = logging.getLogger("exhibit.kiosk")

#: A run of failed frames this long, with none drawn, ends the process so systemd restarts it.
FAILING_EXIT_S = 60.0
FAILING_EXIT = 70  # EX_SOFTWARE
#: Failed frames after the first of their kind are summed up in one line at most this often.
ERROR_REPORT_S = 10.0
#: A whole frame longer than this after start-up is logged (the 1st, 2nd, 4th, 8th... of them).
SLOW_FRAME_MS = 100.0
#: Framed views kept: every scene's start view and the poses visitors took over at lately.
FRAMED_CACHE = 64
#: Seconds of a crossfade between timelines and between scenes.
CROSSFADE_S = 1.0
#: What the screen says when no scene could be prepared (the second line is for staff).
NOTICE = ("This exhibit is resting for a moment.",
          "(no scene could be prepared: see `exhibit status` and the journal)")

@dataclass
class FrameStats:
    """Frame times since the last report, for the STATUS line and the health file."""

    times: list[float] = field(default_factory=list)
    gl_errors: int = 0
    slow_frames: int = 0


def _rss_kb() -> int:
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * (os.sysconf("SC_PAGE_SIZE") // 1024)
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def _round(seconds: float | None) -> float | None:
    return None if seconds is None else round(seconds, 1)


def _fd_count() -> int:
    try:
        return len(os.listdir("/proc/self/fd"))
    except OSError:
        return -1


class FrameErrors:
    """Frames that raised. The first of each kind (exception type and the line that raised it)
    is logged with its traceback, again at most hourly; the others are counted and summed up in
    one line at most every ``every`` seconds, so a frame failing 60 times a second does not
    flood the journal. ``failing_since``: when the current run of failed frames began."""

    def __init__(self, every: float = ERROR_REPORT_S):
        self.every = every
        self.total = 0
        self.failing_since: float | None = None
        self._kinds: dict[tuple, float] = {}  # kind -> when its traceback was last logged
        self._count, self._latest, self._logged = 0, "", -math.inf

    def failed(self, exc: BaseException, now: float) -> None:
        self.total += 1
        if self.failing_since is None:
            self.failing_since = now
        where = traceback.extract_tb(exc.__traceback__)[-1:]
        kind = (type(exc).__name__, *[(w.filename, w.lineno) for w in where])
        if now - self._kinds.get(kind, -math.inf) >= 3600 and len(self._kinds) < 100:
            self._kinds[kind] = self._logged = now
            log.error("a frame failed (the next one tries again)", exc_info=exc)
        else:
            self._count += 1
            self._latest = f"{type(exc).__name__}: {exc}"
        self.flush(now)

    def drawn(self, now: float) -> None:
        self.failing_since = None
        self.flush(now)

    def flush(self, now: float) -> None:
        if self._count and now - self._logged >= self.every:
            log.error("%d more failed frames in the last %.0f s (the last: %s)", self._count,
                      now - self._logged, self._latest)
            self._count, self._logged = 0, now


class Kiosk:
    """The running exhibit. ``window`` is a render target (exhibit.render.target: the GLFW
    Window on a museum's screen, HeadlessTarget in tests and benchmarks). ``state`` is None when
    no scene could be prepared: the window then shows NOTICE. ``preparer(framers)`` makes the
    preparer (exhibit.kiosk.preparing) of every scene but the first, while the kiosk runs;
    None: all of them here, before the first frame (reviews, most tests)."""

    def __init__(self, config: KioskConfig, window, clock=time.monotonic, notifier=None,
                 health_path: Path | None = None, sessions=None, preparer=None):
        journal.install()  # stderr is the journal (a service): structured fields from here on
        self.config = config
        self.window = window
        self.clock = clock
        self.notifier = notifier
        self.health_path = health_path
        #: The visitor-session recorder (exhibit.kiosk.sessions.SessionLog), or None.
        self.sessions = sessions
        #: For the health file: [{"scene", "reason"}] and one line per problem, for people.
        self.scenes_failed: list[dict] = []
        self.problems: list[str] = []
        for problem in getattr(config, "scene_problems", ()):  # broken files, left out
            log.error("scene file left out: %s", problem)
            self.problems.append(f"scene file left out: {problem}")
        try:
            timelines = load_playlist(config.attract_dir)
        except Exception as exc:  # noqa: BLE001 - attract mode can do without timelines
            log.error("no attract timelines: %s", exc)
            self.problems.append(f"no attract timelines: {exc}")
            timelines = []
        device_config = load_config(config.devices_config)
        self.devices = DeviceSet(device_config, clock=clock).open()
        mapper = Mapper(device_config.mapping,
                        ActivityDetector(threshold=device_config.activity_threshold))
        self.governor = for_kiosk(config, window, clock())  # picture quality vs frame time
        #: Text sizes for the HUD, and the framing that keeps the picture clear of it.
        self.text = TextSizes(config.text.caption_cap, config.text.title_cap,
                              config.text.infinity_beyond)
        #: The language on screen and its words (exhibit.kiosk.language).
        self.translate = self._translator(config)
        self._language_since = clock()
        versions = functools.partial(in_every_language, self.translate)
        self.framer = Framer(getattr(window, "size", config.size), self.text, config.drift_px,
                             hud=config.hud, versions=versions, words=self._words())
        #: The time-slice inset's corner (a panel for timelines that slice) and its scene.
        size = tuple(getattr(window, "size", config.size))
        self._inset_rect = inset_rect(size, hud_layout(size, sizes=self.text).margin)
        self._inset_mesh = None
        self._inset_view_cache = None
        inset_framer = Framer(size, self.text, config.drift_px, hud=config.hud,
                              extra=(self._inset_rect,), versions=versions, words=self._words())
        if sessions is not None:
            sessions.language = self.translate.language
        self._framed: OrderedDict[tuple, object] = OrderedDict()
        self._samples: dict[tuple, tuple] = {}   # (scene, params) -> its mesh_sample
        #: The crossfade: what was drawn last (to capture when a cut comes) and when it began.
        self._shown: tuple | None = None
        self._fade_start: float | None = None
        now = clock()
        self.started = now
        self.state = None
        #: Uploaded meshes: (scene, params) -> {mesh level: GpuMesh}; more arrive as the
        #: preparer delivers them (exhibit.kiosk.preparing).
        self.gpu: dict[tuple, dict] = {}
        self._failed: set[tuple] = set()
        framers = Framers(self.framer, inset_framer)
        jobs = scene_jobs(config, timelines, mesh_levels(self.governor))
        first = self._prepare_first(jobs, framers)
        content = tuple(name for name in config.scenes
                        if not any(key[0] == name for key in self._failed)
                        or any(key[0] == name for key in self.gpu))
        if self.gpu:
            self.state = KioskState(Playlist(first), mapper, content,
                                    config.idle_timeout_s, config.blend_s, now,
                                    framer=self._frame_view,
                                    reduced_motion=config.reduced_motion)
        else:
            log.critical("no scene could be prepared: the kiosk shows a notice until it is "
                         "fixed and restarted")
            self.problems.append("no scene could be prepared: the screen shows a notice")
        #: Where the rest are prepared; None: here and now, before the first frame.
        self.preparer = preparer(framers) if preparer is not None and self.gpu else None
        if self.preparer is None:
            for job in jobs:
                self._receive(run_job(job, framers), now)
            self._prepared_at = now
        else:
            for job in jobs:
                self.preparer.submit(job)
            self._prepared_at = None
        self._log_fields: dict[str, str | None] = {}
        self._update_log_fields()
        self.stats = FrameStats()
        self.errors = FrameErrors()
        self.frames = 0
        self._last_report = now
        self._quit = False
        self._install_input()
        #: Start-up work left for after the first frame, one piece per frame (_chores).
        self._chores: list = self._warm_up_chores()
        if self.preparer is None:
            self.warm_up()

    def _translator(self, config: KioskConfig) -> Translator:
        """The languages of [languages]; a catalogue that cannot be read is left out (its
        visitors read English), said once in the log and the health file."""
        catalogues = {SOURCE: Catalogue(SOURCE, "English")}
        for code in config.languages:
            if code == SOURCE or config.catalogues_dir is None:
                continue
            try:
                catalogues.update(load_catalogues(config.catalogues_dir, [code]))
            except ConfigError as exc:
                log.error("language %s left out: %s", code, "; ".join(exc.problems))
                self.problems.append(f"language {code} left out (see the journal)")
        return Translator(catalogues, config.languages)

    def _walked_away(self, now: float) -> None:
        """Attract mode is back: the next visitor finds the museum's own language, not the one
        the last visitor chose."""
        if self.translate.index != 0:
            language = self.translate.reset()
            log.info("language %s (attract mode is back)", language)
            if self.sessions is not None:
                self.sessions.language = language
        self._language_since = now

    def _words(self) -> tuple:
        """The numbers panel's words in every language shown, as _versions orders them."""
        return tuple(self.translate.hud_words(code) for code in self.translate.order)

    def _switch_language(self, events, now: float) -> None:
        """The "language" button, or attract mode's timer, shows the next language."""
        pressed = self.state.mapper.pressed(events, "language")
        timed = (self.config.language_switch_s > 0 and self.state.mode == ATTRACT
                 and now - self._language_since >= self.config.language_switch_s)
        if (pressed or timed) and len(self.translate.order) > 1:
            language = self.translate.next()
            self._language_since = now
            log.info("language %s", language)
            if self.sessions is not None:
                self.sessions.language = language

    def _warm_up_chores(self) -> list:
        """What the first frames would otherwise pay for, done one piece per frame after the
        first (Kiosk._frame): every title and caption panel laid out and rasterised (15 ms at
        each change otherwise), and a frame drawn through a crossfade at every quality level
        the governor may choose (software GL compiles each shader variant at its first draw,
        and the crossfade's snapshot is allocated at the first cut: a 109 ms frame at the first
        scene change of a 1080p kiosk on llvmpipe otherwise)."""
        if self.state is None:
            return []
        names = set(self.state.content) | {t.scene for t in self._all_timelines}
        words = {(scenes.get(name).title, scenes.get(name).caption, name)
                 for name in names if name in scenes.names()}
        words |= {(scenes.get(t.scene).title, k.caption, t.scene)
                  for t in self._all_timelines for k in t.keyframes
                  if t.scene in scenes.names()}
        chores: list = []
        if self.config.hud:
            chores += [functools.partial(self._warm_hud, self._hud(title, caption, scene,
                                                                   language))
                       for language in self.translate.order
                       for title, caption, scene in sorted(words)]
        chores += [functools.partial(self._warm_quality, quality)
                   for quality in self.governor.levels]
        return chores

    def _warm_hud(self, hud: HudInfo) -> bool:
        self.window.renderer.hud.warm(self.window.size, [hud], self.text)
        return True

    def _warm_quality(self, quality) -> bool:
        """A frame at ``quality`` through a crossfade into the back buffer (the next frame
        draws over it); waits while a crossfade is under way (its snapshot is in use)."""
        if self._fade_start is not None or self.state is None:
            return False
        frame = self.state.frame
        levels = self.gpu.get((frame.scene, frame.params))
        if not levels:
            return False
        options = RenderOptions(hud=self.config.hud, quality=quality, text=self.text)
        gpu = _level(levels, quality.mesh)
        hud = self._hud(frame.title, frame.caption, frame.scene)
        self.window.capture(gpu, frame.view, options, hud)
        self.window.draw(gpu, frame.view, options, hud, fade=0.5)
        return True

    def warm_up(self) -> None:
        """All the start-up work left, now (a kiosk that prepares everything before its first
        frame: reviews, tests)."""
        while self._chores:
            self._chores[0]()
            self._chores.pop(0)

    def _chore(self) -> None:
        """One piece of start-up work left for after the first frame (never fatal)."""
        chore = self._chores[0]
        try:
            if not chore():
                return
        except Exception as exc:  # noqa: BLE001 - the frames do it themselves when needed
            log.warning("start-up warm-up step failed: %s", exc)
        self._chores.pop(0)

    # ------------------------------------------------------------------ preparing scenes

    def _prepare_first(self, jobs: list[Job], framers: Framers) -> list:
        """The first frame's scene, here and now: jobs in order until one can be shown, at the
        governor's starting mesh level only (the other levels go back at the head of
        ``jobs``). Returns the playlist to start with: the framed timelines of that scene."""
        self._all_timelines = [t for job in jobs for t in job.timelines]
        level = self.governor.quality.mesh
        with progress.on_terminal():
            while jobs:
                job = jobs.pop(0)
                now_levels = tuple(lv for lv in job.levels if lv[0] == level) or job.levels[:1]
                rest = tuple(lv for lv in job.levels if lv not in now_levels)
                progress.report(f"preparing scene {job.scene}")
                if self.notifier is not None:
                    self.notifier.extend_timeout(60)  # a cold mesh build may take a while
                prepared = run_job(dataclasses.replace(job, levels=now_levels), framers)
                timelines = self._receive(prepared, self.clock())
                if job.key in self.gpu:
                    if rest:
                        jobs.insert(0, dataclasses.replace(job, levels=rest, timelines=()))
                    return timelines
        return []

    def _receive(self, prepared: Prepared, now: float) -> list:
        """A job's result: its meshes uploaded, its timelines into the playlist (in the
        playlist's order), or the scene noted as failed and taken out. Returns the timelines
        received."""
        job = prepared.job
        uploaded: dict[int, object] = {}
        if prepared.error is None:
            try:
                by_mesh: dict[int, object] = {}
                for level, mesh in prepared.meshes.items():
                    if id(mesh) not in by_mesh:
                        by_mesh[id(mesh)] = self.window.renderer.upload(mesh)
                    uploaded[level] = by_mesh[id(mesh)]
            except Exception as exc:  # noqa: BLE001 - one scene must not stop the exhibit
                for gpu in {id(g): g for g in uploaded.values()}.values():
                    if hasattr(gpu, "release"):
                        gpu.release()
                uploaded = {}
                prepared = dataclasses.replace(prepared, error=f"{type(exc).__name__}: {exc}")
        if prepared.error is not None:
            self._scene_failed(job, prepared.error, now)
            return []
        self.gpu.setdefault(job.key, {}).update(uploaded)
        if self.state is not None:
            for timeline in prepared.timelines:
                self.state.playlist.insert(self._position(timeline), timeline, now)
            if self.state.frame.scene == job.scene and self.state.frame.params == job.params:
                self.state.reframe()  # a visitor waited for it: its start view, framed now
        return prepared.timelines

    def _position(self, timeline) -> int:
        """Where ``timeline`` goes among those playing: after every one before it in the
        attract folder's order."""
        order = {t.name: i for i, t in enumerate(self._all_timelines)}
        mine = order.get(timeline.name, len(order))
        return sum(1 for t in self.state.playlist.timelines if order.get(t.name, 0) < mine)

    def _scene_failed(self, job: Job, reason: str, now: float) -> None:
        self._failed.add(job.key)
        log.error("scene %s skipped: %s", job.scene, reason)
        if {"scene": job.scene, "reason": reason} not in self.scenes_failed:
            self.scenes_failed.append({"scene": job.scene, "reason": reason})
            self.problems.append(f"scene {job.scene} skipped: {reason}")
        for t in job.timelines:
            log.warning("attract timeline %s skipped: its scene %s failed", t.name, t.scene)
            self.problems.append(f"attract timeline {t.name} skipped (scene {t.scene})")
        if self.state is not None and job.key not in self.gpu:
            self.state.drop(job.scene, now)

    def _collect(self, now: float) -> None:
        """Whatever the preparer has finished, taken in (a frame's work: uploads only)."""
        begin = time.perf_counter()
        for prepared in self.preparer.results():
            self._receive(prepared, now)
            if prepared.error is None:
                log.info("scene %s prepared (mesh levels %s, %d timelines; %.0f ms to take in)",
                         prepared.job.scene, ",".join(map(str, sorted(prepared.meshes))),
                         len(prepared.timelines), (time.perf_counter() - begin) * 1000)
        if not self.preparer.busy and self._prepared_at is None:
            self._prepared_at = now
            log.info("every scene is prepared (%.1f s after start)", now - self.started)

    # ------------------------------------------------------------------ framing

    def _mesh(self, name: str, params) -> Mesh4D | None:
        """The scene's finest mesh (framing needs its bounds only), None without one."""
        levels = self.gpu.get((name, tuple(params)))
        mesh = getattr(levels[min(levels)], "mesh", None) if levels else None
        return mesh if isinstance(mesh, Mesh4D) else None

    def _frame_view(self, name: str, params, view):
        """KioskState's framer: ``view`` (a scene's start view, or the pose a visitor takes
        over) fitted into the area the scene's own panels leave free. A pose whose picture
        fills the world on purpose (the sensor inside the object: it would need FILL_LIMIT
        times the zoom to fit) keeps its zoom, as a framed timeline does. Cached: the same few
        start views come back at every "home" and scene change."""
        key = (name, tuple(params), view)
        framed = self._framed.get(key)
        if framed is None:
            framed = view
            mesh = self._mesh(name, params)
            if mesh is None:  # not prepared yet: framed when it is (KioskState.reframe)
                return view
            if mesh is not None:
                try:
                    points = self._samples.get(key[:2])
                    if points is None:
                        points = self._samples[key[:2]] = mesh_sample(mesh)
                    fitted = self.framer.scene_view(scenes.get(name), mesh, view, points=points)
                    if fitted.half_height <= FILL_LIMIT * view.half_height:
                        framed = fitted
                except Exception as exc:  # noqa: BLE001 - the scene's own view will do
                    log.warning("scene %s not framed: %s", name, exc)
            while len(self._framed) >= FRAMED_CACHE:
                self._framed.popitem(last=False)
            self._framed[key] = framed
        self._framed.move_to_end(key)
        return framed

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
            log.info("the window system asked to close: ignored (staff quit with %s)",
                     "+".join(self.config.quit_keys))

    # ------------------------------------------------------------------ the loop

    def step(self) -> None:
        """One frame: poll, update, draw, swap (run() adds the watchdog and the reports)."""
        start = self.clock()
        events = self.devices.poll()
        if self.state is None:
            self.window.notice(list(NOTICE), self.drift(start))
        else:
            mode, scene = self.state.mode, self.state.frame.scene
            frame = self.state.update(events, start)
            self._switch_language(events, start)
            if self.sessions is not None:  # never raises, never blocks
                self.sessions.observe(frame.mode, frame.scene, events, start)
            if frame.mode == ATTRACT and mode != ATTRACT:  # after the session took its language
                self._walked_away(start)
            if frame.mode != mode or frame.scene != scene:
                fields = self._update_log_fields()
                if frame.mode != mode:
                    angles = ", ".join(f"{math.degrees(a):.1f}" for a in frame.view.angles)
                    log.info("mode %s: scene %s, angles (%s) degrees", frame.mode, frame.scene,
                             angles, extra=fields)
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
                scene = self.state.frame.scene if self.state is not None else None
                log.warning("slow frame: %.0f ms (scene %s; %d so far)", (end - start) * 1000.0,
                            scene, n)

    def _update_log_fields(self) -> dict[str, str | None]:
        """The journal fields for what is on screen, set for every record from now on (errors
        included) and returned for the record about the change itself."""
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
        frames = len(self.stats.times)
        elapsed = now - self._last_report
        fps = frames / elapsed if elapsed > 0 else 0.0
        p95 = float(np.percentile(self.stats.times, 95)) * 1000 if self.stats.times else 0.0
        self.stats.times.clear()
        self._last_report = now
        # Per device: its state, seconds in it, and seconds it has been missing (null when
        # connected), for `exhibit status --max-lost` and the metrics (exhibit.kiosk.health).
        devices = [{"name": s.get("name", ""), "url": s.get("url", ""),
                    "state": s.get("state", ""), "state_s": _round(s.get("state_s")),
                    "missing_s": _round(s.get("missing_s"))}
                   for s in self.devices.statuses(now)]
        mode = scene = None
        if self.state is not None:
            mode, scene = self.state.mode, self.state.frame.scene
        problems = list(self.problems)
        if self.errors.failing_since is not None:
            problems.append(f"frames failing for {now - self.errors.failing_since:.0f} s "
                            "(see the journal)")
        if self.notifier is not None:
            states = ", ".join(f"{d['url']} {d['state']}" for d in devices)
            what = f"{mode}, {scene}" if self.state is not None else "notice (no scene)"
            self.notifier.status(f"{fps:.0f} fps, {what}; {states}"
                                 + (f"; {len(problems)} problems" if problems else ""))
        if self.health_path is not None:
            from exhibit.kiosk.health import process_uptime, report, write_health

            # Since the process started (imports, window, first meshes included), not since
            # this object was built: that missed the whole start-up (issue 24).
            uptime = process_uptime()
            try:
                write_health(self.health_path, report(**{
                    "time": time.time(), "pid": os.getpid(), "fps": round(fps, 1),
                    "frame_ms_p95": round(p95, 2), "mode": mode, "scene": scene,
                    "devices": devices,
                    "uptime_s": round(now - self.started if uptime is None else uptime, 1),
                    "gl_errors": self.stats.gl_errors, "rss_kb": _rss_kb(), "fds": _fd_count(),
                    "frames": self.frames, "frame_errors": self.errors.total,
                    "problems": problems, "scenes_failed": self.scenes_failed,
                    "language": self.translate.language,
                    **(self.sessions.health() if self.sessions is not None else {}),
                    **self.governor.health()}))  # quality level, frame_ms, target_ms
            except (OSError, TypeError) as exc:
                log.warning("cannot write the health file %s: %s", self.health_path, exc)

    def run(self, duration: float | None = None, screenshot: Path | None = None,
            max_frames: int | None = None) -> int:
        """Run until the maintenance keys (or duration / max_frames, for tests and staff).

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
                if not drawn and start - self.errors.failing_since >= FAILING_EXIT_S:
                    log.critical("no frame drawn for %.0f s (%d failed): exiting, for systemd "
                                 "to restart the kiosk", start - self.errors.failing_since,
                                 self.errors.total)
                    code = FAILING_EXIT
                    break
                frames += 1
                if duration is not None and start - self.started >= duration:
                    break
                if max_frames is not None and frames >= max_frames:
                    break
                spare = min_frame - (self.clock() - start)
                if spare > 0 and (not self.config.vsync or not drawn):
                    time.sleep(spare)  # a failed frame did not wait for vsync: no busy loop
            if screenshot is not None:
                self._screenshot(screenshot)
        finally:
            if self.notifier is not None:
                self.notifier.stopping()
            if self.preparer is not None:
                self.preparer.close()
            self.devices.close()
            if self.sessions is not None:  # a visitor still there: their session ends now
                self.sessions.close(self.clock())
        return code

    def _frame(self, start: float) -> bool:
        """step(), the watchdog and, about once a second, the reports; whether a frame was drawn.
        Exceptions go to FrameErrors: a frame's bug must not end the exhibit."""
        try:
            if self._prepared_at is None and self.frames:  # after the first picture
                self._collect(start)
            self.step()
            self.frames += 1
            self.errors.drawn(start)
            drawn = True
            if self._chores and self.frames > 1:
                self._chore()
        except Exception as exc:  # noqa: BLE001
            self.errors.failed(exc, start)
            drawn = False
        if self.notifier is not None:
            self.notifier.watchdog()
        if start - self._last_report >= 1.0:
            try:
                self._report(start)
            except Exception as exc:  # noqa: BLE001
                self.errors.failed(exc, start)
        return drawn

    def _hud(self, title: str, caption: str, scene: str, language: str | None = None) -> HudInfo:
        """The HUD's words in the language on screen (or ``language``)."""
        tr = self.translate
        return HudInfo(title=tr(title, language), caption=tr(caption, language),
                       axes=scenes.get(scene).axes, axes_label=tr("4D axes", language),
                       words=tr.hud_words(language))

    def _draw(self, frame, now: float) -> None:
        hud = self._hud(frame.title, frame.caption, frame.scene)
        quality = self.governor.quality
        options = RenderOptions(hud=self.config.hud, hud_drift=self.drift(now), quality=quality,
                                text=self.text)
        self.governor.observe(frame.mode, frame.scene, frame.view, now)
        levels = self.gpu.get((frame.scene, frame.params))
        if not levels:  # a visitor chose a scene still being prepared: it comes next
            if self.preparer is not None:
                self.preparer.first((frame.scene, frame.params))
            self.window.notice([self.translate(PREPARING).replace("{title}", hud.title)],
                               self.drift(now))
            self._shown = self._fade_start = None
            return
        gpu = _level(levels, quality.mesh)
        if frame.cut and self._shown is not None:
            # Crossfade: the outgoing picture, drawn once more offscreen, fades out over the
            # new one (never a black frame, never a hard cut).
            self.window.capture(*self._shown)
            self._fade_start = now
        fade = 0.0
        if self._fade_start is not None:
            u = (now - self._fade_start) / CROSSFADE_S
            if u >= 1.0:
                self._fade_start = None
            else:
                fade = 1.0 - u * u * (3.0 - 2.0 * u)
        inset = self._inset(frame) if self.config.hud else None
        self.window.draw(gpu, frame.view, options, hud, fade=fade, inset=inset)
        self._shown = (gpu, frame.view, options, hud)
        if self.governor.update(getattr(self.window, "frame_ms", None), now):
            log.info("quality %s (frames took %.1f ms, the target is %.1f ms)",
                     self.governor.quality.describe(), self.governor.recent_ms or 0.0,
                     self.governor.settings.target_ms)

    def _inset(self, frame):
        """The time-slice inset while a timeline slices a scene that has a 3D world at each
        moment (the collision's pipe and ball, with their touching curve in closed form):
        rebuilt and uploaded when the moment changes (about 1 ms), drawn in the corner the
        timeline's framing keeps free. None otherwise."""
        view = frame.view
        scene = scenes.get(frame.scene)
        if (view.slice_axis is None or scene.world_at is None
                or scene.slice_axis != view.slice_axis):
            return None
        key = (frame.scene, frame.params, round(view.slice_at, 4))
        if self._inset_mesh is None or self._inset_mesh[0] != key:
            world = scene.world_at(dict(frame.params), view.slice_at)
            if self._inset_mesh is not None:
                self._inset_mesh[1].release()
            size = (int(self._inset_rect.width), int(self._inset_rect.height))
            self._inset_mesh = (key, self.window.renderer.upload(world), size)
        key, gpu, size = self._inset_mesh
        r = self._inset_rect
        label = inset_label(scene.axes[view.slice_axis], view.slice_at)
        return Inset(gpu, self._inset_view(frame, scene, size), (r.x0, r.y0, r.width, r.height),
                     label)

    def _inset_view(self, frame, scene, size):
        """The inset's view, framed once for the worlds of the moments at the ends and middle
        of the scene's extent along its time axis, so the frame holds still as time moves."""
        view = frame.view
        key = (frame.scene, frame.params, view.eye_azimuth, view.eye_incidence, view.twist,
               view.eye_r)
        if self._inset_view_cache is None or self._inset_view_cache[0] != key:
            mesh = self._mesh(frame.scene, frame.params)
            low, high = (mesh.bounds() if mesh is not None else (np.full(4, -1.0),
                                                                  np.full(4, 1.0)))
            axis = view.slice_axis
            moments = (low[axis], 0.5 * (low[axis] + high[axis]), high[axis])
            points = np.concatenate([mesh_points(scene.world_at(dict(frame.params), c))
                                     for c in moments])
            self._inset_view_cache = (key, inset_view(view, points, size))
        return self._inset_view_cache[1]

    def release(self) -> None:
        """Free the GPU meshes this kiosk uploaded (each level once) and the inset's. The
        museum's kiosk never needs it (its meshes live as long as the process); a review or a
        test that builds many kiosks on one GL context does, or the context fills up."""
        uploaded = {id(g): g for levels in self.gpu.values() for g in levels.values()}
        if self._inset_mesh is not None:
            uploaded[id(self._inset_mesh[1])] = self._inset_mesh[1]
        for gpu in uploaded.values():
            if hasattr(gpu, "release"):
                gpu.release()
        self.gpu, self._inset_mesh, self._shown = {}, None, None
        # a shared headless pipeline's crossfade snapshot keeps the outgoing frame's mesh
        pipeline = getattr(getattr(self.window, "headless", None), "pipeline", None)
        if pipeline is not None:
            pipeline.release_snapshot()

    def _screenshot(self, path: Path) -> None:
        from PIL import Image

        if self.state is None:
            self.window.notice(list(NOTICE), self.drift(self.clock()))
        else:
            self._draw(self.state.frame, self.clock())
        Image.fromarray(self.window.read()).save(path)


def _level(levels: dict, wanted: int):
    """The mesh at level ``wanted``, else the nearest prepared (a finer one first)."""
    if wanted in levels:
        return levels[wanted]
    return levels[min(levels, key=lambda level: (abs(level - wanted), level > wanted))]


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
                      fullscreen=config.fullscreen and not windowed, samples=0,
                      msaa_samples=config.samples, vsync=config.vsync, monitor=config.monitor)
    except RenderUnavailable as exc:
        raise ExhibitError(f"{exc}. Headless, render pictures instead: "
                           "`exhibit render --figure 8 --out figure-8.png`") from None

