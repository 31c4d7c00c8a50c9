"""How closely a mesh meets what it should: its cut at the domain box and its singular set.

`exhibit inspect --json` reports both per implicit part:

- ``boundary_box_distance``: the largest distance of a boundary vertex from the nearest face of
  the part's box (0 for closed parts). Boundary vertices come from the cut at the box
  (`implicit._clip_to_box`), so this is 0 up to rounding wherever the surface leaves its box;
  a hole anywhere else in the mesh shows up here.
- ``singular_gap``: the largest distance from the traced singular set (the singular points the
  polygonizer found, and those traced along singular curves) to the mesh's triangles.
"""

from __future__ import annotations

import numpy as np


def boundary_vertices(triangles: np.ndarray) -> np.ndarray:
    """Indices of the vertices on boundary edges (edges with one triangle)."""
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(tris) == 0:
        return np.zeros(0, dtype=np.int64)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return np.unique(unique[counts == 1])


def boundary_box_distance(positions, triangles, lo, hi) -> float:
    """The largest distance of a boundary vertex from the nearest face of the box [lo, hi]."""
    b = boundary_vertices(triangles)
    if len(b) == 0:
        return 0.0
    p = np.asarray(positions, dtype=float)[b]
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    to_face = np.minimum(np.abs(p - lo), np.abs(p - hi)).min(axis=1)
    return float(to_face.max())


def _segment_distance(p, a, b):
    d = b - a
    t = np.clip(
        np.einsum("ni,ni->n", p - a, d) / np.maximum(np.einsum("ni,ni->n", d, d), 1e-300), 0.0, 1.0
    )
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)


def point_triangle_distance(p, a, b, c) -> np.ndarray:
    """Distances from points p to triangles (a, b, c), all (N, d), exactly."""
    e1, e2 = b - a, c - a
    gram = np.stack(
        [
            np.stack([np.einsum("ni,ni->n", e1, e1), np.einsum("ni,ni->n", e1, e2)], -1),
            np.stack([np.einsum("ni,ni->n", e2, e1), np.einsum("ni,ni->n", e2, e2)], -1),
        ],
        -2,
    )
    rhs = np.stack([np.einsum("ni,ni->n", p - a, e1), np.einsum("ni,ni->n", p - a, e2)], -1)
    det = gram[:, 0, 0] * gram[:, 1, 1] - gram[:, 0, 1] ** 2
    ok = det > 1e-300
    safe = np.where(ok, det, 1.0)
    s = (gram[:, 1, 1] * rhs[:, 0] - gram[:, 0, 1] * rhs[:, 1]) / safe
    t = (gram[:, 0, 0] * rhs[:, 1] - gram[:, 0, 1] * rhs[:, 0]) / safe
    inside = ok & (s >= 0) & (t >= 0) & (s + t <= 1)
    plane = np.linalg.norm(p - (a + s[:, None] * e1 + t[:, None] * e2), axis=1)
    edges = np.minimum(
        np.minimum(_segment_distance(p, a, b), _segment_distance(p, b, c)),
        _segment_distance(p, c, a),
    )
    return np.where(inside, np.minimum(plane, edges), edges)


def distance_to_mesh(points, positions, triangles, candidates: int = 24) -> np.ndarray:
    """Distance from each point to the nearest triangle among those at its ``candidates`` nearest
    vertices (exact for the meshes here, whose triangles are small)."""
    points = np.asarray(points, dtype=float).reshape(-1, positions.shape[1])
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(points) == 0:
        return np.zeros(0)
    if len(tris) == 0:
        return np.full(len(points), np.inf)
    order = np.argsort(tris.ravel(), kind="stable")
    owners = order // 3
    sorted_v = tris.ravel()[order]
    starts = np.searchsorted(sorted_v, np.arange(len(positions)))
    ends = np.searchsorted(sorted_v, np.arange(len(positions)), side="right")
    out = np.empty(len(points))
    k = min(candidates, len(positions) - 1)
    for start in range(0, len(points), 64):
        chunk = points[start : start + 64]
        d = np.linalg.norm(chunk[:, None] - positions[None], axis=-1)
        nearest = (
            np.argpartition(d, k, axis=1)[:, :candidates]
            if k > 0
            else np.zeros((len(chunk), 1), dtype=np.int64)
        )
        # every (point, triangle at one of its nearest vertices) pair, at once
        v = nearest.ravel()
        count = ends[v] - starts[v]
        total = int(count.sum())
        out[start : start + len(chunk)] = d.min(axis=1)  # a vertex is an upper bound
        if total == 0:
            continue
        which = np.repeat(np.repeat(np.arange(len(chunk)), nearest.shape[1]), count)
        first = np.repeat(starts[v] - (np.cumsum(count) - count), count) + np.arange(total)
        t = tris[owners[first]]
        dist = point_triangle_distance(
            chunk[which], positions[t[:, 0]], positions[t[:, 1]], positions[t[:, 2]]
        )
        np.minimum.at(out, start + which, dist)
    return out
