"""The mesh reaches its singular set (issue 13): the cusp pipe meets its circle of singular
points, and Figure 15's two singular points are on the mesh."""

import math

import numpy as np
import pytest

from exhibit import scenes
from exhibit.scenes import collision
from exhibit.surfaces.metrics import distance_to_mesh


@pytest.mark.parametrize("r", [0.6, 1.0])
def test_cusp_pipe_reaches_its_singular_circle(r):
    mesh = scenes.get("offset-cusp").build({"r": r}, resolution=32)
    surface = mesh.surfaces[0]
    phi = np.linspace(0, 2 * math.pi, 240, endpoint=False)
    circle = np.stack([r * np.cos(phi), r * np.sin(phi), 0 * phi, 0 * phi], -1)
    lo, hi = surface.info["box"]
    diagonal = np.linalg.norm(np.subtract(hi, lo))
    # the analytic circle, independently of the traced set
    assert distance_to_mesh(circle, surface.positions, surface.triangles).max() <= 0.005 * diagonal
    traced = surface.exact.result.singular_positions
    assert np.max(np.abs(traced[:, 2:])) < 1e-5  # u = v = 0
    assert np.max(np.abs(np.hypot(traced[:, 0], traced[:, 1]) - r)) < 1e-5
    assert np.all(
        surface.singular[surface.normals.reshape(len(surface.positions), -1).any(axis=1) == 0]
    )


def test_figure_15_singular_points_are_on_the_mesh():
    part = collision.build_part(collision.FIGURE_PARAMS[15], 24)
    points = part.result.singular_positions
    assert len(points) == 2
    gap = distance_to_mesh(points, part.surface.positions, part.surface.triangles)
    assert gap.max() <= 1e-12


def test_a_singular_region_neither_exhausts_memory_nor_fails():
    """x - min(x, y) vanishes with its gradient on the whole half-space x <= y: its singular
    set is a region, not curves. Tracing it must stop at its caps (the fuzz found this one
    growing past 7 GB), and reaching it must cope with every vertex moved."""
    from exhibit.surfaces.expressions import compile_field
    from exhibit.surfaces.implicit import polygonize

    V = ("x", "y", "z", "w")
    surface = polygonize(
        "region",
        compile_field("-((-(x)) + (min(x, y)))", V, {}),
        compile_field("x^2 + y^2 + z^2 + w^2 - 1", V),
        [-1.2] * 4,
        [1.2] * 4,
        5,
        seed=0,
    ).surface
    assert np.isfinite(surface.positions).all()
