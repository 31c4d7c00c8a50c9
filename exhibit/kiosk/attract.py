"""Attract mode as content: timelines of keyframes that curators write in configs/attract/*.toml.

    name = "The sensor approaches"            # shown to staff, not visitors
    scene = "hopf"                            # a registered scene
    preset = "figure-6"                       # optional: start from a preset's view and params
    params = { rs = 0.7 }                     # optional scene parameters

    [[keyframe]]
    t = 0                                     # seconds from the start of this timeline
    angles = [0, 0, 0, 0, 0, 0]               # degrees; omitted values carry over
    sensor_distance = "inf"                   # or a number; interpolated in r = 1/d
    eye = [20, -60]                           # azimuth, incidence (degrees)
    half_height = 1.6                         # zoom (interpolated geometrically)
    caption = "..."                           # shown from this keyframe on
    ease = "smooth"                           # into the next keyframe: smooth | linear | hold

A timeline lasts until its last keyframe; the playlist plays the files in name order and loops.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from exhibit import scenes
from exhibit.errors import ExhibitError
from exhibit.geometry.view import ViewState

EASES = ("smooth", "linear", "hold")
TOP_KEYS = {"name", "scene", "preset", "params", "keyframe"}
KEYFRAME_KEYS = {"t", "angles", "sensor_distance", "eye", "half_height", "caption", "ease"}


@dataclass(frozen=True)
class Keyframe:
    t: float
    angles: tuple[float, ...]  # radians
    sensor_r: float
    eye: tuple[float, float]  # radians
    half_height: float
    caption: str
    ease: str


@dataclass(frozen=True)
class Timeline:
    name: str
    path: str
    scene: str
    params: dict
    base_view: ViewState
    keyframes: tuple[Keyframe, ...]

    @property
    def duration(self) -> float:
        return self.keyframes[-1].t

    def at(self, t: float) -> tuple[ViewState, str]:
        """The view and caption ``t`` seconds into the timeline (clamped to its ends)."""
        frames = self.keyframes
        t = min(max(t, 0.0), self.duration)
        index = max(i for i, k in enumerate(frames) if k.t <= t)
        a = frames[index]
        if index == len(frames) - 1 or a.ease == "hold":
            return self._view(a, a, 0.0), a.caption
        b = frames[index + 1]
        u = (t - a.t) / (b.t - a.t)
        if a.ease == "smooth":
            u = u * u * (3 - 2 * u)
        return self._view(a, b, u), a.caption

    def _view(self, a: Keyframe, b: Keyframe, u: float) -> ViewState:
        def mix(x, y):
            return x + (y - x) * u
        angles = tuple(mix(x, y) for x, y in zip(a.angles, b.angles))
        half = math.exp(mix(math.log(a.half_height), math.log(b.half_height)))
        return self.base_view.replace(angles=angles, sensor_r=mix(a.sensor_r, b.sensor_r),
                                      eye_azimuth=mix(a.eye[0], b.eye[0]),
                                      eye_incidence=mix(a.eye[1], b.eye[1]), half_height=half)


def _fail(path, key, reason):
    raise ExhibitError(f"{path}: {key}: {reason}")


def _numbers(path, key, value, count):
    if (not isinstance(value, list) or len(value) != count
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                       and math.isfinite(v) for v in value)):
        _fail(path, key, f"must be a list of {count} finite numbers, got {value!r}")
    return [float(v) for v in value]


def load_timeline(path: Path) -> Timeline:
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ExhibitError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ExhibitError(f"{path}: not valid TOML: {exc}") from None
    for key in data:
        if key not in TOP_KEYS:
            _fail(path, key, f"unknown key (allowed: {', '.join(sorted(TOP_KEYS))})")
    name = data.get("name", path.stem)
    if not isinstance(name, str):
        _fail(path, "name", "must be a string")
    scene_name = data.get("scene")
    if not isinstance(scene_name, str):
        _fail(path, "scene", "missing (a scene name, see `exhibit scenes`)")
    if scene_name not in scenes.names():
        _fail(path, "scene", f"no scene named {scene_name!r} (scenes: {', '.join(scenes.names())})")
    scene = scenes.get(scene_name)
    base_view, params = scene.view, {}
    if "preset" in data:
        try:
            preset = scene.preset(str(data["preset"]))
        except ExhibitError as exc:
            _fail(path, "preset", str(exc))
        base_view, params = preset.view, dict(preset.params)
    raw_params = data.get("params", {})
    if not isinstance(raw_params, dict):
        _fail(path, "params", "must be a table of scene parameters")
    params.update(raw_params)
    try:
        params = scene.resolve(params)
    except ExhibitError as exc:
        _fail(path, "params", str(exc))

    raw_frames = data.get("keyframe")
    if not isinstance(raw_frames, list) or len(raw_frames) < 2:
        _fail(path, "keyframe", "needs at least two [[keyframe]] tables")
    frames: list[Keyframe] = []
    previous = Keyframe(0.0, base_view.angles, base_view.sensor_r,
                        (base_view.eye_azimuth, base_view.eye_incidence), base_view.half_height,
                        "", "smooth")
    for i, raw in enumerate(raw_frames):
        where = f"keyframe[{i}]."
        if not isinstance(raw, dict):
            _fail(path, f"keyframe[{i}]", "must be a table")
        for key in raw:
            if key not in KEYFRAME_KEYS:
                _fail(path, where + key, f"unknown key (allowed: {', '.join(sorted(KEYFRAME_KEYS))})")
        t = raw.get("t")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) or t < 0:
            _fail(path, where + "t", f"must be a time in seconds >= 0, got {t!r}")
        if i == 0 and t != 0:
            _fail(path, where + "t", "the first keyframe must be at t = 0")
        if i > 0 and t <= frames[-1].t:
            _fail(path, where + "t", f"{t} must be later than the keyframe before ({frames[-1].t})")
        angles = previous.angles
        if "angles" in raw:
            angles = tuple(math.radians(a) for a in _numbers(path, where + "angles",
                                                             raw["angles"], 6))
        sensor_r = previous.sensor_r
        if "sensor_distance" in raw:
            d = raw["sensor_distance"]
            if d == "inf":
                sensor_r = 0.0
            elif isinstance(d, (int, float)) and not isinstance(d, bool) and math.isfinite(d) \
                    and d > 0:
                sensor_r = 1.0 / d
            else:
                _fail(path, where + "sensor_distance",
                      f"must be \"inf\" or a positive number, got {d!r}")
        eye = previous.eye
        if "eye" in raw:
            eye = tuple(math.radians(a) for a in _numbers(path, where + "eye", raw["eye"], 2))
        half = previous.half_height
        if "half_height" in raw:
            half = _numbers(path, where + "half_height", [raw["half_height"]], 1)[0]
            if half <= 0:
                _fail(path, where + "half_height", "must be positive")
        caption = raw.get("caption", previous.caption)
        if not isinstance(caption, str):
            _fail(path, where + "caption", "must be a string")
        ease = raw.get("ease", "smooth")
        if ease not in EASES:
            _fail(path, where + "ease", f"must be one of {', '.join(EASES)}, got {ease!r}")
        previous = Keyframe(float(t), angles, sensor_r, eye, half, caption, ease)
        frames.append(previous)
    return Timeline(str(name), str(path), scene_name, params, base_view, tuple(frames))


def load_playlist(folder: Path) -> list[Timeline]:
    """Every *.toml in ``folder``, in name order; errors name the file and key."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ExhibitError(f"{folder}: the attract folder does not exist")
    paths = sorted(folder.glob("*.toml"))
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

    def at(self, now: float) -> tuple[Timeline, ViewState, str]:
        t = (now - self.started) % self._total if self._total > 0 else 0.0
        for timeline in self.timelines:
            if t <= timeline.duration:
                view, caption = timeline.at(t)
                return timeline, view, caption
            t -= timeline.duration
        last = self.timelines[-1]
        view, caption = last.at(last.duration)
        return last, view, caption
