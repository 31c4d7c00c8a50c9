"""What the kiosk shows at each instant: attract mode or a visitor in control. Pure logic, driven
by events and a clock, so it is tested without a window or devices.

* Attract: the playlist of timelines plays and loops.
* Real input (the mapping's activity detector ignores noise and drift) hands control to the
  visitor from the pose on screen, so nothing jumps.
* A "next-scene" button, or one bound to nothing, moves to the next scene of the content list
  (Mapper.switches_scene).
* While a visitor turns, the zoom and lens shift follow the picture so it stays in the free
  area with a fair share of it (exhibit.framing.follow), when the kiosk hands a ``follow``.
* After ``idle_timeout_s`` without real input, attract mode returns, gliding from the visitor's
  view into the timeline over ``blend_s`` when the scene is the same.
* Reduced motion (``[accessibility] reduced_motion``): the camera never glides by itself. Attract
  mode moves in slow, held steps (Timeline.at's ``stepped``) and every change of pose is a cut
  (crossfaded by the kiosk); so is the return from a visitor, and the takeover's reframing
  jumps to its end, and the framing follows a visitor's picture in rare steps (cuts) only.
  What a visitor turns still turns smoothly.

Either list may be empty when the kiosk skipped scenes that failed to load (never both): with no
timeline, attract mode slowly turns the first scene of the content list; with no content list,
buttons leave the visitor on the scene shown.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

from exhibit import scenes
from exhibit.devices.base import Event, Kind
from exhibit.devices.mapping import Mapper
from exhibit.geometry.view import ViewState
from exhibit.timelines.model import Params
from exhibit.timelines.playlist import Playlist
from exhibit.framing.follow import Aimer, Follow

ATTRACT, VISITOR = "attract", "visitor"
#: Seconds per turn of θ1 in attract mode when there is no timeline to play.
TURN_S = 120.0
#: Seconds the picture takes to glide into the space a visitor's caption leaves free.
REFRAME_S = 1.0
#: Reduced motion with no timeline: the turn of θ1 goes in this many held steps (cuts).
TURN_STEPS = 12


@dataclass(frozen=True)
class Frame:
    """One frame's content: which mesh (scene and parameters), the view, and the words."""

    mode: str
    scene: str
    params: tuple[tuple[str, float], ...]
    view: ViewState
    title: str
    caption: str
    #: The attract timeline shown ("" for a visitor).
    timeline: str = ""
    #: This frame does not continue the previous one: crossfade into it.
    cut: bool = False
    #: Objects the caption names, tagged on screen: (object name, English words).
    tags: tuple[tuple[str, str], ...] = ()


def _blend(a: ViewState, b: ViewState, u: float) -> ViewState:
    """From a to b (u in [0, 1], eased); angles move the short way round."""
    u = u * u * (3 - 2 * u)

    def angle(x, y):
        return x + math.remainder(y - x, 2 * math.pi) * u

    def mix(x, y):
        return x + (y - x) * u

    return b.replace(
        angles=tuple(angle(x, y) for x, y in zip(a.angles, b.angles)),
        sensor_r=mix(a.sensor_r, b.sensor_r),
        eye_azimuth=angle(a.eye_azimuth, b.eye_azimuth),
        eye_incidence=angle(a.eye_incidence, b.eye_incidence),
        half_height=mix(a.half_height, b.half_height),
        center=(mix(a.center[0], b.center[0]), mix(a.center[1], b.center[1])),
    )


def _camera(view: ViewState) -> ViewState:
    """``view`` without its slice: what the camera shows, whatever moment the slice is at."""
    return view.replace(slice_axis=None, slice_at=0.0)


def unframed(scene_name: str, params: Params, view: ViewState) -> ViewState:
    """The framer when there is none: the view as the scene gives it."""
    return view


class KioskState:
    def __init__(
        self,
        playlist: Playlist,
        mapper: Mapper,
        content: tuple[str, ...],
        idle_timeout_s: float,
        blend_s: float,
        now: float,
        framer: Callable[[str, Params, ViewState], ViewState] = unframed,
        reduced_motion: bool = False,
        follow: Aimer | None = None,
    ):
        """``framer(scene name, params, view) -> view`` frames a scene's start view for the
        screen (zoom and lens shift only). ``follow(scene name, params, view, reference
        sensor) -> Aim | None`` (exhibit.framing.follow.Aims) says where the framing of a
        visitor's pose should go; None: the framing stays as the takeover left it.
        ``reduced_motion``: no glides of the camera but a visitor's own (the module
        docstring)."""
        self.playlist = playlist
        self.framer = framer
        self.mapper = mapper
        self.content = content
        #: The content list as given, in its order (a scene dropped and prepared after all
        #: comes back in its place).
        self._all_content = tuple(content)
        self.idle_timeout_s = idle_timeout_s
        self.blend_s = blend_s
        self.reduced_motion = reduced_motion
        self.mode = ATTRACT
        self.playlist.restart(now)
        #: The last moment someone was there without turning anything (present()).
        self._present_at: float | None = None
        self._blend_from: tuple[ViewState, float, str] | None = None
        #: The zoom and lens shift gliding after a takeover: (from, to, start time).
        self._reframe: tuple | None = None
        #: Reduced motion: this step's takeover jumped to the reframing's end (a cut).
        self._jumped = False
        #: The zoom and lens shift following a visitor's picture (None: they stay).
        self._follow = Follow(follow, reduced_motion) if follow is not None else None
        self._position = 0.0
        self.frame = self._attract_frame(now)

    # ------------------------------------------------------------------ frames

    def _attract_frame(self, now: float) -> Frame:
        label = ""
        if self.playlist.timelines:
            timeline, view, caption = self.playlist.at(now, stepped=self.reduced_motion)
            name, params = timeline.scene, tuple(sorted(timeline.params.items()))
            scene = scenes.get(name)
            label = timeline.path or timeline.name
            tags = self.playlist.keyframe_at(now).labels
        else:
            name = self.content[0]
            scene = scenes.get(name)
            params, caption = tuple(sorted(scene.resolve().items())), scene.caption
            tags = scene.labels
            turn = (now - self.playlist.started) / TURN_S % 1.0
            if self.reduced_motion:
                turn = math.floor(turn * TURN_STEPS) / TURN_STEPS
            turn *= 2 * math.pi
            start = self.start_view(name, params)
            view = start.replace(angles=(start.angles[0] + turn, *start.angles[1:]))
        if self._blend_from is not None:
            start_view, blend_start, blend_scene = self._blend_from
            u = (now - blend_start) / self.blend_s if self.blend_s > 0 else 1.0
            if u >= 1.0 or blend_scene != name:
                self._blend_from = None
            else:
                view = _blend(start_view, view, max(u, 0.0))
        return Frame(ATTRACT, name, params, view, scene.title, caption, label, tags=tags)

    def _visitor_frame(self, scene_name: str, params, view: ViewState) -> Frame:
        scene = scenes.get(scene_name)
        return Frame(
            VISITOR, scene_name, params, view, scene.title, scene.caption, tags=scene.labels
        )

    def _reframe_from(self, view: ViewState, now: float) -> None:
        """A visitor took over: the scene's caption replaces the timeline's, and its panel is
        often larger (five lines for two), so the picture, framed for the short one, would lie
        under it. The pose stays; the zoom and lens shift glide over REFRAME_S into the area
        the scene's own panels leave free. Reduced motion: it starts at its end, a cut."""
        target = self.framer(self.frame.scene, self.frame.params, view)
        if (target.half_height, target.center) != (view.half_height, view.center):
            self._jumped = self.reduced_motion
            self._reframe = (
                (view.half_height, view.center),
                (target.half_height, target.center),
                now - REFRAME_S if self.reduced_motion else now,
            )

    def _reframing(self, view: ViewState, now: float) -> ViewState:
        """``view`` with the zoom and lens shift of the glide under way, if any."""
        if self._reframe is None:
            return view
        (h0, c0), (h1, c1), start = self._reframe
        u = (now - start) / REFRAME_S if REFRAME_S > 0 else 1.0
        if u >= 1.0:
            self._reframe = None
            return view.replace(half_height=h1, center=c1)
        u = max(u, 0.0)
        u = u * u * (3 - 2 * u)
        # the zoom eases in proportion (log space), so growing and shrinking look alike
        half = h0 * (h1 / h0) ** u if h0 > 0 and h1 > 0 else h0 + (h1 - h0) * u
        return view.replace(
            half_height=half, center=(c0[0] + (c1[0] - c0[0]) * u, c0[1] + (c1[1] - c0[1]) * u)
        )

    def reframe(self) -> None:
        """The scene on screen has just been prepared (a visitor chose it before its mesh
        was there): its view, unframed until now, framed for the screen at once."""
        self.frame = dataclasses.replace(
            self.frame, view=self.framer(self.frame.scene, self.frame.params, self.frame.view)
        )

    def drop(self, name: str, now: float) -> None:
        """Scene ``name`` cannot be shown (its preparation failed): out of the content list;
        a visitor on it goes to the next scene, or attract mode when none is left."""
        self.content = tuple(c for c in self.content if c != name)
        if self.frame.scene != name or self.mode == ATTRACT:
            return
        if self._follow is not None:
            self._follow.stop()
        if self.content:
            self.frame = self._next_scene()
        else:
            self.mode = ATTRACT
            self._reframe = None
            self.playlist.restart(now)
            self.frame = self._attract_frame(now)

    def restore(self, name: str) -> None:
        """Scene ``name``, dropped, can be shown after all: back in the content list."""
        if name in self._all_content and name not in self.content:
            keep = {*self.content, name}
            self.content = tuple(c for c in self._all_content if c in keep)

    def _scene_switches(self, events: list[Event]) -> int:
        return sum(1 for e in events if self.mapper.switches_scene(e))

    def home_pressed(self, events: list[Event]) -> bool:
        """A press of a button bound to "home" (the mapping's own home sets fixed angles; the
        kiosk returns to the scene's start view instead)."""
        return any(
            e.kind is Kind.BUTTON
            and e.value > 0
            and any(
                b.action == "home"
                and b.device == e.device
                and b.kind is e.kind
                and b.index == e.index
                for b in self.mapper.config.bindings
            )
            for e in events
        )

    def start_view(self, scene_name: str, params: Params) -> ViewState:
        """Where a scene starts, and where "home" returns: its own view, framed."""
        return self.framer(scene_name, params, scenes.get(scene_name).view)

    def _playlist_position(self, now: float) -> float:
        total = sum(t.duration for t in self.playlist.timelines)
        return (now - self.playlist.started) % total if total > 0 else 0.0

    def _next_scene(self) -> Frame:
        if not self.content:
            return self.frame
        current = self.frame.scene
        index = self.content.index(current) + 1 if current in self.content else 0
        name = self.content[index % len(self.content)]
        scene = scenes.get(name)
        params = tuple(sorted(scene.resolve().items()))
        return self._visitor_frame(name, params, self.start_view(name, params))

    # ------------------------------------------------------------------ the step

    def present(self, now: float) -> None:
        """Someone is there at ``now`` without turning anything: a listen press, or narration
        they asked for still speaking. The idle return counts from the later of this and the
        last real input, so a visitor who listens is not taken for an empty room."""
        if self._present_at is None or now > self._present_at:
            self._present_at = now

    def idle_for(self, now: float) -> float:
        """Seconds since the last real input or presence (inf if neither ever came)."""
        idle = self.mapper.activity.idle_for(now)
        if self._present_at is not None:
            idle = min(idle, max(0.0, now - self._present_at))
        return idle

    def update(self, events: list[Event], now: float) -> Frame:
        previous = self.frame
        frame = self._update(events, now)
        if frame.mode == ATTRACT and previous.mode == ATTRACT:
            # Another timeline, or the playlist starting again: not a continuation.
            position = self._playlist_position(now)
            cut = frame.timeline != previous.timeline or position < self._position
            self._position = position
        elif frame.mode == ATTRACT:  # back from a visitor: a glide when the scene is the same
            self._position = self._playlist_position(now)
            cut = frame.scene != previous.scene or frame.params != previous.params
        else:
            cut = (
                frame.scene != previous.scene
                or frame.params != previous.params
                or self.home_pressed(events)
                or self._jumped
            )
        if self.reduced_motion and frame.mode == ATTRACT:
            # The camera only ever jumps (to the next keyframe's pose, into the timeline from a
            # visitor's view, a step of the turn): each jump is crossfaded.
            cut = cut or _camera(frame.view) != _camera(previous.view)
        if cut != frame.cut:
            frame = self.frame = dataclasses.replace(frame, cut=cut)
        return frame

    def _update(self, events: list[Event], now: float) -> Frame:
        self._jumped = False
        activity = self.mapper.activity
        before = activity.last_active
        view = self.mapper.apply(self.frame.view, events, now)
        active_now = activity.last_active is not None and activity.last_active != before
        switches = self._scene_switches(events)
        if self.home_pressed(events):
            # The scene's own start view, not the mapping's fixed angles.
            view = self.start_view(self.frame.scene, self.frame.params)

        if self.home_pressed(events):
            self._reframe = None
            if self._follow is not None:
                self._follow.stop()
        if self.mode == ATTRACT:
            if active_now or switches:
                self.mode = VISITOR  # take over from the pose on screen: no jump
                self._reframe_from(view, now)
            else:
                self.frame = self._attract_frame(now)
                return self.frame
        view = self._reframing(view, now)
        if self._follow is not None and self._reframe is None:
            view, jumped = self._follow(self.frame.scene, self.frame.params, view, now)
            self._jumped = self._jumped or jumped
        self.frame = self._visitor_frame(self.frame.scene, self.frame.params, view)
        for _ in range(switches):
            self._reframe = None
            self.frame = self._next_scene()
        if switches and self._follow is not None:
            self._follow.stop()
        if self.idle_for(now) > self.idle_timeout_s and not switches:
            self.mode = ATTRACT
            self._reframe = None
            if self._follow is not None:
                self._follow.stop()
            if not self.reduced_motion:  # with reduced motion, a cut (update)
                self._blend_from = (self.frame.view, now, self.frame.scene)
            self.playlist.restart(now)
            self.frame = self._attract_frame(now)
        return self.frame
