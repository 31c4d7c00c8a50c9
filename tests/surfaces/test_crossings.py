"""Crossings of silhouette branches drawn as crossings (issue 22, item 4): the traced cusp's
offset branches cross the circle t = 0 at (0, ±r, 0); every piece ends there to 1e-9."""

from __future__ import annotations

import numpy as np
import pytest

from exhibit.scenes.implicit_scene import cell_size
from exhibit.scenes.offsets import TRACED
from exhibit.surfaces.crossings import find_crossings
from exhibit.surfaces.exact_silhouette import SilhouetteSystem


def silhouette_curves(r: float):
    mesh = TRACED.build_mesh({"r": r}, 48)
    return mesh, [c for c in mesh.curves if c.name.startswith("silhouette along t")]


@pytest.mark.parametrize("r", [1.0, 0.6])
def test_branches_meet_at_each_crossing(r):
    _, curves = silhouette_curves(r)
    ends = np.array([p for c in curves if not c.closed for p in (c.points[0], c.points[-1])])
    for crossing in ([0.0, r, 0.0, 0.0], [0.0, -r, 0.0, 0.0]):
        d = np.linalg.norm(ends - crossing, axis=1)
        # two branches through the crossing: four pieces end exactly there (an X) ...
        assert (d <= 1e-9).sum() == 4, np.sort(d)[:6]
        # ... and none stops short of it ("><")
        assert not ((d > 1e-9) & (d < 0.3)).any(), np.sort(d)[:6]
    for c in curves:
        for points in (c.points, c.points[::-1]):
            d = np.linalg.norm(points[:6, :2] - [[0.0, r]], axis=1)
            d = np.minimum(d, np.linalg.norm(points[:6, :2] - [[0.0, -r]], axis=1))
            if d[0] <= 1e-9:  # the piece runs straight out of the crossing, no zigzag
                assert (np.diff(d) > 0).all(), d


def test_crossing_solved_exactly():
    mesh, curves = silhouette_curves(1.0)
    part = mesh.surfaces[0].exact
    system = SilhouetteSystem(part.f1, part.f2, (2, 3))
    found = find_crossings(system, curves, cell_size(part))
    assert len(found) == 2
    found = found[np.argsort(found[:, 1])]
    assert np.abs(found - [[0, -1, 0, 0], [0, 1, 0, 0]]).max() <= 1e-12
    assert system.residual(found).max() <= 1e-12
