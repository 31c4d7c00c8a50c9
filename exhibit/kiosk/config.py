"""The kiosk's configuration: configs/kiosk.toml and everything it points to, checked as a whole.

Every problem is collected (not just the first) and reported as ``file: key: reason``, so an
installer fixes a config in one pass. Paths in the file are relative to the file itself.
Environment variables override the paths: EXHIBIT_CONFIG (this file), EXHIBIT_DEVICES_CONFIG,
EXHIBIT_ATTRACT_DIR.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from exhibit import scenes
from exhibit.errors import ExhibitError

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "configs" / "kiosk.toml"
MODIFIERS = {"ctrl", "alt", "shift", "super"}

SCHEMA = {
    "display": {"fullscreen", "monitor", "size", "vsync", "samples", "fps_limit", "hud"},
    "content": {"scenes", "start_scene", "resolution"},
    "devices": {"config"},
    "attract": {"timelines", "idle_timeout_s", "blend_s"},
    "burn_in": {"drift_px", "drift_period_s"},
    "maintenance": {"quit_keys"},
}


class ConfigError(ExhibitError):
    """One or more problems, each ``file: key: reason`` on its own line."""

    def __init__(self, problems: list[str]):
        self.problems = problems
        super().__init__("\n".join(problems))


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


class _Reader:
    def __init__(self, path: Path):
        self.path = path
        self.problems: list[str] = []

    def problem(self, key: str, reason: str) -> None:
        self.problems.append(f"{self.path}: {key}: {reason}")

    def get(self, table: dict, section: str, key: str, kind, default, low=None, high=None):
        if key not in table:
            return default
        value = table[key]
        where = f"{section}.{key}"
        if kind is bool:
            if not isinstance(value, bool):
                self.problem(where, f"must be true or false, got {value!r}")
                return default
            return value
        if kind in (int, float):
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or (kind is int and not float(value).is_integer()):
                self.problem(where, f"must be {'a whole number' if kind is int else 'a number'}, "
                                    f"got {value!r}")
                return default
            if (low is not None and value < low) or (high is not None and value > high):
                self.problem(where, f"{value} is out of range [{low}, {high}]")
                return default
            return kind(value)
        if kind is str:
            if not isinstance(value, str):
                self.problem(where, f"must be a string, got {value!r}")
                return default
            return value
        raise AssertionError(kind)


def _path(reader: _Reader, base: Path, table: dict, section: str, key: str, env: str,
          default: str, want_dir: bool) -> Path | None:
    if os.environ.get(env):
        path = Path(os.environ[env])
        where = f"{section}.{key} (from ${env})"
    else:
        raw = reader.get(table, section, key, str, default)
        path = (base / raw) if not Path(raw).is_absolute() else Path(raw)
        where = f"{section}.{key}"
    if want_dir and not path.is_dir():
        reader.problem(where, f"folder {path} does not exist")
        return None
    if not want_dir and not path.is_file():
        reader.problem(where, f"file {path} does not exist")
        return None
    return path


def load_kiosk_config(path: str | Path | None = None, check_linked: bool = True) -> KioskConfig:
    """Read and check the kiosk config; raises ConfigError listing every problem found.

    With ``check_linked`` the device config and the attract timelines it names are loaded and
    checked too (what `exhibit check-config` and `exhibit run` do).
    """
    path = Path(path or os.environ.get("EXHIBIT_CONFIG") or DEFAULT_CONFIG)
    reader = _Reader(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError([f"{path}: cannot read: {exc.strerror or exc}"]) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError([f"{path}: not valid TOML: {exc}"]) from None

    for section, value in data.items():
        if section not in SCHEMA:
            reader.problem(section, f"unknown section (allowed: {', '.join(SCHEMA)})")
        elif not isinstance(value, dict):
            reader.problem(section, "must be a table")
        else:
            for key in value:
                if key not in SCHEMA[section]:
                    reader.problem(f"{section}.{key}", "unknown key (allowed: "
                                   f"{', '.join(sorted(SCHEMA[section]))})")

    def table(name):
        value = data.get(name, {})
        return value if isinstance(value, dict) else {}

    display, content, devices = table("display"), table("content"), table("devices")
    attract, burn_in, maintenance = table("attract"), table("burn_in"), table("maintenance")
    g = reader.get
    values: dict = {"path": path}
    values["fullscreen"] = g(display, "display", "fullscreen", bool, True)
    values["monitor"] = g(display, "display", "monitor", int, 0, 0, 16)
    values["vsync"] = g(display, "display", "vsync", bool, True)
    values["samples"] = g(display, "display", "samples", int, 4, 0, 16)
    values["fps_limit"] = g(display, "display", "fps_limit", float, 60.0, 10, 240)
    values["hud"] = g(display, "display", "hud", bool, True)
    size = display.get("size", [1280, 720])
    if (not isinstance(size, list) or len(size) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) and 160 <= v <= 16384
                       for v in size)):
        reader.problem("display.size", f"must be [width, height] in pixels (160..16384), "
                                       f"got {size!r}")
        size = [1280, 720]
    values["size"] = tuple(size)

    known = scenes.names()
    scene_list = content.get("scenes", known)
    if not isinstance(scene_list, list) or not scene_list or \
            not all(isinstance(s, str) for s in scene_list):
        reader.problem("content.scenes", "must be a non-empty list of scene names")
        scene_list = known
    for name in scene_list:
        if name not in known:
            reader.problem("content.scenes", f"no scene named {name!r} (scenes: {', '.join(known)})")
    values["scenes"] = tuple(s for s in scene_list if s in known) or tuple(known)
    start = g(content, "content", "start_scene", str, values["scenes"][0])
    if start not in values["scenes"]:
        reader.problem("content.start_scene", f"{start!r} is not one of content.scenes")
        start = values["scenes"][0]
    values["start_scene"] = start
    resolution = content.get("resolution", {})
    if not isinstance(resolution, dict):
        reader.problem("content.resolution", "must be a table of scene = resolution")
        resolution = {}
    for name, n in resolution.items():
        if name not in known:
            reader.problem(f"content.resolution.{name}", "no such scene")
        elif isinstance(n, bool) or not isinstance(n, int) or not 4 <= n <= 512:
            reader.problem(f"content.resolution.{name}", f"must be a whole number 4..512, got {n!r}")
    values["resolution"] = {k: v for k, v in resolution.items()
                            if k in known and isinstance(v, int) and 4 <= v <= 512}

    base = path.parent
    values["devices_config"] = _path(reader, base, devices, "devices", "config",
                                     "EXHIBIT_DEVICES_CONFIG", "devices/default.toml", False)
    values["attract_dir"] = _path(reader, base, attract, "attract", "timelines",
                                  "EXHIBIT_ATTRACT_DIR", "attract", True)
    values["idle_timeout_s"] = g(attract, "attract", "idle_timeout_s", float, 90.0, 5, 3600)
    values["blend_s"] = g(attract, "attract", "blend_s", float, 2.0, 0, 30)
    values["drift_px"] = g(burn_in, "burn_in", "drift_px", float, 12.0, 0, 200)
    values["drift_period_s"] = g(burn_in, "burn_in", "drift_period_s", float, 600.0, 10, 86400)
    keys = g(maintenance, "maintenance", "quit_keys", str, "")
    combo = tuple(k.strip().lower() for k in keys.split("+") if k.strip()) if keys else ()
    if combo:
        mods = [k for k in combo if k in MODIFIERS]
        rest = [k for k in combo if k not in MODIFIERS]
        if len(mods) < 2 or len(rest) != 1 or not re.fullmatch(r"[a-z0-9]|f\d{1,2}|escape", rest[0]):
            reader.problem("maintenance.quit_keys", f"{keys!r} must be at least two of "
                           f"{'/'.join(sorted(MODIFIERS))} and one key, like \"ctrl+alt+shift+q\" "
                           "(so no visitor can press it by chance)")
            combo = ()
    values["quit_keys"] = combo

    if check_linked:
        if values["devices_config"] is not None:
            from exhibit.devices.config import load_config
            try:
                load_config(values["devices_config"])
            except ExhibitError as exc:
                reader.problems.append(str(exc))
        if values["attract_dir"] is not None:
            from exhibit.kiosk.attract import load_timeline
            timelines = sorted(values["attract_dir"].glob("*.toml"))
            if not timelines:
                reader.problem("attract.timelines", f"{values['attract_dir']} has no *.toml "
                                                    "timelines")
            for timeline_path in timelines:
                try:
                    load_timeline(timeline_path)
                except ExhibitError as exc:
                    reader.problems.append(str(exc))
        # scene files that failed to load are part of the kiosk's content too
        reader.problems.extend(message for _, message in scenes.LOAD_ERRORS)
    if reader.problems:
        raise ConfigError(reader.problems)
    return KioskConfig(**values)
