"""The paper's examples as scenes, against independent answers."""

import math

import numpy as np
import pytest

from exhibit import scenes
from exhibit.scenes import collision
from exhibit.surfaces import analyse


@pytest.mark.parametrize("figure", [15, 16, 17])
def test_initial_colliding_point_matches_the_closed_form(figure):
    params = collision.FIGURE_PARAMS[figure]
    part = collision.build_part(params, 20)
    point = collision.colliding_point(part)
    expected = collision.initial_colliding_point_closed_form(params)
    np.testing.assert_allclose(
        point, [expected["x"], expected["y"], expected["z"], expected["t"]], atol=1e-8
    )


def test_figure_15_is_two_sheets_meeting_at_two_singular_points_at_t0():
    """Equal radii: at t = 0 the sphere touches the cylinder along the circle x = 0,
    y² + z² = 1, but the surface's normals are dependent only at two of its points,
    (0, ±1, 0, 0), where the two sheets meet: the paper's 'connected' surface is joined there."""
    part = collision.build_part(collision.FIGURE_PARAMS[15], 24)
    points = part.result.singular_positions
    assert len(points) == 2
    np.testing.assert_allclose(points[:, 3], 0.0, atol=1e-6)  # at t = 0
    np.testing.assert_allclose(points[:, 0], 0.0, atol=1e-6)  # x = 0
    np.testing.assert_allclose(np.sort(points[:, 1]), [-1.0, 1.0], atol=1e-6)
    np.testing.assert_allclose(points[:, 2], 0.0, atol=1e-6)


def _offset_of_parabola(radius):
    tau = np.linspace(-1.6, 1.6, 6001)
    normal = np.stack([-2 * tau, np.ones_like(tau)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    base = np.stack([tau, tau**2], -1)
    return np.concatenate([base + radius * normal, base - radius * normal])


@pytest.mark.parametrize("radius", [1.0, 0.5])
def test_offset_silhouette_points_lie_at_distance_r_from_the_parabola(radius):
    mesh = scenes.get("offset-parabola").build({"r": radius}, resolution=32)
    offsets = [c for c in mesh.curves if c.name.startswith("offset curve")]
    assert offsets
    xy = np.concatenate([c.points[:, :2] for c in offsets])
    reference = _offset_of_parabola(radius)
    gap = np.min(np.linalg.norm(xy[:, None] - reference[None], axis=-1), axis=1)
    assert gap.max() < 1e-3  # the reference is sampled every 5e-4 in the curve parameter
    # and the silhouette points are on the pipe: (u, v) on the parabola, (x, y) at distance r
    # along the parabola's normal at (u, v)
    uv = np.concatenate([c.points[:, 2:] for c in offsets])
    assert np.max(np.abs(uv[:, 1] - uv[:, 0] ** 2)) < 1e-9
    assert np.max(np.abs(np.linalg.norm(xy - uv, axis=1) - radius)) < 1e-9
    tangent = np.stack([np.ones(len(uv)), 2 * uv[:, 0]], -1)
    assert np.max(np.abs(np.einsum("ni,ni->n", xy - uv, tangent))) < 1e-9


def test_cusp_scene_has_its_singular_circle():
    mesh = scenes.get("offset-cusp").build(resolution=24)
    circle = [c for c in mesh.curves if c.name == "circle of singular points"]
    assert len(circle) == 1 and circle[0].closed


@pytest.mark.parametrize("number", sorted(scenes.FIGURES))
def test_every_figure_has_a_scene_and_preset(number):
    scene, preset = scenes.figure(number)
    scene.resolve(preset.params)


def test_collision_surface_is_bounded_by_the_contact_interval():
    params = collision.FIGURE_PARAMS[17]
    mesh = scenes.get("collision").build(params, resolution=16)
    t = mesh.surfaces[0].positions[:, 3]
    limit = collision.contact_interval(params)
    assert t.min() >= -limit - 1e-9 and t.max() <= limit + 1e-9
    assert analyse(mesh.surfaces[0].triangles).boundary_edges == 0
    assert math.isclose(mesh.markers[0].position[3], -limit, abs_tol=1e-8)
