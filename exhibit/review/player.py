"""Reviewing attract mode off the exhibit: the real kiosk (exhibit.kiosk.app.Kiosk), headless, on
a clock this module sets, so a curator sees a timeline exactly as visitors will (its framing,
captions, crossfades, language, the time-slice inset and the HUD) without a screen.

:class:`KioskPlayer` builds a Kiosk for one timeline (or for one scene with no timeline) from a
kiosk config: the content is that scene, the attract folder holds just that timeline, the
keyboard is the only device (the config's own keyboard bindings), the quality level is pinned
(the frame governor would step on the timing of whatever machine renders) and attract mode never
changes language by itself. It steps the kiosk on a fake clock and hands back the frames.

`exhibit render --timeline` and `--takeover` (exhibit.commands.render) are built on it, and so
are `--verify` (exhibit.review.claims), the narrated review (exhibit.review.narrated) and the
golden tests of what a visitor sees after taking over (tests/golden/test_takeover.py). What it
plays is checked first, in exhibit.review.setup.
"""

from __future__ import annotations

import dataclasses
import os
import logging
import math
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING
from collections.abc import Callable, Iterable, Iterator

import numpy as np

from exhibit.errors import ExhibitError
from exhibit.kiosk.config import KioskConfig, NarrationConfig, QualityConfig
from exhibit.review.setup import base_config, check_language, keyboard_only, read_timeline
from exhibit.timelines.model import Timeline

if TYPE_CHECKING:
    from exhibit.render import Headless

log = logging.getLogger("exhibit.kiosk")

#: The quality level a review is drawn at (pinned: the governor would follow the machine).
LEVEL = "fxaa"
#: How long a caption has been on screen in the frame a contact sheet shows of it (fully faded
#: in by then), or half its time on screen when that is shorter.
SETTLED_S = 1.5
#: Takeover: attract plays this long, then a view key is held this long.
ATTRACT_S = 3.0
HOLD_S = 0.25
#: The key a takeover presses (the shipped keyboard turns θ1 with q).
TAKEOVER_KEY = "q"


class FakeClock:
    """The kiosk's clock, set by the player."""

    def __init__(self, t: float = 0.0):
        self.t = t

    def __call__(self) -> float:
        return self.t


@dataclass(frozen=True)
class CaptionSpan:
    """A caption of a timeline and when it is on screen (``text`` in English, as written)."""

    start: float
    end: float
    text: str

    @property
    def settled(self) -> float:
        """The moment a contact sheet shows it: fully faded in, still on screen."""
        return self.start + min(SETTLED_S, (self.end - self.start) / 2)


@dataclass
class ReviewFrame:
    """One kiosk frame: when, the picture, and the words as shown (``caption``, translated) and
    as written (``caption_en``)."""

    t: float
    image: np.ndarray
    caption: str
    caption_en: str
    language: str
    mode: str
    scene: str


def caption_spans(timeline: Timeline) -> list[CaptionSpan]:
    """The captions of a timeline in the order shown, each with its time on screen; a caption
    set on the last keyframe is shown for an instant only and left out, as are empty ones."""
    spans: list[CaptionSpan] = []
    frames = timeline.keyframes
    for i, keyframe in enumerate(frames[:-1]):
        if spans and spans[-1].text == keyframe.caption and spans[-1].end == keyframe.t:
            spans[-1] = dataclasses.replace(spans[-1], end=frames[i + 1].t)
        else:
            spans.append(CaptionSpan(keyframe.t, frames[i + 1].t, keyframe.caption))
    return [s for s in spans if s.text and s.end > s.start]


def play_schedule(
    duration: float, fps: float, times: Iterable[float] | None = None
) -> list[tuple[float, bool]]:
    """The kiosk frames a review draws, as (time, kept): every frame of the ``fps`` grid from 0
    to ``duration`` (all kept), or, with ``times``, each of those times (kept) after the grid's
    frames in the LEAD_S before it (not kept). What a frame shows depends on the time alone but
    for a crossfade under way (exhibit.kiosk.app.CROSSFADE_S, begun at a cut), so these few
    frames show each kept time as the whole timeline played at ``fps`` would: a contact sheet of
    a day-long timeline draws a few frames a caption, not the day."""
    end = float(duration)
    count = max(1, int(round(end * fps)))
    if times is None:
        return [(min(i / fps, end), True) for i in range(count + 1)]
    lead = lead_s(fps)
    wanted = sorted({min(max(float(t), 0.0), end) for t in times})
    out: list[tuple[float, bool]] = []
    done = -1.0
    for t in wanted:
        first = max(0, math.ceil(max(t - lead, done) * fps - 1e-9))
        i = first
        while i / fps < t - 1e-9 and i <= count:
            if i / fps > done:
                out.append((i / fps, False))
            i += 1
        out.append((t, True))
        done = t
    return out


def takeover_frames(after: float, fps: float, attract_s: float = ATTRACT_S) -> int:
    """About how many frames :meth:`KioskPlayer.takeover` draws (for the job's size check)."""
    return math.ceil((attract_s + after) * fps) + 3


def lead_s(fps: float) -> float:
    """How long before a kept time :func:`play_schedule` starts stepping: a crossfade and two
    frames (the cut that starts it may fall between two)."""
    from exhibit.kiosk.app import CROSSFADE_S

    return CROSSFADE_S + 2.0 / fps


class KioskPlayer:
    """The real kiosk for one ``timeline`` file (attract mode plays it, from t = 0) or, with
    ``timeline=None``, one ``scene`` with no timeline (attract mode turns it slowly), at
    ``size``, in ``language``, on a fake clock. ``headless`` (an exhibit.render.Headless) is
    used if given, else made and released by :meth:`close`."""

    def __init__(
        self,
        size: tuple[int, int],
        timeline: str | Path | None = None,
        scene: str | None = None,
        language: str | None = None,
        config: KioskConfig | None = None,
        headless: Headless | None = None,
        narrate: bool = False,
    ):
        """``narrate``: the kiosk speaks as after a visitor's listen press (every caption
        held until spoken), onto a tape (exhibit.narration.tape) on the review's clock."""
        from exhibit.kiosk import app
        from exhibit.kiosk.assembly import assemble
        from exhibit.narration.tape import TapePlayer
        from exhibit.render.target import HeadlessTarget

        config = config or base_config()
        self.timeline = read_timeline(timeline) if timeline is not None else None
        if self.timeline is not None:
            self.scene = self.timeline.scene
        elif scene is not None:
            self.scene = scene
        else:
            raise ExhibitError("name a timeline or a scene")
        self.language, catalogues = check_language(config, language)
        self._tmp = Path(tempfile.mkdtemp(prefix="exhibit-review-"))
        self._own_headless = headless is None
        #: Called with 1 after each kiosk frame (a long job's progress).
        self.on_step: Callable[[int], object] | None = None
        try:
            attract = self._tmp / "attract"
            attract.mkdir()
            if timeline is not None and self.timeline is not None:  # one is the other's
                shutil.copyfile(timeline, attract / Path(timeline).name)
                copy_recordings(self.timeline, Path(timeline).parent, attract)
            languages = (self.language, *(c for c in config.languages if c != self.language))
            config = dataclasses.replace(
                config,
                size=(int(size[0]), int(size[1])),
                fullscreen=False,
                scenes=(self.scene,),
                start_scene=self.scene,
                attract_dir=attract,
                devices_config=keyboard_only(config.devices_config, self._tmp / "devices.toml"),
                quality=QualityConfig(level=LEVEL),
                languages=languages,
                catalogues_dir=catalogues,
                language_switch_s=0.0,
                narration=NarrationConfig(attract=narrate, backend="null"),
            )
            self.config = config
            if headless is None:
                from exhibit.render import Headless

                headless = Headless()
            self.headless = headless
            from exhibit.render.offscreen import size_problem

            problem = size_problem(headless.ctx, config.size)  # the pinned level: no MSAA
            if problem is not None:
                raise ExhibitError(f"--size: {problem}")
            self.clock = FakeClock(0.0)
            self.window = HeadlessTarget(headless, config.size)
            quiet = self.timeline is None  # no timeline is what we asked for, not a problem
            logger = logging.getLogger("exhibit.kiosk")
            level = logger.level
            if quiet:
                logger.setLevel(logging.CRITICAL)
            try:
                # never a sound device: the review's narration (if any) goes onto tape
                tape = TapePlayer(self.clock)
                parts = assemble(config, self.window, self.clock, narration_player=tape)
                self.kiosk = app.Kiosk(config, self.window, clock=self.clock, parts=parts)
            finally:
                logger.setLevel(level)
            if self.kiosk.state is None:
                raise ExhibitError(
                    f"the kiosk could not prepare {self.scene}: "
                    + "; ".join(self.kiosk.parts.problems)
                )
            translate = self.kiosk.translate
            if self.language in translate.order:  # shown first already; select it all the same
                translate.index = translate.order.index(self.language)
            self.started = False
        except BaseException:
            self.close()
            raise

    @property
    def duration(self) -> float:
        return self.timeline.duration if self.timeline is not None else 0.0

    def captions(self) -> list[CaptionSpan]:
        return caption_spans(self.timeline) if self.timeline is not None else []

    # ------------------------------------------------------------------ stepping

    def step_to(self, t: float) -> None:
        """One kiosk frame at time ``t`` (never before the last)."""
        self.clock.t = max(float(t), self.clock.t)
        self.kiosk.step()
        self.started = True
        if self.on_step is not None:
            self.on_step(1)

    def run_to(self, t: float, fps: float) -> None:
        """Frames at ``fps`` up to time ``t``, the last exactly at ``t``."""
        step = 1.0 / fps
        n = math.floor((t - self.clock.t) / step - 1e-9) if self.started else 0
        base = self.clock.t
        for i in range(1, n + 1):
            self.step_to(base + i * step)
        self.step_to(t)

    def frame(self) -> ReviewFrame:
        """The frame drawn last."""
        state, image = self.kiosk.state, self.window.image
        assert state is not None  # __init__ refused a kiosk without one
        assert image is not None  # step_to drew a frame
        frame = state.frame
        return ReviewFrame(
            self.clock.t,
            image.copy(),
            self.kiosk.translate(frame.caption),
            frame.caption,
            self.kiosk.translate.language,
            frame.mode,
            frame.scene,
        )

    def key(self, name: str, pressed: bool) -> None:
        """A key on the kiosk's keyboard device, now."""
        keyboard = self.kiosk.devices.keyboard
        assert keyboard is not None  # keyboard_only() gave the review kiosk one
        keyboard.key(name, pressed, t=self.clock())

    def schedule(
        self, fps: float, times: Iterable[float] | None = None
    ) -> list[tuple[float, bool]]:
        """The frames :meth:`play` draws: (time, kept) (see :func:`play_schedule`)."""
        return play_schedule(self.duration, fps, times)

    def play(
        self,
        fps: float,
        times: Iterable[float] | None = None,
        progress: Callable[[int], object] | None = None,
    ) -> Iterator[ReviewFrame]:
        """The timeline from t = 0 to its end at ``fps`` frames a second, every frame (or only
        those at ``times``, each after the few frames on the ``fps`` grid a crossfade into it
        needs: :func:`play_schedule`). The last frame is taken just before the end, where the
        playlist would loop back to the start. ``progress(n)`` is called after each frame."""
        end = self.duration
        last = end - 1e-4 if end > 0 else 0.0
        if progress is not None:
            self.on_step = progress
        for t, kept in self.schedule(fps, times):
            self.step_to(min(t, last))
            if kept:
                shown = self.frame()
                shown.t = t
                yield shown

    def play_through(
        self,
        fps: float,
        progress: Callable[[int], object] | None = None,
        limit_s: float = 3600.0,
    ) -> Iterator[tuple[ReviewFrame, float]]:
        """Every frame at ``fps`` until the timeline has played to its end, however long the
        narration holds it (at most ``limit_s`` of kiosk time): (frame, time into the
        timeline) pairs; the frame that would show it looping back to its start is left out."""
        if progress is not None:
            self.on_step = progress
        assert self.kiosk.state is not None
        playlist = self.kiosk.state.playlist
        reached, k = 0.0, 0
        while k / fps <= limit_s:
            self.step_to(k / fps)
            _, into = playlist.locate(self.clock())
            if into < reached - 1e-6:  # looped back to the start: the end has passed
                return
            reached = into
            yield self.frame(), into
            k += 1

    def takeover(
        self,
        after: float,
        fps: float = 10.0,
        attract_s: float = ATTRACT_S,
        key: str = TAKEOVER_KEY,
        hold_s: float = HOLD_S,
    ) -> ReviewFrame:
        """What a visitor sees ``after`` seconds after taking over: attract plays
        ``attract_s`` seconds, then ``key`` is pressed for ``hold_s`` seconds and let go."""
        self.run_to(attract_s, fps)
        self.key(key, True)
        self.run_to(attract_s + min(hold_s, after), fps)
        self.key(key, False)
        self.run_to(attract_s + after, fps)
        return self.frame()

    def close(self) -> None:
        kiosk = getattr(self, "kiosk", None)
        if kiosk is not None:
            kiosk.devices.close()
            kiosk.release()
            del self.kiosk  # closed: no kiosk left (getattr above)
        if self._own_headless and getattr(self, "headless", None) is not None:
            self.headless.release()
            del self.headless  # released: none left (getattr above)
        shutil.rmtree(self._tmp, ignore_errors=True)

    def __enter__(self) -> KioskPlayer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def copy_recordings(timeline: Timeline, source: Path, attract: Path) -> None:
    """The timeline's recorded narration beside its copy in a review's attract folder, at the
    same paths relative to it (each read as the kiosk reads it: a file that is not a regular
    file, is too big or lies outside ``source`` is not copied, and the review, like the kiosk,
    names it and speaks without it)."""
    from exhibit.narration.recordings import MAX_BYTES
    from exhibit.schema.files import read_regular

    for keyframe in timeline.keyframes:
        for _code, path in keyframe.recordings:
            named = Path(path)
            try:
                # Where the timeline names it (a link inside the folder keeps its own name; read
                # from where it leads, which must lie inside the folder too, as for the kiosk).
                relative = Path(os.path.relpath(named.absolute(), source.absolute()))
                real = named.resolve(strict=True)
                real.relative_to(source.resolve())
                if relative.parts[:1] == ("..",):
                    continue
                data = read_regular(real, MAX_BYTES)
            except (OSError, ValueError, RuntimeError, ExhibitError):
                continue
            target = attract / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
