"""The generalised cross product ⊗ (paper, section 2)."""

import numpy as np
import pytest
from hypothesis import given

from exhibit.geometry import bivector_norm, cross4, generalized_cross

from .strategies import vectors


@given(vectors(), vectors(), vectors(), vectors())
def test_cross4_is_the_determinant_with_the_basis_row(a, b, c, d):
    """⊗(a, b, c) · d = det[d; a; b; c]: the defining cofactor expansion."""
    expected = np.linalg.det(np.array([d, a, b, c]))
    assert cross4(a, b, c) @ d == pytest.approx(expected, rel=1e-9, abs=1e-9)
    np.testing.assert_allclose(generalized_cross(a, b, c), cross4(a, b, c), rtol=1e-9, atol=1e-9)


@given(vectors(), vectors(), vectors())
def test_cross4_is_orthogonal_to_its_arguments(a, b, c):
    n = cross4(a, b, c)
    scale = np.linalg.norm(a) * np.linalg.norm(b) * np.linalg.norm(c)
    for v in (a, b, c):
        assert abs(n @ v) <= 1e-12 * scale * np.linalg.norm(v)


@given(vectors(), vectors(), vectors())
def test_length_is_the_spanned_volume(a, b, c):
    volume = abs(np.prod(np.diag(np.linalg.qr(np.array([a, b, c]).T)[1])))  # stable, unlike Gram
    scale = np.linalg.norm(a) * np.linalg.norm(b) * np.linalg.norm(c)
    assert np.linalg.norm(cross4(a, b, c)) == pytest.approx(volume, abs=1e-9 * scale)


def test_dependent_vectors_give_zero_not_nan():
    a = np.array([1.0, 2.0, 3.0, 4.0])
    n = cross4(a, 2 * a, np.array([0.0, 1.0, 0.0, 0.0]))
    np.testing.assert_array_equal(n, np.zeros(4))


def test_basis_vectors():
    e = np.eye(4)
    # det[e_w; e_x; e_y; e_z] = -1, so ⊗(e_x, e_y, e_z) = -e_w
    np.testing.assert_allclose(cross4(e[0], e[1], e[2]), -e[3])
    np.testing.assert_allclose(cross4(e[1], e[2], e[3]), e[0])


@pytest.mark.parametrize("n", [2, 3, 5])
def test_other_dimensions(n):
    rng = np.random.default_rng(n)
    vs = rng.normal(size=(n - 1, n))
    result = generalized_cross(*vs)
    for v in vs:
        assert abs(result @ v) < 1e-12
    d = rng.normal(size=n)
    assert result @ d == pytest.approx(np.linalg.det(np.vstack([d, vs])))
    if n == 3:
        np.testing.assert_allclose(result, np.cross(vs[0], vs[1]))


def test_batched_and_errors():
    rng = np.random.default_rng(0)
    a, b, c = rng.normal(size=(3, 10, 4))
    np.testing.assert_allclose(cross4(a, b, c)[4], cross4(a[4], b[4], c[4]))
    np.testing.assert_allclose(generalized_cross(a, b, c), cross4(a, b, c), atol=1e-12)
    with pytest.raises(ValueError, match="n-1 vectors"):
        generalized_cross(a[0], b[0])


def test_bivector_norm():
    assert bivector_norm([1, 0, 0, 0], [0, 2, 0, 0]) == pytest.approx(2.0)
    assert bivector_norm([1, 1, 0, 0], [2, 2, 0, 0]) == 0.0
