"""Whether a marked 4D point is hidden behind a surface in the picture, computed on the CPU.

A marker ("first contact, t = ...") is what a caption points at, so the HUD draws it above the
surfaces, always visible; but a visitor must still see when the point itself lies behind a sheet
(a hollow ring and a leader line then, exhibit.render.hud). The z-buffer knows, but reading it
back stalls the GPU; instead the few labelled points are tested against the projected triangles
here: the triangles whose screen box holds the point, then barycentric depth (window depth is
affine in screen space over a triangle, so it interpolates exactly). A few thousand triangles
cost well under a millisecond.
"""

from __future__ import annotations

import numpy as np

from exhibit.geometry.pipeline import ClipTransform

#: A point this close in NDC depth behind a triangle through it counts as on it, not behind it.
DEPTH_TOLERANCE = 2e-3


def hidden(points: np.ndarray, surfaces, ct: ClipTransform) -> np.ndarray:
    """For each 4D point (n, 4), whether some triangle of ``surfaces`` (objects with
    ``positions`` (m, 4) and ``triangles`` (k, 3)) covers it nearer to the eye. Points that are
    themselves clipped or behind a centre count as not hidden (they are not drawn at all)."""
    points = np.asarray(points, dtype=float).reshape(-1, 4)
    out = np.zeros(len(points), dtype=bool)
    if not len(points):
        return out
    clip = ct.clip(points)
    w = clip[:, 3]
    valid = w > 0
    p = np.where(valid[:, None], clip[:, :3] / np.where(valid, w, 1.0)[:, None], 0.0)
    for surface in surfaces:
        if len(surface.triangles) == 0:
            continue
        vc = ct.clip(surface.positions)
        front = vc[:, 3] > 0
        inside = front & np.all(ct.clip_distances(surface.positions) >= 0, axis=1)
        v = vc[:, :3] / np.where(front, vc[:, 3], 1.0)[:, None]
        tris = surface.triangles[np.all(inside[surface.triangles], axis=1)]
        if not len(tris):
            continue
        a, b, c = v[tris[:, 0]], v[tris[:, 1]], v[tris[:, 2]]
        lo = np.minimum(np.minimum(a, b), c)
        hi = np.maximum(np.maximum(a, b), c)
        for i in np.flatnonzero(valid & ~out):
            x, y, z = p[i]
            near = (lo[:, 0] <= x) & (x <= hi[:, 0]) & (lo[:, 1] <= y) & (y <= hi[:, 1]) \
                & (lo[:, 2] < z - DEPTH_TOLERANCE)
            if not near.any():
                continue
            ta, tb, tc = a[near], b[near], c[near]
            e1, e2 = tb - ta, tc - ta
            det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
            ok = np.abs(det) > 1e-14
            det = np.where(ok, det, 1.0)
            dx, dy = x - ta[:, 0], y - ta[:, 1]
            s = (dx * e2[:, 1] - dy * e2[:, 0]) / det
            t = (e1[:, 0] * dy - e1[:, 1] * dx) / det
            covers = ok & (s >= 0) & (t >= 0) & (s + t <= 1)
            depth = ta[:, 2] + s * e1[:, 2] + t * e2[:, 2]
            out[i] = bool(np.any(covers & (depth < z - DEPTH_TOLERANCE)))
    return out
