"""Where a tag's leader line meets the object it names: a point of the object that is on the
screen and in front, chosen on the CPU and kept while it stays so.

A caption that names "the green doughnut" is matched to the picture by a tag with those words
(exhibit.render.hud), never by colour alone. The leader must end on the object where a visitor
sees it: of a few candidate points (the object's points farthest from the middle of the picture
first, so the tag can sit outside it), the first that no surface hides (exhibit.geometry.
occlusion, a few ms for a handful of points). The choice is kept while the point stays on the
screen and in front, and checked again every CHECK_FRAMES frames, so the tag does not wander
while the view turns and the occlusion test costs little per frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from exhibit.geometry.occlusion import hidden
from exhibit.geometry.rims import on_rim
from exhibit.render.gpu import GpuMesh, surface_sample
from exhibit.render.layout import Rect
from exhibit.timelines.object_names import stands_for

if TYPE_CHECKING:
    from exhibit.geometry.pipeline import ClipTransform

#: Where a tag's leader ends: ((x, y) pixels, the object's rgb, whether a surface hides it).
Anchor = tuple[tuple[float, float], tuple[float, float, float], bool]

#: Points of an object considered for its anchor, and how many of them (the outermost first)
#: the occlusion test looks at.
SAMPLE = 300
CANDIDATES = 6
#: ... and how many more when none of those is in front.
MORE_CANDIDATES = 24
#: A candidate's neighbours on the screen (pixels at 720 lines) must be in front too.
NEIGHBOURS_PX = 12.0
#: Two tags for different objects end at least this far apart, in pixels of a 720-line screen
#: (two leaders ending where two rings meet tell a visitor nothing; `--verify` checks it).
TAGS_APART = 24.0
#: The outermost share of an object's points left out of the candidates: its rim.
RIM = 0.15
#: A kept anchor is tested for being in front again every this many frames, or as soon as the
#: view has moved it this many pixels (at 720 lines) since it was last tested.
MOVED_PX = 8.0
CHECK_FRAMES = 8
#: ... which is about this long at the kiosk's frame rate (a review drawing fewer frames a
#: second checks as often in time: TagAnchors.pace).
CHECK_S = 0.25


def _parts(mesh, name: str):
    """The surfaces, curves and markers a tag's ``name`` stands for: that object and its
    pieces ("NAME 2", ...: exhibit.timelines.object_names, aliases resolved when the timeline
    or scene was loaded)."""
    surfaces = [s for s in mesh.surfaces if stands_for(name, s.name)]
    curves = [c for c in mesh.curves if stands_for(name, c.name)]
    markers = [m for m in mesh.markers if stands_for(name, m.name)]
    return surfaces, curves, markers


def _sample(points: np.ndarray, count: int) -> np.ndarray:
    return points[:: max(1, len(points) // count)] if len(points) else points


def _inside(x: float, y: float, rect: Rect) -> bool:
    return rect.x0 <= x <= rect.x1 and rect.y0 <= y <= rect.y1


def picture_box(gpu: GpuMesh, ct: ClipTransform, size: tuple[int, int]) -> Rect | None:
    """The surfaces' box on screen, from the mesh's kept sample of their vertices (exhibit.
    render.gpu.surface_sample); None when none of it shows."""
    if not any(len(s.positions) for s in gpu.mesh.surfaces):
        return None
    pixels, ok = ct.to_pixels(surface_sample(gpu), *size)
    if not ok.any():
        return None
    p = pixels[ok]
    return Rect(*p.min(axis=0), *p.max(axis=0))


class TagAnchors:
    """The frame count that paces the anchors' checks; each mesh keeps its tags' candidate
    points and kept anchors itself (GpuMesh.tag_anchors), so they go with it."""

    def __init__(self) -> None:
        self._frame = 0
        self.check_frames = CHECK_FRAMES
        self._last_ct: ClipTransform | None = None

    def line_points(
        self, gpu: GpuMesh, name: str, ct: ClipTransform, size: tuple[int, int]
    ) -> np.ndarray:
        """(n, 2) pixels of the sampled points of the curves ``name`` stands for (after its
        anchor was asked for): thin lines a tag's words would hide, so they keep off them."""
        entry = gpu.tag_anchors.get(name)
        if entry is None:
            return np.zeros((0, 2))
        lines = entry["points"][entry["part"] < 0]
        pixels, ok = ct.to_pixels(lines, *size)
        return pixels[ok]

    def pace(self, fps: float) -> None:
        """Frames drawn ``fps`` a second: check kept anchors every CHECK_S seconds (a review
        at 5 fps checks every frame, as the kiosk does within a quarter second)."""
        self.check_frames = max(1, min(CHECK_FRAMES, round(CHECK_S * fps)))

    def tick(self, ct: ClipTransform) -> None:
        """Once a frame. A view drawn again (a crossfade's capture, a check's redraw) is not
        counted: the same view gets the same tags."""
        if ct is not self._last_ct:
            self._frame += 1
            self._last_ct = ct

    def anchor(
        self,
        gpu: GpuMesh,
        name: str,
        ct: ClipTransform,
        size: tuple[int, int],
        panels: Sequence[Rect] = (),
        avoid: Sequence[tuple[float, float]] = (),
        apart: float = 0.0,
    ) -> Anchor | None:
        """((x, y) pixels, rgb, hidden) for the object ``name`` in this frame, None when no
        part of it is on the screen off the ``panels`` (a leader from under a panel would cross
        its words); where it can, at least ``apart`` pixels from the points ``avoid`` (other
        objects' tags)."""
        entry = gpu.tag_anchors.get(name)
        if entry is None:
            surfaces, curves, markers = _parts(gpu.mesh, name)
            sheets = [s for s in surfaces if len(s.positions)]
            lines = [c.points for c in curves if len(c.points)] + [
                m.position[None] for m in markers
            ]
            arrays = [s.positions for s in sheets] + lines
            if not arrays:
                return None
            first = (surfaces or curves or markers)[0]
            # which of ``sheets`` each point is a vertex of (-1: a curve's or marker's), which
            step = max(1, sum(len(a) for a in arrays) // SAMPLE)
            part = [np.full(len(s.positions), k) for k, s in enumerate(sheets)]
            part += [np.full(len(a), -1) for a in lines]
            index = [np.arange(len(a)) for a in arrays]
            entry = gpu.tag_anchors[name] = {
                "points": _sample(np.concatenate(arrays), SAMPLE),
                "part": np.concatenate(part)[::step],
                "index": np.concatenate(index)[::step],
                "surfaces": sheets,
                "rgb": tuple(float(c) for c in first.material.color),
                "kept": None,  # (4D point, the frame it was chosen or tested, its pixel then)
                # points of the mesh itself (no marker): the occlusion test can be tight
                "vertices": not markers,
                # what may hide it: the other objects' surfaces (where one part of a surface
                # lies behind another part of it, the pixel still shows the object)
                "others": [s for s in gpu.mesh.surfaces if s not in surfaces],
            }
        points, rgb, vertices = entry["points"], entry["rgb"], entry["vertices"]
        others = entry["others"]
        width, height = size
        kept = entry["kept"]
        if kept is not None:
            point, since, (cx, cy) = kept
            (x, y), ok = (v[0] for v in ct.to_pixels(point[None], width, height))
            on_screen = ok and 0 <= x < width and 0 <= y < height
            on_screen = on_screen and not any(_inside(x, y, p) for p in panels)
            on_screen = on_screen and all(math.hypot(x - u, y - v) >= apart for u, v in avoid)
            still = math.hypot(x - cx, y - cy) < MOVED_PX * height / 720.0
            if on_screen and still and (self._frame - since) % self.check_frames:
                return (float(x), float(y)), rgb, False
            if on_screen and not hidden(point[None], others, ct, vertices)[0]:
                entry["kept"] = (point, self._frame, (x, y))
                return (float(x), float(y)), rgb, False
        pixels, ok = ct.to_pixels(points, width, height)
        ok &= (pixels[:, 0] >= 0) & (pixels[:, 0] < width)
        ok &= (pixels[:, 1] >= 0) & (pixels[:, 1] < height)
        for p in panels:
            ok &= ~(
                (pixels[:, 0] >= p.x0)
                & (pixels[:, 0] <= p.x1)
                & (pixels[:, 1] >= p.y0)
                & (pixels[:, 1] <= p.y1)
            )
        if not ok.any():
            entry["kept"] = None
            return None
        on = np.flatnonzero(ok)
        for x, y in avoid:  # another object's tag ends there: two leaders a visitor can tell
            far = np.hypot(pixels[on, 0] - x, pixels[on, 1] - y) >= apart
            on = on[far] if far.any() else on
        centre = pixels[on].mean(axis=0)
        order = on[np.argsort(-np.linalg.norm(pixels[on] - centre, axis=1))]
        # Outer points first, so the tag can sit outside the object, but off its very rim,
        # where the outline is drawn over it and the eye grazes it.
        order = order[int(RIM * len(order)) :] if len(order) > 4 else order
        reach = NEIGHBOURS_PX * height / 720.0

        part, index, own = entry["part"], entry["index"], entry["surfaces"]

        def rim(k: int) -> bool:
            """A surface's vertex where it turns away from the eye (geometry.rims)."""
            if part[k] < 0:
                return False
            surface = own[part[k]]
            return bool(on_rim(surface.positions, surface.triangles, index[k : k + 1], ct)[0])

        def in_front(candidates: np.ndarray) -> np.ndarray:
            """Those candidates in front, off their object's rims, whose nearest sampled
            neighbours on the screen are in front too: inside what shows of the object, not
            on the edge of what hides it."""
            out = []
            for k in np.flatnonzero(~hidden(points[candidates], others, ct, vertices)):
                if rim(candidates[k]):
                    continue
                d = np.hypot(*(pixels[on] - pixels[candidates[k]]).T)
                near = on[(d > 0) & (d < reach)][:2]
                if not len(near) or not hidden(points[near], others, ct, vertices).any():
                    out.append(k)
            return np.array(out, dtype=int)

        candidates = order[:: max(1, len(order) // (4 * CANDIDATES))][:CANDIDATES]
        front = in_front(candidates)
        if not len(front):  # a thin curve mostly behind: look further before giving up
            more = order[:: max(1, len(order) // (4 * MORE_CANDIDATES))][:MORE_CANDIDATES]
            front = in_front(more)
            candidates = more
        if not len(front):  # no point in front: no tag (a leader must end on its object)
            entry["kept"] = None
            return None
        pick = candidates[front[0]]
        x, y = pixels[pick]
        entry["kept"] = (points[pick], self._frame, (x, y))
        return (float(x), float(y)), rgb, False
