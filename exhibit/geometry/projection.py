"""The paper's projective maps: 4D -> 3D from the sensor, and 4D -> 2D from sensor and eye.

The sensor sits at l/r on the w-axis, the eye at k/r_eye on the z-axis (both in view coordinates,
after the 4D rotation). r = 0 puts a centre at infinity (orthographic). We drive the reciprocal r,
not the distance, so infinity is an ordinary value and the sensor can sweep into the object.

Rays are returned scaled by r: r·(l/r - p) = (-r p_x, -r p_y, -r p_z, 1 - r p_w). That is a
positive multiple of the paper's ray for r > 0 and the paper's orthographic ray l for r = 0, so
one formula serves both and nothing is infinite.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

#: Points whose homogeneous depth 1 - r p_w (or 1 - r1 p_w - r2 p_z) is at most this are at or
#: behind a projection centre: they have no image and are reported as not in front.
MIN_HOMOGENEOUS_DEPTH = 1e-12


class Projected(NamedTuple):
    """Image points and which of them lie in front of the centre(s); the others are set to 0."""

    points: np.ndarray
    in_front: np.ndarray


def _check_points(points: ArrayLike) -> np.ndarray:
    points = np.asarray(points, dtype=float)
    if points.shape[-1:] != (4,):
        raise ValueError(f"expected points of R^4 (last axis 4), got shape {points.shape}")
    return points


def _check_reciprocal(r: float, name: str) -> float:
    r = float(r)
    if not np.isfinite(r) or r < 0:
        raise ValueError(
            f"{name} must be a finite number >= 0 (1/distance; 0 = at infinity), got {r}"
        )
    return r


def _divide(numerators: np.ndarray, depth: np.ndarray) -> Projected:
    in_front = depth > MIN_HOMOGENEOUS_DEPTH
    safe = np.where(in_front, depth, 1.0)
    return Projected(np.where(in_front[..., None], numerators / safe[..., None], 0.0), in_front)


def sensor_depth(points: ArrayLike, r: float) -> np.ndarray:
    """Homogeneous coordinate 1 - r p_w of the sensor projection (> 0 in front of the sensor)."""
    points = _check_points(points)
    return 1.0 - _check_reciprocal(r, "sensor r") * points[..., 3]


def project_to_3d(points: ArrayLike, r: float) -> Projected:
    """v(p) = (p_x, p_y, p_z) / (1 - r p_w): the sensor's view of R^4 in R^3 (paper, section 2)."""
    points = _check_points(points)
    return _divide(points[..., :3], sensor_depth(points, r))


def project_to_2d(points: ArrayLike, r_sensor: float, r_eye: float) -> Projected:
    """v(p) = (p_x, p_y) / (1 - r1 p_w - r2 p_z): sensor and eye in one map (paper, Lemma 3).

    Equal to projecting by the sensor to R^3 and then by the eye to the plane, in either order.
    """
    points = _check_points(points)
    r1 = _check_reciprocal(r_sensor, "sensor r")
    r2 = _check_reciprocal(r_eye, "eye r")
    return _divide(points[..., :2], 1.0 - r1 * points[..., 3] - r2 * points[..., 2])


def sensor_jacobian(points: ArrayLike, r: float) -> np.ndarray:
    """Derivative of v at p, shape (..., 3, 4): dv(t) = t_xyz/h + p_xyz (r t_w)/h², h = 1 - r
    p_w."""
    points = _check_points(points)
    h = sensor_depth(points, r)
    safe = np.where(np.abs(h) > MIN_HOMOGENEOUS_DEPTH, h, np.nan)
    jac = np.zeros(points.shape[:-1] + (3, 4))
    jac[..., :, :3] = np.eye(3) / safe[..., None, None]
    jac[..., :, 3] = points[..., :3] * (r / safe**2)[..., None]
    return np.nan_to_num(jac, nan=0.0)


def sensor_ray(points: ArrayLike, r: float) -> np.ndarray:
    """r·(l/r - p): the ray from p towards the sensor, scaled to stay finite (e_w when r = 0)."""
    points = _check_points(points)
    r = _check_reciprocal(r, "sensor r")
    ray = -r * points
    ray[..., 3] += 1.0
    return ray


def eye_ray(points: ArrayLike, r_eye: float) -> np.ndarray:
    """r2·(k/r2 - p): the ray from p towards the eye on the z-axis (e_z when the eye is at
    infinity)."""
    points = _check_points(points)
    r2 = _check_reciprocal(r_eye, "eye r")
    ray = -r2 * points
    ray[..., 2] += 1.0
    return ray
