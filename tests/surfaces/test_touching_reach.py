"""Touching branches reach the stated exclusion (issue 32, item 4): at Figure 15's parameters
along y, z they stopped 0.055-0.107 (0.63-1.23 cells) from the singular points, growing with
the radius, against the docs' 0.08. Each open end is now continued along the exact branch
(`double_zeros.extend_touching_end`) to the exclusion every silhouette point has: half a cell
from a traced singular point, half a cell from another branch at a crossing.

The geometry is derived here, not taken from the code: with rc = rs = R, vc = 0, vs = 1,
s = 4yt along y, z; the touching branch is the circle x = 0, t = 0, y² + z² = R²; the singular
points (∇f1 ∥ ∇f2: x = 0, z + t = 0, yz = 0 on both surfaces) are (0, ±R, 0, 0); the branch
y = 0 crosses the circle at (0, 0, ±R, 0)."""

import numpy as np
import pytest

from exhibit.scenes import collision
from exhibit.scenes.implicit_scene import cell_size, exclusion_radius, fixed_silhouette
from exhibit.surfaces.mesh import Material


def touching_ends(radius: float):
    part = collision.build_part({"rc": radius, "rs": radius, "vc": 0.0, "vs": 1.0}, 48)
    curves = fixed_silhouette(part, (1, 2), "s", Material())
    touching = [c for c in curves if "touching" in c.name]
    return part, touching


@pytest.mark.parametrize(
    "radius", [1.0, pytest.param(1.5, marks=pytest.mark.slow)], ids=["figure-15", "R=1.5"]
)
def test_touching_branches_reach_the_exclusion(radius):
    part, touching = touching_ends(radius)
    cell = cell_size(part)
    assert len(touching) == 4
    singular = np.array([[0, radius, 0, 0], [0, -radius, 0, 0]])
    crossing = np.array([[0, 0, radius, 0], [0, 0, -radius, 0]])
    to_singular, to_crossing = [], []
    for curve in touching:
        p = curve.points
        # every point, the continued ones included, on the circle x = 0, t = 0, y² + z² = R²
        off = np.abs(np.stack([p[:, 0], p[:, 3], np.hypot(p[:, 1], p[:, 2]) - radius], 1))
        assert off.max() <= 2e-6
        assert not curve.closed
        for end in (p[0], p[-1]):
            ds, dc = (
                np.linalg.norm(singular - end, axis=1).min(),
                np.linalg.norm(crossing - end, axis=1).min(),
            )
            (to_singular if ds < dc else to_crossing).append(min(ds, dc) / cell)
    assert len(to_singular) == len(to_crossing) == 4
    # stated: half a cell from a singular point (exclusion_radius); it was up to 1.23 cells
    assert exclusion_radius(part) == pytest.approx(0.5 * cell)
    assert max(to_singular) <= 0.55 and min(to_singular) >= 0.5
    # at a crossing: half a cell from the crossing branch's points, within 0.75 cell of it
    assert max(to_crossing) <= 0.75
