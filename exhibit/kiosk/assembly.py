"""The running kiosk's parts, built from its config and window and handed to exhibit.kiosk.app.
Kiosk: the devices and the mapping, the frame governor, the languages, the framing, the
time-slice inset, the scenes on the GPU (the first prepared now, the rest by the preparer), the
attract/visitor state and the reports. A test or a review hands the Kiosk parts of its own."""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from exhibit.devices.config import load_config
from exhibit.devices.hub import DeviceSet
from exhibit.devices.mapping import ActivityDetector, Mapper
from exhibit import scenes
from exhibit.errors import ExhibitError
from exhibit.timelines.file import load_playlist
from exhibit.timelines.model import Timeline
from exhibit.timelines.playlist import Playlist
from exhibit.kiosk.config import KioskConfig
from exhibit.kiosk.content import Content, prepare_first
from exhibit.framing.follow import Aims
from exhibit.kiosk.governor import Governor, for_kiosk, mesh_levels
from exhibit.kiosk.hud_words import HudWords
from exhibit.kiosk.language import LanguageChoice, Translator, in_every_language, translator_for
from exhibit.kiosk.narration_cues import NarrationCues
from exhibit.kiosk.narrator import Narrator, SoundPlayer, for_kiosk as narrator_for
from exhibit.preparing.jobs import Framers, scene_jobs
from exhibit.preparing.preparing import Preparer
from exhibit.kiosk.frame_passes import PassSampler
from exhibit.kiosk.reporting import Reporter
from exhibit.preparing.scene_meshes import SceneMeshes
from exhibit.kiosk.slice_inset import SliceInset
from exhibit.framing.start_views import StartViews
from exhibit.kiosk.state import KioskState
from exhibit.kiosk.visits import Visits
from exhibit.render.framer import Framer
from exhibit.render.inset import inset_rect
from exhibit.render.layout import TextSizes, hud_layout
from exhibit.operations.notify import Notifier
from exhibit.render.target import RenderTarget

log = logging.getLogger("exhibit.kiosk")


@dataclass(frozen=True)
class KioskParts:
    """What a Kiosk runs with, built whole before it starts. ``state`` is None when no scene
    could be prepared (the window then shows a notice); ``problems`` and ``scenes_failed`` are
    the health file's lists, appended to as scenes arrive or fail."""

    devices: DeviceSet
    governor: Governor
    text: TextSizes
    translate: Translator
    language: LanguageChoice
    framer: Framer
    inset: SliceInset
    content: Content
    state: KioskState | None
    reporter: Reporter
    started: float
    narrator: Narrator
    #: The HUD's words in the language on screen, and the narration's cues to the frames.
    words: HudWords
    cues: NarrationCues
    #: The language and the session log followed as visitors come and go.
    visits: Visits
    #: One frame measured pass by pass now and then, for the health file.
    passes: PassSampler
    problems: list[str] = field(default_factory=list)
    scenes_failed: list[dict] = field(default_factory=list)

    def health(self, now: float) -> dict:
        """What the parts tell the health file (exhibit.kiosk.reporting.Reporter.report)."""
        return {
            "devices": self.devices.statuses(now),
            "problems": self.problems,
            "scenes_failed": self.scenes_failed,
            "language": self.translate.language,
            "governor": self.governor,
            "narration": self.narrator.status(),
            "frame_passes": self.passes.health(now),
        }


def _timelines(config: KioskConfig, problems: list[str]) -> list[Timeline]:
    try:
        if config.attract_dir is None:  # load_config always sets it
            raise ExhibitError("no attract folder is set")
        return load_playlist(config.attract_dir, scenes.get)
    except Exception as exc:  # noqa: BLE001 - attract mode can do without timelines
        log.error("no attract timelines: %s", exc)
        problems.append(f"no attract timelines: {exc}")
        return []


def assemble(
    config: KioskConfig,
    window: RenderTarget,
    clock: Callable[[], float] = time.monotonic,
    notifier: Notifier | None = None,
    health_path: Path | None = None,
    preparer: Callable[[Framers], Preparer] | None = None,
    narration_player: SoundPlayer | None = None,
) -> KioskParts:
    """The parts, the first scene prepared (the first frame needs it); ``preparer(framers)``
    makes the preparer of the rest (exhibit.preparing.preparing), None: all of them now.
    ``narration_player``: the narrator's player instead of the site's sound device (a review's
    tape, exhibit.narration.tape), its sounds then made when wanted, not on a worker."""
    problems: list[str] = []
    scenes_failed: list[dict] = []
    for problem in config.scene_problems:  # broken files, left out
        log.error("scene file left out: %s", problem)
        problems.append(f"scene file left out: {problem}")
    timelines = _timelines(config, problems)
    device_config = load_config(config.devices_config)
    devices = DeviceSet(device_config, clock=clock).open()
    mapper = Mapper(
        device_config.mapping, ActivityDetector(threshold=device_config.activity_threshold)
    )
    governor = for_kiosk(config, window, clock())  # picture quality vs frame time
    text = TextSizes(config.text.caption_cap, config.text.title_cap, config.text.infinity_beyond)
    translate = translator_for(config, problems)
    language = LanguageChoice(translate, config.language_switch_s, clock())
    # The framing keeps the picture clear of the panels in every language shown.
    versions = functools.partial(in_every_language, translate)
    words = tuple(translate.hud_words(code) for code in translate.order)
    size = window.size
    framer = Framer(size, text, config.drift_px, hud=config.hud, versions=versions, words=words)
    inset = SliceInset(
        inset_rect(size, hud_layout(size, sizes=text).margin), window.renderer.upload
    )
    inset_framer = Framer(
        size,
        text,
        config.drift_px,
        hud=config.hud,
        extra=(inset.rect,),
        versions=versions,
        words=words,
    )
    started = clock()
    framers = Framers(framer, inset_framer)
    jobs = scene_jobs(config, timelines, mesh_levels(governor))
    order = [t for job in jobs for t in job.timelines]  # the attract folder's, before any runs
    meshes = SceneMeshes(window.renderer.upload, problems, scenes_failed)
    first = prepare_first(meshes, jobs, framers, governor.quality.mesh, clock, notifier)
    state = None
    if meshes.gpu:
        state = KioskState(
            Playlist(first),
            mapper,
            meshes.shown(config.scenes),
            config.idle_timeout_s,
            config.blend_s,
            started,
            framer=StartViews(framer, meshes),
            reduced_motion=config.reduced_motion,
            follow=Aims(framer, meshes),
        )
    else:
        log.critical(
            "no scene could be prepared: the kiosk shows a notice until it is fixed and restarted"
        )
        problems.append("no scene could be prepared: the screen shows a notice")
        preparer = None  # nothing to show them on: the rest here and now, for the health file
    content = Content(meshes, state, order)
    content.prepare_rest(jobs, framers, preparer, started)
    narrator = narrator_for(config, timelines, translate, narration_player)
    return KioskParts(
        devices=devices,
        governor=governor,
        text=text,
        translate=translate,
        language=language,
        framer=framer,
        inset=inset,
        content=content,
        state=state,
        reporter=Reporter(notifier, health_path, started),
        started=started,
        narrator=narrator,
        words=HudWords(translate),
        cues=NarrationCues(narrator, translate),
        visits=Visits(language, translate, narrator),
        passes=PassSampler(window, lambda: governor.quality.name),
        problems=problems,
        scenes_failed=scenes_failed,
    )
