"""Refined silhouette runs made into the curves an implicit scene exports: each run cut where it
folds back on itself (the mesh traced two sheets as one), its open ends continued along the exact
curve up to the singular set's exclusion (the traced curve stops where the mesh tears, the exact
one goes on), and fragments the mesh traced twice or too short to see dropped. Apart from the
Newton step and the judgement of each point (:mod:`exhibit.surfaces.exact_silhouette`) because
this is about curves as a visitor sees them, not about single points."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from exhibit.surfaces.exact_silhouette import (
    EXCLUSION_RATIO,
    RESIDUAL_TOLERANCE,
    RefineStats,
    SilhouetteSystem,
    index_runs,
)
from exhibit.surfaces.mesh import Curve
from exhibit.surfaces.singular import jacobian_ratio

#: Consecutive steps of a refined run with a cosine below this: the run folds back on itself.
#: A fold lands both legs on the same curve (cosine -1); a kink where two traced points refine
#: slightly out of order stays near -0.5 (the collision's curves) and is kept.
HAIRPIN_COSINE = -0.9


def refine_curves(
    system: SilhouetteSystem,
    curves: list[Curve],
    max_move: float,
    singular_points: np.ndarray | None = None,
    exclusion_radius: float = 0.0,
) -> tuple[list[Curve], RefineStats]:
    """Each curve's points refined; curves split at dropped and excluded points; open ends
    continued along the exact curve up to the exclusion (``extend_end``); a run lying along
    another (a fragment the mesh traced twice) or shorter than a cell dropped, so no duplicate
    or zero-length curve is exported. ``max_move`` is two cells."""
    stats = RefineStats()
    runs = []
    for curve in curves:
        x, keep, s = system.refine(curve.points, max_move, singular_points, exclusion_radius)
        s.refined = 0
        stats.add(s)
        last = len(x) - 1
        for index, closed in index_runs(keep, curve.closed):
            # an end where the traced curve itself ends is on the mesh's boundary (the box):
            # only ends cut by the judgement, or at a turn, are continued
            ends = (curve.closed or index[0] != 0, curve.closed or index[-1] != last)
            runs += split_at_reversals(curve, x[index], closed, ends)
    cell = 0.5 * max_move
    # continued ends stay within the traced curves' bounding box: the surface's box cuts them
    traced = np.concatenate([c.points for c in curves]) if curves else np.zeros((0, 4))
    bounds = (traced.min(axis=0), traced.max(axis=0)) if len(traced) else None
    # longest first: a fragment is judged against the curves it duplicates
    runs.sort(key=lambda run: -polyline_length(run[1], run[2]))
    out: list[Curve] = []
    for curve, points, closed, ends in runs:
        kept = np.concatenate([c.points for c in out]) if out else np.zeros((0, 4))
        if near(points, kept, cell).all():
            continue
        if not closed:
            points = extend_run(system, points, cell, kept, ends, bounds)
        if polyline_length(points, closed) < cell:
            continue
        out.append(Curve(curve.name, points, curve.material, closed))
    stats.refined = sum(len(c.points) + c.closed for c in out)  # the points exported
    stats.max_residual = max((float(system.residual(c.points).max()) for c in out), default=0.0)
    return out, stats


def split_at_reversals(
    curve: Curve, points: np.ndarray, closed: bool, ends: tuple[bool, bool]
) -> list[tuple[Curve, np.ndarray, bool, tuple[bool, bool]]]:
    """[(curve, points, closed, (continue head, continue tail))]: a run cut where it turns back
    on itself. Where the mesh cannot separate two sheets its zero set can run out along a branch
    on one and back on the other; refined, both legs land on the same curve, a hairpin. Cut at
    the turn (an end to continue), the shorter leg duplicates the longer one."""
    if len(points) < 3:
        return [(curve, points, closed, ends)]
    if not closed:
        points = trim_end_zigzags(points)
    step = np.diff(points, axis=0)
    length = np.linalg.norm(step, axis=1)
    with np.errstate(all="ignore"):
        cosine = np.einsum("ij,ij->i", step[1:], step[:-1]) / (length[1:] * length[:-1])
    # a fold, not a zigzag of one point refined out of order: the legs run back together
    candidates = [int(i) for i in np.flatnonzero(cosine < HAIRPIN_COSINE) + 1]
    turns = [
        i
        for i in candidates
        if 2 <= i <= len(points) - 3
        and np.linalg.norm(points[i + 2] - points[i - 2])
        < 0.5
        * min(np.linalg.norm(points[i + 2] - points[i]), np.linalg.norm(points[i - 2] - points[i]))
    ]
    if len(turns) == 0:
        return [(curve, points, closed, ends)]
    bounds = [0, *turns, len(points) - 1]
    return [
        (curve, points[a : b + 1], False, (ends[0] or a > 0, ends[1] or b < len(points) - 1))
        for a, b in zip(bounds[:-1], bounds[1:])
        if b > a
    ]


def trim_end_zigzags(points: np.ndarray, legs: int = 4) -> np.ndarray:
    """An open run without a short leg that doubles back at either end (up to ``legs`` points
    refined out of order, or a fold too short to cut): otherwise the end's outward direction
    would point back along the run. The run then ends at the turn."""

    def turn(p):
        for i in range(1, min(legs, len(p) - 2) + 1):
            u, v = p[i] - p[i - 1], p[i + 1] - p[i]
            if u @ v < HAIRPIN_COSINE * np.linalg.norm(u) * np.linalg.norm(v):
                return i
        return 0

    points = points[turn(points) :]
    tail = turn(points[::-1])
    return points[: len(points) - tail] if tail else points


def drop_fragments(curves: list, cell: float) -> list:
    """Longest first, the curves that neither lie within ``cell`` of those kept (a piece the
    mesh traced twice) nor are shorter than ``cell`` (a degenerate one)."""
    kept: list = []
    for curve in sorted(curves, key=lambda c: -polyline_length(c.points, c.closed)):
        points = np.concatenate([c.points for c in kept]) if kept else np.zeros((0, 4))
        if near(curve.points, points, cell).all():
            continue
        if polyline_length(curve.points, curve.closed) < cell:
            continue
        kept.append(curve)
    return kept


def near(points: np.ndarray, others: np.ndarray, distance: float) -> np.ndarray:
    """True for each point within ``distance`` of one of ``others``."""
    out = np.zeros(len(points), dtype=bool)
    if len(others) == 0:
        return out
    for start in range(0, len(points), 256):
        d = np.linalg.norm(points[start : start + 256, None] - others[None], axis=-1)
        out[start : start + 256] = d.min(axis=1) < distance
    return out


def polyline_length(points: np.ndarray, closed: bool) -> float:
    p = np.vstack([points, points[:1]]) if closed else points
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def extend_run(
    system: SilhouetteSystem,
    points: np.ndarray,
    cell: float,
    others: np.ndarray,
    ends: tuple[bool, bool] = (True, True),
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """An open run with its ends continued (``extend_end``) where ``ends`` says so."""
    if len(points) < 2:
        return points
    none = np.zeros((0, 4))
    tail = (
        extend_end(system, points[-1], points[-1] - points[-2], cell, others, bounds=bounds)
        if ends[1]
        else none
    )
    head = (
        extend_end(system, points[0], points[0] - points[1], cell, others, bounds=bounds)
        if ends[0]
        else none
    )
    return np.concatenate([head[::-1], points, tail])


def extend_end(
    system: SilhouetteSystem,
    end: np.ndarray,
    outward: np.ndarray,
    cell: float,
    others: np.ndarray,
    reach: float = 8.0,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Points continuing a silhouette curve beyond ``end`` (``march``: predictor along the
    curve's tangent, corrector by the same Newton), for up to ``reach`` cells, until a point would
    be excluded (σ_min/σ_max of (∇f1, ∇f2) below EXCLUSION_RATIO), runs onto ``others`` (another
    traced curve) or out of ``bounds``, or Newton fails even with a step of 1/4096 cell. The
    traced curve stops where the mesh cannot follow it (near a singular point the mesh is torn,
    and points within half a cell of one are excluded); the exact curve goes on to the exclusion
    the ratio states.

    "Runs onto another curve": the continuation passes through a point of ``others``
    (``passes``); it is then cut back to where it came within half a cell of them. Coming
    within half a cell is not enough: two branches that meet at a singular point (the same
    exact curve on either side of it) come that near before either reaches the ratio's
    exclusion where that is narrow, and never meet. The cusp's at r = 0.3 are 0.035 apart at
    |t| = 0.039 in a cell of 0.086: the second branch continued stopped at |t| = 0.061-0.064
    (issue 32), and at r = 0.1 at |t| = 0.20-0.22 against 0.027."""
    out: list[np.ndarray] = []
    p = np.asarray(end, float)
    for q in march(system, end, outward, cell, reach, bounds):
        if passes(p, q, others):
            # it runs onto another curve: stop where it came within half a cell of it
            close = near(np.array(out).reshape(-1, 4), others, 0.5 * cell)
            while out and close[len(out) - 1]:
                out.pop()
            break
        out.append(q)
        p = q
    return np.array(out).reshape(-1, 4)


def march(
    system: SilhouetteSystem,
    start: np.ndarray,
    direction: np.ndarray,
    cell: float,
    reach: float,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> Iterator[np.ndarray]:
    """The exact curve through ``start`` followed in ``direction``: points a quarter cell apart
    (halved down to 1/4096 cell where Newton fails) for up to ``reach`` cells, until the next
    point would be excluded by the ratio or leave ``bounds``. The smallest step is not the
    cell's business: the last steps resolve where σ_min/σ_max reaches EXCLUSION_RATIO (with
    1/64 cell the cusp at r = 0.1 stopped at |t| = 0.030-0.044, σ_min/σ_max 1.4e-4-4.4e-4)."""
    fields = (system.f1, system.f2, system.s)
    p, h, travelled = np.asarray(start, float), 0.25 * cell, 0.0
    direction = np.asarray(direction, float)
    with np.errstate(all="ignore"):
        while travelled < reach * cell and h >= cell / 4096:
            jac = np.stack([f.gradient(p[None])[0] for f in fields])
            if not np.isfinite(jac).all():
                return
            tangent = np.linalg.svd(jac)[2][-1]
            tangent *= np.sign(tangent @ direction) or 1.0
            guess = p + h * tangent
            q = system.newton(guess[None])[0]
            ok = (
                np.isfinite(q).all()
                and system.residual(q[None])[0] <= RESIDUAL_TOLERANCE
                and np.linalg.norm(q - guess) <= 0.5 * h
                and (q - p) @ tangent > 0.25 * h
                and jacobian_ratio(system.f1, system.f2, q[None])[0] >= EXCLUSION_RATIO
            )
            if not ok:
                h /= 2
                continue
            if bounds is not None and ((q < bounds[0]).any() or (q > bounds[1]).any()):
                return
            yield q
            travelled += float(np.linalg.norm(q - p))
            direction, p = q - p, q
            h = min(2 * h, 0.25 * cell)


def passes(p: np.ndarray, q: np.ndarray, others: np.ndarray) -> bool:
    """Whether the step from p to q passes through a point of ``others``: one whose foot on the
    segment lies between its ends, within a quarter of the step's length (an exact curve run
    onto another traced curve, not one meeting it at an angle farther off)."""
    if len(others) == 0:
        return False
    step = q - p
    length2 = float(step @ step)
    if not length2 > 0:
        return False
    along = (others - p) @ step
    inside = (along >= 0) & (along <= length2)
    if not inside.any():
        return False
    foot = p + (along[inside] / length2)[:, None] * step
    return bool((np.linalg.norm(others[inside] - foot, axis=1) <= 0.25 * np.sqrt(length2)).any())
