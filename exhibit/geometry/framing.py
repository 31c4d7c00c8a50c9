"""Framing by the picture: zoom and shift a view so the scene's 3D image lands in a given part of
the screen (the area the text panels leave free), measured from the mesh at that very pose.

Hand-set zooms went wrong as soon as a text panel grew or a pose changed (Figures 9-10 ran off
the top, under the title). Here the view's own projection measures the image: every sample point
in front of both centres is mapped with ``half_height = 1`` and no lens shift, which gives its
position on the image plane through the origin. In those units the screen position is affine in
the two things framing may change, ``half_height`` (a zoom: ndc = X / half_height) and
``center`` (a lens shift: ndc = (X - center) / half_height), for an orthographic and a
perspective eye alike, so the fit is solved exactly, not searched. The pose, the sensor and
the eye are left alone: framing never changes what the picture shows, only where and how big.

Pure numpy, no GL: the kiosk, `exhibit render` and the tests share it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol
from collections.abc import Iterable, Sequence


import numpy as np

from exhibit.geometry.pipeline import clip_transform
from exhibit.geometry.view import ViewState

#: Framing may zoom in or out by at most this factor from the authored half_height: an image
#: that is unbounded (a sheet through the sensor) must not shrink the rest to a dot.
MAX_ZOOM = 6.0
#: Points sampled from a mesh for its bounds: enough to be within a pixel of the hull of a
#: smooth surface at kiosk resolutions.
SAMPLE = 20_000
#: Curves count for the bounds only this far (a fraction of the surfaces' extent) beyond the
#: surfaces: the hypersphere's w axis at sensor distance 3 reaches far out and would shrink
#: the tori to a third of the screen.
CURVE_REACH = 0.5


class _Positions(Protocol):
    @property
    def positions(self) -> np.ndarray: ...


class _Points(Protocol):
    @property
    def points(self) -> np.ndarray: ...


class _Position(Protocol):
    @property
    def position(self) -> np.ndarray: ...


class Drawn(Protocol):
    """What framing reads of a mesh: a surfaces.Mesh4D, which geometry, below surfaces, does
    not import."""

    @property
    def surfaces(self) -> Sequence[_Positions]: ...

    @property
    def curves(self) -> Sequence[_Points]: ...

    @property
    def markers(self) -> Sequence[_Position]: ...


#: A mesh_sample: (surface vertices and markers, curve points); or plain points (n, 4).
Sample = tuple[np.ndarray, np.ndarray] | np.ndarray


@dataclass(frozen=True)
class Bounds:
    """The 3D image's extent on the image plane through the origin (scene units, y up)."""

    x0: float
    y0: float
    x1: float
    y1: float

    def union(self, other: Bounds | None) -> Bounds:
        if other is None:
            return self
        return Bounds(
            min(self.x0, other.x0),
            min(self.y0, other.y0),
            max(self.x1, other.x1),
            max(self.y1, other.y1),
        )


def mesh_sample(mesh: Drawn, limit: int = SAMPLE) -> tuple[np.ndarray, np.ndarray]:
    """A Mesh4D as (surface vertices and markers, curve points) for :func:`sample_bounds`."""
    parts = [s.positions for s in mesh.surfaces if len(s.positions)]
    core = np.concatenate(parts) if parts else np.zeros((0, 4))
    if len(core) > limit:
        core = core[:: int(math.ceil(len(core) / limit))]
    markers = [np.asarray(m.position, dtype=float)[None] for m in mesh.markers]
    curves = [np.asarray(c.points, dtype=float) for c in mesh.curves if len(c.points)]
    return (
        np.concatenate([core, *markers]) if markers else core,
        np.concatenate(curves) if curves else np.zeros((0, 4)),
    )


def sample_bounds(sample: Sample, view: ViewState) -> Bounds | None:
    """The image bounds of a :func:`mesh_sample` (or of plain points): the surfaces and markers
    whole, the curves (axes, wire frames) only up to CURVE_REACH of the surfaces' extent beyond
    it, so a long axis through the sensor's neighbourhood does not shrink the surfaces to a
    corner of the screen. Thin lines may leave the area; surfaces never do."""
    if isinstance(sample, np.ndarray):
        return image_bounds(sample, view)
    core, curves = sample
    b = image_bounds(core, view) if len(core) else None
    c = image_bounds(curves, view) if len(curves) else None
    if b is None or c is None:
        return b if c is None else c
    rx, ry = CURVE_REACH * (b.x1 - b.x0), CURVE_REACH * (b.y1 - b.y0)

    def clamp(v, lo, hi):
        return min(max(v, lo), hi)

    reach = Bounds(
        clamp(c.x0, b.x0 - rx, b.x1 + rx),
        clamp(c.y0, b.y0 - ry, b.y1 + ry),
        clamp(c.x1, b.x0 - rx, b.x1 + rx),
        clamp(c.y1, b.y0 - ry, b.y1 + ry),
    )
    return b.union(reach)


def to_pixels(
    bounds: Bounds, view: ViewState, size: tuple[int, int]
) -> tuple[float, float, float, float]:
    """Image-plane bounds (as :func:`image_bounds` gives them) in pixels at ``view``'s zoom and
    lens shift: (x0, y0, x1, y1), y down. Exact: the screen is affine in both."""
    width, height = size
    aspect = width / height
    hh, (cx, cy) = view.half_height, view.center
    x0 = ((bounds.x0 - cx) / (hh * aspect) + 1) * 0.5 * width
    x1 = ((bounds.x1 - cx) / (hh * aspect) + 1) * 0.5 * width
    y0 = (1 - (bounds.y1 - cy) / hh) * 0.5 * height
    y1 = (1 - (bounds.y0 - cy) / hh) * 0.5 * height
    return x0, y0, x1, y1


def mesh_points(mesh: Drawn, limit: int = SAMPLE) -> np.ndarray:
    """What is drawn of a Mesh4D, as points (n, 4): surface vertices (evenly thinned to
    ``limit``), curve points and markers."""
    parts = [s.positions for s in mesh.surfaces if len(s.positions)]
    surfaces = np.concatenate(parts) if parts else np.zeros((0, 4))
    if len(surfaces) > limit:
        surfaces = surfaces[:: int(math.ceil(len(surfaces) / limit))]
    curves = [np.asarray(c.points, dtype=float) for c in mesh.curves if len(c.points)]
    markers = [np.asarray(m.position, dtype=float)[None] for m in mesh.markers]
    return np.concatenate([surfaces, *curves, *markers]) if (curves or markers) else surfaces


def image_bounds(points: np.ndarray, view: ViewState) -> Bounds | None:
    """The bounds of the points' images at ``view``'s pose (see the module docstring); points
    behind a centre or cut by a clip plane do not count. None when none is seen."""
    unit = view.replace(half_height=1.0, center=(0.0, 0.0))
    ct = clip_transform(unit, 1.0)
    clip = ct.clip(points)
    ok = (clip[:, 3] > 1e-9) & np.all(ct.clip_distances(points) >= 0, axis=1)
    if not ok.any():
        return None
    xy = clip[ok, :2] / clip[ok, 3:4]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    return Bounds(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def _ndc(area: Sequence[float], size: tuple[int, int]) -> tuple[float, float, float, float]:
    """A pixel rectangle (x0, y0, x1, y1; y down) in NDC (x0, y0, x1, y1; y up)."""
    width, height = size
    x0, y0, x1, y1 = area
    return 2 * x0 / width - 1, 1 - 2 * y1 / height, 2 * x1 / width - 1, 1 - 2 * y0 / height


def _half_height(bounds: Bounds, size: tuple[int, int], area: Sequence[float]) -> float | None:
    """The half_height that makes ``bounds`` just fit ``area`` (None: an empty area)."""
    nx0, ny0, nx1, ny1 = _ndc(area, size)
    if nx1 <= nx0 or ny1 <= ny0:
        return None
    aspect = size[0] / size[1]
    bw, bh = max(bounds.x1 - bounds.x0, 1e-9), max(bounds.y1 - bounds.y0, 1e-9)
    return max(bw / (aspect * (nx1 - nx0)), bh / (ny1 - ny0))


def best_area(
    bounds: Bounds, size: tuple[int, int], areas: Iterable[Sequence[float]]
) -> Sequence[float] | None:
    """The area of ``areas`` where ``bounds`` comes out largest (None if all are empty)."""
    best = None
    for area in areas:
        half = _half_height(bounds, size, area)
        if half is not None and (best is None or half < best[0]):
            best = (half, area)
    return None if best is None else best[1]


def fit(
    view: ViewState, bounds: Bounds, size: tuple[int, int], areas: Iterable[Sequence[float]]
) -> ViewState:
    """``view`` with ``half_height`` and ``center`` chosen so ``bounds`` fills one of ``areas``
    (rectangles (x0, y0, x1, y1) in pixels, y down) as largely as it can, centred in it. The
    area where the picture comes out largest wins. Zoom is limited to MAX_ZOOM either way."""
    area = best_area(bounds, size, areas)
    if area is None:
        return view
    fitted = _half_height(bounds, size, area)
    assert fitted is not None  # best_area only returns an area that is not empty
    half = min(max(fitted, view.half_height / MAX_ZOOM), view.half_height * MAX_ZOOM)
    return view.replace(half_height=half, center=_centered(bounds, size, area, half))


def _centered(bounds: Bounds, size, area, half: float) -> tuple[float, float]:
    """The lens shift that puts the middle of ``bounds`` at the middle of ``area``."""
    nx0, ny0, nx1, ny1 = _ndc(area, size)
    aspect = size[0] / size[1]
    return (
        0.5 * (bounds.x0 + bounds.x1) - 0.5 * (nx0 + nx1) * half * aspect,
        0.5 * (bounds.y0 + bounds.y1) - 0.5 * (ny0 + ny1) * half,
    )


def fitting_half_height(
    bounds: Bounds, size: tuple[int, int], area: Sequence[float]
) -> float | None:
    """The ``half_height`` at which ``bounds`` just fits ``area`` (a pixel rectangle), not
    limited by MAX_ZOOM; None for an empty area."""
    return _half_height(bounds, size, area)


def centered_in(
    view: ViewState,
    bounds: Bounds,
    size: tuple[int, int],
    area: Sequence[float],
    half_height: float,
) -> ViewState:
    """``view`` at ``half_height`` with the lens shift that puts the middle of ``bounds`` at
    the middle of ``area`` (a pixel rectangle)."""
    return view.replace(half_height=half_height, center=_centered(bounds, size, area, half_height))


def zoom_about(
    view: ViewState, factor: float, area: Sequence[float], size: tuple[int, int]
) -> ViewState:
    """``view`` zoomed out by ``factor`` about the middle of ``area`` (a pixel rectangle): what
    was there stays there, everything else moves towards it."""
    nx0, ny0, nx1, ny1 = _ndc(area, size)
    aspect = size[0] / size[1]
    mx, my = 0.5 * (nx0 + nx1), 0.5 * (ny0 + ny1)
    half = view.half_height * factor
    cx, cy = view.center
    return view.replace(
        half_height=half,
        center=(cx + mx * aspect * (view.half_height - half), cy + my * (view.half_height - half)),
    )


def frame(
    view: ViewState,
    points: Sample,
    size: tuple[int, int],
    areas: Iterable[Sequence[float]],
    poses: Iterable[ViewState] = (),
) -> ViewState:
    """``view`` framed so the image of ``points`` (an array, or a :func:`mesh_sample`) at its
    pose, and at every pose of ``poses``
    (a timeline's samples: one zoom and shift for all of them, so nothing breathes), lies in
    ``areas``. Unchanged when nothing is seen."""
    bounds = None
    for pose in (view, *poses):
        b = sample_bounds(points, pose)
        if b is not None:
            bounds = b.union(bounds)
    if bounds is None:
        return view
    return fit(view, bounds, size, list(areas))


def pixel_bounds(
    points: np.ndarray, view: ViewState, size: tuple[int, int]
) -> tuple[float, float, float, float] | None:
    """(x0, y0, x1, y1) in pixels (y down) of the points' images at ``view``, for checks."""
    width, height = size
    ct = clip_transform(view, width / height)
    clip = ct.clip(points)
    ok = (clip[:, 3] > 1e-9) & np.all(ct.clip_distances(points) >= 0, axis=1)
    if not ok.any():
        return None
    ndc = clip[ok, :2] / clip[ok, 3:4]
    x = (ndc[:, 0] + 1) * 0.5 * width
    y = (1 - ndc[:, 1]) * 0.5 * height
    return float(x.min()), float(y.min()), float(x.max()), float(y.max())
