"""Curves where a function on a surface touches zero without changing sign (double zeros).

Tracing sign changes of h on the mesh cannot see a zero that h only touches: the silhouette of
the collision along y, z (s = 4yt, and t ≤ 0 on the sheet z > 0, so s keeps its sign across
the circle t = 0, x = 0), or the slice t = 0 where the hyperplane is tangent to the surface. Such
a zero is where |h| has a minimum across the curve. So on every mesh edge whose ends have the same
sign, the derivative of h along the surface in the edge's direction (h's own gradient projected
onto the tangent plane at each end) is checked for a sign change
that makes |h| dip; the dip, estimated from the derivatives, seeds Newton on the caller's exact
system (surface and h = 0). A converged point is kept only if h's gradient along the surface
vanishes there too (|P_T ∇h| at most TANGENTIAL_TOLERANCE times its largest value over the
mesh's vertices): the zero is really a double one, so simple zeros, which the sign-change
tracer already has, are not found twice. Kept points are
joined like marching triangles: a triangle with two kept edges gives a segment between them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from exhibit.surfaces.curves import chain_segments
from exhibit.surfaces.mesh import Curve, Material, Surface

if TYPE_CHECKING:
    from exhibit.surfaces.exact_silhouette import RefineStats, SilhouetteSystem
    from exhibit.surfaces.expressions import ScalarField

#: |∇h along the surface| at a kept point over its largest value at the mesh's vertices, at most.
#: Newton on a double zero converges linearly to about √(residual) ≈ 1e-6 off the curve, where
#: the ratio is of that order; at a simple zero it is of order 1.
TANGENTIAL_TOLERANCE = 1e-4


def surface_gradient(surface: Surface, gradients: np.ndarray) -> np.ndarray:
    """∇h projected onto each vertex's tangent plane (the normals are orthonormal pairs)."""
    n = surface.normals
    return gradients - np.einsum("vk,vki->vi", np.einsum("vki,vi->vk", n, gradients), n)


def dip_candidates(
    surface: Surface, values: np.ndarray, gradients: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Edges (E, 2) on which |h| dips between two ends of the same sign, and the seed points
    (E, 4) where the linear interpolant of the edge derivative vanishes."""
    tris = np.asarray(surface.triangles, dtype=np.int64).reshape(-1, 3)
    p = surface.positions
    pairs = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    # one integer per edge: np.unique on rows (axis=0) sorts ten times slower, same order
    keys = np.unique(pairs[:, 0] * len(p) + pairs[:, 1])
    edges = np.stack([keys // len(p), keys % len(p)], axis=1)
    # h's derivative along the surface: a chord across a fold cuts below it, so the ambient
    # derivative of a linear h (the slice's t) along the chord would show no dip at all.
    tangential = surface_gradient(surface, gradients)
    a, b = edges[:, 0], edges[:, 1]
    d = p[b] - p[a]
    ha, hb = values[a], values[b]
    da = np.einsum("ij,ij->i", tangential[a], d)
    db = np.einsum("ij,ij->i", tangential[b], d)
    sign = np.sign(ha)
    with np.errstate(all="ignore"):
        dip = (ha * hb > 0) & (sign * da < 0) & (sign * db > 0)
        lam = np.clip(da / (da - db), 0.0, 1.0)
        # h along the edge with a linear derivative: h_a + da λ / 2 at its minimum
        lowest = sign * (ha + 0.5 * da * lam)
        dip &= lowest <= 0.5 * np.minimum(np.abs(ha), np.abs(hb))
    dip &= np.isfinite(lam)
    return edges[dip], p[a[dip]] + lam[dip, None] * d[dip]


def tangential_part(normals_f: Sequence[np.ndarray], gradient_h: np.ndarray) -> np.ndarray:
    """|P_T ∇h| with T the orthogonal complement of the two normals."""
    n = np.stack(normals_f, 1)  # (N, 2, 4)
    gram = n @ np.transpose(n, (0, 2, 1))
    with np.errstate(all="ignore"):
        coef = np.linalg.solve(gram + 1e-300 * np.eye(2), (n @ gradient_h[..., None]))[..., 0]
    return np.linalg.norm(gradient_h - np.einsum("nk,nki->ni", coef, n), axis=1)


def double_zero_chains(
    surface: Surface,
    values: ArrayLike,
    gradients: ArrayLike,
    refine: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    normals: Callable[[np.ndarray], Sequence[np.ndarray]],
    h_gradient: Callable[[np.ndarray], np.ndarray],
) -> list[tuple[np.ndarray, bool]]:
    """Polylines [(points, closed)] of the double zeros of h on ``surface``.

    ``refine(seeds) -> (points, keep)`` projects seeds onto the exact zero set (and judges them);
    ``normals(points)`` gives the surface's two normals there, ``h_gradient(points)`` ∇h."""
    if len(surface.triangles) == 0:
        return []
    values = np.asarray(values, dtype=float)
    gradients = np.asarray(gradients, dtype=float)
    ok = np.isfinite(values) & np.isfinite(gradients).all(axis=1)
    values, gradients = np.where(ok, values, 0.0), np.where(ok[:, None], gradients, 0.0)
    edges, seeds = dip_candidates(surface, values, gradients)
    if len(edges) == 0:
        return []
    points, keep = refine(seeds)
    scale = np.linalg.norm(surface_gradient(surface, gradients), axis=1).max()
    with np.errstate(all="ignore"):
        keep &= tangential_part(normals(points), h_gradient(points)) <= TANGENTIAL_TOLERANCE * scale
    if not keep.any():
        return []
    index = {(int(a), int(b)): k for k, (a, b) in enumerate(edges) if keep[k]}
    segments = []
    for tri in np.asarray(surface.triangles, dtype=np.int64):
        found = [
            index[key]
            for key in (
                (min(tri[i], tri[j]), max(tri[i], tri[j])) for i, j in ((0, 1), (1, 2), (2, 0))
            )
            if key in index
        ]
        if len(found) >= 2:
            segments.append(found[:2])
    if not segments:
        return []
    # chained by edge number (the same edge gives the same point in both of its triangles)
    ids = np.asarray(segments, dtype=float)[..., None]
    return [
        (points[np.round(chain[:, 0]).astype(int)], closed)
        for chain, closed in chain_segments(ids, 0.5)
    ]


def touching_silhouette(
    f1: ScalarField,
    f2: ScalarField,
    surface: Surface,
    along: tuple[int, int],
    cell: float,
    singular_points: np.ndarray | None = None,
    exclusion_radius: float = 0.0,
    name: str = "",
    material: Material | None = None,
    stats: RefineStats | None = None,
    others: Iterable[np.ndarray] | None = None,
) -> list[Curve]:
    """The silhouette branches along ``along`` where s touches zero without changing sign,
    refined onto f1 = f2 = s = 0 like the traced ones (surfaces/exact_silhouette.py), each open
    end continued along the exact branch (`extend_touching_end`) until the exclusion every
    silhouette point has (σ_min/σ_max of the normals below EXCLUSION_RATIO, or within
    ``exclusion_radius`` of a traced singular point) or half a cell from another branch (one of
    ``others``, the sign-change curves, or another touching one: a crossing)."""
    from exhibit.surfaces.exact_silhouette import RefineStats, SilhouetteSystem
    from exhibit.surfaces.silhouette_curves import drop_fragments

    system = SilhouetteSystem(f1, f2, along)
    p = surface.positions
    total = RefineStats()

    def refine(seeds):
        x, keep, _ = system.refine(seeds, 2.0 * cell, singular_points, exclusion_radius)
        return x, keep

    with np.errstate(all="ignore"):
        chains = double_zero_chains(
            surface,
            system.s.value(p),
            system.s.gradient(p),
            refine,
            lambda x: [f1.gradient(x), f2.gradient(x)],
            system.s.gradient,
        )
    curves = [
        Curve(name, points, material or Material(), closed)
        for points, closed in chains
        if len(points) >= 2
    ]
    # No fragment shorter than a cell (next to a singular point the refined mesh left one of
    # 0.018 in Figure 15's y, z view), none lying along another.
    out = drop_fragments(curves, cell)
    # Each open end continued along the exact branch up to the stated exclusion.
    scale = np.linalg.norm(surface_gradient(surface, system.s.gradient(p)), axis=1)
    scale = float(np.nanmax(scale)) if np.isfinite(scale).any() else 0.0
    for k, curve in enumerate(out):
        if curve.closed:
            continue
        kept = [c.points for j, c in enumerate(out) if j != k] + list(others or [])
        stop = np.concatenate(kept) if kept else np.zeros((0, 4))
        ends = []
        for end, inner in (
            (curve.points[0], curve.points[1]),
            (curve.points[-1], curve.points[-2]),
        ):
            ends.append(
                extend_touching_end(
                    system, end, end - inner, cell, singular_points, exclusion_radius, scale, stop
                )
            )
        curve.points = np.concatenate([ends[0][::-1], curve.points, ends[1]])
    for curve in out:
        total.refined += len(curve.points) + (1 if curve.closed else 0)
        total.max_residual = max(total.max_residual, float(system.residual(curve.points).max()))
    if stats is not None:
        stats.add(total)
    return out


def extend_touching_end(
    system: SilhouetteSystem,
    end: np.ndarray,
    outward: np.ndarray,
    cell: float,
    singular_points: np.ndarray | None,
    exclusion_radius: float,
    scale: float,
    others: np.ndarray,
    reach: float = 8.0,
) -> np.ndarray:
    """Points continuing a touching branch beyond ``end``, a quarter cell at a time (halved down
    to 1/64 cell where a step fails), for up to ``reach`` cells. The mesh stops such a branch
    about a cell short of a singular point or a crossing (it is torn there, and the dip test
    needs an edge on each side); the exact branch goes on. On a double zero the Jacobian of
    (f1, f2, s) has rank 2, so there is no null vector to follow: the predictor is the last
    direction projected onto the tangent plane of the surface, the corrector the same Newton
    and judgement as every silhouette point (``system.refine``), plus the double-zero test
    (|P_T ∇s| at most TANGENTIAL_TOLERANCE of ``scale``). It stops where a point would be
    excluded, would come within half a cell of ``others``, or no step converges."""
    out, p, h, travelled = [], np.asarray(end, float), 0.25 * cell, 0.0
    direction = np.asarray(outward, float)
    with np.errstate(all="ignore"):
        while travelled < reach * cell and h >= cell / 64:
            normals = np.stack([system.f1.gradient(p[None])[0], system.f2.gradient(p[None])[0]])
            if not np.isfinite(normals).all():
                break
            basis = np.linalg.svd(normals)[2][2:]  # the tangent plane's orthonormal basis
            tangent = basis.T @ (basis @ direction)
            length = np.linalg.norm(tangent)
            if not length > 0:
                break
            tangent /= length
            guess = p + h * tangent
            x, keep, _ = system.refine(guess[None], 2.0 * cell, singular_points, exclusion_radius)
            q = x[0]
            double = tangential_part(
                [system.f1.gradient(x), system.f2.gradient(x)], system.s.gradient(x)
            )[0]
            ok = (
                bool(keep[0])
                and double <= TANGENTIAL_TOLERANCE * scale
                and np.linalg.norm(q - guess) <= 0.5 * h
                and (q - p) @ tangent > 0.25 * h
            )
            if not ok:
                h /= 2
                continue
            if len(others) and np.linalg.norm(others - q, axis=1).min() < 0.5 * cell:
                break
            out.append(q)
            travelled += float(np.linalg.norm(q - p))
            direction, p = q - p, q
            h = min(2 * h, 0.25 * cell)
    return np.array(out).reshape(-1, 4)
