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

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from exhibit.geometry.occlusion import hidden
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
#: A kept anchor is tested for being in front again every this many frames.
CHECK_FRAMES = 8


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
        self._last_ct: ClipTransform | None = None

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
    ) -> Anchor | None:
        """((x, y) pixels, rgb, hidden) for the object ``name`` in this frame, None when no
        part of it is on the screen off the ``panels`` (a leader from under a panel would cross
        its words)."""
        entry = gpu.tag_anchors.get(name)
        if entry is None:
            surfaces, curves, markers = _parts(gpu.mesh, name)
            arrays = [s.positions for s in surfaces] + [c.points for c in curves]
            arrays += [m.position[None] for m in markers]
            arrays = [a for a in arrays if len(a)]
            if not arrays:
                return None
            first = (surfaces or curves or markers)[0]
            entry = gpu.tag_anchors[name] = {
                "points": _sample(np.concatenate(arrays), SAMPLE),
                "rgb": tuple(float(c) for c in first.material.color),
                "kept": None,  # (4D point, the frame it was chosen or checked)
            }
        points, rgb = entry["points"], entry["rgb"]
        width, height = size
        kept = entry["kept"]
        if kept is not None:
            point, since = kept
            (x, y), ok = (v[0] for v in ct.to_pixels(point[None], width, height))
            on_screen = ok and 0 <= x < width and 0 <= y < height
            on_screen = on_screen and not any(_inside(x, y, p) for p in panels)
            if on_screen and (self._frame - since) % CHECK_FRAMES:
                return (float(x), float(y)), rgb, False
            if on_screen and not hidden(point[None], gpu.mesh.surfaces, ct)[0]:
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
        centre = pixels[on].mean(axis=0)
        order = on[np.argsort(-np.linalg.norm(pixels[on] - centre, axis=1))]
        candidates = order[:: max(1, len(order) // (4 * CANDIDATES))][:CANDIDATES]
        covered = hidden(points[candidates], gpu.mesh.surfaces, ct)
        front = np.flatnonzero(~covered)
        pick = candidates[front[0]] if len(front) else candidates[0]
        entry["kept"] = (points[pick], self._frame)
        x, y = pixels[pick]
        return (float(x), float(y)), rgb, not len(front)
