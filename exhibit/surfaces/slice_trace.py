"""The slice S ∩ {x_a = c} of an implicit surface f1 = f2 = 0, traced along the exact curve from
seed points (predictor–corrector), not read off the mesh.

Why: next to a critical value c0 of x_a on S the slice is thinner than a mesh cell. At Figure
15's parameters the slice at t = c > 0 is a loop around the lower half of the pipe, x² = −2c·z − c²
on y² + z² = 1, 2√(2c) wide: 0.003 at c = 1e-6, against cells of 0.04. The mesh's zero set of
x_a − c misses it or cuts it into fragments, and refining those onto the exact surface finds
points with a tiny residual that are far from the slice (where the surface is tangent to the
hyperplane, a residual r only bounds the distance by r/σ, σ the smallest singular value of the
system). So:

- **Transverse curves** (the hyperplane cuts the surface at an angle) are traced in the hyperplane
  from a seed. The tangent is ∇F1 × ∇F2, the cross product of f1's and f2's gradients without
  their x_a part (F = f on the hyperplane): a field that keeps its orientation along the curve,
  so a corrector that jumps to the other side of a thin loop (the side that runs the other way)
  is seen and the step halved. The corrector is Newton on (F1, F2, t·(x − p)); the step grows
  while the curve is straight and shrinks (to 1e-12 of the box) round the sharp ends of a thin
  loop, whose radius of curvature is c itself. A curve is closed when it comes back to its seed
  running the same way; ends that stall (round-off makes a turn of radius below ~1e-8
  unresolvable) are joined to the nearest other end running back (``join_stalled``).
- **Tangency curves** (x_a = c0 exactly, the hyperplane tangent to S along a curve: Figure 15 at
  t = 0, and any rc = rs at t = 0 whatever the speeds) are where F2 has a double zero on F1 = 0:
  ∇F2 = λ∇F1, F1 = 0 (four equations in x and λ whose Jacobian has rank three along such a
  curve). They are traced with the Jacobian's null vector as the tangent and Gauss–Newton as the
  corrector, through the surface's singular points, where the 4D gradients are parallel but the
  3D picture of two tangent surfaces is not singular at all. A curve is a tangency curve only
  where F2 vanishes on it to round-off (TANGENCY_RESIDUAL): off by more, the slice is a thin
  loop near it, which the transverse tracer follows.
- **Seeds** come from the mesh at c and, for slices that the mesh cannot resolve at c, from the
  mesh at c ± δ (a few cells of x_a away), continued to c by Newton in small steps of c.

Every point is accepted by its distance to the exact slice, not only its residual.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from exhibit.surfaces.expressions import ScalarField

#: Newton is done when its step is below this (relative to the box's size).
STEP_TARGET = 1e-13
#: A corrector gives up after this many iterations.
CORRECTOR_ITERATIONS = 12
#: The largest turn (degrees) between the tangents at the two ends of one accepted step; the step
#: grows while the turn stays under GROW_TURN.
MAX_TURN, GROW_TURN = 12.0, 4.0
#: The shortest step tried (relative to the box) before an end counts as stalled.
MIN_STEP = 1e-12
#: A transverse seed needs sin(angle between the hyperplane's F1, F2 normals) at least this: at a
#: tangency the angle is 0 and the curve is the tangency tracer's.
MIN_TRANSVERSE = 1e-6
#: |F2|/|∇F2| on a tangency curve, at most (round-off at the scale of the box).
TANGENCY_RESIDUAL = 1e-12
#: sin(angle between F1's and F2's normals) below which a stalled end is at a crossing.
CROSSING_SIZE = 1e-3
#: At most this many points per curve (a runaway trace stops there, open).
MAX_POINTS = 20000


@dataclass
class SlicePlane:
    """f1 = f2 = 0 within the hyperplane x[axis] = at; points are 4-vectors with x[axis] = at."""

    f1: ScalarField
    f2: ScalarField
    axis: int
    at: float
    scale: float = 1.0  # the box's size, for the absolute tolerances

    def __post_init__(self) -> None:
        self.others = [i for i in range(4) if i != self.axis]

    @np.errstate(all="ignore")
    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Values (2,) and gradients within the hyperplane (2, 3) at one point."""
        p = np.asarray(x, dtype=float)[None]
        values = np.array([self.f1.value(p)[0], self.f2.value(p)[0]], dtype=float)
        grads = np.stack([self.f1.gradient(p)[0], self.f2.gradient(p)[0]])
        return values, grads[:, self.others]

    def lift(self, u: np.ndarray) -> np.ndarray:
        x = np.empty(4)
        x[self.others] = u
        x[self.axis] = self.at
        return x


# ------------------------------------------------------------------------- transverse curves


def transverse_tangent(grads: np.ndarray) -> tuple[np.ndarray, float]:
    """∇F1 × ∇F2 normalised, and sin of the angle between them (0 at a tangency)."""
    n = grads / np.linalg.norm(grads, axis=1, keepdims=True)
    t = np.cross(n[0], n[1])
    size = float(np.linalg.norm(t))
    return (t / size if size > 0 else t), size


@np.errstate(all="ignore")
def correct(
    plane: SlicePlane, guess: np.ndarray, tangent: np.ndarray, max_move: float
) -> np.ndarray | None:
    """Newton on (F1, F2, t·(u − guess)) from ``guess`` (3-vector): the point of the slice in the
    plane through ``guess`` across the curve, or None."""
    u = np.asarray(guess, dtype=float).copy()
    for _ in range(CORRECTOR_ITERATIONS):
        values, grads = plane.evaluate(plane.lift(u))
        jac = np.vstack([grads, tangent])
        rhs = np.concatenate([values, [tangent @ (u - guess)]])
        if not (np.isfinite(jac).all() and np.isfinite(rhs).all()):
            return None
        try:
            step = np.linalg.solve(jac, rhs)
        except np.linalg.LinAlgError:
            return None
        u -= step
        if np.linalg.norm(u - guess) > max_move:
            return None
        if np.linalg.norm(step) <= STEP_TARGET * plane.scale:
            return u
    return None


@dataclass
class Trace:
    points: np.ndarray  # (N, 3) within the hyperplane
    closed: bool
    stalled: tuple[bool, bool]  # whether each end stalled (rather than leaving the box)


def _march(plane: SlicePlane, seed: np.ndarray, sign: float, max_step: float, inside):
    """Points from ``seed`` along sign·(∇F1 × ∇F2): (points after the seed, closed, stalled)."""
    _, grads = plane.evaluate(plane.lift(seed))
    t0, _ = transverse_tangent(grads)
    t0 = sign * t0
    u, t, h = seed, t0, 0.25 * max_step
    out: list[np.ndarray] = []
    cos_max, cos_grow = math.cos(math.radians(MAX_TURN)), math.cos(math.radians(GROW_TURN))
    while len(out) < MAX_POINTS:
        if h < MIN_STEP * plane.scale:
            return out, False, True
        q = correct(plane, u + h * t, t, 0.5 * h + 1e3 * STEP_TARGET * plane.scale)
        if q is None:
            h *= 0.5
            continue
        _, grads = plane.evaluate(plane.lift(q))
        tq, size = transverse_tangent(grads)
        tq = sign * tq
        turn = float(tq @ t)
        if size == 0 or turn < cos_max or (q - u) @ t <= 0.25 * h:
            h *= 0.5
            continue
        # back at the seed, running the same way: closed (the last point is the seed itself)
        if len(out) >= 2 and tq @ t0 > cos_max:
            d = q - u
            s = np.clip((seed - u) @ d / (d @ d), 0.0, 1.0)
            if np.linalg.norm(u + s * d - seed) <= 0.25 * np.linalg.norm(d):
                return out, True, False
        if not inside(q):
            return out, False, False
        out.append(q)
        u, t = q, tq
        if turn > cos_grow:
            h = min(1.5 * h, max_step)
    return out, False, False


def trace_transverse(
    plane: SlicePlane, seed: np.ndarray, max_step: float, inside: Callable[[np.ndarray], bool]
) -> Trace:
    """The whole transverse curve through ``seed`` (3-vector on the slice)."""
    ahead, closed, stalled_ahead = _march(plane, seed, 1.0, max_step, inside)
    if closed:
        return Trace(np.array([seed, *ahead]), True, (False, False))
    back, _, stalled_back = _march(plane, seed, -1.0, max_step, inside)
    points = np.array([*back[::-1], seed, *ahead]).reshape(-1, 3)
    return Trace(points, False, (stalled_back, stalled_ahead))


def on_trace(plane: SlicePlane, seed: np.ndarray, trace: Trace, tolerance: float) -> bool:
    """Whether ``seed`` lies on ``trace``: the traced curve, corrected onto the plane through the
    seed across it from the nearest traced point running the same way, passes through the seed.
    (A thin loop's other side is as near but runs the other way.)"""
    _, grads = plane.evaluate(plane.lift(seed))
    ts, _ = transverse_tangent(grads)
    p = trace.points
    d = np.linalg.norm(p - seed, axis=1)
    tried = 0
    for k in np.argsort(d)[:64]:
        _, g = plane.evaluate(plane.lift(p[k]))
        tk, _ = transverse_tangent(g)
        if tk @ ts < 0.5:  # the other side of a thin loop, or a turn
            continue
        q = correct(plane, p[k] + tk * (tk @ (seed - p[k])), tk, 2 * d[k] + tolerance)
        if q is not None and np.linalg.norm(q - seed) <= tolerance:
            return True
        tried += 1
        if tried == 3:
            break
    return False


def join_stalled(
    plane: SlicePlane, traces: list[Trace], reach: float, crossing_reach: float
) -> list[Trace]:
    """Join open traces where one's last point and another's first (or its own) both stalled
    within ``reach`` of each other: the two sides of a thin loop meet at its sharp ends, where
    round-off stalls both. Each trace runs along ∇F1 × ∇F2, whose orientation holds along the
    whole curve, so a trace continues only at the start of the next; nearest pairs first. Ends
    where the hyperplane's F1 and F2 normals are nearly parallel (sin below CROSSING_SIZE: a
    saddle of x_a, where the slice crosses itself, stalls the tracer some 1e-5 short) are joined
    within ``crossing_reach``: the slice through a saddle is two loops touching there."""
    traces = list(traces)

    def size(u):
        return transverse_tangent(plane.evaluate(plane.lift(u))[1])[1]

    def allowed(a, b) -> float:
        if size(a) < CROSSING_SIZE and size(b) < CROSSING_SIZE:
            return max(reach, crossing_reach)
        return reach

    while True:
        best = None
        for i, a in enumerate(traces):
            for j, b in enumerate(traces):
                if a.closed or b.closed or not (a.stalled[1] and b.stalled[0]):
                    continue
                d = float(np.linalg.norm(a.points[-1] - b.points[0]))
                if (best is None or d < best[0]) and d <= allowed(a.points[-1], b.points[0]):
                    best = (d, i, j)
        if best is None:
            return traces
        _, i, j = best
        if i == j:
            traces[i] = Trace(traces[i].points, True, (False, False))
            continue
        a, b = traces[i], traces[j]
        joined = Trace(np.concatenate([a.points, b.points]), False, (a.stalled[0], b.stalled[1]))
        traces = [t for k, t in enumerate(traces) if k not in (i, j)] + [joined]


def drop_contained(plane: SlicePlane, traces: list[Trace], tolerance: float) -> list[Trace]:
    """Longest first, the traces not lying on one kept already: a trace from a seed on one side
    of a thin loop can stall at both sharp ends while one from the other side goes round an end
    and takes in the first side too."""
    kept: list[Trace] = []
    for trace in sorted(traces, key=lambda t: -len(t.points)):
        middle = trace.points[len(trace.points) // 2]
        if not any(on_trace(plane, middle, other, tolerance) for other in kept):
            kept.append(trace)
    return kept


# --------------------------------------------------------------------------- tangency curves


@np.errstate(all="ignore")
def _tangency_system(plane: SlicePlane, z: np.ndarray, h: float):
    """G(u, λ) = (F1, ∇F2 − λ∇F1) and its Jacobian (central differences of the gradients)."""
    u, lam = z[:3], z[3]
    values, grads = plane.evaluate(plane.lift(u))
    g = np.concatenate([[values[0]], grads[1] - lam * grads[0]])
    jac = np.zeros((4, 4))
    jac[0, :3] = grads[0]
    jac[1:, 3] = -grads[0]
    for k in range(3):
        du = np.zeros(3)
        du[k] = h
        _, gp = plane.evaluate(plane.lift(u + du))
        _, gm = plane.evaluate(plane.lift(u - du))
        jac[1:, k] = ((gp[1] - lam * gp[0]) - (gm[1] - lam * gm[0])) / (2 * h)
    return g, jac, values, grads


def _tangency_tangent(jac: np.ndarray) -> np.ndarray:
    return np.linalg.svd(jac)[2][-1]


@np.errstate(all="ignore")
def _correct_tangency(plane, guess, tangent, h, max_move):
    z = np.asarray(guess, dtype=float).copy()
    for _ in range(CORRECTOR_ITERATIONS):
        g, jac, *_ = _tangency_system(plane, z, h)
        a = np.vstack([jac, tangent])
        rhs = np.concatenate([g, [tangent @ (z - guess)]])
        if not (np.isfinite(a).all() and np.isfinite(rhs).all()):
            return None
        step = np.linalg.lstsq(a, rhs, rcond=None)[0]
        z -= step
        if np.linalg.norm(z[:3] - guess[:3]) > max_move:
            return None
        if np.linalg.norm(step[:3]) <= STEP_TARGET * plane.scale:
            return z
    return None


def tangency_residual(plane: SlicePlane, u: np.ndarray) -> float:
    values, grads = plane.evaluate(plane.lift(u))
    return float(np.max(np.abs(values) / np.linalg.norm(grads, axis=1)))


def tangency_seed(plane: SlicePlane, u: np.ndarray, h: float) -> np.ndarray | None:
    """(u, λ) on a tangency curve near ``u``, or None: λ from ∇F2 = λ∇F1 by least squares,
    then the corrector across the curve."""
    _, grads = plane.evaluate(plane.lift(u))
    lam = float(grads[1] @ grads[0] / (grads[0] @ grads[0]))
    z = np.concatenate([u, [lam]])
    with np.errstate(all="ignore"):
        _, jac, *_ = _tangency_system(plane, z, h)
    if not np.isfinite(jac).all():
        return None
    z = _correct_tangency(plane, z, _tangency_tangent(jac), h, 10 * h)
    if z is None or tangency_residual(plane, z[:3]) > TANGENCY_RESIDUAL:
        return None
    return z


def trace_tangency(
    plane: SlicePlane, seed: np.ndarray, max_step: float, inside: Callable[[np.ndarray], bool]
) -> Trace:
    """The tangency curve through ``seed`` ((u, λ) from tangency_seed)."""
    fd = 1e-6 * plane.scale
    cos_max, cos_grow = math.cos(math.radians(MAX_TURN)), math.cos(math.radians(GROW_TURN))
    _, jac0, *_ = _tangency_system(plane, seed, fd)
    t0 = _tangency_tangent(jac0)
    halves = []
    for sign in (1.0, -1.0):
        z, t, h = seed, sign * t0, 0.25 * max_step
        out: list[np.ndarray] = []
        closed = stalled = False
        while len(out) < MAX_POINTS:
            if h < MIN_STEP * plane.scale * 1e3:  # finite differences: no finer than this
                stalled = True
                break
            direction = t / max(float(np.linalg.norm(t[:3])), 1e-300)
            q = _correct_tangency(plane, z + h * direction, t, fd, 0.5 * h)
            if q is None or tangency_residual(plane, q[:3]) > TANGENCY_RESIDUAL:
                h *= 0.5
                continue
            _, jac, *_ = _tangency_system(plane, q, fd)
            tq = _tangency_tangent(jac)
            tq *= np.sign(tq @ t) or 1.0
            turn = float(tq[:3] @ t[:3]) / max(
                float(np.linalg.norm(tq[:3]) * np.linalg.norm(t[:3])), 1e-300
            )
            if turn < cos_max or (q[:3] - z[:3]) @ direction[:3] <= 0.25 * h:
                h *= 0.5
                continue
            if len(out) >= 2 and sign > 0:
                d = q[:3] - z[:3]
                s = np.clip((seed[:3] - z[:3]) @ d / (d @ d), 0.0, 1.0)
                if np.linalg.norm(z[:3] + s * d - seed[:3]) <= 0.25 * np.linalg.norm(d):
                    closed = True
                    break
            if not inside(q[:3]):
                break
            out.append(q[:3])
            z, t = q, tq
            if turn > cos_grow:
                h = min(1.5 * h, max_step)
        if closed:
            return Trace(np.array([seed[:3], *out]), True, (False, False))
        halves.append((out, stalled))
    (ahead, stalled_ahead), (back, stalled_back) = halves
    points = np.array([*back[::-1], seed[:3], *ahead]).reshape(-1, 3)
    return Trace(points, False, (stalled_back, stalled_ahead))
