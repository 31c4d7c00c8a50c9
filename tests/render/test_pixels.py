"""Marked 4D points land on the pixel the CPU geometry (ClipTransform.to_pixels) predicts."""

import math

import numpy as np
import pytest

from exhibit.geometry import ViewState, clip_transform
from tests.render.conftest import PLAIN, marker_mesh

SIZE = (320, 240)
RNG = np.random.default_rng(7)
POINTS = RNG.uniform(-0.9, 0.9, size=(8, 4))

VIEWS = {
    "orthographic": ViewState(
        sensor_r=0.0, eye_r=0.0, half_height=1.5, angles=(0.3, -0.5, -0.9, 0.4, -0.6, 0.2)
    ),
    "perspective": ViewState(
        sensor_r=1 / 3,
        eye_r=1 / 6,
        half_height=1.5,
        angles=(-0.7, -1.1, -0.4, 1.9, -0.3, -0.5),
        eye_azimuth=0.4,
    ),
    # The hypersphere's setting of Figures 6-8 with the sensor just outside it: image scales up
    # to ~10x near the sensor, the regime where a wrong division would show first.
    "sensor-near": ViewState(
        sensor_r=1 / 2.1,
        eye_r=1 / 9,
        half_height=2.5,
        offset=(0.0, 0.0, 0.0, 1.0),
        eye_azimuth=0.35,
        eye_incidence=-1.05,
        angles=(0.2, -0.3, -0.1, 0.0, 0.0, 0.0),
    ),
}


def marker_centre(image, color):
    match = np.all(np.abs(image.astype(int) - np.array(color) * 255) < 40, axis=-1)
    ys, xs = np.nonzero(match)
    assert len(xs) > 0, "marker not drawn"
    return np.array([xs.mean() + 0.5, ys.mean() + 0.5])


@pytest.mark.parametrize("name", sorted(VIEWS))
def test_markers_land_where_the_cpu_projects_them(gl, name):
    view = VIEWS[name]
    ct = clip_transform(view, SIZE[0] / SIZE[1])
    expected, visible = ct.to_pixels(POINTS, *SIZE)
    # Keep points whose whole disc is on screen.
    inside = visible & np.all((expected > 8) & (expected < np.array(SIZE) - 8), axis=1)
    assert inside.sum() >= 3, "the test views must show most points"
    for point, want in zip(POINTS[inside], expected[inside]):
        gpu = gl.renderer.upload(marker_mesh(point))
        image = gl.image(gpu, view, SIZE, PLAIN, samples=0)
        gpu.release()
        got = marker_centre(image, (1.0, 0.0, 0.0))
        assert np.abs(got - want).max() <= 1.0, (name, point, got, want)


def test_a_point_behind_the_sensor_is_not_drawn(gl):
    view = ViewState(sensor_r=0.5, eye_r=1 / 9, half_height=2.0)
    point = np.array([0.1, 0.1, 0.0, 2.5])  # w beyond the sensor at w = 2
    assert not clip_transform(view, SIZE[0] / SIZE[1]).to_pixels(point, *SIZE).in_front
    gpu = gl.renderer.upload(marker_mesh(point))
    image = gl.image(gpu, view, SIZE, PLAIN, samples=0)
    gpu.release()
    assert image.max() == 0


def test_angles_move_the_marker_as_the_geometry_says(gl):
    point = np.array([0.6, -0.2, 0.3, 0.5])
    gpu = gl.renderer.upload(marker_mesh(point))
    for theta in np.linspace(0.0, math.pi, 5):
        view = ViewState(sensor_r=0.25, eye_r=0.125, angles=(theta, -0.8, -0.6, 0.0, 0.0, 0.0))
        want = clip_transform(view, SIZE[0] / SIZE[1]).to_pixels(point, *SIZE).points
        got = marker_centre(gl.image(gpu, view, SIZE, PLAIN, samples=0), (1.0, 0.0, 0.0))
        assert np.abs(got - want).max() <= 1.0
    gpu.release()
