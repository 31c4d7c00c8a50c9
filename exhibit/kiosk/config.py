"""The kiosk's configuration: the shipped defaults, a site file over them, and everything they
point to, checked as a whole.

The site file (``--config FILE``, else $EXHIBIT_CONFIG, else /etc/exhibit/kiosk.toml when it
exists) holds only the keys it changes; every other value comes from the shipped
configs/kiosk.toml. A relative path resolves against the file that names it, else against the
shipped files. $EXHIBIT_DEVICES_CONFIG and $EXHIBIT_ATTRACT_DIR override those two paths.

Every problem is collected (not just the first) and reported as ``file: key: reason`` against
the file that holds the key, so an installer fixes a config in one pass. The fields are typed
once in :mod:`exhibit.schema`, the same types the running kiosk relies on, so whatever this
accepts can be run.

Why one module of this size: kiosk.toml's schema: every section's model and check, shared by
check-config and run."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import PlainValidator
from pydantic_core import PydanticCustomError

from exhibit import scenes
from exhibit.errors import ConfigError, ExhibitError
from exhibit.kiosk.language import SOURCE, LanguagesSection, load_catalogues
from exhibit.operations.sessions import SessionsConfig, SessionsSection, sessions_config
from exhibit.resources import shipped
from exhibit.schema import Model, check_file_ref, read_toml, validate
from exhibit.schema.layers import leaves, merge, source_of
from exhibit.schema.types import (
    Integer,
    Number,
    Numbers,
    QuitKeys,
    Resolution,
    Text,
    fail,
    number_check,
)

DEFAULT_CONFIG = shipped("configs", "kiosk.toml")
#: Where an installed kiosk keeps its site settings (docs/DEPLOYMENT.md).
SITE_CONFIG = Path("/etc/exhibit/kiosk.toml")

__all__ = [
    "ConfigError",
    "DEFAULT_CONFIG",
    "SITE_CONFIG",
    "KioskConfig",
    "load_kiosk_config",
    "site_config_path",
]

PathText = Annotated[str, Text(4096)]


class Display(Model):
    fullscreen: bool = True
    monitor: Annotated[int, Integer(0, 16)] = 0
    size: Annotated[tuple[float, ...], Numbers(2, 160, 16384, integer=True)] = (1280, 720)
    vsync: bool = True
    samples: Annotated[int, Integer(0, 16)] = 4
    fps_limit: Annotated[float, Number(10, 240)] = 60.0
    hud: bool = True


class Content(Model):
    scenes: list[Annotated[str, Text(100)]] | None = None
    start_scene: Annotated[str, Text(100)] | None = None
    resolution: dict[str, Resolution] = {}


class Devices(Model):
    config: PathText = "devices/default.toml"


class Attract(Model):
    timelines: PathText = "attract"
    idle_timeout_s: Annotated[float, Number(5, 3600)] = 90.0
    blend_s: Annotated[float, Number(0, 30)] = 2.0


class BurnIn(Model):
    drift_px: Annotated[float, Number(0, 200)] = 12.0
    drift_period_s: Annotated[float, Number(10, 86400)] = 600.0


#: The smallest caption cap height, a fraction of the screen height: exhibit.render.layout's,
#: repeated so the config layer imports no GL code (a test checks the two agree).
MIN_CAPTION_CAP = 1.0 / 45.0


@dataclass(frozen=True)
class TextConfig:
    """[text], checked: exhibit.render.layout.TextSizes's fields."""

    caption_cap: float = 0.024
    title_cap: float = 0.034
    infinity_beyond: float = 1000.0


def _caption_cap(value: Any) -> float:
    """A caption cap height: a fraction of the screen height, at least 1/45 (legible from a
    few metres: 24 px capitals at 1080p) and at most 0.1."""
    try:
        return number_check(MIN_CAPTION_CAP, 0.1)(value)
    except PydanticCustomError:
        raise fail(
            "the caption's capital letters must be a fraction of the screen height "
            "from 1/45 (0.0222: 24 px at 1080p, legible from a few metres) to 0.1",
            value,
        ) from None


class Accessibility(Model):
    reduced_motion: bool = False


class NarrationSection(Model):
    """[narration]: spoken descriptions and captions (exhibit.kiosk.narrator)."""

    attract: bool = False
    volume: Annotated[float, Number(0.0, 1.0)] = 0.7
    device: Annotated[str, Text(200, empty_ok=True)] = ""
    backend: Literal["", "null"] = ""


@dataclass(frozen=True)
class NarrationConfig:
    #: attract mode speaks without a press (default: silent until a visitor presses "listen")
    attract: bool = False
    #: 0..1 of the player's safe maximum (exhibit.narration.player.MAX_VOLUME)
    volume: float = 0.7
    #: the output device's name ("" the system's default)
    device: str = ""
    #: "null": play to no device (tests, a site without a speaker); "" the system's
    backend: str = ""


class Text_(Model):
    caption_cap_height: Annotated[float, PlainValidator(_caption_cap)] = 0.024
    title_cap_height: Annotated[float, Number(MIN_CAPTION_CAP, 0.15)] = 0.034
    infinity_beyond: Annotated[float, Number(1, 1e6)] = 1000.0


class Maintenance(Model):
    quit_keys: QuitKeys = ()


# ---------------------------------------------------------------------- [quality]: the governor

#: exhibit.render.quality's ladder, named here so the config layer imports no GL code.
QUALITY_LEVELS = ("msaa", "fxaa", "mesh-75", "mesh-50", "lean", "direct", "scale-75", "scale-50")
MESH_LEVELS = {"full": 0, "reduced": 1, "low": 2}  # mesh resolution x1, x0.75, x0.5


def _choice(*options: str) -> PlainValidator:
    """One of ``options`` (a string): ``Annotated[str, _choice("auto", "full")]``."""

    def check(value: Any) -> str:
        if not isinstance(value, str) or value not in options:
            raise fail("must be one of " + ", ".join(f'"{o}"' for o in options), value)
        return value

    return PlainValidator(check)


def _auto_or_number(low: float, high: float) -> PlainValidator:
    """ "auto" (the governor's choice), or a number in [low, high]."""
    number = number_check(low, high)

    def check(value: Any) -> float | str:
        if value == "auto":
            return "auto"
        try:
            return number(value)
        except PydanticCustomError:
            raise fail(f'must be "auto" or a number in [{low:g}, {high:g}]', value) from None

    return PlainValidator(check)


class QualitySection(Model):
    level: Annotated[str, _choice("auto", *QUALITY_LEVELS)] = "auto"
    lowest: Annotated[str, _choice("auto", *QUALITY_LEVELS)] = "auto"
    antialiasing: Annotated[str, _choice("auto", "msaa", "fxaa", "none")] = "auto"
    mesh: Annotated[str, _choice("auto", *MESH_LEVELS)] = "auto"
    effects: Annotated[str, _choice("auto", "full", "lean")] = "auto"
    render_scale: Annotated[float | Literal["auto"], _auto_or_number(0.25, 1.0)] = "auto"
    target_fps: Annotated[float | Literal["auto"], _auto_or_number(10, 240)] = "auto"
    step_interval_s: Annotated[float, Number(1, 600)] = 4.0
    calm_s: Annotated[float, Number(0, 60)] = 1.5
    headroom: Annotated[float, Number(0.3, 0.95)] = 0.7


@dataclass(frozen=True)
class QualityConfig:
    """[quality], resolved: a pin is None when the governor chooses."""

    level: str = "auto"
    lowest: str = "auto"
    antialiasing_pin: str | None = None
    mesh_pin: int | None = None
    effects_pin: str | None = None
    scale_pin: float | None = None
    target_fps: float | None = None
    step_interval_s: float = 4.0
    calm_s: float = 1.5
    headroom: float = 0.7


def _quality(section: QualitySection) -> QualityConfig:
    def pin(value):
        return None if value == "auto" else value

    return QualityConfig(
        level=section.level,
        lowest=section.lowest,
        antialiasing_pin=pin(section.antialiasing),
        mesh_pin=None if section.mesh == "auto" else MESH_LEVELS[section.mesh],
        effects_pin=pin(section.effects),
        scale_pin=pin(section.render_scale),
        target_fps=pin(section.target_fps),
        step_interval_s=section.step_interval_s,
        calm_s=section.calm_s,
        headroom=section.headroom,
    )


class KioskFile(Model):
    display: Display = Display()
    content: Content = Content()
    devices: Devices = Devices()
    attract: Attract = Attract()
    burn_in: BurnIn = BurnIn()
    maintenance: Maintenance = Maintenance()
    quality: QualitySection = QualitySection()
    text: Text_ = Text_()
    sessions: SessionsSection = SessionsSection()
    languages: LanguagesSection = LanguagesSection()
    accessibility: Accessibility = Accessibility()
    narration: NarrationSection = NarrationSection()


@dataclass(frozen=True)
class KioskConfig:
    path: Path
    fullscreen: bool = True
    monitor: int = 0
    size: tuple[int, int] = (1280, 720)
    vsync: bool = True
    samples: int = 4
    fps_limit: float = 60.0
    hud: bool = True
    scenes: tuple[str, ...] = ()
    start_scene: str = "hopf"
    resolution: dict = field(default_factory=dict)
    devices_config: Path | None = None
    attract_dir: Path | None = None
    idle_timeout_s: float = 90.0
    blend_s: float = 2.0
    drift_px: float = 12.0
    drift_period_s: float = 600.0
    quit_keys: tuple[str, ...] = ()
    #: [text]: the HUD's text sizes (fractions of the screen height) and when distances read ∞
    text: TextConfig = TextConfig()
    #: [quality]: what the frame governor may change, and what is pinned
    quality: QualityConfig = QualityConfig()
    #: [sessions]: the visitor-session log (exhibit.operations.sessions)
    sessions: SessionsConfig = SessionsConfig()
    #: [languages]: the languages shown (the first at start), their catalogues' folder (None:
    #: English only), and attract mode's own language change (seconds; 0: buttons only)
    languages: tuple[str, ...] = (SOURCE,)
    catalogues_dir: Path | None = None
    language_switch_s: float = 0.0
    #: [accessibility]: no continuous camera glides (attract mode moves in slow held steps, each
    #: a crossfaded cut; the glide back from a visitor and the takeover reframe are cuts too) and
    #: no drift of the text panels
    reduced_motion: bool = False
    #: [narration]: the spoken descriptions and captions
    narration: NarrationConfig = NarrationConfig()
    #: the site file layered over the shipped defaults (None: the defaults alone)
    site: Path | None = None
    #: every setting as "section.key" -> (effective value, the file it came from)
    sources: dict = field(default_factory=dict)
    #: scene files on the scene path that failed to load, "file: key: reason" each (only when
    #: loaded with ``broken_scenes_ok``: the kiosk runs with the others and reports these)
    scene_problems: tuple[str, ...] = ()


def site_config_path(path: str | Path | None = None) -> Path | None:
    """The site file: the argument, else $EXHIBIT_CONFIG, else /etc/exhibit/kiosk.toml if it
    exists; None when the shipped defaults stand alone."""
    chosen = path or os.environ.get("EXHIBIT_CONFIG")
    if not chosen:
        # lstat, not exists(): a dangling symlink, a symlink loop or a file behind a folder
        # that cannot be searched is a site file that cannot be read (an error naming it), not
        # an absent one (the shipped defaults, silently without the museum's settings).
        try:
            os.lstat(SITE_CONFIG)
        except FileNotFoundError:
            return None
        except OSError:
            pass
        return SITE_CONFIG
    chosen = Path(chosen)
    try:
        if chosen.resolve() == DEFAULT_CONFIG.resolve():
            return None
    except (OSError, RuntimeError):  # a symlink loop: reported when it is read
        pass
    return chosen


def _unreadable(file: Path, problems: list[str]) -> list[str]:
    """A config file that cannot be read, said plainly when it is a dangling symlink."""
    try:
        if os.path.islink(file) and not os.path.lexists(os.path.realpath(file)):
            return [f"{file}: cannot read: a symlink to {os.readlink(file)}, which does not exist"]
    except OSError:
        pass
    return problems


def _path(
    problems: list[str], origin: Path, raw: str, key: str, env: str, want_dir: bool
) -> tuple[Path | None, str]:
    """A referenced file or folder, and what named it: $ENV if set, else relative to the file
    that names it, else relative to the shipped configs."""
    if os.environ.get(env):
        path, where, named_by = Path(os.environ[env]), f"{key} (from ${env})", f"${env}"
    else:
        named_by = str(origin)
        path, where = origin.parent / raw, key
        fallback = DEFAULT_CONFIG.parent / raw
        if check_file_ref(path, want_dir) and not check_file_ref(fallback, want_dir):
            path = fallback
    reason = check_file_ref(path, want_dir)
    if reason:
        problems.append(f"{origin}: {where}: {reason}")
        return None, named_by
    return path, named_by


def _start_problem(start: str, start_from: Path, scenes_from: Path, site: Path | None) -> str:
    """content.start_scene not among content.scenes, reported against the file a museum edits:
    the site file, when it set either of the two (the shipped defaults are not edited)."""
    if site is None or (start_from != site and scenes_from != site):
        return f"{start_from}: content.start_scene: {start!r} is not one of content.scenes"
    if start_from == site:
        return f"{site}: content.start_scene: {start!r} is not one of content.scenes" + (
            "" if scenes_from == site else " (the shipped defaults' list)"
        )
    return (
        f"{site}: content.scenes: does not include the start scene {start!r} (the shipped "
        f"default of content.start_scene); add it, or set content.start_scene to one of "
        f"the scenes listed here"
    )


def load_kiosk_config(
    path: str | Path | None = None, check_linked: bool = True, broken_scenes_ok: bool = False
) -> KioskConfig:
    """Read and check the shipped defaults with the site file over them; raises ConfigError
    listing every problem found.

    With ``check_linked`` the device config, the attract timelines and the scene files are
    loaded and checked too (what `exhibit check-config` and `exhibit run` do). A scene file
    that fails to load is a problem too, unless ``broken_scenes_ok`` (`exhibit run`): then the
    kiosk runs with the valid scenes, and the broken files are in ``scene_problems`` (a scene
    the config names that did not load is still a problem: no scene named ...).
    """
    site = site_config_path(path)
    problems: list[str] = []
    layers = []
    for file in (DEFAULT_CONFIG, site):
        if file is None:
            continue
        try:
            layers.append((file, read_toml(file)))
        except ConfigError as exc:
            problems.extend(_unreadable(file, exc.problems))
    doc, origin = merge(layers)
    last = site or DEFAULT_CONFIG
    spec = None
    if not problems:
        try:
            spec = validate(KioskFile, doc, lambda loc: source_of(origin, loc, last))
        except ConfigError as exc:
            problems.extend(exc.problems)
    known, scene_problems = scenes.load()

    def where(*key: str) -> Path:
        return source_of(origin, key, last)

    values: dict = {"path": site or DEFAULT_CONFIG, "site": site}
    if spec is not None:
        d, c = spec.display, spec.content
        values.update(
            fullscreen=d.fullscreen,
            monitor=d.monitor,
            size=tuple(d.size),
            vsync=d.vsync,
            samples=d.samples,
            fps_limit=d.fps_limit,
            hud=d.hud,
        )
        scene_list = c.scenes if c.scenes is not None else sorted(known)
        if not scene_list:
            problems.append(
                f"{where('content', 'scenes')}: content.scenes: must name at least one scene"
            )
        for name in scene_list:
            if name not in known:
                problems.append(
                    f"{where('content', 'scenes')}: content.scenes: no scene named "
                    f"{name!r} (scenes: {', '.join(sorted(known))})"
                )
        values["scenes"] = tuple(s for s in scene_list if s in known) or tuple(sorted(known))
        start = c.start_scene if c.start_scene is not None else values["scenes"][0]
        if start not in values["scenes"]:
            problems.append(
                _start_problem(
                    start, where("content", "start_scene"), where("content", "scenes"), site
                )
            )
        values["start_scene"] = start
        for name in c.resolution:
            if name not in known:
                problems.append(
                    f"{where('content', 'resolution', name)}: "
                    f"content.resolution.{name}: no such scene"
                )
        values["resolution"] = {k: v for k, v in c.resolution.items() if k in known}
        values["sources"] = {
            ".".join(key): (value, origin.get(key, last)) for key, value in leaves(doc)
        }
        for name, section, key, env, want_dir in (
            ("devices_config", "devices", "config", "EXHIBIT_DEVICES_CONFIG", False),
            ("attract_dir", "attract", "timelines", "EXHIBIT_ATTRACT_DIR", True),
        ):
            path, named_by = _path(
                problems,
                where(section, key),
                getattr(getattr(spec, section), key),
                f"{section}.{key}",
                env,
                want_dir,
            )
            values[name] = path
            if path is not None:  # --show: the resolved path, and what named it
                values["sources"][f"{section}.{key}"] = (str(path), named_by)
        languages = spec.languages
        if len(set(languages.shown)) != len(languages.shown):
            problems.append(
                f"{where('languages', 'shown')}: languages.shown: names a language "
                f"twice: {languages.shown}"
            )
        values.update(
            languages=tuple(dict.fromkeys(languages.shown)),
            language_switch_s=languages.switch_after_s,
        )
        if any(code != SOURCE for code in languages.shown):
            path, named_by = _path(
                problems,
                where("languages", "catalogues"),
                languages.catalogues,
                "languages.catalogues",
                "EXHIBIT_LANGUAGES_DIR",
                True,
            )
            values["catalogues_dir"] = path
            if path is not None:
                values["sources"]["languages.catalogues"] = (str(path), named_by)
        values.update(
            idle_timeout_s=spec.attract.idle_timeout_s,
            blend_s=spec.attract.blend_s,
            drift_px=spec.burn_in.drift_px,
            drift_period_s=spec.burn_in.drift_period_s,
            quit_keys=spec.maintenance.quit_keys,
            quality=_quality(spec.quality),
            sessions=sessions_config(spec.sessions),
            reduced_motion=spec.accessibility.reduced_motion,
            narration=NarrationConfig(
                spec.narration.attract,
                spec.narration.volume,
                spec.narration.device.strip(),
                spec.narration.backend,
            ),
        )
        t = spec.text
        if t.title_cap_height <= t.caption_cap_height:
            problems.append(
                f"{where('text', 'title_cap_height')}: text.title_cap_height: must be "
                f"larger than text.caption_cap_height ({t.caption_cap_height:g}), "
                f"got {t.title_cap_height:g}"
            )
        else:
            values["text"] = TextConfig(t.caption_cap_height, t.title_cap_height, t.infinity_beyond)

    if check_linked and spec is not None:
        if values["devices_config"] is not None:
            from exhibit.devices.config import load_config

            try:
                load_config(values["devices_config"])
            except ConfigError as exc:
                problems.extend(exc.problems)
            except ExhibitError as exc:
                problems.append(str(exc))
        if values["attract_dir"] is not None:
            from exhibit.timelines.file import load_timeline, timeline_paths

            timelines = timeline_paths(values["attract_dir"])
            if not timelines:
                problems.append(
                    f"{where('attract', 'timelines')}: attract.timelines: "
                    f"{values['attract_dir']} has no *.toml timelines"
                )
            for timeline_path in timelines:
                try:
                    load_timeline(timeline_path, scenes.get)
                except ConfigError as exc:
                    problems.extend(exc.problems)
                except ExhibitError as exc:
                    problems.append(str(exc))
        if values.get("catalogues_dir") is not None:
            try:
                load_catalogues(values["catalogues_dir"], values["languages"])
            except ConfigError as exc:
                problems.extend(exc.problems)
        # scene files that failed to load are part of the kiosk's content too
        if broken_scenes_ok:
            values["scene_problems"] = tuple(message for _, message in scene_problems)
        else:
            problems.extend(message for _, message in scene_problems)
    if problems:
        raise ConfigError(problems)
    return KioskConfig(**values)
