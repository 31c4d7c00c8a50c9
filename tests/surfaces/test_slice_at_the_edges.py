"""Slices next to a critical value of t (issue 32): the collision's slice at t = c, compared with
the exact curve by distance, not by residual.

The exact slice is computed here from the two moving bodies alone. At the moment c the pipe is
(y − vc·c)² + z² = rc² and the ball x² + y² + (z + vs·c)² = rs², so round the pipe at angle φ,
(y, z) = (vc·c + rc cos φ, rc sin φ), the curve has x² = g(φ) = rs² − y² − (z + vs·c)²: one loop
for each arc of φ where g > 0, two loops (x > 0 and x < 0) where g > 0 all round. Near the
loop's sharp ends √g is steep, so the distance is also measured along the other parametrisation,
by x: the ball minus the pipe is x² + 2c(vc·y + vs·z) + c²(vs² − vc²) = rs² − rc², a line in
(y, z) for each x, met by the pipe's circle.

Before this round, at Figure 15's parameters (rc = rs = 1, vc = 0, vs = 1): 0 curves at
t = 1e-6 and 1e-7, 6 open fragments at 1e-9 with points 1.22 from the slice on the wrong half;
at the exact tangency t = 0 with rc = rs = 2, vs = 3, three pieces with a gap of 0.161.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from exhibit.scenes.collision import build_part
from exhibit.surfaces.exact_silhouette import RefineStats
from exhibit.surfaces.slice import slice_curves

T = 3
#: Every slice point within this of the exact curve (round-off resolves a loop's sharp end, of
#: radius c, only to about 1e-7).
DISTANCE = 1e-6
_PARTS: dict = {}


def part(p: dict):
    key = tuple(sorted(p.items()))
    if key not in _PARTS:
        _PARTS[key] = build_part(p, 48)
    return _PARTS[key]


def g(p: dict, c: float, phi):
    y, z = p["vc"] * c + p["rc"] * np.cos(phi), p["rc"] * np.sin(phi)
    return p["rs"] ** 2 - y * y - (z + p["vs"] * c) ** 2


def exact_distance(points: np.ndarray, p: dict, c: float) -> np.ndarray:
    """An upper bound of each point's distance to the exact slice at t = c (see the docstring):
    the nearer of the curve's points at the point's own angle φ and at its own x."""
    rc, rs, vc, vs = p["rc"], p["rs"], p["vc"], p["vs"]
    x, y, z = points[:, 0], points[:, 1] - vc * c, points[:, 2]
    radial = np.abs(np.hypot(y, z) - rc)
    gg = g(p, c, np.arctan2(z, y))
    with np.errstate(invalid="ignore"):
        root = np.sqrt(np.where(gg > -1e-14, np.maximum(gg, 0.0), np.nan))
    d = np.hypot(radial, np.abs(np.abs(x) - root))
    d = np.where(np.isnan(d), np.inf, d)
    if c != 0 and math.hypot(vc, vs) > 0:
        k = (rs * rs - rc * rc - x * x - c * c * (vs * vs - vc * vc)) / (2 * c)
        cos_d = (k - vc * vc * c) / (rc * math.hypot(vc, vs))
        base, delta = math.atan2(vs, vc), np.arccos(np.clip(cos_d, -1.0, 1.0))
        for angle in (base + delta, base - delta):
            q = np.stack([x, vc * c + rc * np.cos(angle), rc * np.sin(angle)], axis=1)
            near = np.linalg.norm(q - points[:, :3], axis=1)
            d = np.minimum(d, np.where(np.abs(cos_d) <= 1, near, np.inf))
    return d


def exact_loops(p: dict, c: float, samples: int = 200_000) -> int:
    inside = g(p, c, np.linspace(0, 2 * math.pi, samples, endpoint=False)) > 0
    if inside.all():
        return 2
    return int((inside & ~np.roll(inside, 1)).sum())


def check_slice(p: dict, c: float, loops: int | None = None):
    stats = RefineStats()
    curves = slice_curves(part(p).surface, T, c, stats)
    expected = exact_loops(p, c) if loops is None else loops
    assert len(curves) == expected, [(len(k.points), k.closed) for k in curves]
    for curve in curves:
        assert curve.closed, "the slice of a closed surface is closed"
        assert np.all(curve.points[:, T] == c)
        assert exact_distance(curve.points, p, c).max() <= DISTANCE
    return curves


FIGURE_15 = {"rc": 1.0, "rs": 1.0, "vc": 0.0, "vs": 1.0}


@pytest.mark.parametrize("c", [1e-6, 1e-9, pytest.param(-1e-7, marks=pytest.mark.slow)])
def test_next_to_the_tangency_the_slice_is_one_thin_loop_on_the_right_half(c):
    """Just after t = 0 the ball touches the pipe only below its axis: z = −(x² + c²)/2c ≤ 0, a
    loop 2√(2c) wide round the lower half (the upper half just before)."""
    (curve,) = check_slice(FIGURE_15, c)
    x, y, z = curve.points[:, :3].T
    assert np.all(-math.copysign(1.0, c) * z >= -DISTANCE)  # on that half, to round-off
    assert np.abs(x).max() <= math.sqrt(2 * abs(c)) * 1.0001
    # round the whole half: from one side of the pipe past its bottom (or top) to the other
    assert y.max() > 0.999 and y.min() < -0.999 and np.abs(z).max() > 0.999


@pytest.mark.parametrize(
    "p",
    [
        {"rc": 2.0, "rs": 2.0, "vc": 0.0, "vs": 3.0},
        {"rc": 1.0, "rs": 1.0, "vc": 0.3, "vs": 1.0},
        pytest.param({"rc": 0.5, "rs": 0.5, "vc": 0.2, "vs": 1.3}, marks=pytest.mark.slow),
    ],
)
def test_an_exact_tangency_is_one_closed_circle_whatever_the_speeds(p):
    """rc = rs: at t = 0 both are centred on the origin and touch along x = 0, y² + z² = rc²."""
    (curve,) = check_slice(p, 0.0, loops=1)
    angle = np.unwrap(np.arctan2(curve.points[:, 2], curve.points[:, 1]))
    assert abs(angle[-1] - angle[0]) > 2 * math.pi - 0.2  # once round
    assert np.diff(angle).max() < 0.2


@pytest.mark.slow
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_nanosecond_after_first_contact_one_tiny_loop_before_it_none(side):
    p = {"rc": 1.0, "rs": 0.7, "vc": 0.2, "vs": 1.0}
    t0 = -(p["rc"] + p["rs"]) / math.hypot(p["vc"], p["vs"])
    curves = check_slice(p, t0 + side * 1e-9)
    if curves:
        assert np.ptp(curves[0].points[:, :3], axis=0).max() < 1e-3


@pytest.mark.slow
def test_next_to_the_saddle_where_the_hole_closes():
    """Figure 17 (rs = 1.2 > rc = 1): two loops while the ball sticks out of both sides of the
    pipe, one after t = 0.2, when its top has passed the pipe's top."""
    p = {"rc": 1.0, "rs": 1.2, "vc": 0.0, "vs": 1.0}
    for c in (0.2 - 1e-8, 0.2 + 1e-9):
        check_slice(p, c)
