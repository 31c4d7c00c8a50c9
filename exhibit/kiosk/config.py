"""The kiosk's configuration: configs/kiosk.toml and everything it points to, checked as a whole.

Every problem is collected (not just the first) and reported as ``file: key: reason``, so an
installer fixes a config in one pass. The fields are typed once in :mod:`exhibit.schema`, the same
types the running kiosk relies on, so whatever this accepts can be run. Paths in the file are relative to the file itself.
Environment variables override the paths: EXHIBIT_CONFIG (this file), EXHIBIT_DEVICES_CONFIG,
EXHIBIT_ATTRACT_DIR.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from exhibit import scenes
from exhibit.errors import ConfigError, ExhibitError
from exhibit.resources import shipped
from exhibit.schema import Model, check_file_ref, read_toml, validate
from exhibit.schema.types import Integer, Number, Numbers, QuitKeys, Resolution, Text

DEFAULT_CONFIG = shipped("configs", "kiosk.toml")

__all__ = ["ConfigError", "DEFAULT_CONFIG", "KioskConfig", "load_kiosk_config"]

PathText = Text(4096)


class Display(Model):
    fullscreen: bool = True
    monitor: Integer(0, 16) = 0
    size: Numbers(2, 160, 16384, integer=True) = (1280, 720)
    vsync: bool = True
    samples: Integer(0, 16) = 4
    fps_limit: Number(10, 240) = 60.0
    hud: bool = True


class Content(Model):
    scenes: list[Text(100)] | None = None
    start_scene: Text(100) | None = None
    resolution: dict[str, Resolution] = {}


class Devices(Model):
    config: PathText = "devices/default.toml"


class Attract(Model):
    timelines: PathText = "attract"
    idle_timeout_s: Number(5, 3600) = 90.0
    blend_s: Number(0, 30) = 2.0


class BurnIn(Model):
    drift_px: Number(0, 200) = 12.0
    drift_period_s: Number(10, 86400) = 600.0


class Maintenance(Model):
    quit_keys: QuitKeys = ()


class KioskFile(Model):
    display: Display = Display()
    content: Content = Content()
    devices: Devices = Devices()
    attract: Attract = Attract()
    burn_in: BurnIn = BurnIn()
    maintenance: Maintenance = Maintenance()


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


def _path(problems: list[str], config: Path, raw: str, key: str, env: str, want_dir: bool
          ) -> Path | None:
    """A referenced file or folder: $ENV if set, else relative to the config file."""
    if os.environ.get(env):
        path, where = Path(os.environ[env]), f"{key} (from ${env})"
    else:
        path, where = (config.parent / raw), key
    reason = check_file_ref(path, want_dir)
    if reason:
        problems.append(f"{config}: {where}: {reason}")
        return None
    return path


def load_kiosk_config(path: str | Path | None = None, check_linked: bool = True) -> KioskConfig:
    """Read and check the kiosk config; raises ConfigError listing every problem found.

    With ``check_linked`` the device config, the attract timelines and the scene files are
    loaded and checked too (what `exhibit check-config` and `exhibit run` do).
    """
    path = Path(path or os.environ.get("EXHIBIT_CONFIG") or DEFAULT_CONFIG)
    problems: list[str] = []
    try:
        spec = validate(KioskFile, read_toml(path), str(path))
    except ConfigError as exc:
        problems.extend(exc.problems)
        spec = None
    known, scene_problems = scenes.load()
    values: dict = {"path": path}
    if spec is not None:
        d, c = spec.display, spec.content
        values.update(fullscreen=d.fullscreen, monitor=d.monitor, size=tuple(d.size),
                      vsync=d.vsync, samples=d.samples, fps_limit=d.fps_limit, hud=d.hud)
        scene_list = c.scenes if c.scenes is not None else sorted(known)
        if not scene_list:
            problems.append(f"{path}: content.scenes: must name at least one scene")
        for name in scene_list:
            if name not in known:
                problems.append(f"{path}: content.scenes: no scene named {name!r} (scenes: "
                                f"{', '.join(sorted(known))})")
        values["scenes"] = tuple(s for s in scene_list if s in known) or tuple(sorted(known))
        start = c.start_scene if c.start_scene is not None else values["scenes"][0]
        if start not in values["scenes"]:
            problems.append(f"{path}: content.start_scene: {start!r} is not one of "
                            "content.scenes")
        values["start_scene"] = start
        for name in c.resolution:
            if name not in known:
                problems.append(f"{path}: content.resolution.{name}: no such scene")
        values["resolution"] = {k: v for k, v in c.resolution.items() if k in known}
        values["devices_config"] = _path(problems, path, spec.devices.config, "devices.config",
                                         "EXHIBIT_DEVICES_CONFIG", False)
        values["attract_dir"] = _path(problems, path, spec.attract.timelines,
                                      "attract.timelines", "EXHIBIT_ATTRACT_DIR", True)
        values.update(idle_timeout_s=spec.attract.idle_timeout_s, blend_s=spec.attract.blend_s,
                      drift_px=spec.burn_in.drift_px,
                      drift_period_s=spec.burn_in.drift_period_s,
                      quit_keys=spec.maintenance.quit_keys)

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
            from exhibit.kiosk.attract import timeline_paths, load_timeline
            timelines = timeline_paths(values["attract_dir"])
            if not timelines:
                problems.append(f"{path}: attract.timelines: {values['attract_dir']} has no "
                                "*.toml timelines")
            for timeline_path in timelines:
                try:
                    load_timeline(timeline_path)
                except ConfigError as exc:
                    problems.extend(exc.problems)
                except ExhibitError as exc:
                    problems.append(str(exc))
        # scene files that failed to load are part of the kiosk's content too
        problems.extend(message for _, message in scene_problems)
    if problems:
        raise ConfigError(problems)
    return KioskConfig(**values)
