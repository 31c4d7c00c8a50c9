"""A surface's rims on the screen (exhibit.geometry.rims): where its triangles turn from
facing the eye to facing away, a tag's leader must not end."""

from __future__ import annotations

import numpy as np

from exhibit.geometry.pipeline import clip_transform
from exhibit.geometry.rims import on_rim
from exhibit.geometry.view import ViewState


def _sheet(fourth: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Two triangles on the edge from vertex 1 to vertex 2; the fourth vertex on the far side
    of that edge (a flat sheet) or folded back over it (the sheet turns away there)."""
    points = np.array([[0, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], [*fourth, 0, 0]], float)
    return points, np.array([[0, 1, 2], [1, 3, 2]])


def test_a_flat_sheet_has_no_rim_and_a_fold_has_one_along_its_crease():
    ct = clip_transform(ViewState(), 1.0)
    flat, tris = _sheet((1.0, 1.0))
    assert not on_rim(flat, tris, np.arange(4), ct).any()
    folded, tris = _sheet((0.2, 0.2))  # the second triangle seen from its back
    assert on_rim(folded, tris, np.arange(4), ct).tolist() == [False, True, True, False]
