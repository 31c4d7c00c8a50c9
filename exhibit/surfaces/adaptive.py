"""Following the surface between the vertices: adaptive refinement of an implicit mesh.

The polygonizer's vertices lie on f1 = f2 = 0 (Newton, residual about 1e-13), but its triangles
are flat, and where the surface bends within a cell they sag off it: next to the cusp's pinch
(the singular circle, where the curvature grows without bound) the dual mesh's triangles were up
to 0.019 off the surface at resolution 48, four times the parabola's pipe, and the sag showed as
sawtooth shading. Here every interior edge whose midpoint is more than a tolerance off the
surface is split at that midpoint, projected onto the surface (minimum-norm Newton, as the
vertices were), a few rounds:

- a projection is rejected (the edge is not split) where Newton meets a nearly singular Jacobian
  or does not converge, where it moves the midpoint more than a third of the edge (it jumped to
  another sheet or another part of the surface), or where the normal plane it lands on is far
  from those of the edge's regular ends (|det(N_mid N_endᵀ)| < MIN_NORMAL_AGREEMENT: the product
  of the cosines of the principal angles between the normal planes);
- boundary and non-manifold edges are never split (the boundary stays the cut at the box, exactly
  on its faces);
- splits are crack-free: a split edge's one new vertex is shared by both its triangles; a
  triangle with three split edges becomes four (red), with two three, with one two (green). A
  triangle with two split edges gets its third split too where that one is allowed, so the
  refined patch is mostly red and only its rim green.

A subdivision never changes the topology: components, Euler characteristic and boundary edges
stay what they were (tests/surfaces/test_sag.py). New vertices get their normals as every vertex
does (∇f1, ∇f2 made orthonormal, Surface.from_normals) and are regular.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from exhibit.geometry.normals import orthonormal_normals
from exhibit.surfaces.metrics import distance_to_surface
from exhibit.surfaces.newton import Field, project_onto
from exhibit.surfaces.parametric import finite_directions
from exhibit.surfaces.singular import nearest_distance, project_onto_singular_set

#: Rounds of splitting (each at most halves an edge; four rounds shrink one 16 times).
ROUNDS = 4
#: A projected midpoint may move at most this fraction of its edge's length.
MAX_MOVE = 1.0 / 3.0
#: Least |det(N_mid N_endᵀ)| between the normal plane at a new vertex and at a regular end.
MIN_NORMAL_AGREEMENT = 0.25


@dataclass
class RefineStats:
    rounds: int = 0
    #: Edges split (new vertices), and those whose midpoint sagged past the tolerance but whose
    #: projection was rejected.
    split: int = 0
    rejected: int = 0
    #: Of the split edges, those split on the singular set.
    onto_singular_set: int = 0


def normal_pairs(fields: Sequence[Field], points: np.ndarray) -> np.ndarray:
    """Orthonormal normal pairs (N, 2, 4) from the fields' gradients, as Surface.from_normals
    makes them (zero where the gradients are dependent or not finite)."""
    with np.errstate(all="ignore"):
        n1 = finite_directions(fields[0].gradient(points))
        n2 = finite_directions(fields[1].gradient(points))
    return orthonormal_normals(n1, n2)


def _edge_keys(edges: np.ndarray) -> np.ndarray:
    return (edges[:, 0].astype(np.int64) << 32) | edges[:, 1].astype(np.int64)


def _triangle_edges(tris: np.ndarray) -> np.ndarray:
    """Keys of each triangle's edges ab, bc, ca, shape (T, 3)."""
    e = np.stack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]], axis=1)  # (T, 3, 2)
    e = np.sort(e, axis=-1)
    return (e[..., 0].astype(np.int64) << 32) | e[..., 1].astype(np.int64)


def split_triangles(tris: np.ndarray, new_vertex: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Split triangles (T, 3) whose edges ab, bc, ca have a new vertex (``new_vertex`` (T, 3), -1
    for an edge not split; ``positions`` hold the new vertices too): 1-2-3 splits that keep each
    triangle's orientation; a two-edge split's quad is cut along its shorter diagonal."""
    marked = new_vertex >= 0
    count = marked.sum(axis=1)
    pieces = [tris[count == 0]]
    # rotate each triangle so that its pattern starts at a fixed edge
    for k, first_edge in ((1, marked), (2, ~marked), (3, None)):
        sel = np.flatnonzero(count == k)
        if len(sel) == 0:
            continue
        t, m = tris[sel], new_vertex[sel]
        shift = np.zeros(len(sel), dtype=np.int64) if first_edge is None else None
        if shift is None:
            assert first_edge is not None
            shift = np.argmax(first_edge[sel], axis=1)
            if k == 2:  # the unmarked edge goes last (ca): start one edge after it
                shift = (shift + 1) % 3
        order = (shift[:, None] + np.arange(3)) % 3
        rows = np.arange(len(sel))[:, None]
        a, b, c = (t[rows, order][:, i] for i in range(3))
        ab, bc, ca = (m[rows, order][:, i] for i in range(3))
        if k == 1:  # ab split
            pieces += [np.stack([a, ab, c], 1), np.stack([ab, b, c], 1)]
        elif k == 2:  # ab and bc split, ca not: the quad a, ab, bc, c
            short = np.linalg.norm(positions[a] - positions[bc], axis=1) <= np.linalg.norm(
                positions[ab] - positions[c], axis=1
            )
            s1 = np.where(short[:, None], np.stack([a, ab, bc], 1), np.stack([a, ab, c], 1))
            s2 = np.where(short[:, None], np.stack([a, bc, c], 1), np.stack([ab, bc, c], 1))
            pieces += [np.stack([ab, b, bc], 1), s1, s2]
        else:
            pieces += [
                np.stack([a, ab, ca], 1),
                np.stack([ab, b, bc], 1),
                np.stack([ca, bc, c], 1),
                np.stack([ab, bc, ca], 1),
            ]
    return np.concatenate(pieces).astype(np.int64)


def _half_sags(fields, a, b, at, reach, singular_set) -> np.ndarray:
    """How far the midpoints of a-at and at-b are from the surface (the larger of the two)."""
    both = np.concatenate([0.5 * (a + at), 0.5 * (at + b)])
    bound = 0.5 * np.concatenate([np.linalg.norm(at - a, axis=1), np.linalg.norm(b - at, axis=1)])
    d = distance_to_surface(fields, both, reach, bound, singular_set)
    return np.maximum(d[: len(a)], d[len(a) :])


def _split_on_singular_set(fields, a, b, newton, newton_ok, sag, tolerance, singular_set):
    """For edges a-b (next to the singular set) whose midpoint sags ``sag``: which to split on
    the singular set instead of at ``newton`` (the projected midpoint, usable where
    ``newton_ok``), the points there and their distances from the midpoints."""
    length = np.linalg.norm(b - a, axis=1)
    mid = 0.5 * (a + b)
    x, found = project_onto_singular_set(fields[0], fields[1], mid, 2.0 * float(length.max()))
    to_a, to_b = np.linalg.norm(x - a, axis=1), np.linalg.norm(x - b, axis=1)
    found &= (np.maximum(to_a, to_b) <= 3.0 * length) & (np.minimum(to_a, to_b) >= 0.1 * length)
    values = np.stack([f.value(x) for f in fields], axis=-1)
    found &= np.all(np.abs(values) <= 1e-9, axis=1)
    off = np.linalg.norm(x - mid, axis=1)
    sag = np.where(newton_ok, sag, off)  # where Newton failed, the midpoint is this far at most
    found &= sag > tolerance
    if not found.any():
        return found, x, off
    reach = 2.0 * float(length.max())
    via_set = np.full(len(a), np.inf)
    via_set[found] = _half_sags(fields, a[found], b[found], x[found], reach, singular_set)
    via_newton = np.full(len(a), np.inf)
    both = found & newton_ok
    via_newton[both] = _half_sags(fields, a[both], b[both], newton[both], reach, singular_set)
    return found & (via_set < via_newton) & (via_set < 0.5 * sag), x, off


@np.errstate(all="ignore")
def refine(
    fields: Sequence[Field],
    positions: np.ndarray,
    normals: np.ndarray,
    singular: np.ndarray,
    triangles: np.ndarray,
    tolerance: float,
    rounds: int = ROUNDS,
    singular_set: np.ndarray | None = None,
    reach: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, RefineStats]:
    """Split the edges whose midpoints sag more than ``tolerance`` off {f = 0 for f in fields}
    (see the module's docstring); edges with a midpoint within ``reach`` of the traced
    ``singular_set`` may be split on it. Returns (positions, normals, singular, triangles,
    stats); the given vertices keep their indices, new ones are appended."""
    stats = RefineStats()
    positions, normals = positions.copy(), normals.copy()
    singular, tris = singular.copy(), np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    fresh_from = 0  # edges touching a vertex at or after this index have not been looked at
    for _ in range(rounds):
        keys = _triangle_edges(tris)
        unique, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
        inverse = inverse.reshape(tris.shape)
        a, b = (unique >> 32).astype(np.int64), (unique & 0xFFFFFFFF).astype(np.int64)
        look = np.flatnonzero((counts == 2) & (np.maximum(a, b) >= fresh_from))
        if len(look) == 0:
            break
        stats.rounds += 1
        pa, pb = positions[a[look]], positions[b[look]]
        length = np.linalg.norm(pb - pa, axis=1)
        mid = 0.5 * (pa + pb)
        moved, sing, unconverged = project_onto(fields, mid, float(length.max()))
        sag = np.linalg.norm(moved - mid, axis=1)
        ok = ~sing & ~unconverged & (sag <= MAX_MOVE * length)
        new_normals = normal_pairs(fields, moved)
        ok &= np.any(new_normals != 0, axis=(1, 2))
        for end in (a[look], b[look]):
            regular = ~singular[end]
            agree = np.abs(np.linalg.det(new_normals @ np.transpose(normals[end], (0, 2, 1))))
            ok &= ~regular | (agree >= MIN_NORMAL_AGREEMENT)
        # An edge across a pinch or a cuspidal edge joins two sheets: its midpoint lies between
        # them and Newton lands on one, leaving half of the edge still across the gap (or meets
        # a singular Jacobian). Such an edge is split where the surface turns, on the singular
        # set (Gauss-Newton on f1, f2 and J's minors), when that leaves its two halves nearer
        # the surface than a split at the projected midpoint would (and under half the sag).
        onto_set = np.zeros(len(look), dtype=bool)
        if singular_set is not None and len(singular_set) and len(fields) == 2:
            try_set = np.flatnonzero((sag > tolerance) | sing | unconverged)
            near = nearest_distance(mid[try_set], singular_set) <= reach
            try_set = try_set[near]
            if len(try_set):
                done, x, off = _split_on_singular_set(
                    fields,
                    pa[try_set],
                    pb[try_set],
                    moved[try_set],
                    ok[try_set],
                    sag[try_set],
                    tolerance,
                    singular_set,
                )
                done_at = try_set[done]
                moved[done_at], new_normals[done_at], sag[done_at] = x[done], 0.0, off[done]
                onto_set[done_at] = ok[done_at] = True
        want = sag > tolerance
        stats.rejected += int((want & ~ok).sum())
        splittable = np.zeros(len(unique), dtype=bool)
        splittable[look[ok]] = True
        split = np.zeros(len(unique), dtype=bool)
        split[look[ok & want]] = True
        if not split.any():
            break
        while True:  # two split edges of a triangle: split the third too where allowed
            per_tri = split[inverse]
            closing = (per_tri.sum(axis=1) == 2)[:, None] & ~per_tri & splittable[inverse]
            if not closing.any():
                break
            split[inverse[closing]] = True
        chosen = np.flatnonzero(split)
        where = np.searchsorted(look, chosen)
        fresh_from = len(positions)
        index = np.full(len(unique), -1, dtype=np.int64)
        index[chosen] = fresh_from + np.arange(len(chosen))
        positions = np.concatenate([positions, moved[where]])
        normals = np.concatenate([normals, new_normals[where]])
        singular = np.concatenate([singular, onto_set[where]])
        stats.onto_singular_set += int(onto_set[where].sum())
        tris = split_triangles(tris, index[inverse], positions)
        stats.split += len(chosen)
    return positions, normals, singular, tris, stats
