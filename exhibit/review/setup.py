"""What a review plays, checked before any GL work: the timeline file, the kiosk config it starts
from (the shipped one unless told), the language and its catalogue, the first shipped timeline
of a scene, and a device config with the keyboard alone. Each problem is one line
(ExhibitError), for `exhibit render --timeline`, `--takeover` and `--verify`."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

from exhibit import scenes
from exhibit.errors import ConfigError, ExhibitError
from exhibit.kiosk.config import KioskConfig, load_kiosk_config
from exhibit.kiosk.language import SOURCE, load_catalogues
from exhibit.resources import shipped
from exhibit.timelines.file import load_timeline, timeline_paths
from exhibit.timelines.model import Timeline


def read_timeline(path: str | Path) -> Timeline:
    """A timeline file, or an ExhibitError that says in one line why not."""
    path = Path(path)
    if not path.is_file():
        raise ExhibitError(
            f"--timeline: {path} is not a file"
            if path.exists()
            else f"--timeline: {path} does not exist"
        )
    try:
        return load_timeline(path, scenes.get)
    except ConfigError as exc:
        first = exc.problems[0] if exc.problems else str(exc)
        more = f" (and {len(exc.problems) - 1} more)" if len(exc.problems) > 1 else ""
        raise ExhibitError(f"--timeline: not a timeline: {first}{more}") from None


def shipped_timeline(scene: str, attract_dir: Path | None = None) -> Path | None:
    """The first attract timeline (in name order) in ``attract_dir`` (default: the shipped
    configs/attract) whose scene is ``scene``; None when there is none."""
    folder = attract_dir or shipped("configs", "attract")
    for path in timeline_paths(folder):
        try:
            doc = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeError, tomllib.TOMLDecodeError):
            continue
        if doc.get("scene") == scene:
            return path
    return None


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(value)


def keyboard_only(devices_config: Path | None, out: Path) -> Path:
    """A device config with the keyboard alone, its bindings as ``devices_config`` has them
    (the shipped one when that binds no keyboard): no serial port or HID device is opened."""
    sources = [p for p in (devices_config, shipped("configs", "devices", "default.toml")) if p]
    for source in sources:
        doc = tomllib.loads(Path(source).read_text(encoding="utf-8"))
        mapping = doc.get("mapping", {})
        binds = [b for b in mapping.get("bind", []) if b.get("device") == "keyboard"]
        if binds:
            break
    lines = ["[devices.keyboard]", 'url = "keyboard://"', "[mapping]"]
    lines += [
        f"{k} = {_toml(v)}"
        for k, v in mapping.items()
        if not isinstance(v, (dict, list)) or k == "home_angles"
    ]
    for bind in binds:
        lines.append("[[mapping.bind]]")
        lines += [f"{k} = {_toml(v)}" for k, v in bind.items()]
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out


def base_config(path: str | Path | None = None) -> KioskConfig:
    """The kiosk config a review starts from: ``path`` over the shipped defaults (else the
    shipped defaults alone, not /etc/exhibit: a review is of what ships unless told)."""
    try:
        return load_kiosk_config(
            path if path is not None else shipped("configs", "kiosk.toml"), check_linked=False
        )
    except ConfigError as exc:
        first = exc.problems[0] if exc.problems else str(exc)
        more = f" (and {len(exc.problems) - 1} more)" if len(exc.problems) > 1 else ""
        raise ExhibitError(f"--config: {first}{more}") from None


def check_language(config: KioskConfig, language: str | None) -> tuple[str, Path | None]:
    """The language to show (default: the config's first) and the folder of its catalogue; an
    ExhibitError for a language with no catalogue or a broken one."""
    language = language or config.languages[0]
    if language == SOURCE:
        return language, config.catalogues_dir
    folder = config.catalogues_dir or shipped("configs", "languages")
    known = sorted({SOURCE, *(p.stem for p in Path(folder).glob("*.toml"))})
    if language not in known:
        raise ExhibitError(
            f"--language: no catalogue for {language!r} in {folder} (languages: {', '.join(known)})"
        )
    try:
        load_catalogues(folder, [language])
    except ConfigError as exc:
        raise ExhibitError(f"--language: {exc.problems[0]}") from None
    return language, folder
