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

import numpy as np

from exhibit.geometry.occlusion import hidden
from exhibit.render.layout import Rect

#: Points of an object considered for its anchor, and how many of them (the outermost first)
#: the occlusion test looks at.
SAMPLE = 300
CANDIDATES = 6
#: A kept anchor is tested for being in front again every this many frames.
CHECK_FRAMES = 8
#: Points of the surfaces whose screen box the tags keep off, where there is room.
PICTURE_SAMPLE = 600


def _parts(mesh, name: str):
    """The surfaces and curves a tag's ``name`` stands for (that name, or names it begins)."""
    surfaces = [s for s in mesh.surfaces if s.name == name or s.name.startswith(name)]
    curves = [c for c in mesh.curves if c.name == name or c.name.startswith(name)]
    markers = [m for m in mesh.markers if m.name == name or m.name.startswith(name)]
    return surfaces, curves, markers


def _sample(points: np.ndarray, count: int) -> np.ndarray:
    return points[:: max(1, len(points) // count)] if len(points) else points


def _inside(x: float, y: float, rect: Rect) -> bool:
    return rect.x0 <= x <= rect.x1 and rect.y0 <= y <= rect.y1


class TagAnchors:
    """Per mesh and tag, the 4D point its leader line ends on (see the module docstring)."""

    def __init__(self) -> None:
        self._kept: dict[tuple[int, str], tuple[np.ndarray, int]] = {}
        self._points: dict[tuple[int, str], tuple[np.ndarray, tuple[float, ...]]] = {}
        self._frame = 0
        self._last_ct = None

    def picture_box(self, gpu, ct, size) -> Rect | None:
        """The surfaces' box on screen (from a sample of their points), None when none shows;
        called once a frame. It counts the frames for CHECK_FRAMES, a view drawn again (a
        crossfade's capture, a check's redraw) not counted: the same view gets the same tags."""
        if ct is not self._last_ct:
            self._frame += 1
            self._last_ct = ct
        points = [s.positions for s in gpu.mesh.surfaces if len(s.positions)]
        if not points:
            return None
        sample = _sample(np.concatenate(points), PICTURE_SAMPLE)
        pixels, ok = ct.to_pixels(sample, *size)
        if not ok.any():
            return None
        p = pixels[ok]
        return Rect(*p.min(axis=0), *p.max(axis=0))

    def anchor(self, gpu, name: str, ct, size, panels=()):
        """((x, y) pixels, rgb, hidden) for the object ``name`` in this frame, None when no
        part of it is on the screen off the ``panels`` (a leader from under a panel would cross
        its words)."""
        key = (id(gpu.mesh), name)
        if key not in self._points:
            surfaces, curves, markers = _parts(gpu.mesh, name)
            arrays = [s.positions for s in surfaces] + [c.points for c in curves]
            arrays += [m.position[None] for m in markers]
            arrays = [a for a in arrays if len(a)]
            if not arrays:
                return None
            first = (surfaces or curves or markers)[0]
            self._points[key] = (
                _sample(np.concatenate(arrays), SAMPLE),
                tuple(float(c) for c in first.material.color),
            )
            if len(self._points) > 64:  # meshes come and go in reviews and tests
                self._points.pop(next(iter(self._points)))
        points, rgb = self._points[key]
        width, height = size
        kept = self._kept.get(key)
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
            self._kept.pop(key, None)
            return None
        on = np.flatnonzero(ok)
        centre = pixels[on].mean(axis=0)
        order = on[np.argsort(-np.linalg.norm(pixels[on] - centre, axis=1))]
        candidates = order[:: max(1, len(order) // (4 * CANDIDATES))][:CANDIDATES]
        covered = hidden(points[candidates], gpu.mesh.surfaces, ct)
        front = np.flatnonzero(~covered)
        pick = candidates[front[0]] if len(front) else candidates[0]
        self._kept[key] = (points[pick], self._frame)
        x, y = pixels[pick]
        return (float(x), float(y)), rgb, not len(front)
