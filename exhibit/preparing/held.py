"""The picture held on screen while a visitor waits for a scene still being prepared
(exhibit.kiosk.app.Kiosk._hold), and what the health file says of it.

Issue 31 kept the picture on screen instead of a dark notice; issue 41 made it honest. A heavy
scene takes a minute or more to polygonize, and controls that do nothing for that long look
broken, so the held picture answers them: the visitor goes on turning the scene they were in.
The input already turns the state's view (of the scene asked for, not drawn yet); the held
picture takes the same change of angles and sensor, within the mapping's limits, and "home"
takes it to its own scene's start. Its caption gives way to the preparing notice (the old one
told of a moment that is over: "moves closer ..." with nothing moving), and the tags that
caption named go with it. The health file names the scene shown and the one being prepared,
not the one asked for as if it were on screen."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Protocol

from exhibit.devices.mapping import PARAMS, MappingConfig
from exhibit.geometry.view import ViewState
from exhibit.preparing.preparing import Preparer
from exhibit.render.frame_request import FrameRequest
from exhibit.timelines.model import Params


class Posed(Protocol):
    """A frame of the kiosk's state (exhibit.kiosk.state.Frame), as far as it matters here."""

    @property
    def scene(self) -> str: ...
    @property
    def params(self) -> Params: ...
    @property
    def view(self) -> ViewState: ...


class Stated(Protocol):
    """The kiosk's state (exhibit.kiosk.state.KioskState), as far as it matters here."""

    @property
    def frame(self) -> Posed: ...


@dataclass
class Held:
    """The picture on screen while a visitor waits: the last one drawn (``request``) of the
    scene and params ``key``, its pose turned by the visitor since."""

    key: tuple[str, Params]
    request: FrameRequest
    #: Whether the last frame's input turned it (the kiosk's loop then runs at its full rate).
    moved: bool = False

    @property
    def scene(self) -> str:
        return self.key[0]

    @property
    def view(self) -> ViewState:
        return self.request.view

    def follow(
        self, before: Posed, after: Posed, mapping: MappingConfig, home: ViewState | None
    ) -> None:
        """One frame's input took the state from ``before`` to ``after``: "home" pressed
        (``home``: this scene's start view) or the same turn of the held pose. A change of
        scene in the state (another one asked for) is no turn."""
        pose = self.view
        if home is not None:
            self.turn(home)
        elif (after.scene, after.params) == (before.scene, before.params):
            self.steer(before.view, after.view, mapping)
        self.moved = self.view != pose

    def steer(self, before: ViewState, after: ViewState, mapping: MappingConfig) -> None:
        """The held pose turned as the state's went from ``before`` to ``after`` (angles the
        short way round, the sensor kept in its range)."""
        angles = list(self.view.angles)
        for i, (a, b) in enumerate(zip(before.angles, after.angles)):
            moved = math.remainder(b - a, 2 * math.pi)
            if moved:
                angles[i] = _angle(angles[i], moved, mapping, PARAMS[i])
        r = self.view.sensor_r
        if after.sensor_r != before.sensor_r:
            r = min(max(0.0, r + after.sensor_r - before.sensor_r), mapping.sensor_r_max)
        self.turn(self.view.replace(angles=tuple(angles), sensor_r=r))

    def turn(self, view: ViewState) -> None:
        """The held pose set to ``view``'s angles and sensor (its framing stays)."""
        pose = self.view.replace(angles=view.angles, sensor_r=view.sensor_r)
        self.request = dataclasses.replace(self.request, view=pose)

    def picture(self, notice: str, drift: tuple[float, float], fade: float) -> FrameRequest:
        """The held picture now: the notice in place of its caption, the tags gone."""
        shown = self.request
        options = dataclasses.replace(shown.options, hud=True, hud_drift=drift)
        hud = shown.hud and dataclasses.replace(shown.hud, caption=notice, note="", tags=())
        return FrameRequest(shown.gpu, shown.view, options, hud, fade=fade)


def _angle(old: float, moved: float, mapping: MappingConfig, param: str) -> float:
    """``old`` moved by ``moved`` radians: wrapped, or held within the parameter's limits (one
    already outside may only move back towards them), as the mapping does."""
    lim = mapping.limits.get(param)
    new = old + moved
    if lim is None or (lim.low is None and lim.high is None):
        new = math.remainder(new, 2 * math.pi)
        return math.pi if new == -math.pi else new
    if lim.high is not None and new > math.radians(lim.high):
        new = max(min(old, new), math.radians(lim.high))
    if lim.low is not None and new < math.radians(lim.low):
        new = min(max(old, new), math.radians(lim.low))
    return new


@dataclass(frozen=True)
class OnScreen:
    """For the health file: the scene shown (None: none, a notice screen), the scene being
    prepared (None: none), and how long a visitor has waited for it (None: nobody waits)."""

    scene: str | None
    preparing: str | None = None
    waiting_s: float | None = None


def on_screen(
    state: Stated | None,
    waiting: tuple[str, float] | None,
    held: Held | None,
    preparer: Preparer | None,
    now: float,
) -> OnScreen | None:
    """What is shown and prepared: while a visitor waits (``waiting``: the scene and since
    when), the held picture's scene and theirs; else the state's scene and the preparer's next.
    None without a state (no scene could be prepared: the notice screen)."""
    if state is None:
        return None
    if waiting is not None:
        return OnScreen(held.scene if held is not None else None, waiting[0], now - waiting[1])
    pending = preparer.pending() if preparer is not None else []
    return OnScreen(state.frame.scene, pending[0].scene if pending else None)
