"""Implicit surfaces that leave their box are cut exactly on its faces (issue 13): every boundary
vertex lies on a face and on the surface, so the boundary is the surface's own intersection with
the face, inscribed in the exact curve, not the outline of the grid's cells."""

import numpy as np
import pytest

from exhibit import scenes
from exhibit.scenes.implicit_scene import mesh_implicit
from exhibit.surfaces.mesh import Material
from exhibit.surfaces.metrics import boundary_box_distance, boundary_vertices


def _check_cut(part):
    surface = part.surface
    lo, hi = (np.array(b) for b in surface.info["box"])
    b = boundary_vertices(surface.triangles)
    assert len(b) > 0
    p = surface.positions[b]
    assert boundary_box_distance(surface.positions, surface.triangles, lo, hi) <= 1e-9
    # inside the box (to rounding) and on the surface
    assert np.all(p >= lo - 1e-9) and np.all(p <= hi + 1e-9)
    values = np.stack([part.f1.value(p), part.f2.value(p)], 1)
    grads = np.stack(
        [np.linalg.norm(part.f1.gradient(p), axis=1), np.linalg.norm(part.f2.gradient(p), axis=1)],
        1,
    )
    assert np.max(np.abs(values) / grads) <= 1e-9
    # the boundary is a polyline with short edges (a cell-shaped edge would zigzag by a cell)
    tris = surface.triangles.astype(np.int64)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    degree = np.bincount(boundary.ravel(), minlength=len(surface.positions))[b]
    assert np.all(degree == 2)  # closed polylines, no branching


@pytest.mark.parametrize(
    "name, params",
    [
        ("offset-parabola", {"r": 0.7}),
        ("offset-cusp", {"r": 1.0}),
        ("offset-cusp-traced", {"r": 1.0}),
    ],
)
def test_paper_pipes_are_cut_at_their_box(name, params):
    mesh = scenes.get(name).build(params, resolution=20)
    _check_cut(mesh.surfaces[0].exact)


def test_a_tilted_plane_is_cut_cleanly_on_every_face():
    """The plane z = 0.3x + 0.2y, w = 0.1x - 0.4y crosses four of the box's faces obliquely."""
    part = mesh_implicit(
        "plane",
        "z - 0.3*x - 0.2*y",
        "w - 0.1*x + 0.4*y",
        ("x", "y", "z", "w"),
        {},
        [-1, -1, -1, -1],
        [1, 1, 1, 1],
        12,
        Material(),
    )
    _check_cut(part)
    p = part.surface.positions
    # the cut reaches the corners of the square |x|, |y| <= 1: the mesh fills it
    assert np.abs(p[:, 0]).max() == pytest.approx(1.0, abs=1e-12)
    assert np.abs(p[:, 1]).max() == pytest.approx(1.0, abs=1e-12)
    area = 0.0
    t = part.surface.triangles
    for a, b, c in t:
        area += 0.5 * np.sqrt(
            max(
                np.linalg.det(
                    np.stack([p[b] - p[a], p[c] - p[a]]) @ np.stack([p[b] - p[a], p[c] - p[a]]).T
                ),
                0,
            )
        )
    # the exact area of the plane over the square: 4 * sqrt(det(I + AᵀA)), A = [[.3, .2], [.1, -.4]]
    a_mat = np.array([[0.3, 0.2], [0.1, -0.4]])
    # (where two faces meet the cut takes a chord across the box's edge: under a cell's area)
    exact = 4 * np.sqrt(np.linalg.det(np.eye(2) + a_mat.T @ a_mat))
    assert exact - 4 * (2 / 12) ** 2 <= area <= exact + 1e-9
