"""Curves traced on meshes: zero sets of per-vertex functions (silhouettes) joined into
polylines."""

from __future__ import annotations

import numpy as np

from exhibit.geometry.silhouette import zero_set_segments
from exhibit.surfaces.mesh import Curve, Material, Surface


def chain_segments(segments: np.ndarray, tolerance: float = 1e-9) -> list[tuple[np.ndarray, bool]]:
    """Join segments (S, 2, d) that share endpoints into polylines: [(points, closed), ...].

    Endpoints closer than ``tolerance`` are the same point (two triangles meeting at an edge
    compute its crossing separately).
    """
    segments = np.asarray(segments, dtype=float)
    if len(segments) == 0:
        return []
    ends = segments.reshape(-1, segments.shape[-1])
    keys = np.round(ends / tolerance).astype(np.int64)
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 2)
    neighbours: dict[int, list[int]] = {}
    for index, (a, b) in enumerate(ids):
        if a == b:
            continue
        neighbours.setdefault(a, []).append(index)
        neighbours.setdefault(b, []).append(index)
    position = {int(i): ends[k] for k, i in enumerate(ids.reshape(-1))}
    used = np.zeros(len(ids), dtype=bool)
    used[ids[:, 0] == ids[:, 1]] = True

    def walk(start_point, start_segment):
        path = [start_point]
        point, segment = start_point, start_segment
        while segment is not None:
            used[segment] = True
            a, b = ids[segment]
            point = b if a == point else a
            path.append(point)
            segment = next((s for s in neighbours.get(point, []) if not used[s]), None)
        return path

    polylines = []
    # Open chains first (start where a point has one segment), then the closed loops left over.
    starts = [p for p, segs in neighbours.items() if len(segs) == 1]
    for point in starts + list(neighbours):
        for segment in neighbours[point]:
            if used[segment]:
                continue
            path = walk(point, segment)
            closed = len(path) > 2 and path[0] == path[-1]
            if closed:
                path = path[:-1]
            polylines.append((np.array([position[p] for p in path]), closed))
    return polylines


def zero_set_curves(
    surface: Surface, values: np.ndarray, name: str, material: Material
) -> list[Curve]:
    """The zero set of per-vertex ``values`` on ``surface`` as Curves (e.g. a silhouette)."""
    segments = zero_set_segments(surface.positions, surface.triangles, values)
    scale = float(np.abs(surface.positions).max()) if len(surface.positions) else 1.0
    return [
        Curve(f"{name} {i + 1}" if i else name, points, material, closed)
        for i, (points, closed) in enumerate(chain_segments(segments, 1e-9 * max(scale, 1.0)))
    ]
