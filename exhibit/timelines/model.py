"""The attract timeline as the kiosk plays it: keyframes, what each caption says of the view
(``while``: Condition, PictureClaims) and the view at any moment (Timeline.at), read from a
timeline file by exhibit.timelines.file. Pure: no file, no scene registry, no GL."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

from exhibit.geometry.view import ViewState

Ease = Literal["smooth", "linear", "hold"]
EASES: tuple[Ease, ...] = get_args(Ease)
Motion = Literal["closer", "farther", "still"]
MOTIONS: tuple[Motion, ...] = get_args(Motion)
#: Reduced motion: a stretch between keyframes plays as held poses about this long, each
#: crossfaded into the next (a 1 s crossfade, then 3 s still).
STEP_S = 4.0
#: Objects one picture claim may name.


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
    #: `exhibit render --timeline --verify` (exhibit.review.claims), never by colour.
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
