"""The one 4x5 clip-space map equals the paper's maps step by step; clipping and depth."""

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from exhibit.geometry import ViewState, clip_transform, project_to_2d, project_to_3d

from .strategies import angles

points = st.lists(st.floats(-2, 2), min_size=4, max_size=4).map(np.array)
views = st.builds(
    ViewState,
    angles=angles(4),
    reading=st.sampled_from(["screen", "object"]),
    sensor_r=st.floats(0, 0.4),
    offset=st.lists(st.floats(-1, 1), min_size=4, max_size=4),
    eye_azimuth=st.floats(-3, 3),
    eye_incidence=st.floats(-3, 3),
    twist=st.floats(-3, 3),
    eye_r=st.floats(0, 0.25),
    half_height=st.floats(0.5, 4),
)


@given(views, points, st.floats(0.5, 2.0))
def test_ndc_is_the_papers_two_centre_map(view, p, aspect):
    """x_ndc, y_ndc = v(p_view) / zoom, with v(p) = (p_x, p_y) / (1 - r1 p_w - r2 p_z)."""
    transform = clip_transform(view, aspect)
    p_view = view.to_view(p)
    expected, in_front = project_to_2d(p_view, view.sensor_r, view.eye_r)
    clip = transform.clip(p)
    assume(in_front and clip[3] > 1e-3)
    ndc = clip[:3] / clip[3]
    np.testing.assert_allclose(
        ndc[0] * view.half_height * aspect, expected[0], rtol=1e-9, atol=1e-9
    )
    np.testing.assert_allclose(ndc[1] * view.half_height, expected[1], rtol=1e-9, atol=1e-9)


@given(views, points)
def test_clip_matrix_is_pose_then_sensor_then_eye(view, p):
    """Composing by hand: rotate and offset, divide by 1 - r w, then the eye's perspective."""
    p_view = view.to_view(p)
    image, in_front = project_to_3d(p_view, view.sensor_r)
    assume(in_front)
    x, y, z = image
    w_eye = 1 - view.eye_r * z
    assume(w_eye > 1e-3)
    clip = clip_transform(view).clip(p)
    ndc = clip[:3] / clip[3]
    np.testing.assert_allclose(
        ndc[:2], [x / w_eye / view.half_height, y / w_eye / view.half_height], rtol=1e-8, atol=1e-8
    )
    # the sensor clip distance is the homogeneous depth 1 - r w
    distances = clip_transform(view).clip_distances(p)
    assert distances[0] == pytest.approx(1 - view.sensor_r * p_view[3], abs=1e-12)


def test_depth_grows_away_from_the_eye_and_spans_near_to_far():
    view = ViewState(eye_r=1 / 5, depth_extent=20)
    transform = clip_transform(view)
    zs = np.array([4.9, 3.0, 0.0, -3.0, -19.9])
    ndc, ok = transform.to_ndc(np.stack([0 * zs, 0 * zs, zs, 0 * zs], axis=-1))
    assert ok.all()
    assert np.all(np.diff(ndc[:, 2]) > 0)  # nearer to the eye = smaller depth
    near, far = 0.99 * 5, -20.0
    edge = transform.clip(np.array([[0, 0, near, 0], [0, 0, far, 0]]))
    np.testing.assert_allclose(edge[:, 2] / edge[:, 3], [-1, 1], atol=1e-12)
    ortho = clip_transform(view.replace(eye_r=0.0))
    ndc, ok = ortho.to_ndc(np.stack([0 * zs, 0 * zs, zs, 0 * zs], axis=-1))
    assert np.all(np.diff(ndc[:, 2]) > 0)


def test_points_behind_the_sensor_are_clipped_at_its_hyperplane():
    """Sensor at distance 2 touching the hypersphere moved to w = 1 (Figure 8)."""
    view = ViewState(offset=(0, 0, 0, 1)).with_sensor_distance(1.5)
    transform = clip_transform(view)
    inside = np.array([[0.0, 0.0, 0.0, 0.4]])  # view w = 1.4 < 1.5
    behind = np.array([[0.0, 0.0, 0.0, 0.8]])  # view w = 1.8 > 1.5: behind the sensor
    assert transform.clip_distances(inside)[0, 0] > 0
    assert transform.clip_distances(behind)[0, 0] < 0
    assert transform.to_ndc(inside).in_front.all()
    assert not transform.to_ndc(behind).in_front.any()


@pytest.mark.parametrize("pitch", [0.0, 0.4, -0.9])
def test_front_clipping_plane_with_pitch(pitch):
    view = ViewState(front_distance=0.5, front_pitch=pitch, eye_r=0.1)
    transform = clip_transform(view)
    rng = np.random.default_rng(2)
    p = rng.uniform(-2, 2, size=(500, 4))
    kept = transform.clip_distances(p)[:, 1] >= 0
    image = project_to_3d(view.to_view(p), view.sensor_r).points
    expected = math.sin(pitch) * image[:, 1] + math.cos(pitch) * image[:, 2] <= 0.5
    np.testing.assert_array_equal(kept, expected)
    assert 0 < kept.sum() < len(p)


def test_pixels_follow_image_convention():
    transform = clip_transform(ViewState(eye_r=0.0, half_height=2.0), aspect=2.0)
    pixels, ok = transform.to_pixels(
        np.array([[0, 0, 0, 0], [4, 2, 0, 0], [-4, -2, 0, 0]]), 200, 100
    )
    np.testing.assert_allclose(pixels, [[100, 50], [200, 0], [0, 100]])
    assert ok.all()


def test_bad_aspect_and_points():
    with pytest.raises(ValueError, match="aspect"):
        clip_transform(ViewState(), aspect=0)
    with pytest.raises(ValueError, match="last axis 4"):
        clip_transform(ViewState()).clip(np.zeros(3))
