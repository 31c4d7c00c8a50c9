"""The exhibit's scenes, registered by name, and the paper's figures as (scene, preset) pairs."""

from __future__ import annotations

import os
import re
from pathlib import Path

from exhibit.errors import ExhibitError
from exhibit.resources import shipped
from exhibit.scenes.base import Parameter, Preset, Scene
from exhibit.scenes import checked, collision, gallery, hopf, offsets
from exhibit.scenes.toml_scene import load_scene_file

#: Where curators' scene files live: the repository's configs/scenes, then every folder in
#: $EXHIBIT_SCENE_PATH (separated by ':').
BUILTIN_SCENE_DIR = shipped("configs", "scenes")
#: Problems met loading scene files: (path, message). Shown by `exhibit scenes`; the other scenes
#: still load, so one broken file never takes the exhibit down.
LOAD_ERRORS: list[tuple[str, str]] = []

_REGISTRY: dict[str, Scene] = {}


def register(scene: Scene) -> Scene:
    if scene.name in _REGISTRY:
        raise ValueError(f"scene {scene.name!r} is registered twice")
    _REGISTRY[scene.name] = scene
    return scene


def names() -> list[str]:
    load()
    return sorted(_REGISTRY)


def get(name: str) -> Scene:
    load()
    try:
        return _REGISTRY[name]
    except KeyError:
        failed = [
            message.replace("\n", "; ")
            for path, message in LOAD_ERRORS
            if _names_scene(Path(path), name)
        ]
        if failed:
            raise ExhibitError(f"scene {name!r} failed to load: {'; '.join(failed)}") from None
        raise ExhibitError(f"no scene named {name!r} (scenes: {', '.join(names())})") from None


def _names_scene(path: Path, name: str) -> bool:
    """Whether a scene file that failed to load meant to be scene ``name``: it is called
    NAME.toml, or says ``name = "NAME"`` on a line of its own (read again, as far as it can be:
    the file did not load)."""
    if path.stem == name:
        return True
    try:
        with open(path, "rb") as file:
            text = file.read(1 << 20).decode("utf-8", "replace")
    except OSError:
        return False
    return re.search(rf"""^\s*name\s*=\s*["']{re.escape(name)}["']""", text, re.M) is not None


#: The paper's figures: number -> (scene, preset).
FIGURES: dict[int, tuple[str, str]] = {
    6: ("hopf", "figure-6"),
    7: ("hopf", "figure-7"),
    8: ("hopf", "figure-8"),
    9: ("offset-parabola", "figure-9"),
    10: ("offset-parabola", "figure-10"),
    11: ("offset-cusp", "figure-11"),
    12: ("offset-cusp", "figure-12"),
    13: ("offset-cusp-traced", "figure-13"),
    14: ("offset-cusp-traced", "figure-14"),
    15: ("collision", "figure-15"),
    16: ("collision", "figure-16"),
    17: ("collision", "figure-17"),
}


def figure(number: int) -> tuple[Scene, Preset]:
    if number not in FIGURES:
        known = ", ".join(str(n) for n in sorted(FIGURES))
        raise ExhibitError(f"no figure {number} (figures: {known})")
    scene_name, preset_name = FIGURES[number]
    scene = get(scene_name)
    return scene, scene.preset(preset_name)


def scene_dirs() -> list[Path]:
    extra = [Path(p) for p in os.environ.get("EXHIBIT_SCENE_PATH", "").split(":") if p]
    return [BUILTIN_SCENE_DIR] + extra


_BUILTIN = (
    hopf.SCENE,
    offsets.PARABOLA,
    offsets.CUSP,
    offsets.TRACED,
    collision.SCENE,
    gallery.CLIFFORD,
    gallery.COMPLEX_SQUARE,
)
_REGISTRY.update((scene.name, scene) for scene in _BUILTIN)
_loaded = False


def _scene_files(folder: Path) -> list[Path]:
    try:
        return sorted(folder.glob("*.toml")) if folder.is_dir() else []
    except OSError as exc:
        LOAD_ERRORS.append((str(folder), f"{folder}: cannot list: {exc.strerror or exc}"))
        return []


def load(reload: bool = False) -> tuple[dict[str, Scene], list[tuple[str, str]]]:
    """The scenes (built-in and curators' files) and the problems met loading the files.

    Called by the CLI and the kiosk (and on first use by :func:`names` and :func:`get`), never at
    import: a broken file must not stop `exhibit --help`. Whatever one file does, it is reported
    as ``(path, "file: key: reason")`` and the other files still load.
    """
    global _loaded
    if _loaded and not reload:
        return dict(_REGISTRY), list(LOAD_ERRORS)
    _REGISTRY.clear()
    _REGISTRY.update((scene.name, scene) for scene in _BUILTIN)
    LOAD_ERRORS.clear()
    for folder in scene_dirs():
        for path in _scene_files(folder):
            try:
                scene = load_scene_file(path)
                if scene.name in _REGISTRY:
                    raise ExhibitError(
                        f"{path}: name: a scene called {scene.name!r} exists already"
                    )
                register(scene)
            except ExhibitError as exc:
                LOAD_ERRORS.append((str(path), str(exc)))
            except Exception as exc:  # noqa: BLE001 - one curator's file never stops the rest
                LOAD_ERRORS.append(
                    (str(path), f"{path}: cannot load: {type(exc).__name__}: {str(exc)[:200]}")
                )
    checked.save()
    _loaded = True
    return dict(_REGISTRY), list(LOAD_ERRORS)


def problems() -> list[tuple[str, str]]:
    """(path, message) for each scene file that failed to load."""
    load()
    return list(LOAD_ERRORS)


__all__ = [
    "FIGURES",
    "LOAD_ERRORS",
    "Parameter",
    "Preset",
    "Scene",
    "figure",
    "get",
    "load",
    "names",
    "problems",
    "register",
    "load_scene_file",
]
