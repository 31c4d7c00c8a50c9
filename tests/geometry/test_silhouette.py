"""Lemmas 2 and 3 against the rank of the projected tangent plane, and the paper's silhouette
curves: offset curves (section 4.2, condition C) and the collision curve (section 4.3, C')."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from exhibit.geometry import (
    eye_ray,
    is_silhouette_point_2d,
    is_silhouette_point_3d,
    lemma2_measure_normals,
    lemma2_measure_tangents,
    lemma3_measure_tangents,
    normals_from_tangents,
    project_to_2d,
    sensor_jacobian,
    sensor_ray,
    silhouette_function,
    silhouette_function_normalized,
    zero_set_segments,
)
from tests.hypothesis_profiles import examples

unit = st.floats(-1, 1)
vec4 = st.lists(unit, min_size=4, max_size=4).map(np.array)


def rank_ratio(matrix):
    """σ_min / σ_max of the projected tangent vectors: 0 when the tangent plane loses dimension."""
    sv = np.linalg.svd(matrix, compute_uv=False)
    return sv[-1] / sv[0] if sv[0] > 0 else 0.0


def projected_tangents_2d(p, t1, t2, r1, r2, h=1e-6):
    """Derivative of the 4D -> 2D map along t1, t2, by central differences (independent of
    lemmas)."""

    def v(q):
        return project_to_2d(q, r1, r2).points

    return np.column_stack([(v(p + h * t) - v(p - h * t)) / (2 * h) for t in (t1, t2)])


@settings(max_examples=examples(200))
@given(vec4, vec4, vec4, st.floats(0, 0.3), st.floats(-2, 2), st.sampled_from([0.0, 0.7, 1.5]))
def test_lemma2_agrees_with_the_rank_of_the_projected_tangent_plane(p, u, w, r, lam, mu):
    """t2 = λρ + μu: a silhouette exactly when μ = 0 (the ray lies in the tangent plane)."""
    assume(1 - r * p[3] > 0.2)
    ray = sensor_ray(p, r)
    t1 = w
    t2 = lam * ray + mu * u
    tangent_frame = np.column_stack([t1, t2])
    assume(rank_ratio(tangent_frame) > 1e-2)  # a nonsingular point: t1, t2 independent
    assume(rank_ratio(np.column_stack([t1, ray])) > 1e-2)  # t1 has an image of its own
    projected = sensor_jacobian(p, r) @ tangent_frame  # the image of the tangent plane, 3x2
    if mu == 0:
        assert rank_ratio(projected) < 1e-12
        assert is_silhouette_point_3d(t1, t2, ray)
        n1, n2 = normals_from_tangents(t1, t2)
        assert is_silhouette_point_3d(n1=n1, n2=n2, ray=ray, tol=1e-9)
    else:
        full_frame = np.column_stack([t1, t2, ray])
        assume(rank_ratio(full_frame) > 1e-2)
        assert rank_ratio(projected) > 1e-6
        assert not is_silhouette_point_3d(t1, t2, ray)


@given(vec4, vec4, vec4)
def test_lemma2_measure_is_the_sine_of_the_ray_to_plane_angle(t1, t2, ray):
    assume(rank_ratio(np.column_stack([t1, t2])) > 1e-2 and np.linalg.norm(ray) > 1e-2)
    q, _ = np.linalg.qr(np.column_stack([t1, t2]))
    normal_part = ray - q @ (q.T @ ray)
    expected = np.linalg.norm(normal_part) / np.linalg.norm(ray)
    assert lemma2_measure_tangents(t1, t2, ray) == pytest.approx(expected, abs=1e-9)
    n1, n2 = normals_from_tangents(t1, t2)
    assert lemma2_measure_normals(n1, n2, ray) == pytest.approx(expected, abs=1e-9)


@settings(max_examples=examples(200))
@given(
    vec4,
    vec4,
    vec4,
    st.floats(0, 0.3),
    st.floats(0, 0.3),
    st.floats(-2, 2),
    st.floats(-2, 2),
    st.sampled_from([0.0, 0.8]),
)
def test_lemma3_agrees_with_the_rank_of_the_2d_image(p, u, w, r1, r2, a, b, mu):
    """t2 = a ρ1 + b ρ2 + μu: a silhouette of the 4D -> 2D map exactly when μ = 0."""
    assume(1 - r1 * p[3] - r2 * p[2] > 0.2)
    ray1, ray2 = sensor_ray(p, r1), eye_ray(p, r2)
    assume(rank_ratio(np.column_stack([ray1, ray2])) > 1e-2)
    t1 = w
    t2 = a * ray1 + b * ray2 + mu * u
    assume(rank_ratio(np.column_stack([t1, t2])) > 1e-2)
    # t1 itself must not (nearly) lie in the rays' plane, or the whole image is ~0 and its rank
    # ratio is rounding noise.
    assume(rank_ratio(np.column_stack([t1, ray1, ray2])) > 1e-2)
    image = projected_tangents_2d(p, t1, t2, r1, r2)
    n1, n2 = normals_from_tangents(t1, t2)
    if mu == 0:
        assert rank_ratio(image) < 1e-6  # finite differences: ~h² accuracy
        assert is_silhouette_point_2d(t1, t2, ray1, ray2)
        assert is_silhouette_point_2d(n1=n1, n2=n2, ray1=ray1, ray2=ray2)
    else:
        assume(rank_ratio(np.column_stack([t1, t2, ray1, ray2])) > 1e-2)
        assert rank_ratio(image) > 1e-4
        assert not is_silhouette_point_2d(t1, t2, ray1, ray2)
        assert not is_silhouette_point_2d(n1=n1, n2=n2, ray1=ray1, ray2=ray2)


@given(vec4, vec4, vec4, vec4)
def test_normal_and_tangent_forms_of_lemma3_measure_agree(t1, t2, ray1, ray2):
    """(n1∧n2)·(ρ1∧ρ2) and det[t1, t2, ρ1, ρ2] are the same number up to sign (Hodge duality),
    for orthonormal frames of complementary planes."""
    assume(rank_ratio(np.column_stack([t1, t2])) > 1e-2)
    assume(rank_ratio(np.column_stack([ray1, ray2])) > 1e-2)
    n1, n2 = normals_from_tangents(t1, t2)
    assert abs(silhouette_function_normalized(n1, n2, ray1, ray2)) == pytest.approx(
        lemma3_measure_tangents(t1, t2, ray1, ray2), abs=1e-9
    )


@given(vec4, vec4)
def test_silhouette_function_is_the_papers_conditions(n1, n2):
    e = np.eye(4)
    # Offsets, XYUV space: C is det(i, j, n1, n2) = 0, the orthographic view along u and v.
    assert silhouette_function(n1, n2, e[2], e[3]) == pytest.approx(
        np.linalg.det(np.array([e[0], e[1], n1, n2])), abs=1e-12
    )
    # Collision, XYZT space: C' is f_x g_y - f_y g_x = 0, the view along x and y.
    assert silhouette_function(n1, n2, e[0], e[1]) == pytest.approx(
        n1[0] * n2[1] - n1[1] * n2[0], abs=1e-12
    )


def pipe_surface(curve, tangent, radius, taus, phis):
    """The paper's pipe 2-surface in XYUV: (u, v) on the curve, (x, y) at distance r from it."""
    tau, phi = np.meshgrid(taus, phis, indexing="ij")
    u, v = curve(tau)
    x, y = u + radius * np.cos(phi), v + radius * np.sin(phi)
    return np.stack([x, y, u, v], axis=-1), tau, phi


def grid_triangles(rows, cols):
    index = np.arange(rows * cols).reshape(rows, cols)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_offset_curve_of_the_parabola_is_the_silhouette_along_u_and_v():
    """Section 4.2: on S = {g = 0, f = 0} with f = v - u², the zero set of condition C projects
    (along u and v) onto the offset curve: points at distance r from y = x² along its normal."""
    radius = 1.0
    taus = np.linspace(-1.5, 1.5, 121)
    phis = np.linspace(0, 2 * math.pi, 181)
    points, tau, phi = pipe_surface(lambda t: (t, t * t), None, radius, taus, phis)
    x, y, u, v = np.moveaxis(points, -1, 0)
    n1 = np.stack([2 * (x - u), 2 * (y - v), -2 * (x - u), -2 * (y - v)], axis=-1)  # ∇g
    n2 = np.stack([0 * x, 0 * x, -2 * u, np.ones_like(x)], axis=-1)  # ∇f
    e = np.eye(4)
    s = silhouette_function(n1, n2, e[2], e[3])
    segments = zero_set_segments(points.reshape(-1, 4), grid_triangles(*tau.shape), s.ravel())
    assert len(segments) > 200
    xy = segments.reshape(-1, 4)[:, :2]
    # The offset curve, computed independently: both sides of the curve along its unit normal
    # (the inner side has the swallowtail of Figure 3, so nearest-distance tests would not do).
    dense = np.linspace(-1.6, 1.6, 4001)
    normal = np.stack([-2 * dense, np.ones_like(dense)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    base = np.stack([dense, dense**2], axis=-1)
    offset = np.concatenate([base + radius * normal, base - radius * normal])
    gap = np.min(np.linalg.norm(xy[:, None, :] - offset[None, :, :], axis=-1), axis=1)
    assert np.all(gap < 5e-3)


def test_cusp_singular_circle_satisfies_C_but_is_not_silhouette():
    """Section 4.2, y² = x³: where ∇f = 0 (u = v = 0) the circle of singular points satisfies
    condition C trivially; by the paper's definition these points are not silhouettes."""
    phi = np.linspace(0, 2 * math.pi, 13)
    x, y = np.cos(phi), np.sin(phi)
    zero = np.zeros_like(phi)
    n1 = np.stack([2 * x, 2 * y, -2 * x, -2 * y], axis=-1)
    n2 = np.stack([zero, zero, zero, zero], axis=-1)  # ∇f = (0, 0, -3u², 2v) at u = v = 0
    e = np.eye(4)
    np.testing.assert_array_equal(silhouette_function(n1, n2, e[2], e[3]), 0.0)
    assert not is_silhouette_point_2d(n1=n1, n2=n2, ray1=e[2], ray2=e[3]).any()
    assert not is_silhouette_point_3d(n1=n1, n2=n2, ray=e[3]).any()


def test_zero_set_of_a_rotated_sphere_is_the_outline_of_its_image():
    """A round 2-sphere in a generic 3-space of R^4, seen orthographically by sensor and eye: its
    image is an ellipse and the silhouette curve must map onto the ellipse's boundary."""
    rng = np.random.default_rng(5)
    q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    theta, phi = np.meshgrid(
        np.linspace(0, math.pi, 91), np.linspace(0, 2 * math.pi, 181), indexing="ij"
    )
    sphere = np.stack(
        [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta), 0 * theta],
        axis=-1,
    )
    points = sphere @ q.T
    n1 = points  # radial direction within the sphere's 3-space
    n2 = np.broadcast_to(q[:, 3], points.shape)  # normal of that 3-space
    s = silhouette_function(n1, n2, sensor_ray(points, 0.0), eye_ray(points, 0.0))
    segments = zero_set_segments(points.reshape(-1, 4), grid_triangles(*theta.shape), s.ravel())
    image = segments.reshape(-1, 4)[:, :2]
    m = q[:2, :3]  # the linear map sphere -> screen
    quadric = np.einsum("ni,ij,nj->n", image, np.linalg.inv(m @ m.T), image)
    assert len(segments) > 100
    np.testing.assert_allclose(quadric, 1.0, atol=5e-3)


def test_zero_set_segments_on_a_single_triangle():
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    segments = zero_set_segments(positions, [[0, 1, 2]], np.array([-1.0, 1.0, 1.0]))
    np.testing.assert_allclose(segments, [[[0.5, 0.0], [0.0, 0.5]]])
    assert zero_set_segments(positions, [[0, 1, 2]], np.array([1.0, 2.0, 3.0])).shape == (0, 2, 2)
    with pytest.raises(ValueError, match="one value per vertex"):
        zero_set_segments(positions, [[0, 1, 2]], np.array([1.0]))
