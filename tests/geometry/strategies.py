"""Hypothesis strategies shared by the geometry tests."""

import math

import numpy as np
from hypothesis import strategies as st

from exhibit.geometry import euler_angle_count

finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False)
angle = st.floats(min_value=-2 * math.pi, max_value=2 * math.pi, allow_nan=False)
#: Angles at and near the gimbal-lock values 0 and ±π, where the inverse is ill-conditioned.
near_lock = st.sampled_from([0.0, math.pi, -math.pi]).flatmap(
    lambda k: st.sampled_from([0.0, 1e-15, -1e-15, 1e-9, -1e-9, 1e-6, -1e-6]).map(lambda e: k + e)
)
any_angle = st.one_of(angle, near_lock)


def angles(n: int):
    return st.lists(any_angle, min_size=euler_angle_count(n), max_size=euler_angle_count(n)).map(
        np.array
    )


def vectors(dim: int = 4, min_norm: float = 1e-3):
    # no subnormals: LAPACK's det warns (divide by zero) on them, and the tests treat it as an error
    return (
        st.lists(
            st.floats(-10, 10, allow_nan=False, allow_subnormal=False), min_size=dim, max_size=dim
        )
        .map(np.array)
        .filter(lambda v: np.linalg.norm(v) >= min_norm)
    )
