"""How many pieces a curve on a surface should show on screen, and how many it does.

Why: the offset curve of Figures 9-14 lies on the tube's outline to a fraction of a pixel, and
the renderer drew it in dashes there. The reference is computed without the renderer: for each
point of the curve, every other point of the surface with the same screen position, found by
Newton on the paper's own equations (f1 = (x - u)² + (y - v)² - r², f2 = v - u² or v² - u³)
restricted to the plane of 4D directions the view collapses (both centres at infinity:
Figures 9 and 11), started from the mesh's triangles under that position. A point is hidden
when such a point lies nearer the eye and more than a pixel away in 4D (within a pixel it is
the same point seen across a fold: the outline itself).

A run of visible points is a piece the picture must show whole; near its ends the curve leaves
the outline so slowly that a pixel decides, so each run is trimmed by a few pixels at both
ends before it is counted.
"""

from __future__ import annotations

import numpy as np

#: Gaps in the reference shorter than this many pixels along the curve are closed (a point a
#: hair past the outline between two on it), and runs are trimmed by TRIM pixels at each end
#: and kept when at least MIN_RUN pixels long.
GAP, TRIM, MIN_RUN = 3.0, 6.0, 12.0


def pipe_equations(kind: str, r: float):
    """f(q) -> (2,) and grad(q) -> (2, 4) of the offset pipe over y = x² ("parabola") or
    y² = x³ ("cusp"), in the scene's coordinates (x, y, u, v)."""

    def f(q):
        x, y, u, v = q
        base = v - u * u if kind == "parabola" else v * v - u**3
        return np.array([(x - u) ** 2 + (y - v) ** 2 - r * r, base])

    def grad(q):
        x, y, u, v = q
        base = [0.0, 0.0, -2.0 * u, 1.0] if kind == "parabola" else [0.0, 0.0, -3.0 * u * u, 2 * v]
        return np.array([[2 * (x - u), 2 * (y - v), -2 * (x - u), -2 * (y - v)], base])

    return f, grad


def samples(points: np.ndarray, closed: bool, step: float) -> np.ndarray:
    """The polyline through ``points`` sampled every ``step`` (scene units) or closer."""
    p = np.concatenate([points, points[:1]]) if closed else points
    out = []
    for a, b in zip(p[:-1], p[1:], strict=True):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + (b - a) * (np.arange(n)[:, None] / n))
    out.append(p[-1:])
    return np.concatenate(out)


def visible(points, f, grad, surface, ct, same: float) -> np.ndarray:
    """For each point of the surface f = 0, whether no other point of it with the same screen
    position lies nearer the eye, more than ``same`` away (orthographic views only)."""
    a = ct.matrix[:, :4]
    if not (np.allclose(a[3], 0.0) and abs(ct.matrix[3, 4] - 1.0) < 1e-12):
        raise ValueError("the reference is for views with both centres at infinity")
    kernel = np.linalg.svd(a[:2])[2][2:].T  # (4, 2): the directions the screen collapses
    depth = a[2]
    p, t = surface.positions, surface.triangles
    lo, hi = p.min(axis=0) - 1e-3, p.max(axis=0) + 1e-3
    corners = (p @ a[:2].T)[t]  # (m, 3, 2)
    cell = 4.0 * float(np.median(np.linalg.norm(corners[:, 1] - corners[:, 0], axis=1)))
    first = np.floor(corners.min(axis=1) / cell).astype(int)
    last = np.floor(corners.max(axis=1) / cell).astype(int)
    buckets: dict[tuple[int, int], list[int]] = {}
    for i in range(len(t)):
        for cx in range(first[i, 0], last[i, 0] + 1):
            for cy in range(first[i, 1], last[i, 1] + 1):
                buckets.setdefault((cx, cy), []).append(i)
    out = np.ones(len(points), dtype=bool)
    for k, q in enumerate(points):
        s = q @ a[:2].T
        near = np.array(buckets.get(tuple(np.floor(s / cell).astype(int)), []), dtype=int)
        if not len(near):
            continue
        c0, c1, c2 = corners[near, 0], corners[near, 1], corners[near, 2]
        e1, e2, d = c1 - c0, c2 - c0, s - c0
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        with np.errstate(all="ignore"):
            l1 = (d[:, 0] * e2[:, 1] - d[:, 1] * e2[:, 0]) / det
            l2 = (e1[:, 0] * d[:, 1] - e1[:, 1] * d[:, 0]) / det
        under = np.isfinite(l1) & (l1 >= -0.05) & (l2 >= -0.05) & (l1 + l2 <= 1.05)
        for j in np.nonzero(under)[0]:
            start = np.array([1.0 - l1[j] - l2[j], l1[j], l2[j]]) @ p[t[near[j]]]
            ab = kernel.T @ (start - q)
            for _ in range(40):
                step = np.linalg.lstsq(grad(q + kernel @ ab) @ kernel, f(q + kernel @ ab), None)[0]
                ab = ab - step
                if np.abs(step).max() < 1e-14:
                    break
            other = q + kernel @ ab
            if (
                np.abs(f(other)).max() < 1e-9
                and np.all(other >= lo)
                and np.all(other <= hi)
                and np.linalg.norm(ab) > same
                and depth @ other < depth @ q
            ):
                out[k] = False
                break
    return out


def runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True."""
    padded = np.concatenate([[False], np.asarray(flags, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(padded.astype(int)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def expected_runs(flags: np.ndarray, pixels: np.ndarray) -> list[tuple[int, int]]:
    """The reference's visible runs, gaps under GAP px closed, trimmed by TRIM px at each end,
    those at least MIN_RUN px long: where the picture must show the curve whole."""
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pixels, axis=0), axis=1))])
    merged: list[list[int]] = []
    for a, b in runs(flags):
        if merged and along[a] - along[merged[-1][1] - 1] < GAP:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    out = []
    for a, b in merged:
        inner = np.flatnonzero((along >= along[a] + TRIM) & (along <= along[b - 1] - TRIM))
        if len(inner) and along[inner[-1]] - along[inner[0]] >= MIN_RUN:
            out.append((int(inner[0]), int(inner[-1]) + 1))
    return out


def pieces(shown: np.ndarray, expected: list[tuple[int, int]]) -> list[tuple[int, float]]:
    """For each expected run, how many pieces the picture shows within it and the share of
    it shown ((1, 1.0): drawn whole; (0, 0.0): not drawn at all)."""
    return [(len(runs(shown[a:b])), round(float(np.mean(shown[a:b])), 3)) for a, b in expected]


#: The least share of a visible run the picture must show: where the curve leaves the outline
#: at a grazing angle, it stays within a pixel of it (in 4D) for many pixels on screen, and the
#: renderer may end it up to a few pixels from where the reference does.
SHARE = 0.85


def whole(counts: dict[str, list[tuple[int, float]]]) -> bool:
    """Every run one piece, drawn along at least SHARE of it."""
    return all(n == 1 and share >= SHARE for runs_ in counts.values() for n, share in runs_)


def near(image: np.ndarray, pixels: np.ndarray, test) -> np.ndarray:
    """For each point on screen, whether ``test`` holds for a pixel within one pixel of it
    (``test``: (n, ...) values of the image -> (n,) bool)."""
    h, w = image.shape[:2]
    x = np.floor(pixels[:, 0]).astype(int)
    y = np.floor(pixels[:, 1]).astype(int)
    out = np.zeros(len(pixels), dtype=bool)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            out |= test(image[np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1)])
    return out
