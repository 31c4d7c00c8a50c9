"""Plane rotations and the n-D Euler angles against the paper's section 3.1."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exhibit.geometry import (
    euler_angle_count,
    euler_planes,
    euler_to_matrix,
    matrix_to_euler,
    plane_rotation,
)
from tests.hypothesis_profiles import examples

from .strategies import angles

X, Y, Z, W = range(4)


def R(i, j, theta, n=4):
    return plane_rotation(n, i, j, theta)


def test_plane_rotation_is_the_papers_R_YZ():
    t = 0.3
    c, s = math.cos(t), math.sin(t)
    expected = np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(plane_rotation(4, Y, Z, t), expected, atol=0)


def test_euler_chain_is_the_papers_product():
    t = np.array([0.1, -0.7, -1.9, 2.5, -0.4, 1.3])
    expected = (
        R(X, Y, t[0])
        @ R(Y, Z, t[1])
        @ R(Z, W, t[2])
        @ R(X, Y, t[3])
        @ R(Y, Z, t[4])
        @ R(X, Y, t[5])
    )
    np.testing.assert_allclose(euler_to_matrix(t), expected, atol=1e-15)
    assert euler_planes(4) == [(0, 1), (1, 2), (2, 3), (0, 1), (1, 2), (0, 1)]


@given(angles(4))
def test_the_papers_closed_form_matrices(t):
    """The three printed phase matrices of section 3.1, transcribed entry by entry."""
    c = np.cos(t)
    s = np.sin(t)
    c1, c2, c3, c4, c5, c6 = c
    s1, s2, s3, s4, s5, s6 = s
    phase1 = np.array(
        [
            [c1, -s1 * c2, s1 * s2 * c3, -s1 * s2 * s3],
            [s1, c1 * c2, -c1 * s2 * c3, c1 * s2 * s3],
            [0, s2, c2 * c3, -c2 * s3],
            [0, 0, s3, c3],
        ]
    )
    phase2 = np.array(
        [[c4, -s4 * c5, s4 * s5, 0], [s4, c4 * c5, -c4 * s5, 0], [0, s5, c5, 0], [0, 0, 0, 1]]
    )
    phase3 = np.array([[c6, -s6, 0, 0], [s6, c6, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(euler_to_matrix(t[:3].tolist() + [0, 0, 0]), phase1, atol=1e-12)
    np.testing.assert_allclose(
        euler_to_matrix(
            t,
        ),
        phase1 @ phase2 @ phase3,
        atol=1e-12,
    )


def test_3d_euler_angles_are_textbook_z_x_z():
    a, b, c = 0.4, 1.1, -2.0

    def rz(t):
        return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])

    def rx(t):
        return np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])

    np.testing.assert_allclose(euler_to_matrix([a, b, c]), rz(a) @ rx(b) @ rz(c), atol=1e-15)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_induction_orient_the_new_axis_then_recurse(n):
    """Dimension n: n-1 rotations orient e_{n-1}, then the (n-1)-D Euler angles do the rest."""
    rng = np.random.default_rng(n)
    t = rng.uniform(-3, 3, euler_angle_count(n))
    first = np.eye(n)
    for k in range(1, n):
        first = first @ plane_rotation(n, k - 1, k, t[k - 1])
    rest = np.eye(n)
    if n > 2:
        rest[: n - 1, : n - 1] = euler_to_matrix(t[n - 1 :])
    np.testing.assert_allclose(euler_to_matrix(t), first @ rest, atol=1e-14)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
@given(data=st.data())
def test_orthonormal_with_det_one(n, data):
    a = euler_to_matrix(data.draw(angles(n)))
    assert a.shape == (n, n)
    np.testing.assert_allclose(a.T @ a, np.eye(n), atol=1e-14)
    assert np.linalg.det(a) == pytest.approx(1.0, abs=1e-13)


@pytest.mark.parametrize("n", [2, 3, 4, 5])
@settings(max_examples=examples(300))
@given(data=st.data())
def test_round_trip_reproduces_the_matrix_even_at_gimbal_lock(n, data):
    a = euler_to_matrix(data.draw(angles(n)))
    back = matrix_to_euler(a)
    assert back.shape == (euler_angle_count(n),)
    assert np.all(np.isfinite(back))
    np.testing.assert_allclose(euler_to_matrix(back), a, atol=1e-12)
    # and a second trip is stable: the angles are a fixed point
    np.testing.assert_allclose(
        euler_to_matrix(matrix_to_euler(euler_to_matrix(back))), a, atol=1e-12
    )


def _range_checks(n, t):
    """First angle of each phase in (-π, π]; all others in [-π, 0] (the paper's ranges)."""
    index = 0
    for m in range(n, 1, -1):
        phase = t[index : index + m - 1]
        assert -math.pi < phase[0] <= math.pi
        assert np.all((phase[1:] >= -math.pi) & (phase[1:] <= 0))
        index += m - 1


@pytest.mark.parametrize("n", [2, 3, 4, 5])
@settings(max_examples=examples(200))
@given(data=st.data())
def test_returned_angles_lie_in_the_documented_ranges(n, data):
    _range_checks(n, matrix_to_euler(euler_to_matrix(data.draw(angles(n)))))


@given(
    st.lists(st.floats(0.05, math.pi - 0.05), min_size=3, max_size=3),
    st.lists(st.floats(-math.pi + 0.05, math.pi - 0.05), min_size=3, max_size=3),
)
def test_angles_in_range_come_back_unchanged(restricted, full):
    t = np.array([full[0], -restricted[0], -restricted[1], full[1], -restricted[2], full[2]])
    np.testing.assert_allclose(matrix_to_euler(euler_to_matrix(t)), t, atol=1e-9)


@given(angles(4))
def test_inverse_satisfies_the_papers_arctan_formulas(t):
    """Step 1 of the paper: θ1 = -arctan(lx/ly), θ2 = -arctan(√(lx²+ly²)/lz),
    θ3 = -arctan(√(lx²+ly²+lz²)/lw), as tangents (arctan is defined modulo π)."""
    a = euler_to_matrix(t)
    lx, ly, lz, lw = a[:, 3]
    th = matrix_to_euler(a)
    if abs(math.sin(th[2])) > 1e-3 and abs(math.sin(th[1])) > 1e-3:
        assert math.sin(th[0]) * ly == pytest.approx(-math.cos(th[0]) * lx, abs=1e-9)
        assert math.sin(th[1]) * lz == pytest.approx(
            -math.cos(th[1]) * math.hypot(lx, ly), abs=1e-9
        )
    if abs(math.sin(th[2])) > 1e-3:
        assert math.sin(th[2]) * lw == pytest.approx(
            -math.cos(th[2]) * math.sqrt(lx * lx + ly * ly + lz * lz), abs=1e-9
        )


def test_random_rotations_from_qr_never_give_nan():
    rng = np.random.default_rng(7)
    for n in (2, 3, 4, 5, 6):
        for _ in range(100):
            q, r = np.linalg.qr(rng.normal(size=(n, n)))
            q = q * np.sign(np.diag(r))
            if np.linalg.det(q) < 0:
                q[:, 0] = -q[:, 0]
            t = matrix_to_euler(q)
            assert np.all(np.isfinite(t))
            np.testing.assert_allclose(euler_to_matrix(t), q, atol=1e-12)


@pytest.mark.parametrize(
    "t",
    [
        [0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 1.2],  # only the twist: everything before it is locked
        [0.7, 0, 0, 0.3, 0, 0],  # θ1 and θ4 are invisible at θ2 = θ3 = θ5 = 0
        [0, -math.pi, 0, 0, -math.pi, 0],
        [1.0, -0.5, -math.pi, 2.0, 0.0, -1.0],
    ],
)
def test_exact_gimbal_lock_is_handled(t):
    a = euler_to_matrix(t)
    back = matrix_to_euler(a)
    assert np.all(np.isfinite(back))
    np.testing.assert_allclose(euler_to_matrix(back), a, atol=1e-14)


def test_lock_convention_puts_the_rotation_on_the_last_angle():
    """At θ2 = θ3 = θ5 = 0 the xy-rotations add up; the free angles are reported as 0."""
    back = matrix_to_euler(euler_to_matrix([0.7, 0, 0, 0.3, 0, 0.2]))
    np.testing.assert_allclose(back, [0, 0, 0, 0, 0, 1.2], atol=1e-14)


def test_batched_angles():
    rng = np.random.default_rng(3)
    t = rng.uniform(-3, 3, (5, 2, 6))
    batch = euler_to_matrix(t)
    assert batch.shape == (5, 2, 4, 4)
    np.testing.assert_allclose(batch[3, 1], euler_to_matrix(t[3, 1]), atol=1e-15)


@pytest.mark.parametrize(
    "bad, message",
    [
        (np.eye(4) * 2, "not orthonormal"),
        (np.diag([1.0, 1.0, 1.0, -1.0]), "reflection"),
        (np.ones((3, 4)), "square"),
        (np.full((4, 4), np.nan), "non-finite"),
    ],
)
def test_matrix_to_euler_rejects_non_rotations(bad, message):
    with pytest.raises(ValueError, match=message):
        matrix_to_euler(bad)


@pytest.mark.parametrize(
    "bad, message",
    [
        ([0.1, 0.2], "1, 3, 6 or 10"),
        ([0.1] * 5, "1, 3, 6 or 10"),
        ([0.1, float("nan"), 0.2], "finite"),
        (0.3, "scalar"),
    ],
)
def test_euler_to_matrix_rejects_bad_angles(bad, message):
    with pytest.raises(ValueError, match=message):
        euler_to_matrix(bad)
