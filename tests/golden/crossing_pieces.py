"""Where two sheets of a surface's 3D image cross, computed without the renderer, and how many
pieces the picture's intersection ink breaks that crossing into.

Why: a crossing whose angle runs near the ink's limit was drawn in dashes (Figure 16), and one
next to a pinch point in beads (the clifford-torus takeover frame). The reference: pairs of
points p ≠ q of the surface with one screen position and one depth (one point of the 3D image),
traced by Newton and continuation on the surface's own equations (the paper's implicit f1, f2,
or a parametrisation), seeded from pairs of mesh vertices that nearly share an image. At each
point, the sine of the angle between the two sheets' tangent planes on screen (depth scaled to
pixels as the ink pass scales it) and whether a third sheet lies in front (the mesh's projected
triangles, with a few pixels of depth to spare for its sag).
"""

from __future__ import annotations

import numpy as np

from tests.golden.outline_pieces import expected_runs, pieces

#: Newton's tolerance (pixels on screen and pixels of scaled depth) and a pair's least 4D
#: distance (closer, Newton has fallen onto the trivial p = q).
TOLERANCE, APART = 1e-7, 0.02


def screen(ct, size, scale: float, p: np.ndarray) -> np.ndarray:
    """(x, y) in pixels and the window depth times ``scale`` (depth in pixels), for (..., 4)."""
    clip = ct.clip(p)
    ndc = clip[..., :3] / clip[..., 3:4]
    return np.stack(
        [
            (ndc[..., 0] + 1) * 0.5 * size[0],
            (1 - ndc[..., 1]) * 0.5 * size[1],
            0.5 * ndc[..., 2] * scale,
        ],
        axis=-1,
    )


def jacobian(fn, u: np.ndarray, h: float = 1e-7) -> np.ndarray:
    cols = []
    for i in range(len(u)):
        e = np.zeros_like(u)
        e[i] = h
        cols.append((fn(u + e) - fn(u - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def newton(fn, u: np.ndarray, steps: int = 30) -> np.ndarray | None:
    for _ in range(steps):
        r = fn(u)
        if np.abs(r).max() < TOLERANCE:
            return u
        u = u - np.linalg.lstsq(jacobian(fn, u), r, rcond=None)[0]
    return u if np.abs(fn(u)).max() < TOLERANCE else None


class Pairs:
    """The double curve of one surface's image: ``pair(u) -> (p, q)``, ``residual(u)`` (one
    fewer equation than unknowns) and the tangent planes ``tangents(p) -> (4, 2)``."""

    def __init__(self, pair, residual, tangents):
        self.pair, self.residual, self.tangents = pair, residual, tangents

    def trace(self, u0, pixel, step_px: float = 0.5, limit: int = 20000) -> list[np.ndarray]:
        """Points u along the curve through u0 both ways, about ``step_px`` apart on screen,
        until Newton fails, the two points meet (a pinch point) or the curve closes."""
        out: list[np.ndarray] = [u0]
        for sign in (1.0, -1.0):
            u, last, run = u0, None, []
            for _ in range(limit):
                j = jacobian(self.residual, u)
                t = np.linalg.svd(j)[2][-1]
                if last is None:
                    t = sign * t
                elif t @ last < 0:
                    t = -t
                speed = np.linalg.norm(jacobian(lambda s: pixel(self.pair(s)[0]), u) @ t)
                h = min(step_px / max(speed, 1e-9), 0.02)
                nxt = newton(self.residual, u + h * t)
                if nxt is None:
                    break
                p, q = self.pair(nxt)
                if np.linalg.norm(p - q) < APART:
                    break
                last, u = t, nxt
                run.append(u)
                if len(run) > 20 and np.linalg.norm(pixel(p) - pixel(self.pair(u0)[0])) < step_px:
                    break  # closed
            out = (out + run) if sign > 0 else (run[::-1] + out)
        return out


def seeds(vertices: np.ndarray, image: np.ndarray, cell: float = 6.0, apart: float = 0.3):
    """Pairs (i, j) of mesh vertices less than a ``cell`` apart in the image (screen and scaled
    depth) and more than ``apart`` apart in 4D."""
    keys = np.floor(image / cell).astype(int)
    buckets: dict[tuple, list[int]] = {}
    for i, k in enumerate(map(tuple, keys)):
        buckets.setdefault(k, []).append(i)
    out = []
    for k, members in buckets.items():
        around = [
            j
            for dx in (-1, 0, 1)
            for dy in (-1, 0, 1)
            for dz in (-1, 0, 1)
            for j in buckets.get((k[0] + dx, k[1] + dy, k[2] + dz), [])
        ]
        for i in members:
            for j in around:
                if (
                    j > i
                    and np.linalg.norm(vertices[i] - vertices[j]) > apart
                    and np.linalg.norm(image[i] - image[j]) < cell
                ):
                    out.append((i, j))
    return out


def sine(pairs: Pairs, jac_screen, p, q) -> float:
    """The sine of the angle between the two sheets' tangent planes at the image of p and q,
    on screen with depth in pixels (as intersect.glsl measures it)."""
    normals = []
    for point in (p, q):
        v = jac_screen(point) @ pairs.tangents(point)
        normals.append(np.cross(v[:, 0], v[:, 1]))
    a, b = normals
    return float(np.linalg.norm(np.cross(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b)))


def front(points_image: np.ndarray, mesh_image: np.ndarray, triangles: np.ndarray, spare: float):
    """For each image point (x, y, depth px), whether no triangle of the projected mesh lies in
    front of it by more than ``spare`` pixels of depth."""
    corners = mesh_image[triangles]
    cell = 8.0
    first = np.floor(corners[:, :, :2].min(axis=1) / cell).astype(int)
    last = np.floor(corners[:, :, :2].max(axis=1) / cell).astype(int)
    buckets: dict[tuple[int, int], list[int]] = {}
    for i in range(len(triangles)):
        for cx in range(first[i, 0], last[i, 0] + 1):
            for cy in range(first[i, 1], last[i, 1] + 1):
                buckets.setdefault((cx, cy), []).append(i)
    out = np.ones(len(points_image), dtype=bool)
    for k, s in enumerate(points_image):
        near_ = np.array(buckets.get(tuple(np.floor(s[:2] / cell).astype(int)), []), dtype=int)
        if not len(near_):
            continue
        c0, c1, c2 = (corners[near_, i] for i in range(3))
        e1, e2, d = c1[:, :2] - c0[:, :2], c2[:, :2] - c0[:, :2], s[:2] - c0[:, :2]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        with np.errstate(all="ignore"):
            l1 = (d[:, 0] * e2[:, 1] - d[:, 1] * e2[:, 0]) / det
            l2 = (e1[:, 0] * d[:, 1] - e1[:, 1] * d[:, 0]) / det
        inside = np.isfinite(l1) & (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
        depth = (1 - l1 - l2) * c0[:, 2] + l1 * c1[:, 2] + l2 * c2[:, 2]
        if np.any(inside & (depth < s[2] - spare)):
            out[k] = False
    return out


def curves(pairs: Pairs, seed_us, pixel, image_of, done_px: float = 3.0):
    """Each double curve through the seeds once: lists of u."""
    found: list[list[np.ndarray]] = []
    covered = np.empty((0, 2))
    for u0 in seed_us:
        start = pixel(pairs.pair(u0)[0])
        if len(covered) and np.min(np.linalg.norm(covered - start, axis=1)) < done_px + 6.0:
            continue
        u = newton(pairs.residual, u0)
        if u is None:
            continue
        p, q = pairs.pair(u)
        if np.linalg.norm(p - q) < APART:
            continue
        s = pixel(p)
        if len(covered) and np.min(np.linalg.norm(covered - s, axis=1)) < done_px:
            continue
        curve = pairs.trace(u, pixel)
        found.append(curve)
        covered = np.concatenate([covered, np.array([pixel(pairs.pair(v)[0]) for v in curve])])
    return found


def ink_pieces(pixels, flags, strength, inked: np.ndarray, plain: np.ndarray, least: float):
    """(pieces, share shown) per run of the curve that is visible where the ink's ``strength``
    (0..1 per point) is at least ``least``, measured on ``inked`` (the picture) against
    ``plain`` (the same without intersection ink): a point is shown where a pixel within one
    pixel of it is darker by at least SOLID x its strength (a line of the ink's width covers one
    of the two pixels it runs between by at least half; beads drop far below that)."""
    lum = np.array([0.2126, 0.7152, 0.0722])
    base = plain.astype(float) @ lum
    dark = (base - inked.astype(float) @ lum) / np.maximum(base, 1.0)
    best = np.zeros(len(pixels))
    h, w = dark.shape
    x = np.floor(pixels[:, 0]).astype(int)
    y = np.floor(pixels[:, 1]).astype(int)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            best = np.maximum(best, dark[np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1)])
    shown = best >= SOLID * strength
    return pieces(shown, expected_runs(flags & (strength >= least), pixels))


#: The least darkening, as a share of the ink's strength, that counts as ink on screen.
SOLID = 0.45
