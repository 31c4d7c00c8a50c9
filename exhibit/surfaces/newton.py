"""Newton projection onto the zero set of a few fields: the minimum-norm step
x <- x - Jᵀ(JJᵀ)⁻¹F, used to put mesh vertices on f1 = f2 = 0 (`implicit.py`), cut points on a
box face, refined edge midpoints (`adaptive.py`) and to measure how far a point is from the
surface (`metrics.py`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

#: σ_min/σ_max of the Jacobian below which a vertex counts as a singular point.
SINGULAR_RATIO = 1e-6
NEWTON_ITERATIONS = 40
#: Newton stops once max(|f1|, |f2|) at a vertex is below this (relative to the gradient size).
NEWTON_TOLERANCE = 1e-13


def _extreme_eigenvalues(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest eigenvalues of symmetric (A, k, k) matrices. For k = 2 (a surface's
    two fields) in closed form: LAPACK's per-matrix call overhead was a third of Newton's time;
    the smallest is det/largest, which keeps its relative accuracy as it goes to zero."""
    if gram.shape[-1] != 2:
        eig = np.linalg.eigvalsh(gram)
        return eig[:, 0], eig[:, -1]
    a, b, c = gram[:, 0, 0], gram[:, 0, 1], gram[:, 1, 1]
    largest = 0.5 * (a + c) + np.hypot(0.5 * (a - c), b)
    smallest = (a * c - b * b) / np.maximum(largest, 1e-300)
    return smallest, largest


def _solve_gram(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """gram⁻¹ rhs for symmetric (A, k, k) matrices that are well conditioned (the singular ones
    are already set aside): Cramer's rule for k = 2, LAPACK otherwise."""
    if gram.shape[-1] != 2:
        return np.linalg.solve(gram, rhs[..., None])[..., 0]
    a, b, c = gram[:, 0, 0], gram[:, 0, 1], gram[:, 1, 1]
    det = a * c - b * b
    return (
        np.stack([c * rhs[:, 0] - b * rhs[:, 1], a * rhs[:, 1] - b * rhs[:, 0]], axis=1)
        / det[:, None]
    )


@np.errstate(all="ignore")
def project_onto(
    fields: Sequence[Field], points: np.ndarray, max_move: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton-project points onto {f = 0 for f in fields} with the minimum-norm step
    x <- x - Jᵀ(JJᵀ)⁻¹F (k fields, k <= 4).

    Returns (positions, singular, unconverged): where σ_min/σ_max of J falls below
    SINGULAR_RATIO, or a point would move more than ``max_move``, it keeps its start position;
    so does a point where a value or the Jacobian is not finite (it counts as unconverged).
    """
    x = points.copy()
    start = points.copy()
    singular = np.zeros(len(x), dtype=bool)
    failed = np.zeros(len(x), dtype=bool)
    active = np.ones(len(x), dtype=bool)
    for _ in range(NEWTON_ITERATIONS):
        if not active.any():
            break
        idx = np.nonzero(active)[0]
        xa = x[idx]
        values = np.stack([f.value(xa) for f in fields], axis=-1)  # (A, k)
        jac = np.stack([f.gradient(xa) for f in fields], axis=1)  # (A, k, 4)
        gram = jac @ np.transpose(jac, (0, 2, 1))  # (A, k, k)
        finite = np.isfinite(values).all(axis=1) & np.isfinite(gram).all(axis=(1, 2))
        failed[idx[~finite]] = True
        active[idx[~finite]] = False
        idx, xa, values, jac, gram = (
            idx[finite],
            xa[finite],
            values[finite],
            jac[finite],
            gram[finite],
        )
        smallest, largest = _extreme_eigenvalues(gram)
        ratio = np.sqrt(np.maximum(smallest, 0.0) / np.maximum(largest, 1e-300))
        is_singular = ratio < SINGULAR_RATIO
        scale = np.sqrt(np.maximum(largest, 1e-300))
        done = np.max(np.abs(values), axis=1) <= NEWTON_TOLERANCE * np.maximum(scale, 1.0)
        singular[idx[is_singular]] = True
        ok = ~is_singular & ~done
        if ok.any():
            solved = _solve_gram(gram[ok], values[ok])
            x[idx[ok]] = xa[ok] - np.einsum("aki,ak->ai", jac[ok], solved)
        active[idx[is_singular | done]] = False
    runaway = ~(np.linalg.norm(x - start, axis=1) <= max_move) | failed
    unconverged = (active | runaway) & ~singular
    x[singular | runaway] = start[singular | runaway]
    return x, singular, unconverged


class Field(Protocol):
    """A scalar function of R^4 with its gradient, vectorised over points (..., 4): a
    ScalarField, or a :class:`CoordinatePlane` (a box face, a slicing hyperplane)."""

    def value(self, points: np.ndarray) -> np.ndarray: ...

    def gradient(self, points: np.ndarray) -> np.ndarray: ...


class CoordinatePlane:
    """The field x[axis] - bound (a box face, a slicing hyperplane) for project_onto and Newton."""

    def __init__(self, axis: int, bound: float):
        self.axis, self.bound = axis, bound

    def value(self, points: np.ndarray) -> np.ndarray:
        return points[..., self.axis] - self.bound

    def gradient(self, points: np.ndarray) -> np.ndarray:
        g = np.zeros(points.shape)
        g[..., self.axis] = 1.0
        return g
