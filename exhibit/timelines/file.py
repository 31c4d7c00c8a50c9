"""The timeline file: attract mode as content, keyframes that curators write in
configs/attract/*.toml, read into exhibit.timelines.model's Timeline.

    name = "The sensor approaches"            # shown to staff, not visitors
    scene = "hopf"                            # a registered scene
    preset = "figure-6"                       # optional: start from a preset's view and params
    params = { rs = 0.7 }                     # optional scene parameters
    fit = false                               # optional: keep the zooms as written (default:
                                              # framed for the screen, exhibit.render.framer)
    slice_axis = "t"                          # optional: the axis slice keyframes cut along
                                              # (default: the scene's own, e.g. the collision's t)

    [[keyframe]]
    t = 0                                     # seconds from the start of this timeline
    angles = [0, 0, 0, 0, 0, 0]               # degrees; omitted values carry over
    sensor_distance = "inf"                   # or a number; interpolated in r = 1/d
    eye = [20, -60]                           # azimuth, incidence (degrees)
    half_height = 1.6                         # zoom (interpolated geometrically)
    caption = "..."                           # shown from this keyframe on
    while = { sensor_distance = [2.9, 3.1] }  # optional: what the caption says of the view
    while = { angles_within = 5 }             # ... or: the pose turns at most 5 degrees
    while = { grows = ["torus Z=-√2/2"] }     # ... or what the picture shows (claims, below)
    labels = { "torus Z=-√2/2" = "green doughnut" }  # tag a named object with words
    ease = "smooth"                           # into the next keyframe: smooth | linear | hold
    slice = -1.5                              # the slice axis = -1.5 glows on the surface
                                              # (exhibit.surfaces.slice); "off" ends it
    hold_framing = true                       # keep the keyframe before's zoom and lens shift
                                              # (the camera holds: what grows, grows on screen)
    describe = "..."                          # for a visitor who cannot see the screen: what
                                              # the picture shows, what moves, where the named
                                              # objects are; spoken before the caption
    narration = { en = "audio/k1-en.wav" }    # recorded narration for this keyframe, per
                                              # language (a path beside this file), spoken
                                              # instead of the synthesised description+caption

A caption that describes the view states it in ``while``, so `exhibit check-config` can play the
timeline and report where the caption is shown while the view says otherwise:
``sensor_distance = "inf"`` or ``[low, high]`` (high may be "inf"), ``sensor_motion = "closer"``,
``"farther"`` or ``"still"``, and ``angles_within = D``: every one of the six angles and the eye's
azimuth and incidence stays within D degrees (0..180) of the pose at the keyframe that states the
``while`` (a caption about one particular view, such as "in the plane ...": it must not be left
on screen while the view turns away). The condition belongs to the caption: it holds until a
keyframe sets a new caption (with its own ``while``, or none); a keyframe may also restate
``while`` alone (``angles_within`` then counts from that keyframe's pose).

A timeline lasts until its last keyframe; the playlist plays the files in name order and loops.
Limits: t 0..86400 s, angles and eye -3600..3600 degrees, sensor_distance "inf" or 0.05..1e6,
half_height 0.001..1000, params -1e6..1e6 (and the scene's own range and checks: a curator's
formulas must be buildable at them), captions up to 2000 characters, slice -1e6..1e6 or "off"
(it carries over like the other keys; between two slice values it moves with the keyframes'
ease, and a keyframe without one holds the previous).

The objects ``labels`` and the claims of ``while`` name are the scene's (exhibit.scenes.base.
Scene.objects): a name stands for the object of exactly that name and its pieces ("NAME 2", ...:
exhibit.timelines.object_names), or is a short name the scene declares (Scene.aliases, e.g.
"offset curve"), written here by its object's name. A name that is neither loads (the kiosk
skips its tag, a claim about it finds nothing) and `exhibit check-config` names it.

The scene a file names is looked up by the caller (``scene``: exhibit.scenes.get, in the kiosk and
the commands), so the timeline stays below the scenes and the narration that speaks it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, Protocol

from pydantic import Field, create_model, model_validator

from exhibit.errors import ConfigError, ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.schema import Model, read_toml, validate
from exhibit.schema.types import (
    MAX_ANGLE,
    Caption,
    Description,
    Distance,
    HalfHeight,
    Name,
    Number,
    Numbers,
    Seconds,
    distance_to_r,
)
from exhibit.timelines.claims import KINDS
from exhibit.timelines.claims.base import MAX_CLAIMED
from exhibit.timelines.model import Condition, Ease, Keyframe, Timeline
from exhibit.timelines.object_names import resolve


class _While(Model):
    """``while = { ... }``: what a caption says of the view and the picture, a key per claim
    kind (exhibit.timelines.claims.KINDS, whose fragments are its fields: WhileSpec below)."""

    @model_validator(mode="after")
    def _not_empty(self):
        keys = [kind.key for kind in KINDS]
        if all(getattr(self, key) is None for key in keys):
            raise ValueError(f"states no condition: give {', '.join(keys[:-1])} or {keys[-1]}")
        return self

    def condition(
        self, pose: tuple[float, ...], aliases: Mapping[str, str] | None = None
    ) -> Condition:
        """The condition, its claims in KINDS' order; ``pose``: the stating keyframe's angles
        and eye (radians); ``aliases``: the scene's (Scene.aliases), resolved in the objects
        the claims name."""
        claims = []
        for kind in KINDS:
            value = getattr(self, kind.key)
            if value is None:
                continue
            claim = kind.parse(value, pose)
            named = set(claim.names()) & set(aliases or ())
            if named:
                claim = kind.parse(_renamed(value, named, aliases or {}), pose)
            claims.append(claim)
        return Condition(tuple(claims))


def _renamed(value: Any, named: set[str], aliases: Mapping[str, str]) -> Any:
    """A claim's value with the objects in ``named`` written by their names: a list of names,
    or a table keyed by them (each kind's value is one or the other)."""
    if isinstance(value, dict):
        return {resolve(k, aliases) if k in named else k: v for k, v in value.items()}
    if isinstance(value, list):
        return [resolve(v, aliases) if isinstance(v, str) and v in named else v for v in value]
    return value


if TYPE_CHECKING:
    WhileSpec = _While
else:
    WhileSpec = create_model(
        "WhileSpec",
        __base__=_While,
        __doc__=_While.__doc__,
        __module__=__name__,
        **{kind.key: (kind.fragment, None) for kind in KINDS},
    )


class KeyframeSpec(Model):
    t: Seconds
    angles: Annotated[tuple[float, ...], Numbers(6, -MAX_ANGLE, MAX_ANGLE)] | None = None
    sensor_distance: Distance | None = None
    eye: Annotated[tuple[float, ...], Numbers(2, -MAX_ANGLE, MAX_ANGLE)] | None = None
    half_height: HalfHeight | None = None
    caption: Caption | None = None
    while_: WhileSpec | None = Field(None, alias="while")
    ease: Ease = "smooth"
    slice: Annotated[float, Number(-1e6, 1e6)] | Literal["off"] | None = None
    hold_framing: bool = False
    labels: Annotated[dict[Name, Name], Field(max_length=MAX_CLAIMED)] | None = None
    describe: Description | None = None
    narration: Annotated[dict[Name, Name], Field(max_length=MAX_CLAIMED)] | None = None


class TimelineFile(Model):
    name: Name | None = None
    scene: Name
    preset: Name | None = None
    params: dict[str, Annotated[float, Number(-1e6, 1e6)]] = {}
    fit: bool | None = None
    slice_axis: Name | None = None
    keyframe: Annotated[list[KeyframeSpec], Field(min_length=2)]


class ScenePreset(Protocol):
    """What a timeline takes from a scene's preset (exhibit.scenes.base.Preset)."""

    @property
    def view(self) -> ViewState: ...
    @property
    def params(self) -> Mapping[str, float]: ...


class TimelineScene(Protocol):
    """What a timeline takes from its scene (exhibit.scenes.base.Scene): the start view, a
    preset's view and parameters, the parameters checked, the axes a slice may cut along, and
    the short names a curator may write for its objects."""

    @property
    def name(self) -> str: ...
    @property
    def view(self) -> ViewState: ...
    @property
    def axes(self) -> tuple[str, ...]: ...
    @property
    def slice_axis(self) -> int | None: ...
    @property
    def aliases(self) -> Mapping[str, str]: ...
    def preset(self, name: str) -> ScenePreset: ...
    def resolve(self, overrides: Mapping[str, Any] | None = None) -> dict[str, float]: ...


#: The scene of a name, or an ExhibitError saying why there is none (exhibit.scenes.get).
SceneLookup = Callable[[str], TimelineScene]


def load_timeline(path: Path, scene_named: SceneLookup) -> Timeline:
    """A timeline from its file, its scene looked up by ``scene_named`` (exhibit.scenes.get);
    ConfigError lists every problem as ``file: key: reason``."""
    path = Path(path)
    spec = validate(TimelineFile, read_toml(path), str(path))
    problems: list[str] = []

    def problem(key: str, reason: str) -> None:
        problems.append(f"{path}: {key}: {reason}")

    scene = None
    try:
        scene = scene_named(spec.scene)
    except ExhibitError as exc:
        problem("scene", str(exc))
    base_view, params = ViewState(), {}
    aliases: Mapping[str, str] = {}
    if scene is not None:
        aliases = scene.aliases
        base_view = scene.view
        if spec.preset is not None:
            try:
                preset = scene.preset(spec.preset)
                base_view, params = preset.view, dict(preset.params)
            except ExhibitError as exc:
                problem("preset", str(exc))
        params.update(spec.params)
        try:
            params = scene.resolve(params)
        except ExhibitError as exc:
            problem("params", str(exc))

    slice_axis = None
    if scene is not None:
        if spec.slice_axis is not None:
            if spec.slice_axis in scene.axes:
                slice_axis = scene.axes.index(spec.slice_axis)
            else:
                problem(
                    "slice_axis",
                    f"{spec.slice_axis!r} is not an axis of {scene.name} "
                    f"(axes: {', '.join(scene.axes)})",
                )
        else:
            slice_axis = scene.slice_axis
        if slice_axis is None and any(k.slice is not None for k in spec.keyframe):
            problem(
                "slice_axis",
                f"keyframes slice, but {scene.name} has no time-like axis: "
                f"name one of {', '.join(scene.axes)}",
            )

    frames: list[Keyframe] = []
    previous = Keyframe(
        0.0,
        base_view.angles,
        base_view.sensor_r,
        (base_view.eye_azimuth, base_view.eye_incidence),
        base_view.half_height,
        "",
        "smooth",
    )
    for i, raw in enumerate(spec.keyframe):
        where = f"keyframe[{i}]."
        if i == 0 and raw.t != 0:
            problem(where + "t", "the first keyframe must be at t = 0")
        if i > 0 and raw.t <= frames[-1].t:
            problem(
                where + "t", f"{raw.t:g} must be later than the keyframe before ({frames[-1].t:g})"
            )
        angles = (
            previous.angles if raw.angles is None else tuple(math.radians(a) for a in raw.angles)
        )
        eye = (
            previous.eye
            if raw.eye is None  # Numbers(2, ...): two angles
            else (math.radians(raw.eye[0]), math.radians(raw.eye[1]))
        )
        previous = Keyframe(
            raw.t,
            angles,
            previous.sensor_r
            if raw.sensor_distance is None
            else distance_to_r(raw.sensor_distance),
            eye,
            previous.half_height if raw.half_height is None else raw.half_height,
            previous.caption if raw.caption is None else raw.caption,
            raw.ease,
            _condition(previous, raw, angles + eye, aliases),
            previous.caption_from if raw.caption is None and raw.while_ is None else i,
            previous.slice_at
            if raw.slice is None
            else None
            if raw.slice == "off"
            else float(raw.slice),
            raw.hold_framing and i > 0,
            _labels(previous, raw, aliases),
            (raw.describe or "").strip(),
            tuple(
                (code, str(path.parent / relative))
                for code, relative in (raw.narration or {}).items()
            ),
        )
        frames.append(previous)
    if problems:
        raise ConfigError(problems)
    return Timeline(
        spec.name or path.stem,
        str(path),
        spec.scene,
        params,
        base_view,
        tuple(frames),
        spec.fit,
        slice_axis,
    )


def _labels(
    previous: Keyframe, raw: KeyframeSpec, aliases: Mapping[str, str]
) -> tuple[tuple[str, str], ...]:
    """The tags in force from this keyframe: its own (an alias written by its object's name),
    else the caption's it keeps (a new caption without ``labels`` has none)."""
    if raw.labels is not None:
        return tuple((resolve(name, aliases), words) for name, words in raw.labels.items())
    return previous.labels if raw.caption is None else ()


def _condition(
    previous: Keyframe, raw: KeyframeSpec, pose: tuple[float, ...], aliases: Mapping[str, str]
) -> Condition | None:
    """The condition in force from this keyframe: its own (``angles_within`` counted from
    ``pose``, this keyframe's; aliases written by their objects' names), else the caption's
    it keeps (a new caption without ``while`` states none)."""
    if raw.while_ is not None:
        return raw.while_.condition(pose, aliases)
    return previous.condition if raw.caption is None else None


def timeline_paths(folder: Path) -> list[Path]:
    """The timeline files in ``folder``, in name order (the order they play)."""
    try:
        return sorted(Path(folder).glob("*.toml"))
    except OSError as exc:
        raise ExhibitError(f"{folder}: cannot list: {exc.strerror or exc}") from None


def load_playlist(folder: Path, scene_named: SceneLookup) -> list[Timeline]:
    """Every *.toml in ``folder``, in name order, their scenes looked up by ``scene_named``;
    errors name the file and key."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ExhibitError(f"{folder}: the attract folder does not exist")
    paths = timeline_paths(folder)
    if not paths:
        raise ExhibitError(f"{folder}: no attract timelines (*.toml) in it")
    return [load_timeline(p, scene_named) for p in paths]
