"""Silhouette points refined onto the exact silhouette of an implicit surface f1 = f2 = 0.

The mesh only tells where the silhouette function s = (∇f1·e_a)(∇f2·e_b) - (∇f1·e_b)(∇f2·e_a)
(Lemma 3(c); condition C of the offset curves along u, v, C' of the collision along x, y)
changes sign. Each point found there is Newton-projected onto f1 = f2 = s = 0, with s built
symbolically from the scene's own f1, f2, and then judged:

- **converged** when the scale-free residual (|f1|/|∇f1|, |f2|/|∇f2|, |s|/(|∇f1||∇f2|), the
  largest of the three) is at most RESIDUAL_TOLERANCE and the point moved less than a few cells;
  otherwise it is *dropped* and counted, never kept at its unrefined place;
- **excluded** when the refined point lies in the neighbourhood of the singular set: where ∇f1 and
  ∇f2 are nearly dependent (σ_min/σ_max of the Jacobian below EXCLUSION_RATIO) or within
  ``exclusion_radius`` of a singular point the polygonizer found. Singular points satisfy s = 0
  trivially (their normals are dependent) but are never silhouettes (the paper's cusp example,
  section 4.2), and near them the mesh bridges across and s changes sign on the bridge: the
  false arcs Newton would otherwise pull onto the singular circle.

Curves are split where points are dropped or excluded, so no segment joins across a gap
(:func:`index_runs`); how an implicit surface's runs become the curves it exports (folds cut,
ends continued, duplicates dropped) is ``surfaces/silhouette_curves.py``.

Why one module of this size: implicit and parametric refinement share the Newton step, the
judgement of each point and the runs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from exhibit.surfaces.expressions import ScalarField
from exhibit.surfaces.mesh import Curve, Material, Surface
from exhibit.surfaces.newton import Field
from exhibit.surfaces.singular import jacobian_ratio

#: The largest scale-free residual a kept point may have.
RESIDUAL_TOLERANCE = 1e-9
#: Newton iterates until the residual is below this (then one more step cannot hurt).
NEWTON_TARGET = 1e-13
ITERATIONS = 60
#: σ_min/σ_max of (∇f1, ∇f2) below this: the point is in the singular set's neighbourhood.
EXCLUSION_RATIO = 1e-4


@dataclass
class RefineStats:
    refined: int = 0
    dropped: int = 0
    excluded: int = 0
    max_residual: float = 0.0

    def add(self, other: RefineStats) -> None:
        self.refined += other.refined
        self.dropped += other.dropped
        self.excluded += other.excluded
        self.max_residual = max(self.max_residual, other.max_residual)

    def to_json(self) -> dict:
        return {
            "refined": int(self.refined),
            "dropped": int(self.dropped),
            "excluded": int(self.excluded),
            "max_residual": float(self.max_residual),
        }


@np.errstate(all="ignore")
def min_norm_newton(
    fields: Sequence[Field], residual: Callable[[np.ndarray], np.ndarray], points: np.ndarray
) -> np.ndarray:
    """Minimum-norm Newton steps x <- x - Jᵀ(JJᵀ)⁻¹F on k fields in R^4 until ``residual``
    (points -> scale-free residuals) is below NEWTON_TARGET, damped only by a tiny Tikhonov term
    where J loses rank (near singular points, which the callers exclude or drop)."""
    x = np.asarray(points, dtype=float).reshape(-1, 4).copy()
    k = len(fields)
    active = np.ones(len(x), dtype=bool)
    for _ in range(ITERATIONS):
        if not active.any():
            break
        idx = np.flatnonzero(active)
        xa = x[idx]
        values = np.stack([f.value(xa) for f in fields], -1)
        jac = np.stack([f.gradient(xa) for f in fields], 1)
        gram = jac @ np.transpose(jac, (0, 2, 1))
        finite = np.isfinite(values).all(1) & np.isfinite(gram).all((1, 2))
        active[idx[~finite]] = False
        if not finite.any():
            break
        idx, xa, values, jac, gram = (
            idx[finite],
            xa[finite],
            values[finite],
            jac[finite],
            gram[finite],
        )
        done = residual(xa) <= NEWTON_TARGET
        active[idx[done]] = False
        go = ~done
        if not go.any():
            break
        g = gram[go]
        g = (
            g
            + 1e-15 * np.trace(g, axis1=1, axis2=2)[:, None, None] * np.eye(k)
            + 1e-300 * np.eye(k)
        )
        solved = np.linalg.solve(g, values[go][..., None])[..., 0]
        x[idx[go]] = xa[go] - np.einsum("aki,ak->ai", jac[go], solved)
    return x


@dataclass
class SilhouetteSystem:
    """f1 = f2 = s = 0 for the orthographic projection along axes ``along`` (two indices)."""

    f1: ScalarField
    f2: ScalarField
    along: tuple[int, int]
    s: ScalarField = field(init=False)

    def __post_init__(self) -> None:
        g1, g2 = self.f1.gradient_expressions, self.f2.gradient_expressions
        a, b = self.along
        self.s = ScalarField(g1[a] * g2[b] - g1[b] * g2[a], self.f1.symbols)

    @np.errstate(all="ignore")
    def residual(self, points: np.ndarray) -> np.ndarray:
        """The scale-free residual at each point (inf where something is not finite)."""
        points = np.asarray(points, dtype=float).reshape(-1, 4)
        g1 = np.linalg.norm(self.f1.gradient(points), axis=1)
        g2 = np.linalg.norm(self.f2.gradient(points), axis=1)
        r = np.stack(
            [
                np.abs(self.f1.value(points)) / g1,
                np.abs(self.f2.value(points)) / g2,
                np.abs(self.s.value(points)) / (g1 * g2),
            ],
            1,
        )
        r = np.where(np.isnan(r), np.inf, r)
        return r.max(axis=1)

    @np.errstate(all="ignore")
    def f1_f2_residual(self, points: np.ndarray) -> np.ndarray:
        """max(|f1|/|∇f1|, |f2|/|∇f2|): how far a point is from the surface, scale-free."""
        points = np.asarray(points, dtype=float).reshape(-1, 4)
        r = np.stack(
            [
                np.abs(f.value(points)) / np.linalg.norm(f.gradient(points), axis=1)
                for f in (self.f1, self.f2)
            ],
            1,
        )
        return np.where(np.isnan(r), np.inf, r).max(axis=1)

    def excluded(
        self,
        points: np.ndarray,
        singular_points: np.ndarray | None = None,
        exclusion_radius: float = 0.0,
    ) -> np.ndarray:
        """True for points in the excluded neighbourhood of the singular set."""
        points = np.asarray(points, dtype=float).reshape(-1, 4)
        ratio = jacobian_ratio(self.f1, self.f2, points)
        near = ~(ratio >= EXCLUSION_RATIO)
        if singular_points is not None and len(singular_points) and exclusion_radius > 0:
            for start in range(0, len(points), 512):
                chunk = points[start : start + 512]
                d = np.linalg.norm(chunk[:, None] - singular_points[None], axis=-1).min(axis=1)
                near[start : start + 512] |= d < exclusion_radius
        return near

    def newton(self, points: np.ndarray) -> np.ndarray:
        return min_norm_newton((self.f1, self.f2, self.s), self.residual, points)

    def refine(
        self,
        points: np.ndarray,
        max_move: float,
        singular_points: np.ndarray | None = None,
        exclusion_radius: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray, RefineStats]:
        """Refined points and which to keep; the rest are dropped (not converged) or excluded."""
        points = np.asarray(points, dtype=float).reshape(-1, 4)
        x = self.newton(points)
        residual = self.residual(x)
        moved = np.linalg.norm(x - points, axis=1)
        converged = (
            (residual <= RESIDUAL_TOLERANCE) & (moved <= max_move) & np.isfinite(x).all(axis=1)
        )
        # Excluded first: a point pulled towards a singular set (where Newton slows down or
        # the residual's normalisation vanishes) is counted there, not as a failure to converge.
        excluded = np.isfinite(x).all(axis=1) & self.excluded(x, singular_points, exclusion_radius)
        keep = converged & ~excluded
        stats = RefineStats(
            refined=int(keep.sum()),
            dropped=int((~converged & ~excluded).sum()),
            excluded=int(excluded.sum()),
            max_residual=float(residual[keep].max()) if keep.any() else 0.0,
        )
        return x, keep, stats


def split_runs(points: np.ndarray, keep: np.ndarray, closed: bool) -> list[tuple[np.ndarray, bool]]:
    """The runs of kept points of a polyline, [(points, closed)], so nothing joins across a gap."""
    return [(points[index], run_closed) for index, run_closed in index_runs(keep, closed)]


def index_runs(keep: np.ndarray, closed: bool) -> list[tuple[np.ndarray, bool]]:
    """The runs of kept indices of a polyline [(indices, closed)] (a lone index is no run)."""
    n = len(keep)
    if keep.all():
        return [(np.arange(n), closed)] if n >= 2 else []
    index = np.flatnonzero(keep)
    if len(index) == 0:
        return []
    breaks = np.flatnonzero(np.diff(index) > 1)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks + 1, [len(index)]])
    pieces = [index[s:e] for s, e in zip(starts, ends)]
    if closed and len(pieces) > 1 and pieces[0][0] == 0 and pieces[-1][-1] == n - 1:
        pieces = [np.concatenate([pieces[-1], pieces[0]])] + pieces[1:-1]
    return [(piece, False) for piece in pieces if len(piece) >= 2]


# ----------------------------------------------------------------------------- parametric X(s, t)


class Span(Protocol):
    """A parameter's interval (exhibit.surfaces.parametric.Interval)."""

    @property
    def start(self) -> float: ...
    @property
    def stop(self) -> float: ...
    @property
    def periodic(self) -> bool: ...


@dataclass
class ParametricExact:
    """A parametric surface's X(s, t), its tangents, its intervals and each vertex's (s, t)."""

    function: Callable[[np.ndarray, np.ndarray], np.ndarray]
    tangents: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    s_interval: Span
    t_interval: Span
    params: np.ndarray  # (V, 2)

    @np.errstate(all="ignore")
    def condition(
        self, st: np.ndarray, along: tuple[int, int]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """g = det[X_s, X_t, e_a, e_b] (Lemma 3(b)): the 2x2 minor of the two other coordinates,
        and the scale-free residual |g| / (|X_s||X_t|), and the tangents' independence."""
        c, d = [k for k in range(4) if k not in along]
        t1, t2 = self.tangents(st[:, 0], st[:, 1])
        g = t1[:, c] * t2[:, d] - t1[:, d] * t2[:, c]
        n1, n2 = np.linalg.norm(t1, axis=1), np.linalg.norm(t2, axis=1)
        wedge = np.sqrt(np.maximum(n1**2 * n2**2 - np.einsum("ni,ni->n", t1, t2) ** 2, 0.0))
        residual = np.abs(g) / (n1 * n2)
        return g, np.where(np.isnan(residual), np.inf, residual), wedge / (n1 * n2)

    def wrap(self, st: np.ndarray) -> np.ndarray:
        st = st.copy()
        for k, interval in enumerate((self.s_interval, self.t_interval)):
            if interval.periodic:
                period = interval.stop - interval.start
                st[:, k] = interval.start + np.mod(st[:, k] - interval.start, period)
        return st

    @np.errstate(all="ignore")
    def refine(
        self, st: np.ndarray, along: tuple[int, int], max_move: float
    ) -> tuple[np.ndarray, np.ndarray, RefineStats]:
        """Newton on g(s, t) = 0 with the minimum-norm step (one equation, two unknowns)."""
        st = np.asarray(st, dtype=float).reshape(-1, 2).copy()
        start_points = self.function(st[:, 0], st[:, 1])
        spans = np.array(
            [
                self.s_interval.stop - self.s_interval.start,
                self.t_interval.stop - self.t_interval.start,
            ]
        )
        h = 1e-6 * spans
        for _ in range(ITERATIONS):
            g, residual, _ = self.condition(st, along)
            go = residual > NEWTON_TARGET
            if not go.any():
                break
            x = st[go]
            gs = (
                self.condition(x + [h[0], 0], along)[0] - self.condition(x - [h[0], 0], along)[0]
            ) / (2 * h[0])
            gt = (
                self.condition(x + [0, h[1]], along)[0] - self.condition(x - [0, h[1]], along)[0]
            ) / (2 * h[1])
            norm2 = gs**2 + gt**2
            step = np.where(norm2 > 0, g[go] / np.where(norm2 > 0, norm2, 1.0), 0.0)
            st[go] = x - step[:, None] * np.stack([gs, gt], 1)
        inside = np.ones(len(st), dtype=bool)
        for k, interval in enumerate((self.s_interval, self.t_interval)):
            if not interval.periodic:
                inside &= (st[:, k] >= interval.start) & (st[:, k] <= interval.stop)
        st = self.wrap(st)
        points = self.function(st[:, 0], st[:, 1])
        _, residual, independence = self.condition(st, along)
        moved = np.linalg.norm(points - start_points, axis=1)
        converged = (
            (residual <= RESIDUAL_TOLERANCE)
            & (moved <= max_move)
            & inside
            & np.isfinite(points).all(axis=1)
        )
        excluded = np.isfinite(points).all(axis=1) & ~(independence >= EXCLUSION_RATIO)
        keep = converged & ~excluded
        stats = RefineStats(
            refined=int(keep.sum()),
            dropped=int((~converged & ~excluded).sum()),
            excluded=int(excluded.sum()),
            max_residual=float(residual[keep].max()) if keep.any() else 0.0,
        )
        return points, keep, stats


def parametric_silhouette(
    surface: Surface,
    exact: ParametricExact,
    along: tuple[int, int],
    name: str,
    material: Material,
    stats: RefineStats | None = None,
) -> list[Curve]:
    """The silhouette along two axes of a parametric surface, refined in (s, t) onto
    det[X_s, X_t, e_a, e_b] = 0. Parameters are interpolated per triangle with periodic ones
    unwrapped, so a curve crossing a seam starts from the right (s, t)."""
    from exhibit.geometry.silhouette import silhouette_function

    if len(surface.triangles) == 0:
        return []
    e = np.eye(4)
    values = silhouette_function(
        surface.normals[:, 0], surface.normals[:, 1], e[along[0]], e[along[1]]
    )
    chains = traced_with_parameters(surface, exact, values)
    if not chains:
        return []
    edge = float(np.max(np.ptp(surface.positions, axis=0))) / max(
        np.sqrt(len(surface.positions)), 1.0
    )
    out: list[Curve] = []
    total = RefineStats()
    for _points, st, closed in chains:
        x, keep, s = exact.refine(st, along, 2.0 * edge)
        runs = split_runs(x, keep, closed)
        s.refined = sum(len(run) + closed for run, closed in runs)  # the points exported
        total.add(s)
        for run, run_closed in runs:
            out.append(
                Curve(name if not out else f"{name} {len(out) + 1}", run, material, run_closed)
            )
    if stats is not None:
        stats.add(total)
    return out


def traced_with_parameters(
    surface: Surface, exact: ParametricExact, values: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray, bool]]:
    """The zero set of per-vertex ``values`` on a parametric surface's mesh as chained polylines
    [(points, (s, t) per point, closed)]. Parameters are interpolated per triangle with periodic
    ones unwrapped, so a curve crossing a seam starts Newton from the right (s, t)."""
    from exhibit.geometry.silhouette import zero_set_segments
    from exhibit.surfaces.curves import chain_segments

    tris = surface.triangles.astype(np.int64)
    params = exact.params[tris].copy()  # (T, 3, 2)
    for k, interval in enumerate((exact.s_interval, exact.t_interval)):
        if interval.periodic:
            period = interval.stop - interval.start
            ref = params[:, :1, k]
            params[:, :, k] = ref + (
                params[:, :, k] - ref - period * np.round((params[:, :, k] - ref) / period)
            )
    soup = np.concatenate([surface.positions[tris], params], axis=2).reshape(-1, 6)
    segments = zero_set_segments(soup, np.arange(len(soup)).reshape(-1, 3), values[tris].ravel())
    if len(segments) == 0:
        return []
    lookup: dict[tuple, np.ndarray] = {}
    scale = max(float(np.abs(surface.positions).max()), 1.0) * 1e-9
    for end in segments.reshape(-1, 6):
        lookup.setdefault(tuple(np.round(end[:4] / scale).astype(np.int64)), end[4:])
    return [
        (
            points,
            np.array([lookup[tuple(np.round(p / scale).astype(np.int64))] for p in points]),
            closed,
        )
        for points, closed in chain_segments(segments[:, :, :4], scale)
    ]
