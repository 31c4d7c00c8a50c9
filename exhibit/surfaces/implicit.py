"""Polygonizing implicit 2-surfaces f1 = f2 = 0 in a box of R^4, with cost that follows the output.

1. Prune coarse-to-fine: a box is split into 16 children only while interval bounds say both f1
   and f2 may vanish in it (bounds are conservative, so no box holding a zero is ever dropped).
   Only about n² of the n⁴ cells survive. The grid is shifted by a random fraction of a cell
   (seeded, so builds are repeatable) so no grid vertex or face sits exactly on a special point.
2. Extract dual quads: in 4D the surface meets the grid's 2-faces (squares) in isolated points.
   Each square is split along its Kuhn diagonal into two triangles; on a triangle the linear
   interpolant of (f1, f2) vanishes at most once, decided exactly by a lexicographic perturbation
   (F - (ε, ε²)), so every 3-face of the grid is crossed an even number of times and the mesh
   closes. A square crossed an odd number of times yields one quad joining the vertices of the
   four cells around it.
3. Place each cell's vertex at the mean of its crossings, then Newton-project it onto the surface
   with the minimum-norm step x <- x - Jᵀ(JJᵀ)⁻¹F. Where σ_min(J)/σ_max(J) is tiny the point is
   singular: it keeps its piecewise-linear position and is reported.

Formulas from scene files may be undefined or overflow on part of the box (sqrt(x) where x < 0,
log(x^2) at x = 0). No NaN or inf reaches the mesh: cells with such corner values hold no
crossing, Newton keeps the start of a point it cannot evaluate, vertices where f1 or f2 is not
finite are dropped with their triangles, and a non-finite gradient makes a zero normal (a
singular vertex). numpy's warnings about those values are silenced: they are handled here.

Why one module of this size: the polygonizer's stages (prune, cross, clip, triangulate) hand
each other large arrays in one layout."""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from exhibit.surfaces import adaptive
from exhibit import progress as progress_line
from exhibit.surfaces.expressions import ScalarField
from exhibit.surfaces.mesh import Material, Surface
from exhibit.surfaces.newton import (  # noqa: F401  (re-exported)
    NEWTON_ITERATIONS,
    NEWTON_TOLERANCE,
    SINGULAR_RATIO,
    CoordinatePlane,
    project_onto,
)
from exhibit.surfaces.parametric import finite_directions, keep_vertices
from exhibit.surfaces.singular import find_singular_points, trace_singular_set

#: Corner values beyond this count as non-finite: the crossing test multiplies two of them.
LARGEST_VALUE = 1e150
#: Cells the grid reaches beyond the box on every side before the mesh is cut at the box.
PAD = 1.5
#: Edges whose midpoint is farther than this many cells off the surface are split
#: (`adaptive.py`): 1/24 of a cell is what the regular parabola's pipe sags at most (0.0049 at
#: resolution 48), so a regular surface is hardly touched and a pinch ends up as smooth.
SAG_TOLERANCE = 1.0 / 24.0

_PAIRS = list(itertools.combinations(range(4), 2))  # the 6 coordinate planes of a square
_OTHERS = [tuple(d for d in range(4) if d not in pair) for pair in _PAIRS]
_CHILD_OFFSETS = np.array(list(itertools.product((0, 1), repeat=4)), dtype=np.int64)
_BITS = 15  # bits per integer grid coordinate in packed keys (grids up to 32768 cells)


@dataclass
class PolygonizeStats:
    resolution: int
    cells: int = 0
    #: Cells whose corner values straddle zero in both functions (the rest hold no crossing).
    straddling: int = 0
    boxes_tested: int = 0
    squares: int = 0
    crossings: int = 0
    singular_points: int = 0
    unconverged: int = 0
    max_residual: float = 0.0
    seconds: float = 0.0
    #: Vertices made where the mesh was cut at the box's faces (and how many of them Newton
    #: could not put on the surface within the face: those stay on the face, off the surface).
    box_cut: tuple[int, int] = (0, 0)
    #: Vertices moved onto the traced singular set so the mesh reaches it.
    snapped: int = 0
    #: Edges split where they sagged off the surface (of them, on the singular set).
    refined: tuple[int, int] = (0, 0)
    levels: list[int] = field(default_factory=list)


@dataclass
class ImplicitResult:
    surface: Surface
    stats: PolygonizeStats
    singular_positions: np.ndarray


def _pack(coords: np.ndarray, extra: np.ndarray | None = None) -> np.ndarray:
    key = np.zeros(len(coords), dtype=np.int64)
    for d in range(coords.shape[1]):
        key = (key << _BITS) | coords[:, d].astype(np.int64)
    if extra is not None:
        key = (key << 3) | extra.astype(np.int64)
    return key


def _evaluate(f1: ScalarField, f2: ScalarField, points: np.ndarray) -> np.ndarray:
    return np.stack([f1.value(points), f2.value(points)], axis=-1)


def _corner_values(f1, f2, origin, h, cells) -> tuple[np.ndarray, np.ndarray]:
    """f1 and f2 at the 16 corners of each cell, two (N, 16) arrays. The corners are built one
    coordinate at a time (origin + integer * h, the same arithmetic as everywhere a grid vertex
    is made): contiguous arrays, where an (N, 16, 4) array's columns and an (N, 16, 2) result's
    reductions over the middle axis ran at half the speed."""
    axes = [origin[d] + (cells[:, d, None] + _CHILD_OFFSETS[None, :, d]) * h[d] for d in range(4)]
    return f1.value_on_axes(axes), f2.value_on_axes(axes)


#: Each plane's square corners v00, v10, v11, v01 as offsets from its base cell, (6, 4, 4).
_RINGS = np.array(
    [
        [
            np.eye(4, dtype=np.int64)[a] * 0,
            np.eye(4, dtype=np.int64)[a],
            np.eye(4, dtype=np.int64)[a] + np.eye(4, dtype=np.int64)[b],
            np.eye(4, dtype=np.int64)[b],
        ]
        for a, b in _PAIRS
    ]
)
#: Cells handled at a time from corner values to crossed squares: their arrays (16 corners,
#: two fields) then stay in the cache, where whole-grid arrays at n = 128 (3.6M values each)
#: made the last doubling of n cost 5.4x instead of 4x.
CHUNK_CELLS = 16384
#: Boxes bounded at a time while pruning.
CHUNK_BOXES = 65536


def _crossed_squares(f1, f2, origin, h, cells):
    """The grid squares the piecewise-linear interpolant may cross: (bases, planes, corner
    values (S, 4, 2), number of straddling cells).

    Only cells whose corners straddle zero in both functions can hold a crossing (a value <= 0
    counts as negative, as the perturbation says). A square crossed by the interpolant
    straddles in both functions, and so does the cell at its base corner (the cell it is the
    lowest face of), so each square is made exactly once, by that cell, with no deduplication,
    and its corner values are taken from the cell's. Positions are always origin + integer
    corner * h, so a grid vertex gets the same value bit for bit wherever it is evaluated."""
    corner_index = {tuple(o): k for k, o in enumerate(_CHILD_OFFSETS.tolist())}
    index = [[corner_index[tuple(v)] for v in ring.tolist()] for ring in _RINGS]
    found: list[tuple[list, list]] = [([], []) for _ in _PAIRS]  # per plane: bases, values
    straddling_cells = 0
    for start in range(0, len(cells), CHUNK_CELLS):
        chunk = cells[start : start + CHUNK_CELLS]
        fields_at_corners = _corner_values(f1, f2, origin, h, chunk)
        straddling = np.ones(len(chunk), dtype=bool)
        for v in fields_at_corners:  # NaN propagates through max and min: such cells drop out
            high, low = v.max(axis=1), v.min(axis=1)
            straddling &= (high > 0) & (low <= 0) & (high < LARGEST_VALUE) & (low > -LARGEST_VALUE)
        chunk = chunk[straddling]
        straddling_cells += len(chunk)
        corner_values = np.stack([v[straddling] for v in fields_at_corners], axis=-1)
        for p in range(len(_PAIRS)):
            square_values = corner_values[:, index[p], :]
            keep = _straddles(square_values)
            found[p][0].append(chunk[keep])
            found[p][1].append(square_values[keep])
    bases = np.concatenate([b for plane in found for b in plane[0]])
    values = np.concatenate([v for plane in found for v in plane[1]])
    planes = np.concatenate(
        [np.full(sum(len(b) for b in plane[0]), p, dtype=np.int64) for p, plane in enumerate(found)]
    )
    return bases, planes, values, straddling_cells


def _prune(f1, f2, origin, h, size, domain_lo, domain_hi, stats, progress) -> np.ndarray:
    """Integer coordinates of the unit cells whose closed boxes may hold a zero of (f1, f2)."""
    boxes = np.zeros((1, 4), dtype=np.int64)
    scale = size
    while True:
        lo = origin + boxes * (scale * h)
        hi = lo + scale * h
        keep = np.all((hi >= domain_lo) & (lo <= domain_hi), axis=1)
        for start in range(0, len(boxes), CHUNK_BOXES):  # cache-sized, as CHUNK_CELLS
            part = slice(start, start + CHUNK_BOXES)
            # f2 is bounded only on the boxes the domain and f1 leave (about half).
            for f in (f1, f2):
                idx = start + np.flatnonzero(keep[part])
                low, high = f.bounds(lo[idx], hi[idx])
                keep[idx] = (low <= 0) & (high >= 0)
        stats.boxes_tested += len(boxes)
        boxes = boxes[keep]
        stats.levels.append(len(boxes))
        if progress:
            progress(f"pruning: {len(boxes)} boxes of side {scale}")
        if scale == 1 or len(boxes) == 0:
            return boxes
        boxes = (2 * boxes[:, None, :] + _CHILD_OFFSETS[None, :, :]).reshape(-1, 4)
        scale //= 2


def _straddles(values: np.ndarray) -> np.ndarray:
    """For corner values (N, corners, 2): both functions have corners on both sides of zero."""
    positive = values > 0
    return np.all(positive.any(axis=1) & ~positive.all(axis=1), axis=1)


def _labelled(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For triangles with (f1, f2) at their corners, shape (T, 3, 2): whether the perturbed linear
    interpolant vanishes inside, and the barycentric coordinates of the unperturbed zero.

    Solves [1 1 1; F1; F2] λ = (1, ε, ε²): λ is positive for all small ε > 0 exactly when each row
    of the inverse matrix is lexicographically positive. Computed with the adjugate so the test is
    the same floating-point arithmetic wherever a triangle appears.
    """
    p0, p1, p2 = values[:, 0, 0], values[:, 1, 0], values[:, 2, 0]
    q0, q1, q2 = values[:, 0, 1], values[:, 1, 1], values[:, 2, 1]
    # adj[i] = row i of the adjugate of M = [1 1 1; p; q], written out (a loop over 3x3 minors
    # with fancy indexing cost twice as much). Row i is (cofactors of M's column i).
    adj = (
        (p1 * q2 - p2 * q1, -(q2 - q1), p2 - p1),
        (-(p0 * q2 - p2 * q0), q2 - q0, -(p2 - p0)),
        (p0 * q1 - p1 * q0, -(q1 - q0), p1 - p0),
    )
    det = adj[0][0] + adj[1][0] + adj[2][0]
    sign = np.sign(det)
    positive = det != 0
    for r0, r1, r2 in adj:  # lexicographic positivity of each row of the inverse times |det|
        lead = np.where(r0 != 0, r0, np.where(r1 != 0, r1, r2))
        positive &= lead * sign > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        bary = np.stack([adj[0][0], adj[1][0], adj[2][0]], axis=1) / det[:, None]
    bary = np.clip(np.nan_to_num(bary), 0.0, 1.0)
    bary /= np.maximum(bary.sum(axis=1, keepdims=True), 1e-300)
    return positive, bary


def reach_singular_set(
    surface: Surface, traced: np.ndarray, radius: float, enough: float, rounds: int = 3
) -> int:
    """Close the gap between the mesh and the traced singular set. Near a pinch or a cusp of the
    surface the grid cannot separate the sheets, and the dual mesh folds over short of the
    singular set. Each sample of the set claims its nearest vertex within ``radius``, and each
    claimed vertex moves onto its nearest claiming sample (an exact point of the surface, marked
    singular, with zero normals); samples still farther than ``enough`` from the triangles claim
    again among the vertices not yet moved. Returns how many vertices moved."""
    from exhibit.surfaces.metrics import distance_to_mesh

    positions = surface.positions
    moved = np.zeros(len(positions), dtype=bool)
    todo = np.arange(len(traced))
    for _ in range(rounds):
        best: dict[int, tuple[float, int]] = {}
        free = np.flatnonzero(~moved)
        if len(free) == 0:  # a singular set that covers the whole mesh
            break
        for start in range(0, len(todo), 64):
            ks = todo[start : start + 64]
            d = np.linalg.norm(traced[ks][:, None] - positions[free][None], axis=-1)
            nearest = np.argmin(d, axis=1)
            for k, j, dist in zip(ks, nearest, d[np.arange(len(ks)), nearest]):
                v = int(free[j])
                if dist < radius and (v not in best or dist < best[v][0]):
                    best[v] = (float(dist), int(k))
        if not best:
            break
        for v, (_, k) in best.items():
            positions[v] = traced[k]
            moved[v] = True
        gap = distance_to_mesh(traced, positions, surface.triangles)
        todo = np.flatnonzero(gap > enough)
        if len(todo) == 0:
            break
    surface.normals[moved] = 0.0
    assert surface.singular is not None  # __post_init__ sets it
    surface.singular[moved] = True
    return int(moved.sum())


def _box_depth(points, lo, hi, scale):
    """How far inside the box each point is, per face (N, 8), in units of each axis's cell."""
    return np.concatenate([(points - lo) / scale, (hi - points) / scale], axis=1)


@np.errstate(all="ignore")
def _clip_to_box(fields, vertices, triangles, singular, lo, hi, cell):
    """Cut the mesh at the box: triangles outside are dropped, triangles across a face are cut
    there, and each cut vertex is Newton-projected onto f1 = f2 = 0 within its face (x_k = bound
    exactly), so the boundary is the surface's own intersection with the face, a smooth polyline.
    Cut points are shared between the two triangles at an edge, so no crack opens."""
    scale = (hi - lo) / max((hi - lo).max(), 1e-300)
    depth = _box_depth(vertices, lo, hi, scale)
    inside = depth.min(axis=1)
    if len(triangles) == 0 or np.all(inside[triangles] >= 0):
        return vertices, triangles, singular, (0, 0)
    tri = triangles.astype(np.int64)
    n_in = (inside[tri] >= 0).sum(axis=1)
    keep = tri[n_in == 3]
    cut_one = tri[n_in == 1]  # one corner inside
    cut_two = tri[n_in == 2]  # two corners inside

    def rotate(t, want_inside):
        """Rotate each triangle so its odd corner comes first (orientation kept)."""
        flag = (inside[t] >= 0) == want_inside
        first = np.argmax(flag, axis=1)
        rows = np.arange(len(t))[:, None]
        return t[rows, (first[:, None] + np.arange(3)) % 3]

    one = rotate(cut_one, True)  # a inside; b, c outside
    two = rotate(cut_two, False)  # a outside; b, c inside
    edges = np.concatenate([one[:, [0, 1]], one[:, [0, 2]], two[:, [1, 0]], two[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    unique, index = np.unique(key, axis=0, return_inverse=True)
    index = index.reshape(-1)
    # the crossing of min-depth = 0 along each edge: bisect on the piecewise-linear depth
    a_pts, b_pts = vertices[unique[:, 0]], vertices[unique[:, 1]]
    a_in = inside[unique[:, 0]] >= 0
    p_in = np.where(a_in[:, None], a_pts, b_pts)
    p_out = np.where(a_in[:, None], b_pts, a_pts)
    t_lo, t_hi = np.zeros(len(unique)), np.ones(len(unique))
    for _ in range(60):
        mid = (t_lo + t_hi) / 2
        m = p_in + mid[:, None] * (p_out - p_in)
        ok = _box_depth(m, lo, hi, scale).min(axis=1) >= 0
        t_lo, t_hi = np.where(ok, mid, t_lo), np.where(ok, t_hi, mid)
    start = p_in + t_lo[:, None] * (p_out - p_in)
    face = np.argmin(_box_depth(start, lo, hi, scale), axis=1)
    bound = np.where(face < 4, lo[face % 4], hi[face % 4])
    axis = face % 4
    new = start.copy()
    failed = np.zeros(len(unique), dtype=bool)
    for k in range(4):
        for b in (lo[k], hi[k]):
            sel = (axis == k) & (bound == b)
            if not sel.any():
                continue
            moved, sing, unconv = project_onto(
                tuple(fields) + (CoordinatePlane(k, b),), start[sel], 2.0 * cell
            )
            moved[:, k] = b
            new[sel] = moved
            failed[sel] = sing | unconv
    base = len(vertices)
    # the index arrays were concatenated: split them back
    n1, n2 = len(one), len(two)
    ab1 = base + index[:n1]
    ac1 = base + index[n1 : 2 * n1]
    ba2 = base + index[2 * n1 : 2 * n1 + n2]
    ca2 = base + index[2 * n1 + n2 :]
    pieces = [
        keep,
        np.stack([one[:, 0], ab1, ac1], 1),
        np.stack([ba2, two[:, 1], two[:, 2]], 1),
        np.stack([ba2, two[:, 2], ca2], 1),
    ]
    all_vertices = np.concatenate([vertices, new])
    all_singular = np.concatenate([singular, np.zeros(len(new), dtype=bool)])
    used, triangles = keep_vertices(
        np.ones(len(all_vertices), dtype=bool), np.concatenate(pieces).astype(np.int64)
    )
    return all_vertices[used], triangles, all_singular[used], (len(new), int(failed.sum()))


@np.errstate(all="ignore")
def polygonize(
    name: str,
    f1: ScalarField,
    f2: ScalarField,
    domain_lo: ArrayLike,
    domain_hi: ArrayLike,
    resolution: int,
    material: Material | None = None,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
    prune: bool = True,
    follow_surface: bool = True,
) -> ImplicitResult:
    """Mesh {f1 = f2 = 0} within the box [domain_lo, domain_hi] at ``resolution`` cells per axis.

    ``prune=False`` visits every cell of the grid (n⁴): the baseline the benchmark compares with.
    ``follow_surface=False`` skips the refinement of edges that sag off the surface (as the mesh
    was before it, for comparisons).
    """
    started = time.perf_counter()
    if progress is None:

        def progress(message: str) -> None:
            progress_line.report(f"{name}: {message}")

    domain_lo = np.asarray(domain_lo, dtype=float)
    domain_hi = np.asarray(domain_hi, dtype=float)
    if domain_lo.shape != (4,) or domain_hi.shape != (4,) or np.any(domain_hi <= domain_lo):
        raise ValueError(f"{name}: the box must have 4 increasing intervals")
    if resolution < 2:
        raise ValueError(f"{name}: resolution must be at least 2")
    stats = PolygonizeStats(resolution=resolution)
    h = (domain_hi - domain_lo) / resolution
    shift = np.random.default_rng(seed).uniform(0.05, 0.95, size=4)
    # The grid reaches PAD cells beyond the box on every side, so the mesh overshoots the box
    # and the cut at its faces (_clip_to_box) is a clean one, not the cells' outline.
    origin = domain_lo - (PAD + shift) * h
    span = resolution + 2 * math.ceil(PAD) + 1
    size = 1 << math.ceil(math.log2(span))
    if prune:
        cells = _prune(
            f1, f2, origin, h, size, domain_lo - PAD * h, domain_hi + PAD * h, stats, progress
        )
    else:
        axes = [np.arange(span)] * 4
        cells = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 4).astype(np.int64)
        stats.boxes_tested = len(cells)
    stats.cells = len(cells)
    empty = Surface(
        name, np.zeros((0, 4)), np.zeros((0, 2, 4)), np.zeros((0, 3)), material or Material()
    )
    if len(cells) == 0:
        stats.seconds = time.perf_counter() - started
        return ImplicitResult(empty, stats, np.zeros((0, 4)))

    bases, planes, values, stats.straddling = _crossed_squares(f1, f2, origin, h, cells)
    stats.squares = len(bases)
    e = np.eye(4, dtype=np.int64)

    # The two Kuhn triangles (v00, v10, v11) and (v00, v01, v11); corner positions only for
    # the squares a triangle is crossed in (origin + integer corner * h, as everywhere).
    tri_index = np.array([[0, 1, 2], [0, 3, 2]])
    crossed = np.zeros(len(bases), dtype=np.int64)
    point_sum = np.zeros((len(bases), 4))
    for tri in tri_index:
        hit, bary = _labelled(values[:, tri, :])
        crossed += hit
        sq = np.flatnonzero(hit)
        corners = origin + (bases[sq, None, :] + _RINGS[planes[sq]][:, tri, :]) * h
        point_sum[sq] += np.einsum("sk,ski->si", bary[sq], corners)
    odd = crossed % 2 == 1
    stats.crossings = int(odd.sum())
    if not odd.any():
        stats.seconds = time.perf_counter() - started
        return ImplicitResult(empty, stats, np.zeros((0, 4)))
    crossing_points = point_sum[odd] / crossed[odd][:, None]

    # The four cells around each crossed square, in cyclic order, and their vertices.
    others = np.array(_OTHERS)[planes[odd]]
    ed1, ed2 = e[others[:, 0]], e[others[:, 1]]
    base = bases[odd]
    ring = np.stack([base, base - ed1, base - ed1 - ed2, base - ed2], axis=1)  # (Q, 4, 4)
    cell_keys, cell_index = np.unique(_pack(ring.reshape(-1, 4) + 1), return_inverse=True)
    cell_index = cell_index.reshape(-1, 4)
    vertex_count = len(cell_keys)
    sums = np.zeros((vertex_count, 4))
    counts = np.zeros(vertex_count)
    np.add.at(sums, cell_index.ravel(), np.repeat(crossing_points, 4, axis=0))
    np.add.at(counts, cell_index.ravel(), 1.0)
    initial = sums / counts[:, None]

    vertices, singular, unconverged = project_onto((f1, f2), initial, 2.0 * float(h.max()))
    stats.unconverged = int(unconverged.sum())

    # Split each quad along its shorter diagonal.
    a, b, c, d = (cell_index[:, k] for k in range(4))
    ac = np.linalg.norm(vertices[a] - vertices[c], axis=1)
    bd = np.linalg.norm(vertices[b] - vertices[d], axis=1)
    use_ac = ac <= bd
    triangles = np.concatenate(
        [
            np.where(use_ac[:, None], np.stack([a, b, c], 1), np.stack([a, b, d], 1)),
            np.where(use_ac[:, None], np.stack([a, c, d], 1), np.stack([b, c, d], 1)),
        ]
    )

    vertices, triangles, singular, stats.box_cut = _clip_to_box(
        (f1, f2), vertices, triangles, singular, domain_lo, domain_hi, float(h.max())
    )

    # Drop vertices off the formulas' domain (with their triangles); positions are finite.
    at_vertices = _evaluate(f1, f2, vertices)
    keep, triangles = keep_vertices(np.isfinite(at_vertices).all(axis=1), triangles)
    vertices, singular, at_vertices = vertices[keep], singular[keep], at_vertices[keep]
    n1 = finite_directions(f1.gradient(vertices))
    n2 = finite_directions(f2.gradient(vertices))
    surface = Surface.from_normals(name, vertices, n1, n2, triangles, material)
    surface.singular = singular | surface.singular
    residual = np.max(np.abs(at_vertices[~singular]), axis=1)
    stats.max_residual = float(residual.max()) if len(residual) else 0.0
    if progress is not None:
        progress("searching for singular points")
    singular_points = find_singular_points(
        f1, f2, vertices, float(h.max()), float(np.max(domain_hi - domain_lo))
    )
    if len(singular_points):
        if progress is not None:
            progress("tracing the singular set")
        cell = float(h.max())
        singular_points = trace_singular_set(f1, f2, singular_points, cell / 4, 3 * cell)
        stats.snapped = reach_singular_set(surface, singular_points, 1.5 * cell, cell / 8)
    if follow_surface and len(surface.triangles):
        if progress is not None:
            progress("following the surface")
        cell = float(h.max())
        assert surface.singular is not None  # __post_init__ sets it
        positions, normals, singular, triangles, refined = adaptive.refine(
            (f1, f2),
            surface.positions,
            surface.normals,
            surface.singular,
            surface.triangles,
            SAG_TOLERANCE * cell,
            singular_set=singular_points,
            reach=1.5 * cell,
        )
        surface = Surface(name, positions, normals, triangles, surface.material, singular)
        stats.refined = (refined.split, refined.onto_singular_set)
    stats.singular_points = len(singular_points)
    stats.seconds = time.perf_counter() - started
    surface.info = {
        "kind": "implicit",
        "max_residual": stats.max_residual,
        "singular_points": stats.singular_points,
        "seconds": stats.seconds,
        "resolution": resolution,
        "cells": stats.cells,
        "box": [domain_lo.tolist(), domain_hi.tolist()],
        "cell_size": float(h.max()),
        "box_cut": list(stats.box_cut),
        "snapped_to_singular_set": stats.snapped,
        "refined_edges": list(stats.refined),
    }
    return ImplicitResult(surface, stats, singular_points)
