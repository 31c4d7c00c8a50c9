"""Where a per-vertex value touches zero on a mesh without changing sign: the live slice's rule
for tangency, in numpy, mirroring the geometry shader (render/shaders/silhouette.glsl).

Marching triangles (zero_set_segments, the shader's `crossing()`) sees only sign changes. Where
the hyperplane x_a = c is tangent to the surface along a curve (Figure 15's scene at t = 0, along
the circle x = 0, y² + z² = 1) h = x_a − c keeps its sign on both sides and nothing is drawn. So
on each edge whose ends have the same sign (no end singular, neither value exactly 0) the cubic
Hermite interpolant H(λ), λ in [0, 1], is fitted to h and to h's derivative along the surface in
the edge's direction at the two ends, D = (P_T ∇h)·(p_j − p_i) (∇h projected onto each end's
tangent plane: a chord across a fold cuts below the surface, so the ambient derivative of a linear
h would show no dip). Where D changes sign so that |h| decreases then increases, H' has exactly
one root λ* in (0, 1) (found by bisection), and the edge counts as touching when

    |H(λ*)| ≤ TOUCH_TOLERANCE · (σD_j − σD_i),    σ the sign of h at the ends.

σD_j − σD_i is the change of h's derivative across the edge, about κℓ² with κ the second
derivative of h along the surface in the edge's direction and ℓ the edge's length, so the test is
scale-free: h's smallest value along the edge is at most a fiftieth of what the curvature alone
makes it rise over the edge. At exact tangency H(λ*) is 0 up to the interpolation error and
round-off (the ratio is at most 1.1e-3 on 99% of the edges crossing Figure 15's circle at
resolution 48); off tangency by m, with h ≈ m + κs²/2, the ratio is m/(κℓ²),
so an edge lights up only while the true slice is a loop of radius √(2m/κ) ≤ √(2·TOUCH_TOLERANCE)ℓ
= 0.2ℓ, smaller than the edge itself. On the side where the dip stops short of zero (h keeps
its sign: no slice at all) it lights up only while σH(λ*) ≤ SAME_SIDE_TOLERANCE·(σD_j − σD_i),
what interpolation leaves at an exact tangency: at Figure 15's t = c the wrongly lit half
circle now goes out at c ≈ 1e-5 instead of 1e-4 (tests/geometry/test_touching.py).
A triangle with two touching edges (the first two, in the
order (0, 1), (1, 2), (2, 0)) gives a segment between the points at λ*; a triangle the value
crosses gives its sign-change segment instead, never both.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

#: |H(λ*)| over the change of the derivative across the edge (about κℓ²), at most.
TOUCH_TOLERANCE = 0.02
#: σH(λ*) over the same, at most: the dip must reach zero, or come within what interpolation
#: leaves at an exact tangency (the ratio is at most 9e-4 on 99% of the edges crossing Figure
#: 15's circle at resolution 48). Without it, just after the tangency the half of the circle
#: where h stays below zero lit up too, where the true slice is absent (issue 32).
SAME_SIDE_TOLERANCE = 2e-3
#: Bisection steps for the root of H' on [0, 1] (λ* to 2⁻¹⁶).
BISECTION_STEPS = 16

_EDGES = ((0, 1), (1, 2), (2, 0))


def tangential_gradient(gradient: ArrayLike, normals: ArrayLike) -> np.ndarray:
    """(V, 4): a gradient (one 4-vector, or one per vertex) minus its parts along each vertex's
    two orthonormal normals (normals (V, 2, 4); zero at singular points, leaving it whole)."""
    normals = np.asarray(normals, dtype=float)
    g = np.broadcast_to(np.asarray(gradient, dtype=float), normals[:, 0].shape)
    return g - np.einsum("vk,vki->vi", np.einsum("vki,vi->vk", normals, g), normals)


def hermite_dip(
    h0: ArrayLike, h1: ArrayLike, d0: ArrayLike, d1: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each edge: whether |h| dips on it (same sign at the ends, σd0 < 0 < σd1), the λ* in
    [0, 1] where the cubic Hermite interpolant's derivative vanishes, and H(λ*)."""
    h0, h1, d0, d1 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (h0, h1, d0, d1)))
    sign = np.where(h0 > 0, 1.0, -1.0)
    dip = ((h0 > 0) == (h1 > 0)) & (h0 != 0) & (h1 != 0) & (sign * d0 < 0) & (sign * d1 > 0)
    a = 3 * (h1 - h0) - 2 * d0 - d1
    b = 2 * (h0 - h1) + d0 + d1
    lo, hi = np.zeros_like(h0), np.ones_like(h0)
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        slope = d0 + mid * (2 * a + 3 * b * mid)
        below = sign * slope < 0  # |h| still decreasing: the minimum is further on
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    lam = 0.5 * (lo + hi)
    value = h0 + lam * (d0 + lam * (a + b * lam))
    return dip, lam, value


def touching_edges(
    h0: ArrayLike, h1: ArrayLike, d0: ArrayLike, d1: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Whether each edge touches zero (hermite_dip, then the tolerance), and λ* on it."""
    dip, lam, value = hermite_dip(h0, h1, d0, d1)
    sign = np.where(np.asarray(h0) > 0, 1.0, -1.0)
    rise = sign * (np.asarray(d1, dtype=float) - np.asarray(d0, dtype=float))
    near = (np.abs(value) <= TOUCH_TOLERANCE * rise) & (sign * value <= SAME_SIDE_TOLERANCE * rise)
    return dip & near, lam


def touching_segments(
    positions: ArrayLike,
    triangles: ArrayLike,
    values: ArrayLike,
    gradients: ArrayLike,
    singular: np.ndarray | None = None,
) -> np.ndarray:
    """Segments (S, 2, dim) where ``values`` touches zero without changing sign: per triangle with
    no sign change, the points on its first two touching edges. ``gradients`` (V, 4) are the
    values' gradients along the surface (tangential_gradient); ``singular`` (V,) marks vertices
    whose edges are skipped (zero normals: no tangent plane)."""
    positions = np.asarray(positions, dtype=float)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    values = np.asarray(values, dtype=float)
    gradients = np.asarray(gradients, dtype=float)
    if singular is None:
        singular = np.zeros(len(positions), dtype=bool)
    positive = values[triangles] > 0
    crossed = positive.any(axis=1) & ~positive.all(axis=1)  # the shader's crossing()
    hits, points = [], []
    for i, j in _EDGES:
        a, b = triangles[:, i], triangles[:, j]
        d = positions[b] - positions[a]
        ok, lam = touching_edges(
            values[a],
            values[b],
            np.einsum("ij,ij->i", gradients[a], d),
            np.einsum("ij,ij->i", gradients[b], d),
        )
        hits.append(ok & ~singular[a] & ~singular[b] & ~crossed)
        points.append(positions[a] + lam[:, None] * d)
    hits_ = np.stack(hits, axis=1)  # (T, 3)
    points_ = np.stack(points, axis=1)  # (T, 3, dim)
    rows = np.flatnonzero(hits_.sum(axis=1) >= 2)
    first = np.argmax(hits_[rows], axis=1)
    rest = hits_[rows].copy()
    rest[np.arange(len(rows)), first] = False
    second = np.argmax(rest, axis=1)
    return np.stack([points_[rows, first], points_[rows, second]], axis=1)


#: The tangency test is worth running only near a critical value of x_a on the surface: where
#: some vertex's tangential gradient |P_T e_a| is at most this (the axis within 60° of the
#: normal plane) and its x_a within an edge's length of the slice.
GATE_GRADIENT = 0.5


def critical_values(positions: ArrayLike, normals: ArrayLike) -> tuple[np.ndarray, ...]:
    """Per axis a, the sorted x_a of the regular vertices where |P_T e_a| ≤ GATE_GRADIENT: a
    slice x_a = c can touch the surface only near these (normals orthonormal, so |P_T e_a|² =
    1 − n1_a² − n2_a²)."""
    positions = np.asarray(positions, dtype=float)
    normals = np.asarray(normals, dtype=float)
    regular = np.einsum("ij,ij->i", normals[:, 0], normals[:, 0]) > 0.25
    tangential = 1.0 - normals[:, 0] ** 2 - normals[:, 1] ** 2  # (V, 4): |P_T e_a|² per axis
    near = regular[:, None] & (tangential <= GATE_GRADIENT**2)
    return tuple(np.sort(positions[near[:, a], a]) for a in range(positions.shape[1]))


def near_critical(values: np.ndarray, at: float, band: float) -> bool:
    """Whether a sorted array of critical values has one within ``band`` of ``at``."""
    i = int(np.searchsorted(values, at - band))
    return i < len(values) and values[i] <= at + band
