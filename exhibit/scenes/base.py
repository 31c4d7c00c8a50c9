"""What a scene is: a named, parameterised recipe for a Mesh4D, with words for visitors and
preset views. Scenes know nothing of GL or devices."""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable, Mapping

from exhibit.errors import ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.schema.types import MAX_RESOLUTION, MIN_RESOLUTION
from exhibit.surfaces.mesh import Mesh4D
from exhibit.timelines.object_names import MARKS, resolve


@dataclass(frozen=True)
class Parameter:
    name: str
    default: float
    minimum: float = -math.inf
    maximum: float = math.inf
    help: str = ""

    def to_json(self) -> dict:
        def finite(v):
            return v if math.isfinite(v) else None

        return {
            "name": self.name,
            "default": self.default,
            "minimum": finite(self.minimum),
            "maximum": finite(self.maximum),
            "help": self.help,
        }


@dataclass(frozen=True)
class Preset:
    """A named view of a scene (e.g. one of the paper's figures), with parameter overrides."""

    name: str
    view: ViewState
    params: Mapping[str, float] = field(default_factory=dict)
    caption: str = ""
    #: Framed by the picture for the screen (exhibit.render.framer); False keeps the view as
    #: given (Figure 8: the torus filling the world is the point).
    fit: bool = True


@dataclass(frozen=True)
class Scene:
    name: str
    title: str
    caption: str
    parameters: tuple[Parameter, ...]
    build_mesh: Callable[[dict, int], Mesh4D]
    view: ViewState = field(default_factory=ViewState)
    presets: tuple[Preset, ...] = ()
    #: Names of the four coordinates (e.g. x, y, u, v for the offset pipes; x, y, z, t for
    #: collisions).
    axes: tuple[str, str, str, str] = ("x", "y", "z", "w")
    default_resolution: int = 64
    #: Changes whenever the scene's definition changes outside the code (e.g. its TOML file's
    #: hash), so cached meshes of the old definition are not reused.
    version: str = ""
    #: The start view and presets are fitted into the screen's free area (exhibit.render.framer)
    #: unless False.
    fit: bool = True
    #: The time-like axis for the slice explorer (the collision's t), and the 3D world at a
    #: value c of it for the inset: (params, c) -> a Mesh4D lying in the hyperplane axis = c
    #: (the pipe and the ball at time c). None: the inset shows the slice curves alone.
    slice_axis: int | None = None
    world_at: Callable[[dict, float], Mesh4D] | None = None
    #: The file a curator wrote it in (a TOML scene), None for the shipped Python scenes.
    source: Path | None = None
    #: Whether parameter values make sense together beyond each one's range: (params) -> None,
    #: or the reason they do not (the collision with nothing moving). Scene.resolve asks it.
    check: Callable[[dict], str | None] | None = None
    #: Objects the scene's caption names, tagged on screen with words in the visitor's language
    #: (an object of ``objects`` or an alias, English words): words, not colour alone. Aliases
    #: are resolved here, when the scene is made; check-config names any other name.
    labels: tuple[tuple[str, str], ...] = ()
    #: The names of every object the scene may draw (surfaces, curves, markers), each once: a
    #: curve traced in pieces is one object, "NAME" (its pieces "NAME 2", "NAME 3", ...:
    #: exhibit.timelines.object_names). The marks the renderer draws live (MARKS: "outline",
    #: "pinch points", "slice") are always added. What labels and claims may name.
    objects: tuple[str, ...] = ()
    #: Short names a curator may write for an object: alias -> the object's name ("offset
    #: curve" for "offset curve (silhouette along u, v)"), resolved when a timeline or the
    #: scene is loaded.
    aliases: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        objects = tuple(dict.fromkeys(self.objects + MARKS))
        aliases = dict(self.aliases)
        labels = tuple((resolve(name, aliases), words) for name, words in self.labels)
        # frozen: set once, here (dataclasses.replace makes a new scene and comes here again)
        object.__setattr__(self, "objects", objects)
        object.__setattr__(self, "aliases", aliases)
        object.__setattr__(self, "labels", labels)

    def resolve(self, overrides: Mapping[str, Any] | None = None) -> dict[str, float]:
        """Defaults with overrides applied; an unknown name or bad value raises ExhibitError
        (the values may be anything: they are checked here)."""
        values = {p.name: float(p.default) for p in self.parameters}
        known = {p.name: p for p in self.parameters}
        for key, raw in (overrides or {}).items():
            if key not in known:
                names = ", ".join(known) or "none"
                raise ExhibitError(
                    f"scene {self.name!r} has no parameter {key!r} (parameters: {names})"
                )
            try:
                if isinstance(raw, bool):  # true is not 1.0 to a curator
                    raise TypeError
                if isinstance(raw, str) and not raw.isascii():  # float() reads "٣" and "１"
                    raise ValueError(raw)
                value = float(raw)
            except (TypeError, ValueError, OverflowError):
                raise ExhibitError(
                    f"parameter {key}={raw!r} of scene {self.name!r} is not a number"
                ) from None
            p = known[key]
            if not (math.isfinite(value) and p.minimum <= value <= p.maximum):
                raise ExhibitError(
                    f"parameter {key}={raw} of scene {self.name!r} must lie in "
                    f"[{p.minimum}, {p.maximum}]"
                )
            values[key] = value
        reason = self.check(values) if self.check is not None else None
        if reason:
            raise ExhibitError(f"{self.name}: {reason}")
        return values

    def preset(self, name: str) -> Preset:
        for preset in self.presets:
            if preset.name == name:
                return preset
        names = ", ".join(p.name for p in self.presets) or "none"
        raise ExhibitError(f"scene {self.name!r} has no preset {name!r} (presets: {names})")

    def build(
        self, overrides: Mapping[str, object] | None = None, resolution: int | None = None
    ) -> Mesh4D:
        resolution = int(resolution or self.default_resolution)
        if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
            raise ExhibitError(
                f"resolution must lie in [{MIN_RESOLUTION}, {MAX_RESOLUTION}], got {resolution}"
            )
        return self.build_mesh(self.resolve(overrides), resolution)

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "title": self.title,
            "caption": self.caption,
            "axes": list(self.axes),
            "parameters": [p.to_json() for p in self.parameters],
            "presets": [p.name for p in self.presets],
            "objects": list(self.objects),
            "aliases": dict(self.aliases),
        }


def parse_overrides(items: list[str] | None) -> dict[str, str]:
    """`--param k=v` arguments as a dict (values are checked later by Scene.resolve)."""
    overrides: dict[str, str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ExhibitError(f"--param: {item!r} is not NAME=VALUE")
        overrides[key.strip()] = value.strip()
    return overrides


def parse_resolution(text: str | int | None) -> int | None:
    """`--resolution N`: None (the scene's default) or a whole number within the one cap that
    scene files and the kiosk config share."""
    if text is None:
        return None
    try:
        if isinstance(text, str) and not text.isascii():  # int() reads "１２" and "٣"
            raise ValueError(text)
        value = int(text)
    except (TypeError, ValueError):
        raise ExhibitError(
            f"--resolution must be a whole number written with the digits 0-9, got {text!r}"
        ) from None
    if not MIN_RESOLUTION <= value <= MAX_RESOLUTION:
        raise ExhibitError(
            f"--resolution must lie in [{MIN_RESOLUTION}, {MAX_RESOLUTION}], got {value}"
        )
    return value


def build_from_arguments(scene: Scene, args: argparse.Namespace) -> Mesh4D:
    """The mesh the shared options (add_scene_arguments: --param, --resolution) ask for, with a
    progress line while it builds when a person watches a terminal."""
    from exhibit import progress

    overrides = parse_overrides(args.param)
    resolution = parse_resolution(args.resolution)
    with progress.on_terminal():
        return scene.build(overrides, resolution)


def add_scene_arguments(parser: argparse.ArgumentParser) -> None:
    """The scene, --param and --resolution options every scene command shares."""
    parser.add_argument("scene", help="scene name (see `exhibit scenes`)")
    parser.add_argument(
        "--param", action="append", default=[], metavar="K=V", help="scene parameter (repeatable)"
    )
    parser.add_argument("--resolution", metavar="N", help="mesh resolution (default: the scene's)")
