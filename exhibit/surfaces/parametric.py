"""Tessellation of parametric 2-surfaces X(s, t) in R^4 on (s, t) rectangles, periodic or not.

Samples are placed where the surface bends: along each parameter the spacing follows the
curvature measured on a finer pilot grid (the turning of the tangent plane plus arc length), so
flat stretches get few rows and bends many. The result is still a structured grid, so it is
crack-free by construction: every edge belongs to the same grid line on both sides.

A point function from a scene file may be undefined or overflow on part of the rectangle: such
samples are dropped with their triangles, and tangents that are not finite give zero normals
(a singular vertex), so no NaN or inf reaches the Surface.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from exhibit.geometry.normals import complement_plane
from exhibit.surfaces.mesh import Material, Surface

PointFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]
TangentFunction = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

#: Finite-difference step for surfaces without analytic tangents (relative to the domain size).
FD_STEP = 1e-6


@dataclass(frozen=True)
class Interval:
    start: float
    stop: float
    periodic: bool = False

    def __post_init__(self) -> None:
        if not (np.isfinite(self.start) and np.isfinite(self.stop) and self.stop > self.start):
            raise ValueError(f"parameter interval [{self.start}, {self.stop}] is empty or infinite")

    def uniform(self, count: int) -> np.ndarray:
        """count samples; a periodic interval leaves out its end (it is the start again)."""
        return np.linspace(self.start, self.stop, count, endpoint=not self.periodic)


def finite_difference_tangents(
    function: PointFunction, s_interval: Interval, t_interval: Interval
) -> TangentFunction:
    hs = FD_STEP * (s_interval.stop - s_interval.start)
    ht = FD_STEP * (t_interval.stop - t_interval.start)

    def tangents(s, t):
        return (
            (function(s + hs, t) - function(s - hs, t)) / (2 * hs),
            (function(s, t + ht) - function(s, t - ht)) / (2 * ht),
        )

    return tangents


def _bend_density(points: np.ndarray, frames: np.ndarray, axis: int, periodic: bool) -> np.ndarray:
    """Weight of each pilot interval along ``axis``: its share of the arc length plus its share
    of the tangent plane's turning, each taken as the largest over the other parameter."""

    def step(a):
        if periodic:
            return np.roll(a, -1, axis=axis), a
        count = a.shape[axis]
        return (
            np.take(a, np.arange(1, count), axis=axis),
            np.take(a, np.arange(count - 1), axis=axis),
        )

    nxt, cur = step(points)
    length = np.linalg.norm(nxt - cur, axis=-1)
    length = np.where(np.isfinite(length), length, 0.0).max(axis=1 - axis)
    f_next, f_cur = step(frames)
    # How far the next normal frame leaves the current normal plane (0 when the plane is fixed).
    overlap = np.einsum("...ai,...bi->...ab", f_next, f_cur)
    turning = np.sqrt(np.maximum(2.0 - np.sum(overlap**2, axis=(-1, -2)), 0.0))
    turning = np.where(np.isfinite(turning), turning, 0.0).max(axis=1 - axis)
    density = length / max(length.sum(), 1e-300)
    if turning.sum() > 1e-9:
        density = density + turning / turning.sum()
    return density


def _equidistribute(pilot: np.ndarray, density: np.ndarray, count: int, interval: Interval):
    """Place count samples so each interval carries the same share of the density."""
    edges = pilot if not interval.periodic else np.append(pilot, interval.stop)
    weights = density + 0.25 * density.mean()  # never starve a flat stretch entirely
    if not weights.sum() > 0:  # nothing measurable (e.g. undefined on the whole pilot grid)
        return interval.uniform(count)
    cumulative = np.concatenate([[0.0], np.cumsum(weights)])
    targets = np.linspace(0.0, cumulative[-1], count + (0 if not interval.periodic else 1))
    samples = np.interp(targets, cumulative, edges)
    return samples[:-1] if interval.periodic else samples


def finite_directions(vectors: np.ndarray) -> np.ndarray:
    """Rows of (..., 4) scaled by their largest component, non-finite or zero rows set to zero.

    Normal and tangent planes depend only on directions; the scaling keeps the 4D cross products
    that turn them into planes from overflowing, and a zero row reads as a singular point."""
    vectors = np.asarray(vectors, dtype=float)
    with np.errstate(all="ignore"):
        largest = np.max(np.abs(vectors), axis=-1, keepdims=True)
        usable = np.isfinite(largest) & (largest > 0)
        return np.where(usable, vectors / np.where(usable, largest, 1.0), 0.0)


def keep_vertices(keep: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop the vertices not in ``keep`` with every triangle touching them, then any vertex left
    without a triangle. Returns (the vertices to keep, the triangles renumbered to them)."""
    triangles = triangles[np.all(keep[triangles], axis=1)]
    used = np.zeros(len(keep), dtype=bool)
    used[triangles] = True
    return used, (np.cumsum(used) - 1)[triangles]


def grid_triangles(rows: int, cols: int, periodic_rows: bool, periodic_cols: bool) -> np.ndarray:
    """Two triangles per grid cell, wrapping where periodic; vertex (i, j) has index i*cols + j."""
    ri = np.arange(rows if periodic_rows else rows - 1)
    cj = np.arange(cols if periodic_cols else cols - 1)
    i, j = np.meshgrid(ri, cj, indexing="ij")
    i2, j2 = (i + 1) % rows, (j + 1) % cols
    a, b, c, d = i * cols + j, i2 * cols + j, i2 * cols + j2, i * cols + j2
    tris = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return tris.astype(np.int32)


@np.errstate(all="ignore")
def tessellate(
    name: str,
    function: PointFunction,
    s_interval: Interval,
    t_interval: Interval,
    resolution: tuple[int, int],
    tangents: TangentFunction | None = None,
    material: Material | None = None,
    adaptive: bool = True,
) -> Surface:
    """A Surface sampling X(s, t) on a rows x cols grid; tangents analytic when given.

    Samples where X is not finite are left out with their triangles (see the module's notes)."""
    started = time.perf_counter()
    rows, cols = resolution
    if rows < 2 or cols < 2:
        raise ValueError(f"{name}: resolution must be at least 2 x 2, got {rows} x {cols}")
    tangents = tangents or finite_difference_tangents(function, s_interval, t_interval)
    s_samples, t_samples = s_interval.uniform(rows), t_interval.uniform(cols)
    if adaptive:
        s_pilot, t_pilot = s_interval.uniform(2 * rows), t_interval.uniform(2 * cols)
        S, T = np.meshgrid(s_pilot, t_pilot, indexing="ij")
        pilot_points = function(S, T)
        frames = np.stack(complement_plane(*map(finite_directions, tangents(S, T))), axis=-2)
        s_samples = _equidistribute(
            s_pilot, _bend_density(pilot_points, frames, 0, s_interval.periodic), rows, s_interval
        )
        t_samples = _equidistribute(
            t_pilot, _bend_density(pilot_points, frames, 1, t_interval.periodic), cols, t_interval
        )
    S, T = np.meshgrid(s_samples, t_samples, indexing="ij")
    positions = function(S, T).reshape(-1, 4)
    t1, t2 = (finite_directions(t).reshape(-1, 4) for t in tangents(S, T))
    keep, triangles = keep_vertices(
        np.all(np.isfinite(positions), axis=1),
        grid_triangles(rows, cols, s_interval.periodic, t_interval.periodic),
    )
    surface = Surface.from_tangents(name, positions[keep], t1[keep], t2[keep], triangles, material)
    assert surface.singular is not None  # __post_init__ sets it
    surface.info = {
        "kind": "parametric",
        "max_residual": None,
        "singular_points": int(surface.singular.sum()),
        "seconds": time.perf_counter() - started,
        "resolution": [rows, cols],
    }
    from exhibit.surfaces.exact_silhouette import ParametricExact

    surface.exact = ParametricExact(
        function, tangents, s_interval, t_interval, np.stack([S, T], -1).reshape(-1, 2)[keep]
    )
    return surface
