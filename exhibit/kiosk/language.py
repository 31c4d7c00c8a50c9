"""Captions in the visitor's language: one TOML catalogue per language, keyed by the English text.

    # configs/languages/de.toml
    language = "de"
    name = "Deutsch"
    [text]
    "When a ball meets a pipe" = "Wenn eine Kugel auf ein Rohr trifft"
    [voice]
    name = "de"      # espeak-ng's voice for the narration (espeak-ng --voices=de lists them)

A language is data: its words and voice. A site's catalogue adds to the shipped one line by line.

Why TOML keyed by the English words, not gettext .po files: curators already write scenes and
timelines in TOML through the same checked reader (exhibit.schema: `file: key: reason`), the
English text in a scene or timeline is what they see and change, and a catalogue needs no
compile step or extra tool on a museum PC. The cost, a changed English caption losing its
translation, is what `exhibit check-config` reports: every title, caption and HUD word the kiosk
can show, in every language it shows, must have a translation, in glyphs the font has.

English is the source: it needs no catalogue. A missing translation shows the English text
(never a blank), and a broken catalogue leaves that language out with one log line.
"""

from __future__ import annotations

import io
import logging
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Protocol
from collections.abc import Callable, Iterable, Sequence

from pydantic import Field, field_validator

from exhibit.errors import ConfigError
from exhibit.narration.speech import DEFAULT_RATE_WPM, Voice, set_voice
from exhibit.resources import shipped
from exhibit.timelines.model import Timeline
from exhibit.render.layout import KEY_WORDS
from exhibit.schema import Model, read_toml, validate
from exhibit.schema.types import Caption, Name, Number, Text

log = logging.getLogger("exhibit.kiosk")

SOURCE = "en"
#: Words the HUD itself shows, beside the scenes' and timelines' own: the gizmo's caption,
#: the numbers panel's labels, the words of marker labels (exhibit.scenes.collision's
#: "first contact, t = ..."; the formula after the comma is not translated) and the key's
#: entries under the numbers (exhibit.render.layout.KEY_WORDS: "first contact" is one).
HUD_WORDS = tuple(dict.fromkeys(("4D axes", "sensor", "eye", "fov", "first contact", *KEY_WORDS)))
#: What the screen says while the scene a visitor chose is still being prepared (the kiosk's
#: first seconds after a cold start); {title} is the scene's title, in the same language.
PREPARING = "Preparing: {title}…"
LanguageCode = Annotated[str, Field(pattern=r"^[a-z]{2,3}(-[A-Z]{2})?$")]
#: The shortest time between two changes of language by attract mode's timer.
MIN_SWITCH_S = 10.0


class LanguagesSection(Model):
    """``[languages]`` of kiosk.toml: which languages, in order (the first is shown at start),
    where the catalogues are, and how often attract mode changes language by itself (0: only
    a visitor's "language" button does)."""

    shown: Annotated[list[LanguageCode], Field(min_length=1, max_length=12)] = [SOURCE]
    catalogues: Name = "languages"
    switch_after_s: Annotated[float, Number(0, 86400)] = 0

    @field_validator("switch_after_s")
    @classmethod
    def _readable(cls, value: float) -> float:
        # A language that changes faster than a caption can be read is no language at all.
        if 0 < value < MIN_SWITCH_S:
            raise ValueError(
                f"must be 0 (buttons only) or at least {MIN_SWITCH_S:g} s, got {value:g}"
            )
        return value


#: A translation: never empty or blank (the title or caption would be shown blank), as long as
#: an English caption may be.
Translation = Annotated[str, Text(2000, multiline=True)]


#: An espeak-ng voice's name, as ``espeak-ng --voices`` lists it ("de", "fr-fr", "en-gb-x-rp").
VoiceName = Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_+-]{0,39}$")]


class VoiceSpec(Model):
    """``[voice]`` of a catalogue: how espeak-ng speaks the language (both keys optional: the
    voice named by the language's code, at exhibit.narration.speech.DEFAULT_RATE_WPM)."""

    name: VoiceName | None = None
    rate_wpm: Annotated[int, Field(ge=80, le=450)] | None = None


class CatalogueFile(Model):
    language: LanguageCode
    name: Name
    text: dict[Caption, Translation] = {}
    voice: VoiceSpec = VoiceSpec()


@dataclass(frozen=True)
class Catalogue:
    language: str
    name: str
    text: dict = field(default_factory=dict)
    path: Path | None = None
    #: the [voice] keys this catalogue's file sets (None: not set, the shipped file's or default)
    voice_name: str | None = None
    rate_wpm: int | None = None

    @property
    def voice(self) -> Voice:
        """The narration's voice: the [voice] table's, else espeak-ng's voice named like the
        language, at exhibit.narration.speech.DEFAULT_RATE_WPM."""
        return Voice(self.voice_name or self.language, self.rate_wpm or DEFAULT_RATE_WPM)


def load_catalogue(path: Path) -> Catalogue:
    doc = read_toml(path)
    # A blank translation would show the title or caption blank: refused, named by its English
    # key as check-config names every translation (text.'English': reason).
    blank = []
    if isinstance(doc.get("text"), dict):
        for english, text in list(doc["text"].items()):
            if isinstance(text, str) and not text.strip():
                blank.append(
                    f"{path}: text.{english!r}: the translation is empty (a blank "
                    "title or caption); translate it or leave the line out to show "
                    "the English"
                )
                del doc["text"][english]
    try:
        spec = validate(CatalogueFile, doc, str(path))
    except ConfigError as exc:
        raise ConfigError(blank + exc.problems) from None
    if blank:
        raise ConfigError(blank)
    if spec.language != path.stem:
        raise ConfigError(
            [f"{path}: language: {spec.language!r} does not match the file name ({path.stem}.toml)"]
        )
    return Catalogue(
        spec.language, spec.name, dict(spec.text), path, spec.voice.name, spec.voice.rate_wpm
    )


def shipped_catalogues() -> Path:
    """The shipped catalogues' folder (configs/languages)."""
    return shipped("configs", "languages")


def layered(shipped_one: Catalogue, site: Catalogue) -> Catalogue:
    """``site`` over ``shipped_one``, line by line: every shipped line stays unless the site
    gives the same English key; the site's name and [voice] keys win where it sets them. Its
    path is the site file's (where a curator adds what check-config says is missing)."""
    return Catalogue(
        site.language,
        site.name,
        {**shipped_one.text, **site.text},
        site.path,
        site.voice_name or shipped_one.voice_name,
        site.rate_wpm or shipped_one.rate_wpm,
    )


def load_catalogues(
    folder: Path | None, languages: Iterable[str], base: Path | None = None
) -> dict[str, Catalogue]:
    """The catalogue of every language shown but English: ``folder``'s ``<code>.toml`` over
    the shipped one (``base``, default configs/languages), line by line (:func:`layered`); a
    language needs one of the two. Each language's voice is registered for the narration
    (exhibit.narration.speech.set_voice). ConfigError names each problem."""
    out: dict[str, Catalogue] = {SOURCE: Catalogue(SOURCE, "English")}
    problems: list[str] = []
    folder = folder or Path(".")
    base = base or shipped_catalogues()
    same = folder.resolve() == base.resolve()
    for code in languages:
        if code == SOURCE:
            continue
        own, under = folder / f"{code}.toml", base / f"{code}.toml"
        try:
            if same or not under.is_file():
                catalogue = load_catalogue(own)
            elif not own.exists() and not own.is_symlink():
                catalogue = load_catalogue(under)
            else:
                catalogue = layered(load_catalogue(under), load_catalogue(own))
        except ConfigError as exc:
            problems.extend(exc.problems)
            continue
        out[code] = catalogue
    if problems:
        raise ConfigError(problems)
    for code, catalogue in out.items():
        if code != SOURCE:
            set_voice(code, catalogue.voice)
    return out


class Translator:
    """The language on screen and its words. ``next()`` moves to the next language shown (a
    visitor's button, or attract mode's timer)."""

    def __init__(self, catalogues: dict[str, Catalogue], order: Iterable[str] = (SOURCE,)):
        self.catalogues = catalogues
        self.order = [code for code in order if code in catalogues] or [SOURCE]
        self.index = 0

    @property
    def language(self) -> str:
        return self.order[self.index]

    def next(self) -> str:
        self.index = (self.index + 1) % len(self.order)
        return self.language

    def reset(self) -> str:
        """Back to the first language shown (the museum's own), for the next visitor."""
        self.index = 0
        return self.language

    def hud_words(self, language: str | None = None) -> tuple[tuple[str, str], ...]:
        """Every HUD word in the language on screen (or ``language``): HudInfo.words."""
        return tuple((word, self(word, language)) for word in HUD_WORDS)

    def __call__(self, text: str, language: str | None = None) -> str:
        if not text:
            return text
        catalogue = self.catalogues.get(language or self.language)
        return catalogue.text.get(text, text) if catalogue is not None else text


class LanguageSettings(Protocol):
    """What the languages read of the kiosk's config (exhibit.kiosk.config.KioskConfig, which
    imports this module)."""

    @property
    def languages(self) -> tuple[str, ...]: ...
    @property
    def catalogues_dir(self) -> Path | None: ...
    @property
    def attract_dir(self) -> Path | None: ...
    @property
    def scenes(self) -> tuple[str, ...]: ...


def translator_for(config: LanguageSettings, problems: list[str]) -> Translator:
    """The languages of [languages]; a catalogue that cannot be read is left out (its visitors
    read English), said once in the log and in ``problems`` (the health file's)."""
    catalogues = {SOURCE: Catalogue(SOURCE, "English")}
    for code in config.languages:
        if code == SOURCE or config.catalogues_dir is None:
            continue
        try:
            catalogues.update(load_catalogues(config.catalogues_dir, [code]))
        except ConfigError as exc:
            log.error("language %s left out: %s", code, "; ".join(exc.problems))
            problems.append(f"language {code} left out (see the journal)")
    return Translator(catalogues, config.languages)


class LanguageChoice:
    """When the language on screen changes: a visitor's "language" button, attract mode's
    timer (every ``switch_s`` seconds, 0: never), and back to the first language shown (the
    museum's own) when attract mode returns, so the next visitor does not find the last one's.
    ``on_change(language)`` hears of each change (the session log)."""

    def __init__(
        self,
        translator: Translator,
        switch_s: float,
        now: float,
        on_change: Callable[[str], None] | None = None,
    ):
        self.translator = translator
        self.switch_s = switch_s
        self.on_change = on_change
        self._since = now

    def _changed(self, language: str, now: float, why: str = "") -> None:
        self._since = now
        log.info("language %s%s", language, why)
        if self.on_change is not None:
            self.on_change(language)

    def walked_away(self, now: float) -> None:
        if self.translator.index != 0:
            self._changed(self.translator.reset(), now, " (attract mode is back)")
        self._since = now

    def update(self, pressed: bool, attract: bool, now: float) -> None:
        timed = self.switch_s > 0 and attract and now - self._since >= self.switch_s
        if (pressed or timed) and len(self.translator.order) > 1:
            self._changed(self.translator.next(), now)


def in_every_language(translator: Translator, text: str) -> tuple[str, ...]:
    """``text`` in every language shown, in their order: what the framing keeps the picture
    clear of (exhibit.render.framer's ``versions``; a module function, so a worker process can
    be handed it with its translator)."""
    return tuple(translator(text, code) for code in translator.order)


# ---------------------------------------------------------------------- for check-config


def shown_texts(scene_names: Iterable[str], timelines: Sequence[Timeline]) -> dict[str, str]:
    """Every English text the kiosk can show, with where it comes from: the content scenes'
    titles and captions, every timeline's scene title and keyframe captions, the HUD's words."""
    from exhibit import scenes

    texts: dict[str, str] = {}
    for name in scene_names:
        scene = scenes.get(name)
        texts.setdefault(scene.title, f"scene {name}: title")
        texts.setdefault(scene.caption, f"scene {name}: caption")
        for obj, words in scene.labels:
            texts.setdefault(words, f"scene {name}: label of {obj}")
    for timeline in timelines:
        texts.setdefault(scenes.get(timeline.scene).title, f"scene {timeline.scene}: title")
        for i, keyframe in enumerate(timeline.keyframes):
            texts.setdefault(keyframe.caption, f"{timeline.path}: keyframe[{i}].caption")
            if keyframe.description:
                texts.setdefault(keyframe.description, f"{timeline.path}: keyframe[{i}].describe")
            for obj, words in keyframe.labels:
                texts.setdefault(words, f"{timeline.path}: keyframe[{i}].labels.{obj}")
    for word in HUD_WORDS:
        texts.setdefault(word, "the HUD")
    texts.setdefault(PREPARING, "the screen while a scene is prepared")
    return texts


def coverage_problems(config: LanguageSettings) -> list[str]:
    """For `exhibit check-config`: every text the kiosk shows, in every language it shows, has
    a translation, in characters the HUD's fonts can draw (the catalogues load: checked with the
    config)."""
    from exhibit import scenes
    from exhibit.timelines.file import load_playlist

    if config.catalogues_dir is None:
        return []
    timelines = (
        load_playlist(config.attract_dir, scenes.get) if config.attract_dir is not None else []
    )
    texts = shown_texts(config.scenes, timelines)
    problems = []
    for catalogue in load_catalogues(config.catalogues_dir, config.languages).values():
        if catalogue.language == SOURCE:
            continue
        problems += missing(catalogue, texts) + uncovered(catalogue)
    return problems


def missing(catalogue: Catalogue, texts: dict[str, str]) -> list[str]:
    """``texts``: English text -> where it comes from. One problem per text the catalogue does
    not translate."""
    return [
        f"{catalogue.path}: text: no translation of {english!r} (from {where})"
        for english, where in texts.items()
        if english and english not in catalogue.text
    ]


@lru_cache(maxsize=8)
def _codepoints(style: str) -> frozenset[int]:
    """The characters the HUD's font for ``style`` has glyphs for (its cmap, via fontTools)."""
    from fontTools.ttLib import TTFont

    from exhibit.render.text import font

    source = font(style, 20).path
    if isinstance(source, io.BytesIO):
        source.seek(0)
    with TTFont(source, lazy=True) as face:
        return frozenset(face.getBestCmap())


def uncovered(catalogue: Catalogue, styles: Iterable[str] = ("sans", "bold")) -> list[str]:
    """One problem per translation with characters the HUD's fonts cannot draw."""
    problems = []
    sets = [_codepoints(style) for style in styles]
    for english, text in catalogue.text.items():
        lacking = sorted(
            {ch for ch in text if not ch.isspace() and any(ord(ch) not in s for s in sets)}
        )
        if lacking:
            problems.append(
                f"{catalogue.path}: text.{english!r}: the font has no glyph for "
                f"{''.join(lacking)!r}"
            )
    return problems
