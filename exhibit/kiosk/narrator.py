"""Narration in the running kiosk: "listen" speaks what the screen shows, in the visitor's
language, and attract mode waits for it.

A press of a ``listen`` button (exhibit.devices.mapping) turns narration on, from the caption on
screen, and a second press turns it off; a visitor walking away turns it off (attract mode is
silent unless the site's [narration] attract says otherwise). The press is no takeover: attract
mode goes on, spoken. Each segment (exhibit.narration.script: a keyframe's description and
caption) is spoken once, when its keyframe comes; while narration is on, attract mode holds the
last moment of a segment's window until its words have been spoken (:meth:`Narrator.hold_at`).
In a visitor's own scene it speaks the scene's title and caption once.

Never in the frame loop: the sounds are made (synthesised, cached on disk, recordings checked)
by a worker thread from the first press on (from start-up when attract mode speaks), and
`exhibit prepare` fills the cache before; the player
(exhibit.narration.player) plays from its own thread. A sound not ready yet is spoken when it
is; one that cannot be made is skipped and named in the health file, never a crash. The engine
has a time limit a call (exhibit.tools.ESPEAK_CALL_S; a review and `exhibit prepare` also one in
all): once it has hung, the segments after it are skipped at once, not waited for one by one,
and its process never outlives the kiosk (exhibit.tools)."""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from exhibit.narration.script import Segment, segment_at, segments
from exhibit.narration.speech import SpeechBudget, SpeechSkipped

if TYPE_CHECKING:
    from exhibit.timelines.model import Timeline
    from exhibit.kiosk.config import KioskConfig
    from exhibit.kiosk.language import Translator
    from exhibit.narration.sound import Sound

log = logging.getLogger("exhibit.kiosk")

#: A window ends this long before the next keyframe when held (so its caption stays on screen).
HOLD_EPSILON_S = 1e-3
#: The longest attract mode waits for a sound still being made before it moves on.
MAX_PENDING_S = 5.0


@dataclass(frozen=True)
class Spoken:
    """What is being spoken: a timeline's segment (timeline path, segment index, language) or a
    visitor's scene (scene name, -1, language)."""

    source: str
    index: int
    language: str


class SoundPlayer(Protocol):
    """What the narrator plays through: exhibit.narration.player.Player on the site's sound
    device, or a review's tape (exhibit.narration.tape.TapePlayer)."""

    def play(self, sound: Any) -> None: ...
    def stop(self) -> None: ...
    @property
    def playing(self) -> bool: ...
    def status(self) -> dict: ...
    def close(self) -> None: ...


class Narrator:
    """``timelines``: the kiosk's (exhibit.timelines.model.Timeline); ``translate(text, code)``:
    its words (exhibit.kiosk.language); ``player``: an exhibit.narration.player.Player (or one
    with its interface); ``make(segment) -> Sound``: how a segment's sound is made (default:
    its recording, else synthesised speech from the cache, within ``budget``: the time the
    speech engine may take, exhibit.narration.speech.SpeechBudget, by default a limit a call
    and none in all, as the kiosk runs for weeks)."""

    def __init__(
        self,
        timelines: Sequence,
        languages: Sequence[str],
        translate: Callable[[str, str], str],
        player: SoundPlayer,
        attract: bool = False,
        make: Callable[[Segment], object] | None = None,
        background: bool = True,
        budget: SpeechBudget | None = None,
    ) -> None:
        self.budget = budget if budget is not None else SpeechBudget()
        #: Any: a review reads its tape back through it (exhibit.narration.tape.TapePlayer).
        self.player: Any = player
        self.attract = attract
        self.pressed_on = False
        self._translate = translate
        self._make = make or (lambda segment: make_sound(segment, self.budget))
        self._scripts: dict[tuple[str, str], list[Segment]] = {
            (t.path, code): segments(t, code, translate) for t in timelines for code in languages
        }
        self._sounds: dict[tuple[str, int, str], object] = {}
        self._failed: dict[tuple[str, int, str], str] = {}
        #: Those skipped because the engine hung before: key -> that first reason.
        self._skipped: dict[tuple[str, int, str], str] = {}
        self._speaking: Spoken | None = None
        #: What was spoken lately: (when it started, what, its segment), for reviews (bounded:
        #: a kiosk runs for weeks).
        self.history: deque[tuple[float, Spoken, Segment]] = deque(maxlen=1000)
        self._pending_since: float | None = None
        self._lock = threading.Lock()
        self._worker: threading.Thread | None = None
        self._background = background
        if attract:
            self._start_worker()

    def _start_worker(self) -> None:
        """Make every segment's sound on a worker thread, once narration is wanted (a kiosk
        nobody asks to speak makes none; `exhibit prepare` has filled the cache anyway)."""
        if self._worker is None and self._background:
            self._worker = threading.Thread(
                target=self._prepare_all, name="exhibit-narration", daemon=True
            )
            self._worker.start()

    # ------------------------------------------------------------------ preparing sounds

    def _prepare_all(self) -> None:
        for (path, _code), parts in list(self._scripts.items()):
            for n, segment in enumerate(parts):
                self._sound((path, n, segment.language), segment)

    def _sound(self, key: tuple[str, int, str], segment: Segment):
        """The sound of a segment, made once (by whichever thread asks first)."""
        with self._lock:
            if key in self._sounds or key in self._failed:
                return self._sounds.get(key)
        try:
            sound = self._make(segment)
        except Exception as exc:  # noqa: BLE001 - a sound that cannot be made is skipped
            with self._lock:
                self._failed[key] = str(exc)
                if isinstance(exc, SpeechSkipped):
                    self._skipped[key] = exc.reason
                    return None  # logged once, when it hung
            log.warning("narration of %s, segment %d (%s): %s", key[0], key[1], key[2], exc)
            return None
        with self._lock:
            self._sounds.setdefault(key, sound)
            return self._sounds[key]

    def _request(self, key: tuple[str, int, str], segment: Segment) -> None:
        """Make the sound now: on a thread of its own in the kiosk (it is wanted before the
        worker reaches it), here without one (reviews and tests run on a fake clock)."""
        if not self._background:
            self._sound(key, segment)
            return
        threading.Thread(
            target=self._sound, args=(key, segment), name="exhibit-narration", daemon=True
        ).start()

    def ready(self, key: tuple[str, int, str]) -> object | None:
        with self._lock:
            return self._sounds.get(key)

    # ------------------------------------------------------------------ the visitor's control

    def on(self, attract_mode: bool) -> bool:
        """Whether narration speaks now (``attract_mode``: the kiosk is in attract mode)."""
        return self.pressed_on or (self.attract and attract_mode)

    def press(self) -> None:
        """A listen button: on (from the caption on screen), or off."""
        self.pressed_on = not self.pressed_on
        log.info("narration %s", "on" if self.pressed_on else "off")
        self._start_worker()
        self._stop()  # off: silence; on: the segment on screen spoken from its start

    @property
    def speaking(self) -> bool:  # words playing, or being made to play now
        return self.player.playing or self._pending_since is not None

    def walked_away(self) -> None:
        """The visitor's session ended: narration off (attract mode's own, if any, goes on)."""
        if self.pressed_on:
            log.info("narration off: the visitor walked away")
        self.pressed_on = False
        self._stop()

    def _stop(self) -> None:
        self._speaking = None
        self._pending_since = None
        self.player.stop()

    # ------------------------------------------------------------------ each frame

    def speak_timeline(self, timeline: Timeline, t: float, language: str, now: float) -> None:
        """Speak the segment of ``timeline`` whose window holds ``t``, once (attract mode)."""
        parts = self._scripts.get((timeline.path, language))
        if not parts:
            return
        n = segment_at(parts, t)
        if n is None:
            return
        self._speak(Spoken(timeline.path, n, language), parts[n], now)

    def speak_scene(self, scene: str, title: str, caption: str, language: str, now: float) -> None:
        """Speak a visitor's scene: its title and caption, once."""
        text = " ".join(
            w.strip()
            for w in (self._translate(title, language), self._translate(caption, language))
        )
        segment = Segment(-1, 0.0, 0.0, text.strip(), language)
        self._speak(Spoken(scene, -1, language), segment, now)

    def _speak(self, spoken: Spoken, segment: Segment, now: float) -> None:
        key = (spoken.source, spoken.index, spoken.language)
        if self._speaking != spoken:
            self._speaking = spoken
            self._pending_since = now
            self.player.stop()
            if self.ready(key) is None:
                self._request(key, segment)
        if self._pending_since is None:
            return  # started already (or given up on)
        sound = self.ready(key)
        if sound is not None:
            self.player.play(sound)
            self._pending_since = None
            self.history.append((now, spoken, segment))
        elif key in self._failed or now - self._pending_since > MAX_PENDING_S:
            self._pending_since = None  # never ready: attract mode does not wait for it

    def speaking_until(self, language: str) -> tuple[str, float] | None:
        """(timeline path, the end of its window) of the timeline segment whose words still go
        on in ``language`` (or whose sound is still being made): attract mode must not pass
        that moment of that timeline yet; None: nothing holds it."""
        s = self._speaking
        if s is None or s.index < 0 or s.language != language:
            return None
        parts = self._scripts.get((s.source, language)) or []
        if s.index >= len(parts):
            return None
        return (s.source, parts[s.index].end - HOLD_EPSILON_S) if self.speaking else None

    def hold_at(self, timeline: Timeline, t: float, language: str) -> float | None:
        """Where attract mode must hold ``timeline`` instead of reaching ``t`` (see
        speaking_until); None: no need."""
        until = self.speaking_until(language)
        if until is None or until[0] != timeline.path or t < until[1]:
            return None
        return until[1]

    def status(self) -> dict:
        """For the health file and `exhibit status`."""
        with self._lock:
            failed = dict(self._failed)
            made = len(self._sounds)
        s = self._speaking
        return {
            "on": self.pressed_on,
            "attract": self.attract,
            "speaking": None if s is None else f"{s.source} #{s.index} ({s.language})",
            "sounds": made,
            "failed": [f"{k[0]} #{k[1]} ({k[2]}): {why}" for k, why in sorted(failed.items())],
            "player": self.player.status(),
        }

    def failures(self) -> list[str]:
        """The segments that could not be made, one line each ("PATH #N (en): why"), those
        skipped after the engine hung counted on the line of the one it hung on."""
        with self._lock:
            failed, skipped = dict(self._failed), dict(self._skipped)
        return report_lines(
            (f"{k[0]} #{k[1]} ({k[2]})", skipped.get(k, why), k in skipped)
            for k, why in sorted(failed.items())
        )

    def close(self) -> None:
        self.player.stop()
        self.player.close()


def for_kiosk(
    config: KioskConfig,
    timelines: Sequence[Timeline],
    translate: Translator,
    player: SoundPlayer | None = None,
) -> Narrator:
    """The kiosk's narrator: its [narration] settings (exhibit.kiosk.config.NarrationConfig),
    every timeline in every language shown, its player opened on the site's device (or
    ``player``: a review's tape, whose sounds are made when wanted)."""
    settings = config.narration
    background = player is None
    if player is None:
        from exhibit.narration.player import Player

        player = Player(
            device=settings.device or None,
            volume=settings.volume,
            backend=settings.backend or None,
        )
    return Narrator(
        timelines,
        tuple(config.languages),
        lambda text, code: translate(text, code),
        player,
        attract=settings.attract,
        background=background,
        # a review is a command: its speech has a time in all, the kiosk's only one a call
        budget=SpeechBudget() if background else SpeechBudget.for_command(),
    )


def make_sound(segment: Segment, budget: SpeechBudget | None = None) -> Sound:
    """A segment's sound: the curator's recording (checked: exhibit.narration.recordings) when
    it has one, else its words synthesised (cached: exhibit.narration.cache) within
    ``budget``."""
    from exhibit.narration.cache import spoken
    from exhibit.narration.recordings import load_recording

    if segment.recording is not None:
        return load_recording(Path(segment.recording), Path(segment.root or "."))
    return spoken(segment.text, segment.language, budget=budget)


@dataclass(frozen=True)
class Prepared:
    """One segment's sound made ahead (exhibit prepare, check-config): how long it speaks
    against the window its caption is shown, or why it cannot be made."""

    timeline: str
    segment: Segment
    seconds: float | None
    error: str | None = None
    #: Not made because the engine hung (or the run's time ran out) before: ``error`` says why.
    skipped: bool = False

    @property
    def overrun(self) -> float:
        """Seconds the narration runs past its window (attract mode holds the caption)."""
        return 0.0 if self.seconds is None else max(0.0, self.seconds - self.segment.window)


def prepare_all(
    config: KioskConfig,
    timelines: Sequence,
    progress: Callable[[str], object] | None = None,
    budget: SpeechBudget | None = None,
) -> list[Prepared]:
    """Every segment of every timeline in every language shown, its sound made (synthesised
    into the cache, recordings checked) as the kiosk will want it; ``progress(text)`` is told
    each one. The speech engine's time is ``budget`` (default: a command's,
    SpeechBudget.for_command): once it has hung, the segments after it are skipped at once."""
    from exhibit.kiosk.language import translator_for

    budget = budget if budget is not None else SpeechBudget.for_command()

    translate = translator_for(config, [])
    out = []
    for timeline in timelines:
        for code in config.languages:
            for segment in segments(timeline, code, lambda text, c: translate(text, c)):
                if progress is not None:
                    progress(f"narration: {Path(timeline.path).name} keyframe {segment.keyframe}")
                try:
                    sound = make_sound(segment, budget)
                except SpeechSkipped as exc:
                    out.append(Prepared(timeline.path, segment, None, exc.reason, skipped=True))
                    continue
                except Exception as exc:  # noqa: BLE001 - reported per segment, by name
                    out.append(Prepared(timeline.path, segment, None, str(exc)))
                    continue
                out.append(Prepared(timeline.path, segment, float(sound.duration)))
    return out


def report_lines(failures: Iterable[tuple[str, str, bool]]) -> list[str]:
    """``failures`` as (where, why, skipped) in order, as lines "where: why" for a report;
    those skipped after the engine hung are not listed one by one: the line of the segment it
    hung on says how many ("...: espeak-ng did not answer within 20 s (speaking '...'); speech
    skipped for 59 more segments")."""
    failures = list(failures)
    skipped = [why for _, why, was_skipped in failures if was_skipped]
    lines = []
    for where, why, was_skipped in failures:
        if was_skipped:
            continue
        if skipped and why == skipped[0]:
            n = len(skipped)
            why = f"{why}; speech skipped for {n} more segment{'s' if n != 1 else ''}"
            skipped = []
        lines.append(f"{where}: {why}")
    if skipped:  # it hung before this run's first segment (a shared budget)
        where = next(where for where, _, was_skipped in failures if was_skipped)
        n = len(skipped)
        lines.append(
            f"{where}: {skipped[0]}; speech skipped for {n} segment{'s' if n != 1 else ''}"
        )
    return lines
