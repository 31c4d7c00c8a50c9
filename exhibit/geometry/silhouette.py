"""Silhouettes under projection: Lemma 2 (4D -> 3D, isolated points) and Lemma 3 (4D -> 2D, curves).

Silhouette points are nonsingular points whose tangent plane loses dimension under the projection.
Every test here comes with a scale-free measure in [0, 1] (or [-1, 1] for the signed function) so a
tolerance means the same thing for every surface; singular points (dependent tangents or normals)
are never silhouettes, as in the paper's cusp example (section 4.2).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from exhibit.geometry.cross import bivector_norm, cross4

#: Measures at or below this count as zero for the silhouette predicates.
SILHOUETTE_TOLERANCE = 1e-9
#: |a ∧ b| / (|a||b|) below this means a pair of tangents or normals is dependent: a singular point.
SINGULAR_TOLERANCE = 1e-9


def _dot(a, b):
    return np.einsum("...i,...i", a, b)


def _norm(v):
    return np.linalg.norm(v, axis=-1)


def _safe_ratio(numerator, denominator):
    return np.where(denominator > 0, numerator / np.where(denominator > 0, denominator, 1.0), 0.0)


def is_singular_pair(u1: ArrayLike, u2: ArrayLike, tol: float = SINGULAR_TOLERANCE) -> np.ndarray:
    """True where u1, u2 (two tangents or two normals) do not span a plane."""
    u1 = np.asarray(u1, dtype=float)
    u2 = np.asarray(u2, dtype=float)
    return bivector_norm(u1, u2) <= tol * _norm(u1) * _norm(u2)


# ----------------------------------------------------------------------------- Lemma 2 (4D -> 3D)


def lemma2_measure_tangents(t1: ArrayLike, t2: ArrayLike, ray: ArrayLike) -> np.ndarray:
    """sin of the angle between the ray ρ and the tangent plane: |⊗(t1,t2,ρ)| / (|t1∧t2| |ρ|).

    0 on the silhouette (ρ in the tangent plane, Lemma 2); 0 too at singular points.
    """
    return _safe_ratio(_norm(cross4(t1, t2, ray)), bivector_norm(t1, t2) * _norm(ray))


def lemma2_measure_normals(n1: ArrayLike, n2: ArrayLike, ray: ArrayLike) -> np.ndarray:
    """The same measure from normals: |(n2·ρ)n1 - (n1·ρ)n2| / (|n1∧n2| |ρ|), the length of ρ's
    component in the normal plane over |ρ|."""
    n1 = np.asarray(n1, dtype=float)
    n2 = np.asarray(n2, dtype=float)
    ray = np.asarray(ray, dtype=float)
    n = _dot(n2, ray)[..., None] * n1 - _dot(n1, ray)[..., None] * n2
    return _safe_ratio(_norm(n), bivector_norm(n1, n2) * _norm(ray))


def is_silhouette_point_3d(
    t1: ArrayLike | None = None,
    t2: ArrayLike | None = None,
    ray: ArrayLike | None = None,
    *,
    n1: ArrayLike | None = None,
    n2: ArrayLike | None = None,
    tol: float = SILHOUETTE_TOLERANCE,
) -> np.ndarray:
    """Lemma 2: p is a silhouette point of the sensor projection iff t1, t2, ρ are dependent.

    Give tangents (t1, t2) or normals (n1=, n2=). Singular points are never silhouettes.
    """
    if ray is None:
        raise ValueError("give t1, t2 and ray, or n1=, n2= and ray")
    if n1 is not None and n2 is not None:
        return (lemma2_measure_normals(n1, n2, ray) <= tol) & ~is_singular_pair(n1, n2)
    if t1 is None or t2 is None:
        raise ValueError("give t1, t2 and ray, or n1=, n2= and ray")
    return (lemma2_measure_tangents(t1, t2, ray) <= tol) & ~is_singular_pair(t1, t2)


# ----------------------------------------------------------------------------- Lemma 3 (4D -> 2D)


def silhouette_function(
    n1: ArrayLike, n2: ArrayLike, ray1: ArrayLike, ray2: ArrayLike
) -> np.ndarray:
    """s = (n1·ρ1)(n2·ρ2) - (n1·ρ2)(n2·ρ1) = (n1∧n2)·(ρ1∧ρ2).

    Smooth and signed over the surface; its zero set is the 4D -> 2D silhouette curve (Lemma 3(c):
    ρ1, ρ2 and the tangent plane are dependent exactly when the normal plane meets the plane
    orthogonal to span(ρ1, ρ2)). With ρ1 = e_u, ρ2 = e_v it is the paper's condition C for offset
    curves; with e_x, e_y (or e_t, e_z) the collision curve C'.
    """
    n1 = np.asarray(n1, dtype=float)
    n2 = np.asarray(n2, dtype=float)
    return (_dot(n1, ray1) * _dot(n2, ray2)) - (_dot(n1, ray2) * _dot(n2, ray1))


def silhouette_function_normalized(
    n1: ArrayLike, n2: ArrayLike, ray1: ArrayLike, ray2: ArrayLike
) -> np.ndarray:
    """s / (|n1∧n2| |ρ1∧ρ2|) in [-1, 1]: the same zero set, independent of the normals' lengths.

    0 at singular points and where the rays are parallel (no defined 2D image).
    """
    s = silhouette_function(n1, n2, ray1, ray2)
    return _safe_ratio(s, bivector_norm(n1, n2) * bivector_norm(ray1, ray2))


def lemma3_measure_tangents(
    t1: ArrayLike, t2: ArrayLike, ray1: ArrayLike, ray2: ArrayLike
) -> np.ndarray:
    """|det[t1, t2, ρ1, ρ2]| / (|t1∧t2| |ρ1∧ρ2|) in [0, 1]: Lemma 3(b)'s test, scale-free."""
    t1, t2, ray1, ray2 = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (t1, t2, ray1, ray2))
    )
    det = np.abs(_dot(cross4(t1, t2, ray1), ray2))
    return _safe_ratio(det, bivector_norm(t1, t2) * bivector_norm(ray1, ray2))


def is_silhouette_point_2d(
    t1: ArrayLike | None = None,
    t2: ArrayLike | None = None,
    ray1: ArrayLike | None = None,
    ray2: ArrayLike | None = None,
    *,
    n1: ArrayLike | None = None,
    n2: ArrayLike | None = None,
    tol: float = SILHOUETTE_TOLERANCE,
) -> np.ndarray:
    """Lemma 3: p is a silhouette point of the 4D -> 2D map iff t1, t2, ρ1, ρ2 are dependent
    (b), equivalently iff n1, n2 and the plane orthogonal to ρ1, ρ2 are dependent (c)."""
    if ray1 is None or ray2 is None:
        raise ValueError("give t1, t2, ray1 and ray2, or n1=, n2=, ray1 and ray2")
    if n1 is not None and n2 is not None:
        measure = np.abs(silhouette_function_normalized(n1, n2, ray1, ray2))
        return (measure <= tol) & ~is_singular_pair(n1, n2)
    if t1 is None or t2 is None:
        raise ValueError("give t1, t2, ray1 and ray2, or n1=, n2=, ray1 and ray2")
    return (lemma3_measure_tangents(t1, t2, ray1, ray2) <= tol) & ~is_singular_pair(t1, t2)


# ----------------------------------------------------------------------------- zero sets on meshes


def zero_set_segments(positions: ArrayLike, triangles: ArrayLike, values: ArrayLike) -> np.ndarray:
    """Line segments where a per-vertex scalar crosses zero on a triangle mesh (marching triangles).

    Each triangle whose vertex values change sign gives one segment between the two crossing
    points on its edges, found by linear interpolation; the segments join into the silhouette
    curve of silhouette_function. Vertices with value exactly 0 count as positive, so a crossing is
    never reported twice. Returns shape (segments, 2, dim).
    """
    positions = np.asarray(positions, dtype=float)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    values = np.asarray(values, dtype=float)
    if values.shape != positions.shape[:1]:
        raise ValueError("need one value per vertex")
    negative = values[triangles] < 0  # (T, 3)
    count = negative.sum(axis=1)
    crossing = (count == 1) | (count == 2)
    tris = triangles[crossing]
    neg = negative[crossing]
    # The odd vertex out is the lone negative (count 1) or the lone non-negative (count 2).
    lone = np.where(neg.sum(axis=1) == 1, np.argmax(neg, axis=1), np.argmin(neg, axis=1))
    apex = tris[np.arange(len(tris)), lone]
    others = np.stack(
        [tris[np.arange(len(tris)), (lone + 1) % 3], tris[np.arange(len(tris)), (lone + 2) % 3]],
        axis=1,
    )

    def crossing_point(a, b):
        va, vb = values[a], values[b]
        t = va / (va - vb)  # va, vb have opposite signs (or vb is 0): denominator is nonzero
        return positions[a] + t[:, None] * (positions[b] - positions[a])

    return np.stack(
        [crossing_point(apex, others[:, 0]), crossing_point(apex, others[:, 1])], axis=1
    )
