"""The framing follows a visitor's picture: while a visitor turns the knobs, the zoom
(``half_height``) and the lens shift (``ViewState.center``) glide so that the surface stays in the
area the panels leave free, with a fair share of it. Never the angles, the sensor or the eye:
what the picture shows is the visitor's, only where and how big it is on the screen follows.

* **When.** The framing holds while the picture sits comfortably in a free rectangle: inside it
  (up to SLACK of the screen height over its edges) and at least FAIR_SHARE of its width or
  height. When the picture drifts out, or shrinks below that share, the framing glides to the
  fit of the picture at the pose (exhibit.geometry.framing, the same fit the takeover and the
  start views use, so the panels stay clear) and keeps following the pose until it has caught
  up; then it holds again, so small turns do not make the picture breathe.
* **How.** A critically damped glide (time constant TAU_S, no overshoot for a target that stands
  still), in log zoom (growing and shrinking look alike) and lens shift, rate-limited to
  ZOOM_RATE and SHIFT_RATE: the view never jumps and never oscillates.
* **Cheaply.** The target is measured every SAMPLE_S of kiosk time, from a thinned sample of the
  mesh (POINTS vertices), the free area cached per scene; frames in between only step the glide.
* **The visitor's approach is kept.** The zoom fits the picture as it would be with the sensor
  no nearer than the visitor has had it in this visit (the farthest sensor so far): driving the
  sensor in makes the picture grow, as it should, and the zoom does not undo it; backing out
  shrinks it and the zoom follows. Where the picture then overflows the area, the lens shift
  still centres it there, unless it fills the world on purpose (it would need FILL_LIMIT times
  the zoom to fit, as for timelines and the takeover): then the framing holds.
* **Reduced motion** (``[accessibility] reduced_motion``): the framing never glides by itself.
  When the picture has left its comfortable place and the visitor has stopped turning for
  PAUSE_S, the framing jumps to its target in one step, a cut the kiosk crossfades (as the
  takeover's reframing does), at most once every STEP_GAP_S.

:class:`Aims` measures (the kiosk's framer and meshes); :class:`Follow` glides (pure, on the
clock KioskState is given), so the tests drive it with a fake clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol
from collections.abc import Callable, Iterable

from exhibit import scenes
from exhibit.geometry.framing import (
    MAX_ZOOM,
    Bounds,
    centered_in,
    fitting_half_height,
    mesh_sample,
    sample_bounds,
    to_pixels,
)
from exhibit.geometry.view import ViewState
from exhibit.timelines.model import Params
from exhibit.framing.timeline_framing import FILL_LIMIT
from exhibit.render.framer import Framer
from exhibit.surfaces.mesh import Mesh4D

#: Seconds of kiosk time between two measurements of where the framing should go.
SAMPLE_S = 0.15
#: The glide's time constant: it is 63 % of the way to a target that stands still after TAU_S
#: (critically damped: 95 % after about 2.2 TAU_S, never beyond it), and follows a target that
#: moves steadily about TAU_S behind.
TAU_S = 0.5
#: The glide's natural frequency for that time constant ((1 + x) e^-x = 1/e at x = 2.146).
OMEGA = 2.146 / TAU_S
#: The zoom changes by at most this much per second, in log units (twice as large in a second).
ZOOM_RATE = 0.7
#: The lens shift moves by at most this many half-heights per second (1.25 screen heights).
SHIFT_RATE = 2.5
#: The picture counts as small below this share of its free rectangle's width and height.
FAIR_SHARE = 0.55
#: How far (a fraction of the screen height) the picture may stray over its area's edges before
#: the framing follows.
SLACK = 0.015
#: The glide has caught up when within this much (log zoom; half-heights of shift).
SETTLED = 0.02
#: Mesh points measured (surface vertices and markers; as many again of curves at most).
POINTS = 2000
#: Another free rectangle is taken only when it shows the picture this much larger.
AREA_HYSTERESIS = 1.1
#: Reduced motion: a step waits for the pose to rest this long, and steps are this far apart.
PAUSE_S = 1.0
STEP_GAP_S = 2.0


@dataclass(frozen=True)
class Aim:
    """Where the framing should go at a pose: the zoom and lens shift, and whether the picture
    already sits comfortably where the framing is now (then there is no need to move)."""

    half_height: float
    center: tuple[float, float]
    comfortable: bool


class MeshLookup(Protocol):
    """Where the framing finds a scene's mesh (exhibit.preparing.scene_meshes.SceneMeshes)."""

    def mesh(self, name: str, params: Iterable) -> Mesh4D | None: ...


class Aimer(Protocol):
    def __call__(
        self, scene: str, params: Params, view: ViewState, reference_r: float
    ) -> Aim | None: ...


class Aims:
    """``aims(scene, params, view, reference_r)`` -> the :class:`Aim` at ``view`` for the
    ``framer``'s screen (exhibit.render.framer.Framer) and the scene's mesh from ``content``
    (``content.mesh(name, params)``); None where the framing is to hold: a scene that opts out
    of framing (``fit = False``), a mesh not prepared, nothing seen."""

    def __init__(self, framer: Framer, content: MeshLookup, points: int = POINTS) -> None:
        self.framer = framer
        self.content = content
        self.points = points
        self._samples: dict[tuple, tuple] = {}
        self._areas: dict[str, list] = {}
        self._area: dict[str, object] = {}  # the rectangle chosen last, per scene

    def _sample(self, name: str, params):
        key = (name, tuple(params))
        sample = self._samples.get(key)
        if sample is None:
            mesh = self.content.mesh(name, params)
            if mesh is None:
                return None
            core, curves = mesh_sample(mesh, self.points)
            if len(curves) > self.points:
                curves = curves[:: math.ceil(len(curves) / self.points)]
            sample = self._samples[key] = (core, curves)
        return sample

    def areas(self, name: str) -> list:
        """The free rectangles for the scene's own title and caption (the takeover's)."""
        areas = self._areas.get(name)
        if areas is None:
            scene = scenes.get(name)
            areas = self._areas[name] = list(self.framer.areas(scene.title, [(scene.caption, "")]))
        return areas

    def _choose(self, name: str, bounds: Bounds, areas: list):
        """The rectangle where ``bounds`` comes out largest, the last one kept unless another
        is AREA_HYSTERESIS better (two nearly equal ones must not take turns)."""
        size = self.framer.size
        halves: list[tuple[float, object]] = []
        for area in areas:
            half = fitting_half_height(bounds, size, area)
            if half is not None:
                halves.append((half, area))
        if not halves:
            return None
        best = min(halves, key=lambda ha: ha[0])
        last = self._area.get(name)
        for half, area in halves:
            if area == last and half <= best[0] * AREA_HYSTERESIS:
                return area
        self._area[name] = best[1]
        return best[1]

    def comfortable(self, bounds: Bounds, view: ViewState, areas: list) -> bool:
        """The picture lies in one of ``areas`` (up to SLACK over its edges) with at least
        FAIR_SHARE of its width or height."""
        size = self.framer.size
        x0, y0, x1, y1 = to_pixels(bounds, view, size)
        slack = SLACK * size[1]
        for a in areas:
            inside = x0 >= a[0] - slack and y0 >= a[1] - slack
            inside = inside and x1 <= a[2] + slack and y1 <= a[3] + slack
            share = max((x1 - x0) / max(a[2] - a[0], 1e-9), (y1 - y0) / max(a[3] - a[1], 1e-9))
            if inside and share >= FAIR_SHARE:
                return True
        return False

    def __call__(
        self, scene: str, params: Params, view: ViewState, reference_r: float
    ) -> Aim | None:
        if not scenes.get(scene).fit:
            return None
        sample = self._sample(scene, params)
        if sample is None:
            return None
        areas = self.areas(scene)
        seen = sample_bounds(sample, view)
        if seen is None or not areas:
            return None
        # the zoom: the picture with the sensor no nearer than the visitor has had it
        reference = seen
        if view.sensor_r > reference_r:
            reference = sample_bounds(sample, view.replace(sensor_r=reference_r)) or seen
        area = self._choose(scene, reference, areas)
        if area is None:
            return None
        size, half = self.framer.size, view.half_height
        need = fitting_half_height(reference, size, area)
        assert need is not None  # _choose only gives a rectangle that is not empty
        comfortable = self.comfortable(seen, view, areas)
        if need > FILL_LIMIT * half:  # fills the world on purpose: keep it
            return Aim(half, view.center, comfortable)
        target = min(max(need, half / MAX_ZOOM), half * MAX_ZOOM)
        whole = fitting_half_height(seen, size, area)
        if whole is None or whole > FILL_LIMIT * target:  # the sensor driven in: shift held
            return Aim(target, view.center, comfortable)
        placed = centered_in(view, seen, size, area, target)
        return Aim(target, placed.center, comfortable)


def _pose(view: ViewState) -> tuple:
    """What the visitor sets: the angles, the sensor and the eye."""
    return (
        view.angles,
        view.sensor_r,
        view.eye_azimuth,
        view.eye_incidence,
        view.twist,
        view.eye_r,
    )


class Follow:
    """The framing of a visitor's view, following the picture (the module docstring).
    ``follow(scene, params, view, now)`` -> (``view`` with the zoom and lens shift of this
    instant, whether that was a jump: reduced motion's step). The glide starts from the first
    view it is handed, and again from any view whose zoom or shift it did not set itself (home,
    a new scene, the takeover's reframing); :meth:`stop` forgets it (attract mode)."""

    def __init__(self, aim: Aimer | Callable, reduced_motion: bool = False) -> None:
        self.aim = aim
        self.reduced_motion = reduced_motion
        self._framing: tuple[float, tuple[float, float]] | None = None

    def stop(self) -> None:
        self._framing = None

    def _start(self, view: ViewState, now: float) -> None:
        self._x = [math.log(view.half_height), view.center[0], view.center[1]]
        self._v = [0.0, 0.0, 0.0]
        self._target: list[float] | None = None
        self._next = now
        self._last = now
        self._reference = view.sensor_r
        self._pose = _pose(view)
        self._posed_at = now
        self._stepped_at = -math.inf

    def _view(self, view: ViewState) -> ViewState:
        half, center = math.exp(self._x[0]), (self._x[1], self._x[2])
        self._framing = (half, center)
        return view.replace(half_height=half, center=center)

    def __call__(
        self, scene: str, params: Params, view: ViewState, now: float
    ) -> tuple[ViewState, bool]:
        if view.half_height <= 0:
            return view, False
        if self._framing != (view.half_height, view.center):
            self._start(view, now)
        dt = max(now - self._last, 0.0)
        self._last = now
        self._reference = min(self._reference, view.sensor_r)
        pose = _pose(view)
        if pose != self._pose:
            self._pose, self._posed_at = pose, now
        if now >= self._next:
            self._next = now + SAMPLE_S
            aim = self.aim(scene, params, view, self._reference)
            # gliding, the target is followed until caught up; a step goes only where the
            # picture is not comfortable at that moment
            latched = self._target is not None and not self.reduced_motion
            if aim is None or aim.half_height <= 0 or not (latched or not aim.comfortable):
                self._target = None
            else:
                self._target = [math.log(aim.half_height), aim.center[0], aim.center[1]]
        jumped = False
        if self._target is not None:
            if self.reduced_motion:
                rested = now - self._posed_at >= PAUSE_S
                if rested and now - self._stepped_at >= STEP_GAP_S:
                    self._x, self._target = list(self._target), None
                    self._stepped_at, jumped = now, True
            else:
                self._glide(dt)
        return self._view(view), jumped

    def _glide(self, dt: float) -> None:
        """One step of the critically damped glide towards the target (exact for a target
        that holds over the step), rate-limited."""
        target = self._target
        assert target is not None
        w = OMEGA
        e = math.exp(-w * dt)
        x, v = [], []
        for xi, vi, ti in zip(self._x, self._v, target):
            a = xi - ti
            b = vi + w * a
            x.append(ti + (a + b * dt) * e)
            v.append((b - w * (a + b * dt)) * e)
        half = math.exp(self._x[0])
        # the limits: ZOOM_RATE in log zoom, SHIFT_RATE half-heights in the shift
        dz = x[0] - self._x[0]
        if abs(dz) > ZOOM_RATE * dt:
            x[0] = self._x[0] + math.copysign(ZOOM_RATE * dt, dz)
            v[0] = math.copysign(min(abs(v[0]), ZOOM_RATE), dz)
        dx, dy = x[1] - self._x[1], x[2] - self._x[2]
        moved, most = math.hypot(dx, dy), SHIFT_RATE * half * dt
        if moved > most:
            k = most / moved
            x[1], x[2] = self._x[1] + dx * k, self._x[2] + dy * k
            speed = math.hypot(v[1], v[2])
            if speed > SHIFT_RATE * half:
                v[1], v[2] = v[1] * SHIFT_RATE * half / speed, v[2] * SHIFT_RATE * half / speed
        self._x, self._v = x, v
        off = max(abs(x[0] - target[0]), math.hypot(x[1] - target[1], x[2] - target[2]) / half)
        pace = max(abs(v[0]), math.hypot(v[1], v[2]) / half) / OMEGA
        if off < SETTLED and pace < SETTLED:
            self._v, self._target = [0.0, 0.0, 0.0], None
