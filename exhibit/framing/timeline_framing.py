"""Attract timelines framed for the screen (exhibit.render.framer's free area and
exhibit.geometry.framing's fit), done once at start-up for the whole playlist.

* One area of the free space for all of a timeline (the best for all its poses sampled every
  0.5 s and at every keyframe, clear of all its captions), so moving between keyframes never
  crosses a panel.
* Either one zoom and shift for all of it, or one per keyframe (each keyframe fitted to the
  poses half way to its neighbours, both ends of a stretch zoomed out a little where a sample
  between them spills out; FramedTimeline interpolates the lens shift as the rest of the view),
  whichever shows the picture larger.
* Zooms written in the timeline are replaced, except at a keyframe whose picture fills the world
  on purpose (it would need FILL_LIMIT times its zoom to fit the screen: the hypersphere's sensor
  at distance 2, Figure 8's moment), which keeps its own; the framing moves into and out of it.
  A timeline that says ``fit = false`` is left as written, and so is one whose scene or preset
  opts out.
* A fixed budget whatever the timeline's length (a day-long stretch, tens of thousands of
  keyframes): at most MAX_POSES poses are sampled (keyframes first, up to MAX_KEYFRAME_POSES,
  spread evenly; then an even grid), and a timeline of more than MAX_FOLLOWED_KEYFRAMES
  keyframes gets the one framing for all (left as written if a sampled pose fills the world).

Here in the kiosk's layer because the framing is the screen's (exhibit.render.framer); the
timeline (exhibit.timelines) and the framing's math lie below it.
"""

from __future__ import annotations

import bisect
import dataclasses
import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from exhibit.geometry.framing import (
    best_area,
    fit,
    mesh_sample,
    sample_bounds,
    to_pixels,
    zoom_about,
)
from exhibit.geometry.view import ViewState
from exhibit.timelines.model import Keyframe, Timeline
from exhibit.render.framer import Framer
from exhibit.render.layout import hud_layout
from exhibit.scenes.base import Scene
from exhibit.surfaces.mesh import Mesh4D

#: Seconds between the poses sampled along a timeline (keyframes are always sampled).
TIMELINE_STEP_S = 0.5
#: Points of a mesh used to frame a timeline (dozens of poses): its bounds to a pixel or so.
TIMELINE_POINTS = 4000
#: Where the picture between two keyframes spills out of its area, both are zoomed out by
#: GROWTH, up to MAX_GROWTH_STEPS times.
GROWTH = 1.06
MAX_GROWTH_STEPS = 12
#: A keyframe whose picture would need more than this much zooming out to fit on the screen
#: fills the world on purpose (the sensor inside the object: Figure 8's moment) and is kept.
FILL_LIMIT = 3.0
#: The budget: poses sampled along one timeline (the shipped ones, a minute or so with a dozen
#: keyframes, stay under it and are sampled as described above), of them keyframes at most
#: MAX_KEYFRAME_POSES; keyframes fitted one by one at most MAX_FOLLOWED_KEYFRAMES.
MAX_POSES = 400
MAX_KEYFRAME_POSES = 200
MAX_FOLLOWED_KEYFRAMES = 64


def frame_timeline(framer: Framer, timeline: Timeline, scene: Scene, mesh: Mesh4D) -> Timeline:
    """The timeline framed for ``framer``'s screen (see the module docstring), or the timeline
    itself when it says ``fit = false``, its scene or preset opts out, or every keyframe fills
    the world."""
    return _TimelineFramer(framer).timeline(timeline, scene, mesh)


class _TimelineFramer:
    """frame_timeline's steps, with the framer's screen at hand."""

    def __init__(self, framer: Framer):
        self.framer = framer
        self.size, self.sizes = framer.size, framer.sizes

    def timeline(self, timeline: Timeline, scene: Scene, mesh: Mesh4D) -> Timeline:
        base = timeline.base_view
        presets = [p for p in scene.presets if p.view == base]
        wanted = timeline.fit
        if wanted is False or not scene.fit or any(not p.fit for p in presets):
            return timeline
        points = mesh_sample(mesh, TIMELINE_POINTS)
        frames = timeline.keyframes
        times = sample_times(timeline)
        pose = _Poses(timeline)
        bounds = {t: sample_bounds(points, pose(t)) for t in times}
        if len(frames) > MAX_FOLLOWED_KEYFRAMES:
            return self._uniform(timeline, scene, bounds, pose)
        fills = tuple(self._fills(pose(k.t), bounds[k.t]) for k in frames)
        if all(fills):
            return timeline

        def framed_stretch(t: float) -> bool:
            """Whether ``t`` lies at or between keyframes that are both framed."""
            i = timeline.index_at(t)
            return not fills[i] and (i + 1 == len(frames) or not fills[i + 1] or t == frames[i].t)

        seen = [b for t, b in bounds.items() if b is not None and framed_stretch(t)]
        if not seen:
            return timeline
        captions = [(c,) for c in dict.fromkeys(k.caption for k in frames)]
        # One area for the whole timeline (the best for all of it), so moving from one
        # keyframe's framing to the next never crosses a panel.
        union = seen[0]
        for b in seen[1:]:
            union = union.union(b)
        area = best_area(union, self.size, self.framer.areas(scene.title, captions))
        if area is None:
            return timeline
        # Two candidates, the larger picture wins: one framing for all (nothing moves but the
        # object), or one per keyframe (the camera follows; larger where poses differ much, and
        # the only one for a timeline with moments that fill the world).
        following = self._per_keyframe(timeline, points, times, bounds, fills, framed_stretch, area)
        if any(fills):
            return following or timeline
        uniform = fit(base, union, self.size, [area])
        if following is not None and (
            np.mean([np.log(k.half_height) for k in following.keyframes])
            < np.log(uniform.half_height)
        ):
            return following
        return FramedTimeline.of(timeline, [uniform] * len(frames), fills)

    def _uniform(self, timeline, scene, bounds, pose):
        """One framing for all of a timeline with too many keyframes to fit one by one; the
        timeline as written when a sampled pose fills the world (or nothing is seen)."""
        if any(self._fills(pose(t), b) for t, b in bounds.items()):
            return timeline
        seen = list(bounds.values())
        union = seen[0]
        for b in seen[1:]:
            union = union.union(b)
        captions = [(c,) for c in dict.fromkeys(k.caption for k in timeline.keyframes)]
        area = best_area(union, self.size, self.framer.areas(scene.title, captions))
        if area is None:
            return timeline
        uniform = fit(timeline.base_view, union, self.size, [area])
        return FramedTimeline.of(timeline, [uniform] * len(timeline.keyframes))

    def _fills(self, view: ViewState, bounds) -> bool:
        """Whether a keyframe's picture fills the world on purpose (Figure 8's moment in a
        timeline): it would have to zoom out more than FILL_LIMIT times beyond its own zoom
        to fit on the screen at all."""
        if bounds is None:
            return True
        margin = hud_layout(self.size, "", ("",), self.sizes).margin
        screen = (margin, margin, self.size[0] - margin, self.size[1] - margin)
        return fit(view, bounds, self.size, [screen]).half_height > FILL_LIMIT * view.half_height

    def _per_keyframe(self, timeline, points, times, bounds, fills, framed_stretch, area):
        """Each framed keyframe fitted to the poses around it (half way to its framed
        neighbours), both ends of a stretch zoomed out where the picture between them spills
        out of ``area``; keyframes that fill the world keep their own view. None if it still
        spills."""
        frames = timeline.keyframes
        pose = _Poses(timeline)
        views: list = []
        boxes: list = []
        for i, k in enumerate(frames):
            own = pose(k.t)
            if fills[i]:
                views.append(own)
                boxes.append(None)
                continue
            lo = k.t - 0.5 * (k.t - frames[i - 1].t) if i and not fills[i - 1] else k.t
            hi = (
                k.t + 0.5 * (frames[i + 1].t - k.t)
                if i + 1 < len(frames) and not fills[i + 1]
                else k.t
            )
            near = [b for t, b in bounds.items() if lo <= t <= hi and b is not None]
            box = near[0]
            for b in near[1:]:
                box = box.union(b)
            views.append(fit(own, box, self.size, [area]))
            boxes.append(box)
        groups = held_groups(frames, fills)
        for group in groups:  # one framing for keyframes that hold it: fitted to them all
            union = boxes[group[0]]
            for i in group[1:]:
                union = union.union(boxes[i])
            held = fit(views[group[0]], union, self.size, [area])
            for i in group:
                views[i] = views[i].replace(half_height=held.half_height, center=held.center)
        group_of = {i: g for g in groups for i in g}
        checked = [t for t in times if framed_stretch(t)]
        for _ in range(MAX_GROWTH_STEPS):  # between keyframes: zoom out where it spills
            framed = FramedTimeline.of(timeline, views, fills)
            framed_pose = _Poses(framed)
            spills = set()
            for t in checked:
                if bounds[t] is None:
                    continue
                box = to_pixels(bounds[t], framed_pose(t), self.size)
                if not _inside(box, area):
                    i = framed.index_at(t)
                    spills |= {j for j in (i, i + 1) if j < len(frames) and not fills[j]}
            if not spills:
                return framed
            spills |= {j for i in spills for j in group_of.get(i, ())}
            views = [
                zoom_about(v, GROWTH, area, self.size) if i in spills else v
                for i, v in enumerate(views)
            ]
        return None


def held_groups(frames: Sequence[Keyframe], fills: Sequence[bool]) -> list[list[int]]:
    """Runs of keyframes that share one framing: a keyframe that says ``hold_framing`` joins
    the one before, unless either fills the world (those keep their own view)."""
    groups: list[list[int]] = []
    for i, k in enumerate(frames):
        if i and k.hold_framing and not fills[i] and not fills[i - 1]:
            if groups and groups[-1][-1] == i - 1:
                groups[-1].append(i)
            else:
                groups.append([i - 1, i])
    return groups


def sample_times(timeline: Timeline) -> list[float]:
    """The times framing samples: every TIMELINE_STEP_S, every keyframe and the end; for a
    timeline that would need more than MAX_POSES of them, keyframes (up to MAX_KEYFRAME_POSES,
    spread evenly, the first and last among them) and an even grid filling up MAX_POSES."""
    frames, duration = timeline.keyframes, timeline.duration
    if math.ceil(duration / TIMELINE_STEP_S) + len(frames) + 1 <= MAX_POSES:
        return sorted(
            {*np.arange(0.0, duration, TIMELINE_STEP_S).tolist(), *(k.t for k in frames), duration}
        )
    keys = [k.t for k in frames]
    if len(keys) > MAX_KEYFRAME_POSES:
        picks = np.linspace(0, len(keys) - 1, MAX_KEYFRAME_POSES).round().astype(int)
        keys = [keys[i] for i in np.unique(picks)]
    grid = np.linspace(0.0, duration, MAX_POSES - len(keys)).tolist()
    return sorted({*keys, *grid})


class _Poses:
    """``timeline.at(t)[0]`` in O(log n): played on the two keyframes around ``t`` only (the
    same view: Timeline.at interpolates between those two), so sampling a timeline of many
    keyframes does not cost a scan of them all per sample."""

    def __init__(self, timeline: Timeline):
        self.timeline = timeline
        self.times = [k.t for k in timeline.keyframes]

    def __call__(self, t: float) -> ViewState:
        timeline, frames = self.timeline, self.timeline.keyframes
        t = min(max(t, 0.0), timeline.duration)
        i = max(0, bisect.bisect_right(self.times, t) - 1)
        changes: dict[str, Any] = {"keyframes": frames[i : i + 2]}  # fields of two types
        if isinstance(timeline, FramedTimeline):
            changes.update(centers=timeline.centers[i : i + 2], fills=timeline.fills[i : i + 2])
        return dataclasses.replace(timeline, **changes).at(t)[0]


def _inside(box, area, tolerance: float = 1.0) -> bool:
    x0, y0, x1, y1 = box
    return (
        x0 >= area[0] - tolerance
        and y0 >= area[1] - tolerance
        and x1 <= area[2] + tolerance
        and y1 <= area[3] + tolerance
    )


@dataclasses.dataclass(frozen=True)
class FramedTimeline(Timeline):
    """A timeline whose keyframes carry their own framing: the zoom in each keyframe's
    half_height (interpolated as any zoom is) and the lens shift in ``centers`` (one per
    keyframe, interpolated with the same easing as the rest of the view)."""

    centers: tuple = ()
    #: Per keyframe: whether it fills the world on purpose (kept as written, not framed).
    fills: tuple = ()

    @classmethod
    def of(
        cls, timeline: Timeline, views: list[ViewState], fills: Sequence[bool] = ()
    ) -> FramedTimeline:
        fields = {f.name: getattr(timeline, f.name) for f in dataclasses.fields(Timeline)}
        fields["keyframes"] = tuple(
            dataclasses.replace(k, half_height=v.half_height)
            for k, v in zip(timeline.keyframes, views)
        )
        return cls(
            **fields,
            centers=tuple(v.center for v in views),
            fills=tuple(fills) or (False,) * len(views),
        )

    def _view(self, a, b, u: float) -> ViewState:
        view = super()._view(a, b, u)
        (ax, ay), (bx, by) = self.centers[self._index(a)], self.centers[self._index(b)]
        return view.replace(center=(ax + (bx - ax) * u, ay + (by - ay) * u))

    def _index(self, keyframe) -> int:
        return bisect.bisect_left(self._times, keyframe.t)

    @functools.cached_property
    def _times(self) -> list[float]:
        return [k.t for k in self.keyframes]
