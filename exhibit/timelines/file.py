"""Attract mode as content: timelines of keyframes that curators write in configs/attract/*.toml.

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

Why one module of this size: the timeline file format and its player share every keyframe rule."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal, get_args

from pydantic import Field, model_validator

from exhibit import scenes
from exhibit.errors import ConfigError, ExhibitError
from exhibit.geometry.view import ViewState
from exhibit.schema import Model, read_toml, validate
from exhibit.schema.types import (
    MAX_ANGLE,
    Caption,
    Description,
    Distance,
    DistanceRange,
    HalfHeight,
    Name,
    Number,
    Numbers,
    Seconds,
    distance_to_r,
)

Ease = Literal["smooth", "linear", "hold"]
EASES: tuple[Ease, ...] = get_args(Ease)
Motion = Literal["closer", "farther", "still"]
MOTIONS: tuple[Motion, ...] = get_args(Motion)
#: Reduced motion: a stretch between keyframes plays as held poses about this long, each
#: crossfaded into the next (a 1 s crossfade, then 3 s still).
STEP_S = 4.0
#: Objects one picture claim may name.
MAX_CLAIMED = 16


@dataclass(frozen=True)
class Condition:
    """What a caption says about the view, for `exhibit check-config` to hold it to.

    ``sensor_r``: the range of r = 1/d the sensor must stay in (None: any); ``motion``: the
    sensor must move closer (r grows), farther (r shrinks) or stay still; ``angles_within``: the
    six angles and the eye (azimuth, incidence) stay within that many degrees of ``pose``, the
    pose at the keyframe that states the condition (radians: θ1..θ6, azimuth, incidence)."""

    sensor_r: tuple[float, float] | None = None
    sensor_distance: tuple[float, float] | None = None  # as written, for messages
    motion: str | None = None
    angles_within: float | None = None
    pose: tuple[float, ...] | None = None
    #: What the caption says the picture shows, measured on the rendered frames by
    #: `exhibit render --timeline --verify` (exhibit.kiosk.claims), never by colour.
    picture: PictureClaims | None = None


@dataclass(frozen=True)
class PictureClaims:
    """Claims about the named objects on screen while a caption is shown (each name: a
    surface, curve or marker of the scene, or the start of such names: "offset curve" is every
    piece of it; or a live mark: "outline", "pinch points", "slice"). ``visible``: each shows
    at every moment; ``absent``: none of it shows at any moment; ``grows`` / ``shrinks``: its area
    on screen at the caption's end against its start; ``outgrows`` (a, b): a grows far more
    than b; ``fills``: (name, share) pairs, the object covers at least that share of the
    screen at every moment."""

    visible: tuple[str, ...] = ()
    absent: tuple[str, ...] = ()
    grows: tuple[str, ...] = ()
    shrinks: tuple[str, ...] = ()
    outgrows: tuple[str, str] | None = None
    fills: tuple[tuple[str, float], ...] = ()

    def names(self) -> tuple[str, ...]:
        """Every object the claims name, once each, in order."""
        named = [*self.visible, *self.absent, *self.grows, *self.shrinks]
        named += list(self.outgrows or ())
        named += [name for name, _ in self.fills]
        return tuple(dict.fromkeys(named))


#: A scene's parameters as a hashable key: (name, value) pairs, sorted by name.
Params = tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class Keyframe:
    t: float
    angles: tuple[float, ...]  # radians
    sensor_r: float
    eye: tuple[float, float]  # radians
    half_height: float
    caption: str
    ease: str
    condition: Condition | None = None
    #: the keyframe whose caption (and condition) is shown from here: where a problem is reported
    caption_from: int = 0
    #: where the slice cuts (ViewState.slice_at), None: no slice
    slice_at: float | None = None
    #: keeps the framing of the keyframe before (exhibit.kiosk.timeline_framing): the camera
    #: holds, so what grows on the way here grows on screen
    hold_framing: bool = False
    #: objects the caption names, tagged on screen with words (exhibit.render.object_tags):
    #: (object name, or the start of names, English words); they belong to the caption
    labels: tuple[tuple[str, str], ...] = ()
    #: what the picture shows, for a visitor who cannot see it (English; spoken before the
    #: caption): only on the keyframe that states it
    description: str = ""
    #: recorded narration of this keyframe: (language code, path), spoken instead of the
    #: synthesised description and caption (exhibit.narration)
    recordings: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Timeline:
    name: str
    path: str
    scene: str
    params: dict
    base_view: ViewState
    keyframes: tuple[Keyframe, ...]
    #: Framed for the screen (exhibit.render.framer) unless False.
    fit: bool | None = None
    #: The axis the keyframes' slices cut along (an index of the scene's axes), or None.
    slice_axis: int | None = None

    @property
    def duration(self) -> float:
        return self.keyframes[-1].t

    def at(self, t: float, stepped: bool = False) -> tuple[ViewState, str]:
        """The view and caption ``t`` seconds into the timeline (clamped to its ends).

        ``stepped`` (reduced motion): the camera does not glide. The pose (angles, sensor
        distance, eye, zoom and lens shift) moves in slow steps of about STEP_S seconds, each
        held, which the kiosk shows as crossfaded cuts; the slice, content rather than
        camera motion, still moves with the keyframes' ease. The last keyframe only ends the
        last stretch then: its pose would be shown for an instant before the playlist moves on,
        so the instant ``t = duration`` belongs to the stretch before it."""
        frames = self.keyframes
        t = min(max(t, 0.0), self.duration)
        index = self.index_at(t)
        if stepped and index == len(frames) - 1:
            index -= 1
        a = frames[index]
        if index == len(frames) - 1 or a.ease == "hold":
            return self._view(a, a, 0.0), a.caption
        b = frames[index + 1]
        u = (t - a.t) / (b.t - a.t)

        def eased(x: float) -> float:
            return x * x * (3 - 2 * x) if a.ease == "smooth" else x

        view = self._view(a, b, eased(u))
        if stepped:
            # Slow steps: the stretch in steps of about STEP_S, each pose held (a caption
            # saying "the viewpoint moves closer" stays true, a step at a time).
            steps = max(1, round((b.t - a.t) / STEP_S))
            held = self._view(a, b, eased(min(steps - 1, int(u * steps)) / steps))
            view = held.replace(slice_axis=view.slice_axis, slice_at=view.slice_at)
        return view, a.caption

    def step_times(self) -> list[float]:
        """When a stepped (reduced-motion) playback moves to its next held pose: the slow steps
        of every stretch and its keyframes, from the first step on."""
        out = []
        for a, b in zip(self.keyframes, self.keyframes[1:]):
            steps = max(1, round((b.t - a.t) / STEP_S))
            out += [a.t + (b.t - a.t) * k / steps for k in range(1, steps)] + [b.t]
        return out[:-1]  # the last keyframe ends the last stretch (Timeline.at)

    def index_at(self, t: float) -> int:
        """The keyframe in force ``t`` seconds in (its caption is the one shown)."""
        return max(i for i, k in enumerate(self.keyframes) if k.t <= t)

    def _view(self, a: Keyframe, b: Keyframe, u: float) -> ViewState:
        def mix(x, y):
            return x + (y - x) * u

        angles = tuple(mix(x, y) for x, y in zip(a.angles, b.angles))
        half = math.exp(mix(math.log(a.half_height), math.log(b.half_height)))
        sliced = {}
        if self.slice_axis is not None and a.slice_at is not None:
            at = a.slice_at if b.slice_at is None else mix(a.slice_at, b.slice_at)
            sliced = {"slice_axis": self.slice_axis, "slice_at": at}
        return self.base_view.replace(
            angles=angles,
            sensor_r=mix(a.sensor_r, b.sensor_r),
            eye_azimuth=mix(a.eye[0], b.eye[0]),
            eye_incidence=mix(a.eye[1], b.eye[1]),
            half_height=half,
            **sliced,
        )


class WhileSpec(Model):
    """``while = { ... }``: the state of the view a caption describes."""

    sensor_distance: DistanceRange | None = None
    sensor_motion: Motion | None = None
    #: degrees the pose (six angles and the eye) may turn from the stating keyframe's
    angles_within: Annotated[float, Number(0, 180)] | None = None
    #: What the picture shows (PictureClaims): objects by name.
    visible: Annotated[list[Name], Field(min_length=1, max_length=MAX_CLAIMED)] | None = None
    absent: Annotated[list[Name], Field(min_length=1, max_length=MAX_CLAIMED)] | None = None
    grows: Annotated[list[Name], Field(min_length=1, max_length=MAX_CLAIMED)] | None = None
    shrinks: Annotated[list[Name], Field(min_length=1, max_length=MAX_CLAIMED)] | None = None
    outgrows: Annotated[list[Name], Field(min_length=2, max_length=2)] | None = None
    fills: (
        Annotated[
            dict[Name, Annotated[float, Number(0.001, 1.0)]],
            Field(min_length=1, max_length=MAX_CLAIMED),
        ]
        | None
    ) = None

    @model_validator(mode="after")
    def _not_empty(self):
        if all(getattr(self, name) is None for name in type(self).model_fields):
            raise ValueError(
                "states no condition: give sensor_distance, sensor_motion, angles_within, "
                "visible, absent, grows, shrinks, outgrows or fills"
            )
        return self

    def picture(self) -> PictureClaims | None:
        """The claims about the picture, None when it makes none."""
        if not any(
            (self.visible, self.absent, self.grows, self.shrinks, self.outgrows, self.fills)
        ):
            return None
        return PictureClaims(
            tuple(self.visible or ()),
            tuple(self.absent or ()),
            tuple(self.grows or ()),
            tuple(self.shrinks or ()),
            None if self.outgrows is None else (self.outgrows[0], self.outgrows[1]),
            tuple((self.fills or {}).items()),
        )

    def condition(self, pose: tuple[float, ...]) -> Condition:
        """The condition, with ``pose`` (the stating keyframe's angles and eye, radians)."""
        d = self.sensor_distance
        r = None if d is None else (distance_to_r(d[1]), distance_to_r(d[0]))
        within = None if self.angles_within is None else float(self.angles_within)
        return Condition(
            r,
            d,
            self.sensor_motion,
            within,
            None if within is None else tuple(pose),
            self.picture(),
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


def load_timeline(path: Path) -> Timeline:
    """A timeline from its file; ConfigError lists every problem as ``file: key: reason``."""
    path = Path(path)
    spec = validate(TimelineFile, read_toml(path), str(path))
    problems: list[str] = []

    def problem(key: str, reason: str) -> None:
        problems.append(f"{path}: {key}: {reason}")

    scene = None
    try:
        scene = scenes.get(spec.scene)
    except ExhibitError as exc:
        problem("scene", str(exc))
    base_view, params = ViewState(), {}
    if scene is not None:
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
            _condition(previous, raw, angles + eye),
            previous.caption_from if raw.caption is None and raw.while_ is None else i,
            previous.slice_at
            if raw.slice is None
            else None
            if raw.slice == "off"
            else float(raw.slice),
            raw.hold_framing and i > 0,
            _labels(previous, raw),
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


def _labels(previous: Keyframe, raw: KeyframeSpec) -> tuple[tuple[str, str], ...]:
    """The tags in force from this keyframe: its own, else the caption's it keeps (a new
    caption without ``labels`` has none)."""
    if raw.labels is not None:
        return tuple(raw.labels.items())
    return previous.labels if raw.caption is None else ()


def _condition(previous: Keyframe, raw: KeyframeSpec, pose: tuple[float, ...]) -> Condition | None:
    """The condition in force from this keyframe: its own (``angles_within`` counted from
    ``pose``, this keyframe's), else the caption's it keeps (a new caption without ``while``
    states none)."""
    if raw.while_ is not None:
        return raw.while_.condition(pose)
    return previous.condition if raw.caption is None else None


def timeline_paths(folder: Path) -> list[Path]:
    """The timeline files in ``folder``, in name order (the order they play)."""
    try:
        return sorted(Path(folder).glob("*.toml"))
    except OSError as exc:
        raise ExhibitError(f"{folder}: cannot list: {exc.strerror or exc}") from None


def load_playlist(folder: Path) -> list[Timeline]:
    """Every *.toml in ``folder``, in name order; errors name the file and key."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ExhibitError(f"{folder}: the attract folder does not exist")
    paths = timeline_paths(folder)
    if not paths:
        raise ExhibitError(f"{folder}: no attract timelines (*.toml) in it")
    return [load_timeline(p) for p in paths]


@dataclass
class Playlist:
    """Plays timelines one after another, looping; knows where it is at any time."""

    timelines: list[Timeline]
    started: float = 0.0
    _total: float = field(init=False)

    def __post_init__(self) -> None:
        self._total = sum(t.duration for t in self.timelines)

    def restart(self, now: float, index: int = 0) -> None:
        self.started = now - sum(t.duration for t in self.timelines[:index])

    def insert(self, index: int, timeline: Timeline, now: float) -> None:
        """``timeline`` added at ``index`` (the kiosk's, as its scene becomes ready), the one
        playing at ``now`` going on where it is."""
        current, offset = None, 0.0
        if self.timelines and self._total > 0:
            t = (now - self.started) % self._total
            for i, playing in enumerate(self.timelines):
                if t <= playing.duration:
                    current, offset = i, t
                    break
                t -= playing.duration
        self.timelines.insert(index, timeline)
        self._total += timeline.duration
        if current is None:
            self.started = now
        else:
            current += index <= current
            # A µs inside the timeline: at a boundary, rounding in at()'s sums could hand the
            # instant to a neighbour (at() gives a boundary to the timeline before it).
            duration = self.timelines[current].duration
            if duration > 2e-6:
                offset = min(max(offset, 1e-6), duration - 1e-6)
            self.started = now - sum(t.duration for t in self.timelines[:current]) - offset

    def at(self, now: float, stepped: bool = False) -> tuple[Timeline, ViewState, str]:
        """The timeline playing at ``now``, its view and caption (``stepped``: Timeline.at's,
        for reduced motion)."""
        timeline, t = self.locate(now)
        view, caption = timeline.at(t, stepped)
        return timeline, view, caption

    def keyframe_at(self, now: float) -> Keyframe:
        """The keyframe in force at ``now`` (its caption is the one shown)."""
        timeline, t = self.locate(now)
        return timeline.keyframes[timeline.index_at(min(max(t, 0.0), timeline.duration))]

    def hold(self, seconds: float) -> None:
        """Everything from now on ``seconds`` later: the timeline on screen holds where it is
        (narration still speaking: exhibit.kiosk.narrator)."""
        self.started += seconds

    def locate(self, now: float) -> tuple[Timeline, float]:
        """The timeline playing at ``now`` and the time into it."""
        t = (now - self.started) % self._total if self._total > 0 else 0.0
        for timeline in self.timelines:
            if t <= timeline.duration:
                return timeline, t
            t -= timeline.duration
        last = self.timelines[-1]
        return last, last.duration
