"""The attract timeline as the kiosk plays it: keyframes, what each caption says of the view and
the picture (``while``: a Condition, its claims one kind a module in exhibit.timelines.claims)
and the view at any moment (Timeline.at), read from a timeline file by exhibit.timelines.file.
Pure: no file, no scene registry, no GL."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

from exhibit.geometry.view import ViewState
from exhibit.timelines.claims.base import Claim

Ease = Literal["smooth", "linear", "hold"]
EASES: tuple[Ease, ...] = get_args(Ease)
#: Reduced motion: a stretch between keyframes plays as held poses about this long, each
#: crossfaded into the next (a 1 s crossfade, then 3 s still).
STEP_S = 4.0


@dataclass(frozen=True)
class Condition:
    """What a caption says in ``while``: one claim per kind it states (exhibit.timelines.claims),
    in the order of its KINDS. The view conditions (sensor distance, motion, pose) are held to
    the timeline file by `exhibit check-config`; every claim, those about the picture too, to
    the frames the kiosk draws by `exhibit render --timeline --verify`, never by colour."""

    claims: tuple[Claim, ...] = ()

    def claim(self, key: str) -> Claim | None:
        """The claim of the kind with that ``while`` key, if the caption makes one."""
        return next((c for c in self.claims if c.key == key), None)


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
    #: keeps the framing of the keyframe before (exhibit.framing.timeline_framing): the camera
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
