"""A planted Lemma 2 point on a small mesh, for the CPU rule (tests/geometry) and the geometry
shader's discs (tests/render)."""

from __future__ import annotations

import numpy as np

from exhibit.surfaces.parametric import grid_triangles

C = 0.3  # the planted Lemma 2 point lies at x = 0, w = C


def planted(n: int, shift: tuple[float, float]):
    """X(x, w) = (x, x w, w²/2 - C w, w): the tangent plane contains e_w exactly where x = 0 and
    w = C, a simple zero of u = P_N e_w. An n x n grid, shifted by ``shift`` cells."""
    h = 2.0 / n
    xs = -1.0 + (np.arange(n + 1) + shift[0]) * h
    ws = -1.0 + (np.arange(n + 1) + shift[1]) * h
    X, W = np.meshgrid(xs, ws, indexing="ij")
    x, w = X.ravel(), W.ravel()
    positions = np.stack([x, x * w, w * w / 2 - C * w, w], axis=1)
    t1 = np.stack([np.ones_like(x), w, 0 * x, 0 * x], axis=1)
    t2 = np.stack([0 * x, x, w - C, np.ones_like(x)], axis=1)
    normals = np.linalg.svd(np.stack([t1, t2], axis=1))[2][:, 2:]  # (V, 2, 4), orthonormal
    # Oriented alike at every vertex (det[t1, t2, n1, n2] > 0), as the polygonizer's ∇f1, ∇f2
    # and the parametric ⊗ normals are: the winding compares neighbouring frames.
    flip = np.linalg.det(np.stack([t1, t2, normals[:, 0], normals[:, 1]], axis=1)) < 0
    normals[flip, 1] *= -1
    return positions, normals, grid_triangles(n + 1, n + 1, False, False)


# Shifts that put the point inside a triangle, on a grid line, on a diagonal, near a vertex.
SHIFTS = [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.25, 0.75), (0.5, 0.5), (1e-9, 0.5), (0.3, 0.3)]
