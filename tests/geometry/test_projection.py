"""The paper's projective maps v: R^4 -> R^3 (sensor) and R^4 -> R^2 (sensor and eye)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exhibit.geometry import eye_ray, project_to_2d, project_to_3d, sensor_jacobian, sensor_ray

points = st.lists(st.floats(-3, 3, allow_nan=False), min_size=4, max_size=4).map(np.array)
reciprocal = st.floats(0.0, 0.3)


def test_orthographic_drops_w():
    p = np.array([[1.0, 2.0, 3.0, 4.0], [-1.0, 0.5, 0.0, -7.0]])
    image, in_front = project_to_3d(p, 0.0)
    np.testing.assert_array_equal(image, p[:, :3])
    assert in_front.all()


def test_perspective_formula_and_points_behind_the_sensor():
    p = np.array([[1.0, 2.0, 3.0, 1.0], [1.0, 1.0, 1.0, 2.0], [1.0, 1.0, 1.0, 3.0]])
    image, in_front = project_to_3d(p, 0.5)  # sensor at w = 2
    np.testing.assert_allclose(image[0], [2.0, 4.0, 6.0])
    assert in_front.tolist() == [True, False, False]
    np.testing.assert_array_equal(image[1:], 0.0)  # defined, not inf or NaN


@given(points, reciprocal, reciprocal)
def test_two_centre_map_is_sensor_then_eye_in_either_order(p, r1, r2):
    """Paper, before Lemma 3: mapping to XYZ then XY equals mapping to XYW then XY."""
    direct, ok = project_to_2d(p, r1, r2)
    if not ok:
        return
    xyz, ok1 = project_to_3d(p, r1)
    via_xyz = xyz[:2] / (1 - r2 * xyz[2])
    xyw = np.array([p[0], p[1], p[3]]) / (1 - r2 * p[2])  # the eye first, into the XYW space
    via_xyw = xyw[:2] / (1 - r1 * xyw[2])
    np.testing.assert_allclose(direct, via_xyz, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(direct, via_xyw, rtol=1e-9, atol=1e-9)


@given(points, reciprocal, st.lists(st.floats(-1, 1), min_size=4, max_size=4).map(np.array))
def test_jacobian_matches_finite_differences(p, r, t):
    if 1 - r * p[3] < 0.2:
        return
    h = 1e-6
    fd = (project_to_3d(p + h * t, r).points - project_to_3d(p - h * t, r).points) / (2 * h)
    np.testing.assert_allclose(sensor_jacobian(p, r) @ t, fd, rtol=1e-5, atol=1e-6)


@given(points, st.floats(0.01, 0.3))
def test_rays_point_at_the_centres(p, r):
    sensor = np.array([0, 0, 0, 1 / r])
    ray = sensor_ray(p, r)
    expected = sensor - p
    # a positive multiple of the paper's ray l/r - p
    np.testing.assert_allclose(ray, r * expected, atol=1e-12)
    eye = np.array([0, 0, 1 / r, 0])
    np.testing.assert_allclose(eye_ray(p, r), r * (eye - p), atol=1e-12)


def test_rays_at_infinity_are_the_axes():
    p = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(sensor_ray(p, 0.0), [0, 0, 0, 1])
    np.testing.assert_array_equal(eye_ray(p, 0.0), [0, 0, 1, 0])


def test_bad_input():
    with pytest.raises(ValueError, match="last axis 4"):
        project_to_3d(np.zeros(3), 0.0)
    with pytest.raises(ValueError, match=">= 0"):
        project_to_3d(np.zeros(4), -1.0)
    with pytest.raises(ValueError, match=">= 0"):
        project_to_2d(np.zeros(4), 0.0, float("inf"))
