"""Slices of a 2-surface in R^4 by a hyperplane x_a = c: the curves S ∩ {x_a = c}.

For the collision surface (axes x, y, z, t) the slice at t = c is the 3D world at the moment c:
the curve where the pipe and the ball meet then, empty before the first contact, one loop just
after it, two while the ball fills the pipe's cross-section (the paper's "hole", Figure 17).

The slice is traced as the zero set of x_a - c on the mesh (marching triangles, chained into
polylines), then every point is refined onto the exact slice:

- an implicit surface: minimum-norm Newton on (f1, f2, x_a - c) in R^4, with the scale-free
  residual max(|f1|/|∇f1|, |f2|/|∇f2|, |x_a - c|) at most RESIDUAL_TOLERANCE;
- a parametric surface X(s, t): minimum-norm Newton in (s, t) on X_a(s, t) = c.

A point that does not converge, or moves more than a few mesh edges, is dropped and counted, and
its curve is split there, as for the exact silhouettes (surfaces/exact_silhouette.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exhibit.surfaces.curves import zero_set_curves
from exhibit.surfaces.expressions import ScalarField
from exhibit.surfaces.exact_silhouette import (
    drop_fragments,
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

    def refine(self, points: np.ndarray, max_move: float):
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
    """The slice S ∩ {x_axis = at} as curves refined onto the exact surface (see the module's
    docstring). Without an exact surface behind the mesh (one loaded from the cache), nothing
    can be refined and every traced point counts as dropped."""
    if len(surface.triangles) == 0:
        return []
    exact = surface.exact
    values = surface.positions[:, axis] - at
    max_move = MAX_MOVE_EDGES * mean_edge(surface)
    if isinstance(exact, ParametricExact):
        chains = traced_with_parameters(surface, exact, values)
    else:
        chains = [(c.points, None, c.closed) for c in traced_slice(surface, axis, at, name)]
    total = RefineStats()
    out: list[Curve] = []
    material = material or Material()
    for points, st, closed in chains:
        if st is not None and isinstance(exact, ParametricExact):
            x, keep, s = _refine_parametric(exact, st, axis, at, max_move)
        elif exact is not None and hasattr(exact, "f1") and hasattr(exact, "f2"):
            x, keep, s = ImplicitSlice(exact.f1, exact.f2, axis, at).refine(points, max_move)
        else:
            total.dropped += len(points)
            continue
        runs = split_runs(x, keep, closed)
        s.refined = sum(len(run) + closed for run, closed in runs)  # the points exported
        total.add(s)
        for run, run_closed in runs:
            label = name if not out else f"{name} {len(out) + 1}"
            out.append(Curve(label, run, material, run_closed))
    if exact is not None and hasattr(exact, "f1") and hasattr(exact, "f2") and st_free(chains):
        # Where the hyperplane is tangent to the surface along a curve, x_a - c touches zero
        # without changing sign and the mesh's zero set misses it (surfaces/double_zeros.py).
        out += tangency_curves(surface, exact, axis, at, max_move, name, material, total, len(out))
        # A mesh vertex exactly on the hyperplane (one the mesh put on a singular point, where
        # the tangency circle passes) gives the sign-change trace a loop shorter than a cell
        # along the tangency curve: a duplicate, not a curve of its own.
        out = drop_fragments(out, mean_edge(surface))
        for i, curve in enumerate(out):
            curve.name = name if i == 0 else f"{name} {i + 1}"
        total.refined = sum(len(c.points) + c.closed for c in out)  # the points exported
    if stats is not None:
        stats.add(total)
    return out


def st_free(chains) -> bool:
    return all(st is None for _, st, _ in chains)


def tangency_curves(
    surface: Surface,
    exact,
    axis: int,
    at: float,
    max_move: float,
    name: str,
    material: Material,
    total: RefineStats,
    already: int,
) -> list[Curve]:
    """The curves along which the hyperplane x_axis = at touches the surface, refined onto
    f1 = f2 = 0 and the hyperplane."""
    from exhibit.surfaces.double_zeros import double_zero_chains, join_ends

    system = ImplicitSlice(exact.f1, exact.f2, axis, at)
    e = np.zeros(4)
    e[axis] = 1.0

    def refine(seeds):
        x, keep, _ = system.refine(seeds, max_move)
        return x, keep

    p = surface.positions
    chains = double_zero_chains(
        surface,
        p[:, axis] - at,
        np.tile(e, (len(p), 1)),
        refine,
        lambda x: [exact.f1.gradient(x), exact.f2.gradient(x)],
        lambda x: np.tile(e, (len(x), 1)),
    )
    edge = max_move / MAX_MOVE_EDGES
    chains = join_ends(chains, 4.0 * edge, refine, 0.5 * edge)
    out: list[Curve] = []
    for points, closed in chains:
        if len(points) < 2:
            continue
        total.refined += len(points) + closed  # a closed curve repeats its first point
        total.max_residual = max(total.max_residual, float(system.residual(points).max()))
        label = name if not (already + len(out)) else f"{name} {already + len(out) + 1}"
        out.append(Curve(label, points, material, closed))
    return out
