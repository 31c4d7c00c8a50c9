"""Singular points of f1 = f2 = 0: where ∇f1 and ∇f2 are dependent and the surface may pinch,
cross itself or end in a cusp (the paper's circle of singular points on the cusp's offset pipe).

Mesh vertices only come near such points, so they are found by a search: from the vertices
where the Jacobian is worst conditioned, Gauss-Newton drives f1, f2 and all six 2x2 minors of the
Jacobian (rank < 2 exactly when they all vanish) to zero together.

The system is built from the fields' differentiable forms, so abs, sign, min and max have finite
derivatives (their derivative almost everywhere); a search that meets a point where something is
not finite stops there and finds nothing.
"""

from __future__ import annotations

import itertools

import numpy as np

from exhibit.surfaces.evaluation import evaluate, lambdify
from exhibit.surfaces.expressions import ScalarField

#: Vertices whose σ_min/σ_max is below this multiple of the cell size (relative to the box)
#: start a search: near a singular set the ratio falls off like the distance to it.
SEED_RATIO_PER_CELL = 4.0
ITERATIONS = 30
TOLERANCE = 1e-10


@np.errstate(all="ignore")
def jacobian_ratio(f1: ScalarField, f2: ScalarField, points: np.ndarray) -> np.ndarray:
    """σ_min/σ_max of the 2x4 Jacobian at each point (0 at singular points, NaN where a
    gradient is not finite)."""
    g1, g2 = f1.gradient(points), f2.gradient(points)
    # Eigenvalues of the 2x2 Gram matrix JJᵀ in closed form (much cheaper than an SVD).
    a, b, c = (
        np.einsum("ni,ni->n", g1, g1),
        np.einsum("ni,ni->n", g1, g2),
        np.einsum("ni,ni->n", g2, g2),
    )
    mean, spread = (a + c) / 2, np.hypot((a - c) / 2, b)
    largest, smallest = mean + spread, np.maximum(mean - spread, 0.0)
    return np.where(largest > 0, np.sqrt(smallest / np.where(largest > 0, largest, 1.0)), 0.0)


class _SingularSystem:
    """F(x) = (f1, f2, minors of J) with its symbolic Jacobian, lambdified once."""

    def __init__(self, f1: ScalarField, f2: ScalarField):
        import sympy  # only when a search runs: it is slow to import

        g1, g2 = f1.gradient_expressions, f2.gradient_expressions
        minors = [g1[i] * g2[j] - g1[j] * g2[i] for i, j in itertools.combinations(range(4), 2)]
        equations = [f1.differentiable, f2.differentiable] + minors
        symbols = f1.symbols
        self._f = [lambdify(symbols, e) for e in equations]
        self._j = [[lambdify(symbols, sympy.diff(e, s)) for s in symbols] for e in equations]

    def residual(self, x):
        return np.stack([evaluate(f, x) for f in self._f], 1)

    def jacobian(self, x):
        return np.stack([np.stack([evaluate(d, x) for d in row], 1) for row in self._j], 1)


@np.errstate(all="ignore")
def find_singular_points(
    f1: ScalarField, f2: ScalarField, vertices: np.ndarray, cell_size: float, box_size: float
) -> np.ndarray:
    """Singular points near the given mesh vertices (deduplicated to cell_size/4), shape (K, 4)."""
    if len(vertices) == 0:
        return np.zeros((0, 4))
    ratio = jacobian_ratio(f1, f2, vertices)
    seeds = vertices[ratio < SEED_RATIO_PER_CELL * cell_size / box_size]
    if len(seeds) == 0:
        return np.zeros((0, 4))
    points = _search_from(f1, f2, seeds, 3 * cell_size)
    if len(points) == 0:
        return np.zeros((0, 4))
    keys = np.round(points / (cell_size / 4)).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return points[np.sort(first)]


@np.errstate(all="ignore")
def _search_from(f1: ScalarField, f2: ScalarField, seeds: np.ndarray, reach: float) -> np.ndarray:
    """Gauss-Newton on (f1, f2, minors) from each seed; the points it converges to within
    ``reach`` of their seed (the rest are dropped)."""
    x, found = project_onto_singular_set(f1, f2, seeds, reach)
    return x[found]


@np.errstate(all="ignore")
def project_onto_singular_set(
    f1: ScalarField, f2: ScalarField, seeds: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Newton on (f1, f2, minors) from each seed: (the points reached, whether each
    converged within ``reach`` of its seed)."""
    cache = f1.__dict__.setdefault("_singular_systems", {})
    system = cache.get(id(f2))
    if system is None:
        system = cache[id(f2)] = _SingularSystem(f1, f2)
    x = seeds.copy()
    going = np.ones(len(x), dtype=bool)
    for _ in range(ITERATIONS):
        if not going.any():
            break
        r = system.residual(x[going])
        j = system.jacobian(x[going])
        jtj = np.einsum("aki,akj->aij", j, j)
        jtr = np.einsum("aki,ak->ai", j, r)
        finite = np.isfinite(jtj).all(axis=(1, 2)) & np.isfinite(jtr).all(axis=1)
        going[np.flatnonzero(going)[~finite]] = False
        jtj, jtr = jtj[finite], jtr[finite]
        if len(jtj) == 0:
            continue
        mu = 1e-12 * np.trace(jtj, axis1=1, axis2=2)[:, None, None] * np.eye(4)
        delta = (np.linalg.pinv(jtj + mu) @ jtr[..., None])[..., 0]
        x[going] -= delta
    r = system.residual(x)
    scale = 1.0 + np.abs(system.residual(seeds)).max(axis=1)
    found = (
        going
        & (np.abs(r).max(axis=1) <= TOLERANCE * scale)
        & (np.linalg.norm(x - seeds, axis=1) <= reach)
    )
    return x, found


def nearest_distance(a: np.ndarray, b: np.ndarray, chunk: int = 128) -> np.ndarray:
    """For each point of a, the distance to the nearest point of b."""
    out = np.empty(len(a))
    for start in range(0, len(a), chunk):
        d = np.linalg.norm(a[start : start + chunk, None] - b[None], axis=-1)
        out[start : start + chunk] = d.min(axis=1)
    return out


def trace_singular_set(
    f1: ScalarField,
    f2: ScalarField,
    points: np.ndarray,
    spacing: float,
    reach: float,
    rounds: int = 6,
    limit: int = 4000,
    max_pairs: int = 200_000,
) -> np.ndarray:
    """The singular set sampled every ``spacing`` along its curves: from the points the search
    found, new searches start at the midpoints of pairs closer than ``reach`` but farther apart
    than ``spacing``, round after round, so gaps along a singular curve fill in (an isolated
    singular point has no partner and stays alone).

    A singular set that is not made of curves (a formula like x - min(x, y) is singular on a
    whole region) would make the pairs grow without bound: tracing stops at ``limit`` points or
    ``max_pairs`` pairs in a round, keeping what it has, so a curator's formula cannot exhaust
    the memory."""
    points = np.asarray(points, dtype=float).reshape(-1, 4)
    for _ in range(rounds):
        if len(points) < 2 or len(points) > limit:
            break
        pieces: list[np.ndarray] = []
        pairs = 0
        for start in range(0, len(points), 256):
            chunk = points[start : start + 256]
            d = np.linalg.norm(chunk[:, None] - points[None], axis=-1)
            i, j = np.nonzero((d > spacing) & (d < reach))
            i = i + start
            keep = i < j
            # only pairs with no point of the set already between them
            a, b = points[i[keep]], points[j[keep]]
            pieces.append((a + b) / 2)
            pairs += len(a)
            if pairs > max_pairs:
                break
        if pairs > max_pairs:
            break
        mids = np.concatenate(pieces) if pieces else np.zeros((0, 4))
        if len(mids) == 0:
            break
        keys = np.round(mids / (spacing / 2)).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        mids = mids[np.sort(first)]
        mids = mids[nearest_distance(mids, points) > spacing / 2]
        if len(mids) == 0:
            break
        new = _search_from(f1, f2, mids, reach)
        if len(new) == 0:
            break
        distance = nearest_distance(new, points)
        new = new[distance > spacing / 4]
        if len(new) == 0:
            break
        keys = np.round(new / (spacing / 4)).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        points = np.concatenate([points, new[np.sort(first)]])
    return points
