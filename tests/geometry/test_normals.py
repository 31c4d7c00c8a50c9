"""Lemma 1: the normal of the projected surface from the 4D tangents (b) or normals (c), checked
against the normal of v(S) computed independently by finite differences of v∘X."""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from exhibit.geometry import (
    normals_from_tangents,
    project_to_3d,
    projected_normal_from_normals,
    projected_normal_from_tangents,
    sensor_ray,
    tangents_from_normals,
)
from tests.hypothesis_profiles import examples

from .strategies import vectors
from .surfaces import PolynomialSurface, finite_difference_tangents, parallel_error

cases = st.tuples(st.integers(0, 10_000), st.floats(-1, 1), st.floats(-1, 1), st.floats(0, 0.4))


def reference_normal(surface, s, t, r):
    """Normal of the projected surface v(S): cross product of finite-difference tangents of v∘X."""
    ys, yt = finite_difference_tangents(
        lambda a, b: project_to_3d(surface.point(a, b), r).points, s, t
    )
    return np.cross(ys, yt), ys, yt


@settings(max_examples=examples(150))
@given(cases)
def test_lemma1_normals_agree_with_finite_differences(case):
    seed, s, t, r = case
    surface = PolynomialSurface(seed)
    p = surface.point(s, t)
    assume(1 - r * p[3] > 0.3)
    t1, t2 = surface.tangents(s, t)
    expected, ys, yt = reference_normal(surface, s, t, r)
    # stay away from the silhouette, where the projected normal vanishes (Lemma 2)
    assume(np.linalg.norm(expected) > 1e-3 * np.linalg.norm(ys) * np.linalg.norm(yt))
    ray = sensor_ray(p, r)

    from_tangents = projected_normal_from_tangents(t1, t2, ray)  # Lemma 1(b)
    assert parallel_error(from_tangents, expected) < 1e-6

    n1, n2 = normals_from_tangents(t1, t2)  # then Lemma 1(c) from the normals
    from_normals = projected_normal_from_normals(n1, n2, ray)
    assert parallel_error(from_normals, expected) < 1e-6

    # The paper's three steps: v(p + t_i) - v(p) span the tangent plane of v(S) for any length.
    scale = 0.05
    image = project_to_3d(np.array([p, p + scale * t1, p + scale * t2]), r)
    assume(image.in_front.all())
    steps = np.cross(image.points[1] - image.points[0], image.points[2] - image.points[0])
    assert parallel_error(steps, expected) < 1e-6


@given(vectors(), vectors())
def test_tangents_and_normals_are_complementary_orthonormal_frames(a, b):
    scale = np.linalg.norm(a) * np.linalg.norm(b)
    assume(np.linalg.norm(np.cross(a[:3], b[:3])) > 1e-3 * scale or abs(a[3]) + abs(b[3]) > 1e-2)
    assume(abs(a @ b) < 0.999 * scale)
    t1, t2 = tangents_from_normals(a, b)
    frame = np.array([t1, t2])
    np.testing.assert_allclose(frame @ frame.T, np.eye(2), atol=1e-9)
    for n in (a, b):
        np.testing.assert_allclose(frame @ n, 0.0, atol=1e-9 * np.linalg.norm(n))
    n1, n2 = normals_from_tangents(t1, t2)
    # the normals recovered span the same plane as a, b
    basis = np.array([n1, n2])
    for n in (a, b):
        residual = n - basis.T @ (basis @ n)
        assert np.linalg.norm(residual) < 1e-9 * np.linalg.norm(n)


def test_singular_points_give_zero_vectors_not_nan():
    n = np.array([1.0, 2.0, 0.0, -1.0])
    t1, t2 = tangents_from_normals(n, 3 * n)
    np.testing.assert_array_equal(t1, 0.0)
    np.testing.assert_array_equal(t2, 0.0)
    zero = projected_normal_from_normals(n, np.zeros(4), np.array([0, 0, 0, 1.0]))
    assert np.all(np.isfinite(zero))


def test_implicit_hopf_torus_normals_match_its_parametrisation():
    """The torus x²+z² = a, y²+w² = b: Lemma 1(c) from ∇f1, ∇f2 equals Lemma 1(b) from ∂/∂α,
    ∂/∂β."""
    from exhibit.geometry.hopf import hopf_torus, hopf_torus_tangents

    alpha, beta = np.meshgrid(np.linspace(0, 6, 9), np.linspace(0, 6, 9))
    p = hopf_torus(0.3, alpha, beta) + [0, 0, 0, 1.0]
    t1, t2 = hopf_torus_tangents(0.3, alpha, beta)
    x, y, z, w = np.moveaxis(p - [0, 0, 0, 1.0], -1, 0)
    zero = np.zeros_like(x)
    grad1 = np.stack([2 * x, zero, 2 * z, zero], axis=-1)
    grad2 = np.stack([zero, 2 * y, zero, 2 * w], axis=-1)
    ray = sensor_ray(p, 1 / 3)
    a = projected_normal_from_tangents(t1, t2, ray).reshape(-1, 3)
    b = projected_normal_from_normals(grad1, grad2, ray).reshape(-1, 3)
    for u, v in zip(a, b):
        assert parallel_error(u, v) < 1e-9


@pytest.mark.parametrize("shape", [(), (7,), (3, 5)])
def test_batched_shapes(shape):
    rng = np.random.default_rng(1)
    t1, t2, ray = rng.normal(size=(3,) + shape + (4,))
    assert projected_normal_from_tangents(t1, t2, ray).shape == shape + (3,)
    assert projected_normal_from_normals(t1, t2, ray).shape == shape + (3,)
    assert tangents_from_normals(t1, t2)[0].shape == shape + (4,)
