"""Lemma 2 points on a mesh, each claimed by one triangle: the CPU mirror of the geometry
shader's rule (exhibit/render/shaders/silhouette.glsl), used to test it.

A Lemma 2 point is a zero of u = P_N ρ, the sensor ray's part in the normal plane (n1·ρ = n2·ρ
= 0). Solving each triangle's linear interpolant of u for its zero, in a frame of the triangle's
own, let a zero near a shared edge be claimed by both triangles or by neither, since the two
triangles interpolate u in different frames. So a triangle claims a point by the winding of u
around its boundary instead: each edge's turn of u is measured in the normal frame of the
edge's lower-numbered vertex, so both triangles at an edge compute the very same angle, and
a zero of the field so defined lies in exactly one triangle. The disc is placed at the linear
interpolant's zero, clamped into the claiming triangle. Only triangles whose interpolant
vanishes inside or within MARGIN of them are checked for a winding (the shader's shortcut past
its arc tangents: 2% of the Hopf tori's triangles at resolution 24 are checked, 0.3% at 64).

Around a singular point (zero normals: the sheets meet, the normal plane is undefined) u
winds as well, and the triangles next to it, which cannot resolve the normal plane's fast turn,
show that winding as a zero that is no Lemma 2 point. Singular points are never silhouettes
(the paper, section 4.2), so triangles within SINGULAR_REACH mean edges of a singular vertex
mark nothing (`marking_vertices`, a flag uploaded with each vertex).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

#: The interpolant is degenerate (u vanishes along a curve, not at a point) when its Jacobian's
#: determinant is below this times the largest |u|² on the triangle: no point is marked.
DEGENERATE = 1e-6
#: A triangle is checked for a winding only where u's interpolant (in its first vertex's frame)
#: vanishes at most this far outside it, in barycentric coordinates: a margin for the frames'
#: differences, and the geometry shader's shortcut past its arc tangents.
MARGIN = 0.5
#: A vertex counts as singular (no normal plane) when its first normal is shorter than this.
SINGULAR_NORMAL = 0.5
#: Triangles with a vertex closer than this many median edge lengths to a singular vertex
#: mark no Lemma 2 point.
SINGULAR_REACH = 3.0


def _dot(a, b):
    return np.einsum("...i,...i", a, b)


def edge_turns(
    m1: np.ndarray, m2: np.ndarray, u: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """The angle by which u turns from vertex lo to vertex hi, both seen in lo's normal frame."""
    a0, b0 = _dot(u[lo], m1[lo]), _dot(u[lo], m2[lo])
    a1, b1 = _dot(u[hi], m1[lo]), _dot(u[hi], m2[lo])
    return np.arctan2(a0 * b1 - b0 * a1, a0 * a1 + b0 * b1)


def turns(m1: ArrayLike, m2: ArrayLike, rays: ArrayLike, triangles: ArrayLike) -> np.ndarray:
    """The angle by which u = P_N ρ turns around each triangle: a multiple of 2π up to the
    rounding of the frames (the sign follows the triangle's vertex order)."""
    m1, m2, rays = (np.asarray(v, dtype=float) for v in (m1, m2, rays))
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    u = _dot(m1, rays)[:, None] * m1 + _dot(m2, rays)[:, None] * m2  # the same in any frame
    turn = np.zeros(len(tris))
    for k in range(3):
        i, j = tris[:, k], tris[:, (k + 1) % 3]
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        turn += np.where(i < j, 1.0, -1.0) * edge_turns(m1, m2, u, lo, hi)
    return turn


def lemma2_marks(
    m1: ArrayLike, m2: ArrayLike, rays: ArrayLike, triangles: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """(triangle indices, barycentric coordinates (K, 3)) of the Lemma 2 marks.

    m1, m2: each vertex's orthonormal normals (V, 4) in the coordinates of ``rays`` (V, 4), the
    ray towards the sensor at each vertex; zero normals mark singular vertices, whose
    triangles are skipped (singular points are never silhouettes)."""
    m1, m2, rays = (np.asarray(v, dtype=float) for v in (m1, m2, rays))
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    winds = np.abs(turns(m1, m2, rays, tris)) >= np.pi  # the shader's test: 0 or ±2π, ±4π...
    u = _dot(m1, rays)[:, None] * m1 + _dot(m2, rays)[:, None] * m2
    # Where in the triangle: the zero of u's linear interpolant in vertex 0's frame.
    v0 = tris[:, 0]
    coords = np.stack(
        [
            np.stack([_dot(u[tris[:, k]], m1[v0]), _dot(u[tris[:, k]], m2[v0])], axis=-1)
            for k in range(3)
        ],
        axis=1,
    )  # (T, 3, 2)
    e1, e2 = coords[:, 1] - coords[:, 0], coords[:, 2] - coords[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    scale = _dot(coords, coords).max(axis=1)
    solvable = (np.abs(det) > DEGENERATE * scale) & (scale > 0)
    safe = np.where(solvable, det, 1.0)
    c0 = coords[:, 0]
    l1 = (-c0[:, 0] * e2[:, 1] + c0[:, 1] * e2[:, 0]) / safe
    l2 = (-e1[:, 0] * c0[:, 1] + e1[:, 1] * c0[:, 0]) / safe
    raw = np.stack([1.0 - l1 - l2, l1, l2], axis=1)
    # The shader's shortcut: a zero of the interpolant far outside the triangle, no winding.
    close = raw.min(axis=1) >= -MARGIN
    bary = np.clip(raw, 0.0, None)
    bary /= np.maximum(bary.sum(axis=1, keepdims=True), 1e-300)
    singular = _dot(m1, m1) < SINGULAR_NORMAL**2
    claimed = winds & solvable & close & ~singular[tris].any(axis=1)
    index = np.flatnonzero(claimed)
    return index, bary[index]


def marking_vertices(
    positions: ArrayLike, normals: ArrayLike, triangles: ArrayLike, reach: float = SINGULAR_REACH
) -> np.ndarray:
    """(V,) bool: the vertices farther than ``reach`` median edge lengths from every singular
    vertex (zero normals); a triangle may mark a Lemma 2 point only if all three are. A
    distance, not rings of triangles: a singular vertex belongs to one sheet's triangles, and
    the other sheet passes it as closely."""
    positions = np.asarray(positions, dtype=float)
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n1 = np.asarray(normals, dtype=float)[:, 0]
    anchors = positions[_dot(n1, n1) < SINGULAR_NORMAL**2]
    if len(anchors) == 0 or len(tris) == 0:
        return np.ones(len(positions), dtype=bool)
    edge = float(np.median(np.linalg.norm(positions[tris[:, 1]] - positions[tris[:, 0]], axis=1)))
    radius = reach * edge
    if not radius > 0:
        return np.ones(len(positions), dtype=bool)
    # Only vertices in a grid cell (of the radius' size) next to an anchor's can be near one:
    # a hash of the cells first, exact distances for those few (this runs at upload).
    lo = np.minimum(positions.min(axis=0), anchors.min(axis=0)) - radius
    hi = np.maximum(positions.max(axis=0), anchors.max(axis=0)) + radius
    span = np.floor((hi - lo) / radius).astype(np.int64) + 2

    def code(points) -> np.ndarray:
        """One integer per grid cell of a point (cells of the radius' size)."""
        k = np.floor((points - lo) / radius).astype(np.int64)
        return ((k[:, 0] * span[1] + k[:, 1]) * span[2] + k[:, 2]) * span[3] + k[:, 3]

    steps = np.stack(np.meshgrid(*[(-1.0, 0.0, 1.0)] * 4, indexing="ij"), axis=-1).reshape(-1, 4)
    near_cells = np.unique(code((anchors[:, None, :] + radius * steps[None]).reshape(-1, 4)))
    candidates = np.flatnonzero(np.isin(code(positions), near_cells))
    marking = np.ones(len(positions), dtype=bool)
    p = positions[candidates]
    # |p - a|² = |p|² + |a|² - 2 p·a, one matrix product for all pairs.
    d2 = _dot(p, p)[:, None] + _dot(anchors, anchors)[None, :] - 2.0 * p @ anchors.T
    marking[candidates] = d2.min(axis=1) >= radius**2
    return marking


def eligible_triangles(
    positions: ArrayLike, normals: ArrayLike, triangles: ArrayLike, reach: float = SINGULAR_REACH
) -> np.ndarray:
    """Indices of the triangles that may mark Lemma 2 points (all three vertices marking)."""
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    marking = marking_vertices(positions, normals, tris, reach)
    return np.flatnonzero(marking[tris].all(axis=1))


def lemma2_exclusion(
    positions: ArrayLike, normals: ArrayLike, triangles: ArrayLike, reach: float = SINGULAR_REACH
) -> dict:
    """Where the Lemma 2 marks stop next to singular vertices, as distances of a point:

    - ``never_within`` = reach·e (e the median edge): a triangle marks only if its three
      vertices are at least that far from every singular vertex, and a point of it lies in
      their convex hull, so no mark is nearer (to within the triangle's curvature);
    - ``always_from`` = reach·e + D, D the longest edge of a triangle with a vertex nearer than
      reach·e: a point farther than that lies in a triangle whose vertices are all farther than
      reach·e, so it is marked wherever the winding resolves it.

    Between the two a point is marked or not as its triangle's vertices fall. Closer than
    reach·e the triangles cannot resolve the normal plane's turn next to a point where the
    sheets meet (Figure 15's (0, ±1, 0, 0)): without this rule, a third of the Lemma 2 points 2-3
    edges from one were not marked and one in twelve twice."""
    positions = np.asarray(positions, dtype=float)
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(tris) == 0:
        return {
            "median_edge": 0.0,
            "reach_edges": reach,
            "never_within": 0.0,
            "always_from": 0.0,
            "longest_edge_within": 0.0,
        }
    edge = float(np.median(np.linalg.norm(positions[tris[:, 1]] - positions[tris[:, 0]], axis=1)))
    marking = marking_vertices(positions, normals, tris, reach)
    near = ~marking[tris].all(axis=1)
    longest = 0.0
    if near.any():
        t = tris[near]
        longest = float(
            max(
                np.linalg.norm(positions[t[:, k]] - positions[t[:, (k + 1) % 3]], axis=1).max()
                for k in range(3)
            )
        )
    return {
        "median_edge": edge,
        "reach_edges": reach,
        "never_within": reach * edge if near.any() else 0.0,
        "always_from": reach * edge + longest if near.any() else 0.0,
        "longest_edge_within": longest,
    }
