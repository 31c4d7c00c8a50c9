"""Whether a marked 4D point is hidden behind a surface in the picture, computed on the CPU.

A marker ("first contact, t = ...") is what a caption points at, so the HUD draws it above the
surfaces, always visible; but a visitor must still see when the point itself lies behind a sheet
(a hollow ring and a leader line then, exhibit.render.hud). The z-buffer knows, but reading it
back stalls the GPU; instead the few labelled points are tested against the projected triangles
here: the triangles with vertices on both sides of the point in x and in y (one bit code per
vertex, OR-ed per triangle), then barycentric depth on those few (window depth is affine in
screen space over a triangle, so it interpolates exactly). The collision mesh at the kiosk's
resolution 40 (30,000 triangles) costs about 1.5 ms a frame.
"""

from __future__ import annotations

from typing import Protocol
from collections.abc import Iterable


import numpy as np


from exhibit.geometry.pipeline import ClipTransform

#: A point this close in NDC depth behind a triangle through it counts as on it, not behind it
#: (a marker or curve on a surface lies a chord's sag off its triangles).
DEPTH_TOLERANCE = 2e-3
#: For points that are vertices of the surfaces (no sag): this share of the surface's NDC depth
#: range instead, where less. With a distant sensor a whole scene may lie within 0.02 of NDC
#: depth, where 2e-3 let a doughnut's tag end on the doughnut in front of it.
VERTEX_SHARE = 1e-2


class Triangles(Protocol):
    """What occlusion reads of a surface (a surfaces.Surface, above geometry)."""

    @property
    def positions(self) -> np.ndarray: ...

    @property
    def triangles(self) -> np.ndarray: ...


def hidden(
    points: np.ndarray,
    surfaces: Iterable[Triangles],
    ct: ClipTransform,
    vertices: bool = False,
) -> np.ndarray:
    """For each 4D point (n, 4), whether some triangle of ``surfaces`` (objects with
    ``positions`` (m, 4) and ``triangles`` (k, 3)) covers it nearer to the eye. Points that are
    themselves clipped or behind a centre count as not hidden (they are not drawn at all).
    ``vertices``: the points are vertices of the surfaces (a tag's anchor), so the tolerance
    can be tighter (VERTEX_SHARE)."""
    points = np.asarray(points, dtype=float).reshape(-1, 4)
    out = np.zeros(len(points), dtype=bool)
    if not len(points):
        return out
    clip = ct.clip(points)
    w = clip[:, 3]
    valid = w > 0
    p = np.where(valid[:, None], clip[:, :3] / np.where(valid, w, 1.0)[:, None], 0.0)
    for surface in surfaces:
        tris = surface.triangles
        if len(tris) == 0:
            continue
        # ct.clip without the homogeneous column: this runs every frame a label is shown.
        vc = surface.positions @ ct.matrix[:, :4].T + ct.matrix[:, 4]
        front = vc[:, 3] > 0
        v = vc[:, :3] / np.where(front, vc[:, 3], 1.0)[:, None]
        depths = v[front, 2]
        spread = float(np.ptp(depths)) if len(depths) else 0.0
        tolerance = min(DEPTH_TOLERANCE, VERTEX_SHARE * spread) if vertices else DEPTH_TOLERANCE
        # triangles with a vertex behind the eye and one in front: tested apart (straddling)
        across = tris[~front[tris].all(axis=1) & front[tris].any(axis=1)]
        for i in np.flatnonzero(valid & ~out):
            x, y, z = p[i]
            # Vertex-level sides first (cheap): a triangle can cover the point only if its
            # vertices are on both sides of it in x and in y, all in front of the eye.
            code = (
                (v[:, 0] <= x)
                | ((v[:, 0] >= x) << 1)
                | ((v[:, 1] <= y) << 2)
                | ((v[:, 1] >= y) << 3)
                | (~front << 4)
            ).astype(np.uint8)
            either = code[tris[:, 0]] | code[tris[:, 1]] | code[tris[:, 2]]
            near = either == 15  # both sides in x and y, no vertex behind the eye
            if straddling(vc, across, ct, surface.positions, (x, y, z), tolerance):
                out[i] = True
                continue
            if not near.any():
                continue
            cand = tris[near]
            # each vertex's clip distances (front plane, ...): (k, 3, planes)
            dist = ct.clip_distances(surface.positions[cand].reshape(-1, 4)).reshape(
                len(cand), 3, -1
            )
            ta, tb, tc = v[cand[:, 0]], v[cand[:, 1]], v[cand[:, 2]]
            e1, e2 = tb - ta, tc - ta
            det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
            good = np.abs(det) > 1e-14
            det = np.where(good, det, 1.0)
            dx, dy = x - ta[:, 0], y - ta[:, 1]
            s = (dx * e2[:, 1] - dy * e2[:, 0]) / det
            t = (e1[:, 0] * dy - e1[:, 1] * dx) / det
            covers = good & (s >= 0) & (t >= 0) & (s + t <= 1)
            # A triangle the clip planes cut covers the point only where it is kept: its clip
            # distances at the point (interpolated on the screen: near enough for a test that
            # a whole surface near the sensor, cut by the tilted front plane, is in front).
            at = dist[:, 0] + s[:, None] * (dist[:, 1] - dist[:, 0])
            at = at + t[:, None] * (dist[:, 2] - dist[:, 0])
            covers &= np.all(at >= 0, axis=1)
            depth = ta[:, 2] + s * e1[:, 2] + t * e2[:, 2]
            out[i] = bool(np.any(covers & (depth < z - tolerance)))
    return out


def straddling(
    vc: np.ndarray,
    tris: np.ndarray,
    ct: ClipTransform,
    positions: np.ndarray,
    point: tuple[float, float, float],
    tolerance: float,
) -> bool:
    """Whether one of ``tris``, triangles with a vertex behind the eye (a sheet passing by the
    sensor, drawn huge: the GPU clips it at the eye and draws the rest), covers the NDC
    ``point`` nearer to the eye. Homogeneous rasterisation (Olano and Greer 1997): with the
    vertices' clip coordinates (X, Y, W) as the columns of A, the point is inside where the
    weights u = A^-1 (x, y, 1) are all >= 0; its depth is then sum(u Z) and its clip distances
    sum(u d), each in front of the eye (sum(u W) = 1)."""
    if not len(tris):
        return False
    x, y, z = point
    corners = vc[tris]  # (k, 3, 4): X, Y, Z, W of each vertex
    a = np.stack([corners[:, :, 0], corners[:, :, 1], corners[:, :, 3]], axis=1)  # (k, 3, 3)
    good = np.abs(np.linalg.det(a)) > 1e-14
    if not good.any():
        return False
    u = np.linalg.solve(a[good], np.broadcast_to([x, y, 1.0], (int(good.sum()), 3))[..., None])
    u = u[..., 0]
    inside = np.all(u >= 0, axis=1)
    depth = np.sum(u * corners[good][:, :, 2], axis=1)
    dist = ct.clip_distances(positions[tris[good]].reshape(-1, 4)).reshape(len(u), 3, -1)
    kept = np.all(np.sum(u[:, :, None] * dist, axis=1) >= 0, axis=1)
    return bool(np.any(inside & kept & (depth < z - tolerance)))
