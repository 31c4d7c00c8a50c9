"""ViewState: both readings of the Euler angles, the eye orbit, reciprocal distances, validation."""

import math

import numpy as np
import pytest
from hypothesis import given

from exhibit.geometry import ViewState, euler_to_matrix, project_to_3d

from .strategies import angles


@given(angles(4))
def test_readings(t):
    a = euler_to_matrix(t)
    np.testing.assert_allclose(ViewState(angles=t).rotation(), a.T, atol=1e-14)
    np.testing.assert_allclose(ViewState(angles=t, reading="object").rotation(), a, atol=1e-14)


@given(angles(4))
def test_screen_reading_sensor_and_eye_directions(t):
    """Section 3.2: the sensor lies along w6 (A's 4th column, set by θ1..θ3), the eye along z6."""
    view = ViewState(angles=t)
    a = euler_to_matrix(t)
    np.testing.assert_allclose(view.sensor_direction(), a[:, 3], atol=1e-14)
    np.testing.assert_allclose(view.eye_direction(), a[:, 2], atol=1e-14)
    moved = ViewState(angles=list(t[:3]) + [1.0, -2.0, 0.5])
    np.testing.assert_allclose(moved.sensor_direction(), a[:, 3], atol=1e-14)  # θ4..θ6: no effect
    twisted = ViewState(angles=list(t[:5]) + [t[5] + 1.0])
    np.testing.assert_allclose(twisted.eye_direction(), a[:, 2], atol=1e-14)  # θ6: twist only


def test_eye_orbit_is_theta4_to_theta6_of_the_screen_reading():
    via_angles = ViewState(angles=(0, 0, 0, 0.4, -1.1, 0.3))
    via_eye = ViewState(eye_azimuth=0.4, eye_incidence=-1.1, twist=0.3)
    np.testing.assert_allclose(via_angles.rotation(), via_eye.rotation(), atol=1e-15)


@given(angles(4))
def test_theta4_to_theta6_only_turn_the_3d_image(t):
    """In the screen reading the last three angles rotate the 4D -> 3D image rigidly."""
    rng = np.random.default_rng(0)
    p = rng.normal(size=(6, 4))
    base = ViewState(angles=list(t[:3]) + [0, 0, 0], sensor_r=0.2)
    turned = base.replace(angles=t)
    a = project_to_3d(base.to_view(p), 0.2).points
    b = project_to_3d(turned.to_view(p), 0.2).points
    distances = [np.linalg.norm(x[:, None] - x[None], axis=-1) for x in (a, b)]
    np.testing.assert_allclose(distances[0], distances[1], atol=1e-9)


def test_reciprocal_distances_and_field_of_view():
    view = ViewState().with_sensor_distance(math.inf)
    assert view.sensor_r == 0 and view.sensor_distance == math.inf
    view = view.with_sensor_distance(2.0)
    assert view.sensor_r == 0.5 and view.sensor_distance == 2.0
    view = view.with_eye(10.0, field_of_view=30.0)
    assert view.field_of_view == pytest.approx(30.0)
    assert view.eye_distance == pytest.approx(10.0)
    assert view.with_eye(math.inf).field_of_view == 0.0


def test_lights_are_normalised():
    view = ViewState(lights=[(0, 0, 2), (3, 4, 0)])
    assert view.lights == ((0, 0, 1), (0.6, 0.8, 0))


def test_offset_translates_after_rotating():
    view = ViewState(angles=(0.3, -0.2, -0.5, 0, 0, 0), offset=(0, 0, 0, 1))
    np.testing.assert_allclose(view.to_view(np.zeros(4)), [0, 0, 0, 1])
    np.testing.assert_allclose(view.pose()[:4, 4], [0, 0, 0, 1])


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"angles": (1, 2, 3)}, "angles must be 6 numbers"),
        ({"angles": (0, 0, 0, 0, 0, float("nan"))}, "finite"),
        ({"reading": "sideways"}, "reading"),
        ({"sensor_r": -0.1}, "sensor_r"),
        ({"eye_r": float("inf")}, "eye_r"),
        ({"half_height": 0}, "half_height"),
        ({"front_distance": 20.0, "eye_r": 0.1}, "less than the eye distance"),
        ({"lights": [(0, 0, 0)]}, "lights\\[0\\]"),
        ({"offset": (1, 2)}, "offset"),
    ],
)
def test_invalid_views_name_the_field(changes, message):
    with pytest.raises(ValueError, match=message):
        ViewState(**changes)


def test_distances_must_be_positive():
    with pytest.raises(ValueError, match="positive"):
        ViewState().with_sensor_distance(0)
    with pytest.raises(ValueError, match="positive"):
        ViewState().with_eye(-3.0)
