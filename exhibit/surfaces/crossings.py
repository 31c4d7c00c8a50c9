"""Crossings of silhouette branches, drawn as crossings (an X, not "><").

Where two branches of the silhouette f1 = f2 = s = 0 cross (the offset branch and the circle
t = 0 of the traced cusp, Figures 13-14, at (0, ±r, 0)), s restricted to the surface has a
saddle: its gradient along the surface vanishes. The mesh cannot resolve the saddle: its zero set
turns a corner a little before the crossing, from one branch onto the other, and the refined
points there fall out of order. So:

- **found**: points of the refined curves where s changes slowly along the surface (its
  tangential gradient small against the curve's median) are the starting points of
  Gauss-Newton on the system f1 = f2 = s = 0, P_T ∇s = 0 (P_T the projection onto the
  surface's tangent plane), seven equations in four unknowns with a zero residual at a crossing;
- **judged**: a solution is a crossing when it converged (scale-free residual of the silhouette
  system at most RESIDUAL_TOLERANCE), lies within a cell of where it started and is isolated
  (the system's Jacobian has full rank: a branch where s only touches zero, a curve of such
  critical points, is not a crossing);
- **joined**: every curve is cut within a cell of each crossing and each piece that ends there
  gets the crossing itself as its end point, with the gap between filled by points projected
  onto the exact curve.
"""

from __future__ import annotations

import numpy as np

from exhibit.surfaces.exact_silhouette import (
    RESIDUAL_TOLERANCE,
    SilhouetteSystem,
    index_runs,
)
from exhibit.surfaces.mesh import Curve
from exhibit.surfaces.silhouette_curves import polyline_length

#: Refined points where s changes along the surface at under this fraction of the curve's median
#: rate start a crossing search (near a crossing the rate falls to 0 linearly).
CANDIDATE_SLOPE = 0.25
MAX_TRIES = 12
#: σ_min/σ_max of the crossing system's Jacobian at a solution above this: an isolated crossing.
ISOLATION_RATIO = 1e-6
ITERATIONS = 40


@np.errstate(all="ignore")
def tangential_slope(system: SilhouetteSystem, points: np.ndarray) -> np.ndarray:
    """|P_T ∇s| / (|∇f1||∇f2|): how fast s changes along the surface, per unit length. It
    vanishes where branches of s = 0 cross (a critical point of s on the surface)."""
    points = np.asarray(points, float).reshape(-1, 4)
    normals = np.stack([system.f1.gradient(points), system.f2.gradient(points)], 1)
    grad_s = system.s.gradient(points)
    gram = normals @ np.transpose(normals, (0, 2, 1))
    finite = np.isfinite(gram).all((1, 2)) & np.isfinite(grad_s).all(1)
    out = np.full(len(points), np.inf)
    if finite.any():
        n, g = normals[finite], grad_s[finite]
        coefficients = np.linalg.solve(gram[finite], np.einsum("aki,ai->ak", n, g)[..., None])
        tangential = g - np.einsum("aki,ak->ai", n, coefficients[..., 0])
        scale = np.linalg.norm(n[:, 0], axis=1) * np.linalg.norm(n[:, 1], axis=1)
        out[finite] = np.linalg.norm(tangential, axis=1) / scale
    return np.where(np.isfinite(out), out, np.inf)


class _CrossingEquations:
    """F(x) = (f1/n1, f2/n2, s/(n1 n2), L P_T ∇s/(n1 n2)), constant scales from the start."""

    def __init__(self, system: SilhouetteSystem, start: np.ndarray, length: float) -> None:
        self.system = system
        p = start[None]
        self.n1 = float(np.linalg.norm(system.f1.gradient(p)))
        self.n2 = float(np.linalg.norm(system.f2.gradient(p)))
        self.length = length

    @np.errstate(all="ignore")
    def __call__(self, x: np.ndarray) -> np.ndarray:
        s = self.system
        p = x[None]
        normals = np.stack([s.f1.gradient(p)[0], s.f2.gradient(p)[0]])
        grad_s = s.s.gradient(p)[0]
        coefficients = np.linalg.solve(normals @ normals.T, normals @ grad_s)
        tangential = grad_s - normals.T @ coefficients
        scale = self.n1 * self.n2
        return np.concatenate(
            [
                [s.f1.value(p)[0] / self.n1, s.f2.value(p)[0] / self.n2, s.s.value(p)[0] / scale],
                self.length * tangential / scale,
            ]
        )

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        h = 1e-6 * self.length
        columns = [(self(x + h * e) - self(x - h * e)) / (2 * h) for e in np.eye(4)]
        return np.stack(columns, 1)


def solve_crossing(system: SilhouetteSystem, start: np.ndarray, cell: float) -> np.ndarray | None:
    """The crossing near ``start`` by Gauss-Newton, or None (not converged, too far, not
    isolated)."""
    equations = _CrossingEquations(system, np.asarray(start, float), cell)
    if not (np.isfinite(equations.n1) and np.isfinite(equations.n2)):
        return None
    x = np.asarray(start, float).copy()
    with np.errstate(all="ignore"):
        for _ in range(ITERATIONS):
            value = equations(x)
            jac = equations.jacobian(x)
            if not (np.isfinite(value).all() and np.isfinite(jac).all()):
                return None
            step = np.linalg.lstsq(jac, value, rcond=None)[0]
            x = x - step
            if np.linalg.norm(step) < 1e-14 * max(1.0, float(np.abs(x).max())):
                break
        value, jac = equations(x), equations.jacobian(x)
        if not (np.isfinite(value).all() and np.isfinite(jac).all()):
            return None
        sigma = np.linalg.svd(jac, compute_uv=False)
    if np.linalg.norm(x - start) > cell:
        return None
    if system.residual(x[None])[0] > RESIDUAL_TOLERANCE or np.abs(value[3:]).max() > 1e-9:
        return None
    if not sigma[-1] >= ISOLATION_RATIO * sigma[0]:
        return None
    return x


def find_crossings(system: SilhouetteSystem, curves: list[Curve], cell: float) -> np.ndarray:
    """The crossings of the refined ``curves`` (see the module's doc), one per crossing. Each
    curve's points where s changes along the surface at under CANDIDATE_SLOPE times its median
    rate start the solver, the slowest first, at most MAX_TRIES per curve, one per cell."""
    found: list[np.ndarray] = []
    for curve in curves:
        slope = tangential_slope(system, curve.points)
        finite = np.isfinite(slope)
        if not finite.any():
            continue
        limit = CANDIDATE_SLOPE * float(np.median(slope[finite]))
        tried: list[np.ndarray] = []
        for i in np.argsort(slope)[: MAX_TRIES * 8]:
            if not slope[i] < limit or len(tried) >= MAX_TRIES:
                break
            p = curve.points[i]
            if any(np.linalg.norm(p - c) < cell for c in tried + found):
                continue
            tried.append(p)
            x = solve_crossing(system, p, cell)
            if x is not None and not any(np.linalg.norm(x - c) < 1e-6 * cell for c in found):
                found.append(x)
    return np.array(found).reshape(-1, 4)


def join_at_crossings(
    system: SilhouetteSystem, curves: list[Curve], crossings: np.ndarray, cell: float
) -> list[Curve]:
    """Curves cut within ``cell`` of each crossing; each piece ending there ends at the crossing
    (the gap filled with points projected onto the exact curve). Names are kept; pieces shorter
    than a tenth of a cell are dropped."""
    if len(crossings) == 0:
        return curves
    out: list[Curve] = []
    for curve in curves:
        p = curve.points
        d = np.linalg.norm(p[:, None] - crossings[None], axis=-1)
        inside = (d < cell).any(axis=1)
        if not inside.any():
            out.append(curve)
            continue
        last = len(p) - 1
        for index, closed in index_runs(~inside, curve.closed):
            points = p[index]
            # only ends cut here are joined: an open curve's own ends stay where they are
            head = None
            if curve.closed or index[0] != 0:
                head = _bridge(system, points[0], crossings, cell)
            tail = None
            if curve.closed or index[-1] != last:
                tail = _bridge(system, points[-1], crossings, cell)
            pieces = [points]
            if head is not None:
                pieces.insert(0, head[::-1])
            if tail is not None:
                pieces.append(tail)
            joined = np.concatenate(pieces)
            if polyline_length(joined, closed) >= 0.1 * cell:
                out.append(Curve(curve.name, joined, curve.material, closed))
    return out


def _bridge(
    system: SilhouetteSystem, end: np.ndarray, crossings: np.ndarray, cell: float
) -> np.ndarray | None:
    """Points from beyond ``end`` to the nearest crossing within two cells, ending exactly at
    it; intermediate points are projected onto the exact curve and kept where they converge
    and stay near the chord. None when no crossing is that near."""
    d = np.linalg.norm(crossings - end, axis=1)
    k = int(np.argmin(d))
    if d[k] > 2 * cell:
        return None
    target = crossings[k]
    steps = max(int(np.ceil(d[k] / (0.25 * cell))), 1)
    fractions = np.arange(1, steps) / steps
    chord = end + fractions[:, None] * (target - end)
    keep = np.zeros(len(chord), dtype=bool)
    if len(chord):
        projected = system.newton(chord)
        moved = np.linalg.norm(projected - chord, axis=1)
        keep = (system.residual(projected) <= RESIDUAL_TOLERANCE) & (
            moved <= 0.25 * d[k] * np.minimum(fractions, 1 - fractions)
        )
        chord = projected
    return np.vstack([chord[keep], target[None]])
