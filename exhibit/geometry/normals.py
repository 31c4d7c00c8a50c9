"""Tangent and normal planes of a 2-surface in R^4, and the projected normal of Lemma 1.

A surface point carries either two tangents t1, t2 (parametric surfaces: ∂/∂s, ∂/∂t) or two
normals n1, n2 (implicit f1 = f2 = 0: ∇f1, ∇f2). The paper converts between them with ⊗; the
projected normal needs one ray per vertex and per frame, which is what the renderer's vertex
shader evaluates with these same formulas.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from exhibit.geometry.cross import cross4


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i", a, b)


def complement_plane(u1: ArrayLike, u2: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Two orthogonal vectors spanning the plane orthogonal to span(u1, u2) in R^4.

    The paper's construction: w1 = ⊗(u1, u2, a) with a basis vector a chosen per point so the
    result is largest (well conditioned), then w2 = ⊗(u1, u2, w1) ("b replaced by t1"). Both are
    normalised. Where u1, u2 are dependent (a singular point) both are zero vectors.
    """
    u1 = np.asarray(u1, dtype=float)
    u2 = np.asarray(u2, dtype=float)
    u1, u2 = np.broadcast_arrays(u1, u2)
    candidates = _cross_with_basis(u1, u2)  # (..., 4 choices, 4)
    lengths = np.linalg.norm(candidates, axis=-1)
    best = np.argmax(lengths, axis=-1)
    w1 = np.take_along_axis(candidates, best[..., None, None], axis=-2)[..., 0, :]
    w2 = cross4(u1, u2, w1)
    return _normalise_or_zero(w1), _normalise_or_zero(w2)


def orthonormal_normals(n1: ArrayLike, n2: ArrayLike) -> np.ndarray:
    """(..., 2, 4): an orthonormal pair spanning the same plane as n1, n2 (e.g. ∇f1, ∇f2),
    made as the complement of the complement (zero where n1, n2 are dependent)."""
    t1, t2 = complement_plane(n1, n2)
    m1, m2 = complement_plane(t1, t2)
    return np.stack([m1, m2], axis=-2)


def _cross_with_basis(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """⊗(a, b, e_k) for k = 0..3, shape (..., 4, 4): each is made of the six 2x2 minors
    P_ij = a_i b_j - a_j b_i of (a, b), so they are computed once instead of four full ⊗s
    (the same products and differences as cross4 with a basis vector: the same numbers)."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    p_xy, p_xz, p_xw = ax * by - ay * bx, ax * bz - az * bx, ax * bw - aw * bx
    p_yz, p_yw, p_zw = ay * bz - az * by, ay * bw - aw * by, az * bw - aw * bz
    zero = np.zeros_like(p_xy)
    rows = [
        (zero, -p_zw, p_yw, -p_yz),  # ⊗(a, b, e_x)
        (p_zw, zero, -p_xw, p_xz),  # ⊗(a, b, e_y)
        (-p_yw, p_xw, zero, -p_xy),  # ⊗(a, b, e_z)
        (p_yz, -p_xz, p_xy, zero),
    ]  # ⊗(a, b, e_w)
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def _normalise_or_zero(v: np.ndarray, tiny: float = 1e-300) -> np.ndarray:
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(length > tiny, v / np.where(length > tiny, length, 1.0), 0.0)


def tangents_from_normals(n1: ArrayLike, n2: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangents of the plane orthogonal to the normals (zero at singular points)."""
    return complement_plane(n1, n2)


def normals_from_tangents(t1: ArrayLike, t2: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal normals of the plane orthogonal to the tangents (zero at degenerate points)."""
    return complement_plane(t1, t2)


def projected_normal_from_tangents(t1: ArrayLike, t2: ArrayLike, ray: ArrayLike) -> np.ndarray:
    """Lemma 1(b): π_XYZ(⊗(t1, t2, ρ)) is the normal of the projected surface v(S) at v(p).

    ``ray`` is ρ (any positive multiple, e.g. projection.sensor_ray). Zero exactly where p is a
    silhouette point of the projection (Lemma 2) or the tangents are dependent.
    """
    return cross4(t1, t2, ray)[..., :3]


def projected_normal_from_normals(n1: ArrayLike, n2: ArrayLike, ray: ArrayLike) -> np.ndarray:
    """Lemma 1(c): n = (n2·ρ) n1 - (n1·ρ) n2 is the combination of n1, n2 orthogonal to ρ, and
    π_XYZ(n) is the normal of v(S) at v(p). Zero exactly at silhouette or singular points."""
    n1 = np.asarray(n1, dtype=float)
    n2 = np.asarray(n2, dtype=float)
    ray = np.asarray(ray, dtype=float)
    n = _dot(n2, ray)[..., None] * n1 - _dot(n1, ray)[..., None] * n2
    return n[..., :3]
