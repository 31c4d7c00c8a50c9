"""What the kiosk shows at each instant: attract mode or a visitor in control. Pure logic, driven
by events and a clock, so it is tested without a window or devices.

* Attract: the playlist of timelines plays and loops.
* Real input (the mapping's activity detector ignores noise and drift) hands control to the
  visitor from the pose on screen, so nothing jumps.
* A "next-scene" button, or one bound to nothing, moves to the next scene of the content list
  (Mapper.switches_scene).
* After ``idle_timeout_s`` without real input, attract mode returns, gliding from the visitor's
  view into the timeline over ``blend_s`` when the scene is the same.

Either list may be empty when the kiosk skipped scenes that failed to load (never both): with no
timeline, attract mode slowly turns the first scene of the content list; with no content list,
buttons leave the visitor on the scene shown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from exhibit import scenes
from exhibit.devices.base import Event
from exhibit.devices.mapping import Mapper
from exhibit.geometry.view import ViewState
from exhibit.kiosk.attract import Playlist

ATTRACT, VISITOR = "attract", "visitor"
#: Seconds per turn of θ1 in attract mode when there is no timeline to play.
TURN_S = 120.0


@dataclass(frozen=True)
class Frame:
    """One frame's content: which mesh (scene and parameters), the view, and the words."""

    mode: str
    scene: str
    params: tuple[tuple[str, float], ...]
    view: ViewState
    title: str
    caption: str


def _blend(a: ViewState, b: ViewState, u: float) -> ViewState:
    """From a to b (u in [0, 1], eased); angles move the short way round."""
    u = u * u * (3 - 2 * u)

    def angle(x, y):
        return x + math.remainder(y - x, 2 * math.pi) * u

    def mix(x, y):
        return x + (y - x) * u

    return b.replace(angles=tuple(angle(x, y) for x, y in zip(a.angles, b.angles)),
                     sensor_r=mix(a.sensor_r, b.sensor_r),
                     eye_azimuth=angle(a.eye_azimuth, b.eye_azimuth),
                     eye_incidence=angle(a.eye_incidence, b.eye_incidence),
                     half_height=mix(a.half_height, b.half_height))


class KioskState:
    def __init__(self, playlist: Playlist, mapper: Mapper, content: tuple[str, ...],
                 idle_timeout_s: float, blend_s: float, now: float):
        self.playlist = playlist
        self.mapper = mapper
        self.content = content
        self.idle_timeout_s = idle_timeout_s
        self.blend_s = blend_s
        self.mode = ATTRACT
        self.playlist.restart(now)
        self._blend_from: tuple[ViewState, float, str] | None = None
        self.frame = self._attract_frame(now)

    # ------------------------------------------------------------------ frames

    def _attract_frame(self, now: float) -> Frame:
        if self.playlist.timelines:
            timeline, view, caption = self.playlist.at(now)
            name, params = timeline.scene, tuple(sorted(timeline.params.items()))
            scene = scenes.get(name)
        else:
            name = self.content[0]
            scene = scenes.get(name)
            params, caption = tuple(sorted(scene.resolve().items())), scene.caption
            turn = 2 * math.pi * ((now - self.playlist.started) / TURN_S % 1.0)
            view = scene.view.replace(angles=(scene.view.angles[0] + turn,
                                              *scene.view.angles[1:]))
        if self._blend_from is not None:
            start_view, start, blend_scene = self._blend_from
            u = (now - start) / self.blend_s if self.blend_s > 0 else 1.0
            if u >= 1.0 or blend_scene != name:
                self._blend_from = None
            else:
                view = _blend(start_view, view, max(u, 0.0))
        return Frame(ATTRACT, name, params, view, scene.title, caption)

    def _visitor_frame(self, scene_name: str, params, view: ViewState) -> Frame:
        scene = scenes.get(scene_name)
        return Frame(VISITOR, scene_name, params, view, scene.title, scene.caption)

    def _scene_switches(self, events: list[Event]) -> int:
        return sum(1 for e in events if self.mapper.switches_scene(e))

    def _next_scene(self) -> Frame:
        if not self.content:
            return self.frame
        current = self.frame.scene
        index = self.content.index(current) + 1 if current in self.content else 0
        name = self.content[index % len(self.content)]
        scene = scenes.get(name)
        params = tuple(sorted(scene.resolve().items()))
        return self._visitor_frame(name, params, scene.view)

    # ------------------------------------------------------------------ the step

    def update(self, events: list[Event], now: float) -> Frame:
        activity = self.mapper.activity
        before = activity.last_active
        view = self.mapper.apply(self.frame.view, events, now)
        active_now = activity.last_active is not None and activity.last_active != before
        switches = self._scene_switches(events)

        if self.mode == ATTRACT:
            if active_now or switches:
                self.mode = VISITOR  # take over from the pose on screen: no jump
                self.frame = self._visitor_frame(self.frame.scene, self.frame.params, view)
            else:
                self.frame = self._attract_frame(now)
                return self.frame
        else:
            self.frame = self._visitor_frame(self.frame.scene, self.frame.params, view)
        for _ in range(switches):
            self.frame = self._next_scene()
        if activity.idle_for(now) > self.idle_timeout_s and not switches:
            self.mode = ATTRACT
            self._blend_from = (self.frame.view, now, self.frame.scene)
            self.playlist.restart(now)
            self.frame = self._attract_frame(now)
        return self.frame
