"""Slices of a 2-surface in R^4 by a hyperplane x_a = c: the curves S ∩ {x_a = c}.

For the collision surface (axes x, y, z, t) the slice at t = c is the 3D world at the moment c:
the curve where the pipe and the ball meet then, empty before the first contact, one loop just
after it, two while the ball fills the pipe's cross-section (the paper's "hole", Figure 17).

- an implicit surface: the curves are traced along the exact slice from seed points
  (surfaces/slice_trace.py), tangency curves (the hyperplane tangent to S along a curve) by
  their own system; seeds come from the mesh's zero set of x_a − c at c and, where the slice is
  too thin for the mesh (next to a critical value of x_a), at c ± δ, carried to c by Newton.
  A point is accepted when Newton's last step, a distance, is below 1e-13 of the box, not by
  its residual (next to a tangency a tiny residual allows points far from the slice).
- a parametric surface X(s, t): the mesh's zero set of x_a − c (marching triangles, chained),
  each point refined by minimum-norm Newton in (s, t) on X_a(s, t) = c; a point that does not
  converge, or moves more than a few mesh edges, is dropped and counted, and its curve is split
  there, as for the exact silhouettes (surfaces/exact_silhouette.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exhibit.surfaces.curves import zero_set_curves
from exhibit.surfaces.expressions import ScalarField
from exhibit.surfaces.exact_silhouette import (
    ITERATIONS,
    NEWTON_TARGET,
    RESIDUAL_TOLERANCE,
    ParametricExact,
    RefineStats,
    min_norm_newton,
    split_runs,
    traced_with_parameters,
)
from exhibit.surfaces.implicit import CoordinatePlane
from exhibit.surfaces.mesh import Curve, Material, Surface

#: How far (in mean mesh edges) refinement may move a traced point before it counts as lost.
MAX_MOVE_EDGES = 3.0
#: How a slice is drawn wherever it appears (live on the surfaces, in the inset, its touching
#: curve): a bright warm white no scene colour uses; width in px at 720 px.
SLICE_MATERIAL = Material(color=(1.0, 0.93, 0.55), line_width=3.5)


@dataclass
class ImplicitSlice:
    """f1 = f2 = 0 and x[axis] = at, for Newton."""

    f1: ScalarField
    f2: ScalarField
    axis: int
    at: float

    @np.errstate(all="ignore")
    def residual(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float).reshape(-1, 4)
        r = np.stack(
            [
                np.abs(f.value(points)) / np.linalg.norm(f.gradient(points), axis=1)
                for f in (self.f1, self.f2)
            ]
            + [np.abs(points[:, self.axis] - self.at)],
            axis=1,
        )
        return np.where(np.isnan(r), np.inf, r).max(axis=1)

    def refine(
        self, points: np.ndarray, max_move: float
    ) -> tuple[np.ndarray, np.ndarray, RefineStats]:
        points = np.asarray(points, dtype=float).reshape(-1, 4)
        x = min_norm_newton(
            (self.f1, self.f2, CoordinatePlane(self.axis, self.at)), self.residual, points
        )
        x[:, self.axis] = np.where(np.isfinite(x[:, self.axis]), self.at, x[:, self.axis])
        return x, *_judge(
            self.residual(x),
            np.linalg.norm(x - points, axis=1),
            max_move,
            np.isfinite(x).all(axis=1),
        )


def _judge(residual, moved, max_move, finite) -> tuple[np.ndarray, RefineStats]:
    keep = (residual <= RESIDUAL_TOLERANCE) & (moved <= max_move) & finite
    return keep, RefineStats(
        refined=int(keep.sum()),
        dropped=int((~keep).sum()),
        max_residual=float(residual[keep].max()) if keep.any() else 0.0,
    )


@np.errstate(all="ignore")
def _refine_parametric(
    exact: ParametricExact, st: np.ndarray, axis: int, at: float, max_move: float
):
    """Newton on g(s, t) = X_a(s, t) - c with the minimum-norm step (one equation, two
    unknowns; ∇g = (X_s[a], X_t[a]) from the surface's own tangents)."""
    st = np.asarray(st, dtype=float).reshape(-1, 2).copy()
    start = exact.function(st[:, 0], st[:, 1])

    def condition(st):
        x = exact.function(st[:, 0], st[:, 1])
        t1, t2 = exact.tangents(st[:, 0], st[:, 1])
        return x[:, axis] - at, t1[:, axis], t2[:, axis]

    for _ in range(ITERATIONS):
        g, gs, gt = condition(st)
        go = np.abs(g) > NEWTON_TARGET
        if not go.any():
            break
        norm2 = gs[go] ** 2 + gt[go] ** 2
        step = np.where(norm2 > 0, g[go] / np.where(norm2 > 0, norm2, 1.0), 0.0)
        st[go] -= step[:, None] * np.stack([gs[go], gt[go]], 1)
    inside = np.ones(len(st), dtype=bool)
    for k, interval in enumerate((exact.s_interval, exact.t_interval)):
        if not interval.periodic:
            inside &= (st[:, k] >= interval.start) & (st[:, k] <= interval.stop)
    st = exact.wrap(st)
    points = exact.function(st[:, 0], st[:, 1])
    residual = np.abs(points[:, axis] - at)
    residual = np.where(np.isnan(residual), np.inf, residual)
    return points, *_judge(
        residual,
        np.linalg.norm(points - start, axis=1),
        max_move,
        np.isfinite(points).all(axis=1) & inside,
    )


def mean_edge(surface: Surface) -> float:
    tris = surface.triangles.astype(np.int64)
    if len(tris) == 0:
        return 0.0
    p = surface.positions
    return float(np.linalg.norm(p[tris[:, 0]] - p[tris[:, 1]], axis=1).mean())


def traced_slice(
    surface: Surface, axis: int, at: float, name: str = "slice", material: Material | None = None
) -> list[Curve]:
    """S ∩ {x_axis = at} on the mesh alone (marching triangles, chained), unrefined."""
    if len(surface.triangles) == 0:
        return []
    return zero_set_curves(surface, surface.positions[:, axis] - at, name, material or Material())


def slice_curves(
    surface: Surface,
    axis: int,
    at: float,
    stats: RefineStats | None = None,
    name: str = "slice",
    material: Material | None = None,
) -> list[Curve]:
    """The slice S ∩ {x_axis = at} as curves on the exact surface (see the module's docstring).
    Without an exact surface behind the mesh (one loaded from the cache), nothing can be
    refined and every traced point counts as dropped."""
    if len(surface.triangles) == 0:
        return []
    exact = surface.exact
    material = material or Material()
    total = RefineStats()
    if isinstance(exact, ParametricExact):
        out = _parametric_slice(surface, exact, axis, at, name, material, total)
    elif exact is not None and hasattr(exact, "f1") and hasattr(exact, "f2"):
        out = [
            Curve(name, points, material, closed)
            for points, closed in implicit_slice(surface, exact.f1, exact.f2, axis, at, total)
        ]
    else:
        out = []
        total.dropped += sum(len(c.points) for c in traced_slice(surface, axis, at, name))
    for i, curve in enumerate(out):
        curve.name = name if i == 0 else f"{name} {i + 1}"
    if stats is not None:
        stats.add(total)
    return out


def _parametric_slice(surface, exact, axis, at, name, material, total) -> list[Curve]:
    max_move = MAX_MOVE_EDGES * mean_edge(surface)
    out: list[Curve] = []
    for _points, st, closed in traced_with_parameters(
        surface, exact, surface.positions[:, axis] - at
    ):
        x, keep, s = _refine_parametric(exact, st, axis, at, max_move)
        runs = split_runs(x, keep, closed)
        s.refined = sum(len(run) + closed for run, closed in runs)  # the points exported
        total.add(s)
        out += [Curve(name, run, material, run_closed) for run, run_closed in runs]
    return out


#: Seeds for slices the mesh cannot resolve at c come from the mesh at c ± δ, δ these many mean
#: edges (in units of x_a), continued to c.
SEED_OFFSETS = (1.0, 4.0)
#: Seeds taken from each traced chain, at most (spread along it).
SEEDS_PER_CHAIN = 6
#: Tangency candidates tried, at most, before giving up on finding a tangency curve.
TANGENCY_TRIES = 40


def implicit_slice(
    surface: Surface, f1: ScalarField, f2: ScalarField, axis: int, at: float, total: RefineStats
) -> list[tuple[np.ndarray, bool]]:
    """[(points (N, 4), closed)] of f1 = f2 = 0, x_axis = at, traced along the exact curves
    (surfaces/slice_trace.py): tangency curves first, then the transverse ones through seeds
    from the mesh at ``at`` and at ``at`` ± δ."""
    from exhibit.surfaces import slice_trace as st

    p = surface.positions
    lo, hi = p.min(axis=0), p.max(axis=0)
    scale = float((hi - lo).max()) or 1.0
    edge = mean_edge(surface)
    pad = 0.5 * edge
    plane = st.SlicePlane(f1, f2, axis, at, scale)
    others = plane.others

    def inside(u):
        return bool(np.all(u >= lo[others] - pad) and np.all(u <= hi[others] + pad))

    curves: list[st.Trace] = []
    with np.errstate(all="ignore"):
        for trace in _tangency_traces(surface, plane, at, edge, inside):
            curves.append(trace)
        traces: list[st.Trace] = []
        for seed in _transverse_seeds(surface, plane, edge):
            near_tangency = any(
                np.linalg.norm(t.points - seed, axis=1).min() <= edge for t in curves
            )
            if near_tangency or any(
                np.linalg.norm(t.points - seed, axis=1).min() <= 2 * edge
                and st.on_trace(plane, seed, t, 1e-7 * scale)
                for t in traces
            ):
                continue
            traces.append(st.trace_transverse(plane, seed, edge, inside))
        curves += st.drop_contained(
            plane, st.join_stalled(plane, traces, 1e-6 * scale, 0.01 * edge), 1e-7 * scale
        )
    out = []
    system = ImplicitSlice(f1, f2, axis, at)
    for trace in curves:
        if len(trace.points) < 2:
            continue
        points = np.array([plane.lift(u) for u in trace.points])
        total.refined += len(points) + trace.closed  # a closed curve repeats its first point
        total.max_residual = max(total.max_residual, float(system.residual(points).max()))
        out.append((points, trace.closed))
    return out


def _tangency_traces(surface, plane, at, edge, inside):
    """Tangency curves of the hyperplane with the surface, seeded where |x_a − c| dips on a mesh
    edge (surfaces/double_zeros.py) and kept only where the tangency is exact to round-off."""
    from exhibit.surfaces import slice_trace as st
    from exhibit.surfaces.double_zeros import dip_candidates

    p = surface.positions
    e = np.zeros(4)
    e[plane.axis] = 1.0
    _, seeds = dip_candidates(surface, p[:, plane.axis] - at, np.tile(e, (len(p), 1)))
    traces: list = []
    tries = 0
    for seed in seeds:
        if tries >= TANGENCY_TRIES:
            break
        if any(
            np.linalg.norm(t.points - seed[plane.others], axis=1).min() <= 2 * edge for t in traces
        ):
            continue
        tries += 1
        z = st.tangency_seed(plane, seed[plane.others], 1e-6 * plane.scale)
        if z is not None:
            traces.append(st.trace_tangency(plane, z, edge, inside))
    return traces


def _transverse_seeds(surface, plane, edge):
    """Points of the transverse slice curves (3-vectors in the hyperplane), the best-conditioned
    first: from the mesh's own slice at c, and from its slices at c ± δ continued to c."""
    from exhibit.surfaces import slice_trace as st

    axis, at = plane.axis, plane.at
    candidates = []
    for offset in (0.0, *(s * d * edge for d in SEED_OFFSETS for s in (1.0, -1.0))):
        for curve in traced_slice(surface, axis, at + offset):
            take = np.unique(np.linspace(0, len(curve.points) - 1, SEEDS_PER_CHAIN).astype(int))
            points = curve.points[take]
            if offset:
                points = _continue(plane, points, at + offset)
            candidates.append(points)
    if not candidates:
        return []
    seeds = []
    for point in np.concatenate(candidates):
        if not np.isfinite(point).all():
            continue
        u = point[plane.others]
        _, grads = plane.evaluate(plane.lift(u))
        tangent, _ = st.transverse_tangent(grads)
        q = st.correct(plane, u, tangent, edge)
        if q is None:
            continue
        _, grads = plane.evaluate(plane.lift(q))
        _, size = st.transverse_tangent(grads)
        if size >= st.MIN_TRANSVERSE:
            seeds.append((size, q))
    seeds.sort(key=lambda s: -s[0])
    return [q for _, q in seeds]


def _continue(plane, points: np.ndarray, start: float) -> np.ndarray:
    """``points`` on the slice at x_a = ``start`` carried to x_a = plane.at by Newton in steps
    of x_a that halve the distance left (the slice changes shape smoothly in between, unless a
    critical value lies between: then a point may be lost, never kept off the slice, since
    the seeds are checked again)."""
    x = np.asarray(points, dtype=float).copy()
    gap = start - plane.at
    for k in range(1, 60):
        c = plane.at + gap * 0.5**k
        if abs(c - plane.at) <= 1e-15 * plane.scale:
            break
        x = ImplicitSlice(plane.f1, plane.f2, plane.axis, c).refine(x, np.inf)[0]
    return ImplicitSlice(plane.f1, plane.f2, plane.axis, plane.at).refine(x, np.inf)[0]
