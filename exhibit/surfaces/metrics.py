"""How closely a mesh meets what it should: its cut at the domain box and its singular set.

`exhibit inspect --json` reports both per implicit part:

- ``boundary_box_distance``: the largest distance of a boundary vertex from the nearest face of
  the part's box (0 for closed parts). Boundary vertices come from the cut at the box
  (`implicit._clip_to_box`), so this is 0 up to rounding wherever the surface leaves its box;
  a hole anywhere else in the mesh shows up here.
- ``singular_gap``: the largest distance from the traced singular set (the singular points the
  polygonizer found, and those traced along singular curves) to the mesh's triangles.

and how closely the mesh follows the surface between its vertices (`surface_sag`):

- ``max_vertex_distance``: the largest distance of a vertex from the true surface;
- ``max_sag``: the largest distance of an edge's midpoint or a triangle's centroid from it (the
  triangles' sag, largest where the surface bends fast: next to a pinch or a singular circle).

Distances to f1 = f2 = 0 are estimated by `distance_to_surface`: the minimum-norm Newton
projection, then foot-point steps (move along the tangent plane towards the point, project
again) while they bring the surface point nearer. Every estimate is the distance to a point of
the surface, so it can only overestimate; near a pinch, where the Jacobian is nearly singular,
the plain Newton step alone overestimated the cusp's sag almost threefold.

"A point of the surface" is meant to the last digit, not to a residual tolerance: a vertex
already within Newton's tolerance gets one more step (so a vertex 8e-13 off reads 8e-13, not
0), and next to a singular set, where a residual of 1e-9 allows a point to sit 1e-7 off the
surface (the cusp's f2 = v² - u³ is 6e-21 at u = -1.9e-7), the projection is iterated until it
stops moving (`_project_near_singular`). Before, `inspect` said 1.0e-7 for the cusp's vertices,
whose true largest distance is 2.6e-7 (tests/surfaces/test_vertex_distance.py).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from exhibit.surfaces.expressions import ScalarField
from exhibit.surfaces.newton import project_onto
from exhibit.surfaces.singular import project_onto_singular_set


def boundary_vertices(triangles: np.ndarray) -> np.ndarray:
    """Indices of the vertices on boundary edges (edges with one triangle)."""
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(tris) == 0:
        return np.zeros(0, dtype=np.int64)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return np.unique(unique[counts == 1])


def boundary_box_distance(
    positions: ArrayLike, triangles: np.ndarray, lo: ArrayLike, hi: ArrayLike
) -> float:
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


def point_triangle_distance(
    p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
) -> np.ndarray:
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


def distance_to_mesh(
    points: ArrayLike, positions: np.ndarray, triangles: ArrayLike, candidates: int = 24
) -> np.ndarray:
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


#: Foot-point steps after the first projection (each a tangent step and a Newton projection).
FOOT_POINT_STEPS = 8
#: Iterations of the projection next to a singular set (it converges linearly there).
SINGULAR_ITERATIONS = 400
#: That projection has stopped once its step is below this fraction of the distance travelled.
STILL = 1e-6
#: Singular values the pseudo-inverse keeps (relative) with the minors added: they are rank 3
#: on a singular curve and not quite consistent once scaled (u/3 from f2, u/2 from a minor),
#: and at 1e-6 that mismatch was amplified into a slide along the circle (7.9e-4 at
#: resolution 32).
MINORS_RCOND = 1e-3


@np.errstate(all="ignore")
def _newton_step(fields, y: np.ndarray) -> np.ndarray:
    """One more minimum-norm Newton step y - Jᵀ(JJᵀ)⁻¹F(y), taken even where `project_onto`
    stopped at its tolerance (1e-13 of the gradient): where J is well conditioned this puts the
    point on the surface to rounding, so a vertex 8e-13 off is measured 8e-13 off, not 0."""
    if len(y) == 0:
        return y
    values = np.stack([f.value(y) for f in fields], axis=-1)
    jac = np.stack([f.gradient(y) for f in fields], axis=1)
    gram = jac @ np.transpose(jac, (0, 2, 1))
    solved = np.linalg.solve(gram + 1e-300 * np.eye(len(fields)), values[..., None])[..., 0]
    out = y - np.einsum("nki,nk->ni", jac, solved)
    return np.where(np.isfinite(out).all(axis=1)[:, None], out, y)


def _tangent_step(fields, y: np.ndarray, toward: np.ndarray) -> np.ndarray:
    """(toward - y) with its normal part (the span of the fields' gradients at y) removed."""
    d = toward - y
    jac = np.stack([f.gradient(y) for f in fields], axis=1)  # (N, k, 4)
    gram = jac @ np.transpose(jac, (0, 2, 1))
    with np.errstate(all="ignore"):
        coeff = np.linalg.solve(
            gram + 1e-300 * np.eye(len(fields)), np.einsum("nki,ni->nk", jac, d)[..., None]
        )[..., 0]
    step = d - np.einsum("nki,nk->ni", jac, coeff)
    return np.where(np.isfinite(step), step, 0.0)


@np.errstate(all="ignore")
def _project_near_singular(fields, points: np.ndarray, max_move: float, rcond: float = 1e-6):
    """Gauss-Newton onto {f = 0} for points where the plain projection met a nearly singular
    Jacobian: next to a singular curve, where the fields' zero sets still meet but a gradient
    vanishes (the cusp's f2 = v² - u³ at u = v = 0) or two become parallel. Each equation is
    divided by its gradient's length (so a vanishing gradient still steers its field to zero,
    linearly at a double zero) and the pseudo-inverse drops singular values under 1e-6 (the
    dependent direction). Converged: |f_i|/|∇f_i| ≤ 1e-9 for every field and the step below
    STILL of the way travelled (the point has stopped), within ``max_move``.
    (Next to the cusp's circle the first step can overshoot to u < 0, where v² = u³ has no
    points but u = v = 0, and Gauss-Newton then creeps: those points are left to the singular
    set's own projection.)
    Returns (positions, converged)."""
    x = points.copy()
    converged = np.zeros(len(x), dtype=bool)
    going = np.ones(len(x), dtype=bool)
    for _ in range(SINGULAR_ITERATIONS):
        idx = np.flatnonzero(going)
        if len(idx) == 0:
            break
        xa = x[idx]
        values = np.stack([f.value(xa) for f in fields], axis=-1)  # (A, k)
        jac = np.stack([f.gradient(xa) for f in fields], axis=1)  # (A, k, 4)
        length = np.linalg.norm(jac, axis=-1)
        usable = np.isfinite(values).all(axis=1) & np.isfinite(jac).all(axis=(1, 2))
        # a field with a zero gradient is satisfied only where it vanishes (it gives no step)
        flat = length == 0
        usable &= np.all(~flat | (values == 0), axis=1)
        length = np.where(~flat, length, 1.0)
        scaled = np.where(usable[:, None] & ~flat, values / length, 0.0)
        unit = np.where(usable[:, None, None], jac / length[..., None], 0.0)
        step = np.einsum("nik,nk->ni", np.linalg.pinv(unit, rcond=rcond), scaled)
        step = np.where(np.isfinite(step), step, 0.0)
        # Still: the residual is within tolerance and the step no longer moves the point
        # (next to a singular set the residual is tiny long before the point is on the
        # surface: Newton on u³ = 0 creeps by a third each step). The remaining error is
        # then about twice the last step, a millionth of the distance travelled.
        travelled = np.linalg.norm(xa - points[idx], axis=1)
        still = np.linalg.norm(step, axis=1) <= STILL * travelled
        done = usable & np.all(np.abs(scaled) <= 1e-9, axis=1) & still
        converged[idx[done]] = True
        going[idx[done | ~usable]] = False
        step_on = usable & ~done
        x[idx[step_on]] = xa[step_on] - step[step_on]
    within = np.linalg.norm(x - points, axis=1) <= max_move
    return x, converged & within


@np.errstate(all="ignore")
def distance_to_surface(
    fields: Sequence[ScalarField],
    points: ArrayLike,
    max_move: float,
    fallback: ArrayLike | None = None,
    known: np.ndarray | None = None,
) -> np.ndarray:
    """How far each point is from {f = 0 for f in fields}: the distance to a point of the surface
    found by Newton (minimum-norm steps) and foot-point steps, or ``fallback`` (an upper bound per
    point, e.g. the distance to a nearby vertex) where that is smaller, or where Newton fails (a
    nearly singular Jacobian, no convergence within ``max_move``) the distance to the nearest of
    ``known`` points of the surface (the traced singular set) if smaller. inf where nothing gives
    a bound."""
    p = np.asarray(points, dtype=float).reshape(-1, 4)
    best = np.full(len(p), np.inf) if fallback is None else np.asarray(fallback, dtype=float).copy()
    if len(p) == 0:
        return best
    y, singular, unconverged = project_onto(fields, p, max_move)
    ok = ~singular & ~unconverged
    y[ok] = _newton_step(fields, y[ok])
    dist = np.where(ok, np.linalg.norm(y - p, axis=1), np.inf)
    stuck = np.flatnonzero(~ok)
    if len(stuck):
        near, converged = _project_near_singular(fields, p[stuck], max_move)
        dist[stuck[converged]] = np.linalg.norm(near[converged] - p[stuck[converged]], axis=1)
        if known is not None and len(known) and len(fields) == 2:
            # next to a singular curve the nearest point is often on it: Gauss-Newton on f1, f2
            # and J's minors from the point lands there (to its tolerance, 1e-10 on minors that
            # vanish quadratically: the cusp's circle to 1e-7), then the projection above
            # finishes the way onto the surface
            on_set, found = project_onto_singular_set(fields[0], fields[1], p[stuck], max_move)
            values = np.stack([f.value(on_set) for f in fields], axis=-1)
            found &= np.all(np.abs(values) <= 1e-9, axis=1)
            on_set[found], still = _project_near_singular(
                _with_minors(fields), on_set[found], max_move, MINORS_RCOND
            )
            found[np.flatnonzero(found)[~still]] = False
            to_set = np.where(found, np.linalg.norm(on_set - p[stuck], axis=1), np.inf)
            dist[stuck] = np.minimum(dist[stuck], to_set)
            failed = stuck[~np.isfinite(dist[stuck])]
            dist[failed] = _nearest_distance(p[failed], np.asarray(known).reshape(-1, 4))
    for _ in range(FOOT_POINT_STEPS):
        idx = np.flatnonzero(ok & (dist > 0))
        if len(idx) == 0:
            break
        z = y[idx] + _tangent_step(fields, y[idx], p[idx])
        moved, sing, unconv = project_onto(fields, z, max_move)
        moved[~sing & ~unconv] = _newton_step(fields, moved[~sing & ~unconv])
        nearer = np.linalg.norm(moved - p[idx], axis=1)
        better = ~sing & ~unconv & (nearer < dist[idx])
        gain = dist[idx][better] - nearer[better]
        y[idx[better]] = moved[better]
        dist[idx[better]] = nearer[better]
        ok[idx[~better]] = False  # no progress: this one is done
        if not better.any() or gain.max() <= 1e-12 * max(float(dist[idx].max()), 1e-300):
            break
    return np.minimum(best, dist)


def _with_minors(fields) -> tuple:
    """f1, f2 and the six 2x2 minors of their Jacobian, as fields: the singular set's equations.
    Projected onto with every equation scaled by its gradient (`_project_near_singular`), a
    point next to the cusp's circle goes to it linearly in each direction (the minors vanish
    like u² and v there), where f1, f2 alone let v wander: v² = u³ has no root at u < 0.
    Cached on f1 (as `singular.project_onto_singular_set` caches its system)."""
    f1, f2 = fields
    cache = f1.__dict__.setdefault("_minor_fields", {})
    if id(f2) not in cache:
        g1, g2 = f1.gradient_expressions, f2.gradient_expressions
        cache[id(f2)] = (f1, f2) + tuple(
            ScalarField(g1[i] * g2[j] - g1[j] * g2[i], f1.symbols)
            for i, j in itertools.combinations(range(4), 2)
        )
    return cache[id(f2)]


def _nearest_distance(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest of a (small) set of targets; inf if none."""
    out = np.full(len(points), np.inf)
    if len(targets) == 0:
        return out
    for start in range(0, len(points), 256):
        chunk = points[start : start + 256]
        d = np.linalg.norm(chunk[:, None] - targets[None], axis=-1)
        out[start : start + 256] = d.min(axis=1)
    return out


def unique_edges(triangles: np.ndarray) -> np.ndarray:
    """The undirected edges (E, 2) of a triangle mesh, each once, lower index first."""
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0)


def surface_sag(
    fields: Sequence[ScalarField],
    positions: ArrayLike,
    triangles: ArrayLike,
    cell: float,
    singular_positions: np.ndarray | None = None,
) -> dict:
    """``max_vertex_distance`` and ``max_sag`` (see the module's docstring) of a mesh of
    f1 = f2 = 0, with Newton allowed to move a point two ``cell`` sizes. A vertex Newton cannot
    place (a singular vertex) is measured to the nearest traced singular point; edge midpoints
    and centroids are bounded by their distance to the nearest corner (a point of the surface up
    to its own distance)."""
    p = np.asarray(positions, dtype=float).reshape(-1, 4)
    tris = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    known = np.zeros((0, 4)) if singular_positions is None else np.asarray(singular_positions)
    known = known.reshape(-1, 4)
    vertex = distance_to_surface(fields, p, 2.0 * cell, known=known)
    if len(tris) == 0:
        return {"max_vertex_distance": float(vertex.max(initial=0.0)), "max_sag": 0.0}
    edges = unique_edges(tris)
    a, b = p[edges[:, 0]], p[edges[:, 1]]
    midpoint_bound = 0.5 * np.linalg.norm(b - a, axis=1) + np.minimum(
        vertex[edges[:, 0]], vertex[edges[:, 1]]
    )
    midpoints = distance_to_surface(fields, 0.5 * (a + b), 2.0 * cell, midpoint_bound, known)
    centroid = p[tris].mean(axis=1)
    corner = np.linalg.norm(p[tris] - centroid[:, None], axis=-1) + vertex[tris]
    centroids = distance_to_surface(fields, centroid, 2.0 * cell, corner.min(axis=1), known)
    used = np.unique(tris)
    return {
        "max_vertex_distance": float(vertex[used].max()),
        "max_sag": float(max(midpoints.max(), centroids.max())),
    }
