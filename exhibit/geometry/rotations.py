"""Plane rotations and the paper's n-dimensional Euler angles (section 3.1).

Conventions (the paper's):

* ``plane_rotation(n, i, j, θ)`` rotates the plane of axes i, j: entries (i,i)=(j,j)=cos θ,
  (i,j)=-sin θ, (j,i)=sin θ. The paper's R_YZ(θ) is ``plane_rotation(4, 1, 2, θ)``.
* Euler angles in R^n are built inductively: first orient the body-fixed last axis e_{n-1} with
  n-1 rotations in the planes (0,1), (1,2), ..., (n-2,n-1), then orient the remaining R^{n-1}
  with the (n-1)-dimensional Euler angles. In R^4 this is the paper's

      A = R_XY4(θ1) R_YZ4(θ2) R_ZW4(θ3) R_XY3(θ4) R_YZ3(θ5) R_XY2(θ6),   world = A · body,

  so the columns of A are the body axes i, j, k, l in world coordinates. R^n has n(n-1)/2 angles:
  1, 3, 6, 10 for n = 2, 3, 4, 5.

Inverse (``matrix_to_euler``): the paper's steps with atan2. Each phase strips the rotations it
found from the matrix before the next phase looks at it, so the angles returned always rebuild the
input matrix, whatever happens at gimbal lock.

Ranges: the first angle of each phase (θ1, θ4, θ6 in R^4: the R_XY rotations) spans (-π, π]; every
other angle (θ2, θ3, θ5) lies in [-π, 0]. This is the paper's "no ± before the square roots":
θ_k = -atan2(‖l[:k]‖, l[k]) with the norm non-negative.

Gimbal lock: when the two components an angle is read from are both (nearly) zero — θ2, θ3 or θ5
near 0 or -π makes the angles before it in its phase undefined — that angle is set to 0 and the
later angles carry the rotation. No NaN is ever produced.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

#: Size (relative to the column) below which the two components that define an angle count as
#: zero: gimbal lock. A few ulps, so only rounding noise is dropped, never a real rotation.
GIMBAL_TOLERANCE = 1e-14
#: Largest |AᵀA - I| accepted by matrix_to_euler before it refuses the input as not a rotation.
ORTHONORMAL_TOLERANCE = 1e-6


def euler_angle_count(n: int) -> int:
    """Number of Euler angles of R^n: n(n-1)/2."""
    return n * (n - 1) // 2


def dimension_for_angle_count(count: int) -> int:
    """Inverse of euler_angle_count; raises ValueError if count is not a triangular number >= 1."""
    n = int(round((1 + math.sqrt(1 + 8 * count)) / 2))
    if n < 2 or euler_angle_count(n) != count:
        raise ValueError(
            f"{count} angles do not describe a rotation: "
            "expected 1, 3, 6 or 10 (n(n-1)/2 angles for R^n)"
        )
    return n


def euler_planes(n: int) -> list[tuple[int, int]]:
    """The rotation planes of the n-D Euler chain, in the order of the angles.

    R^4: [(0,1), (1,2), (2,3), (0,1), (1,2), (0,1)] — the paper's XY4, YZ4, ZW4, XY3, YZ3, XY2.
    """
    planes: list[tuple[int, int]] = []
    for m in range(n, 1, -1):
        planes.extend((k - 1, k) for k in range(1, m))
    return planes


def plane_rotation(n: int, i: int, j: int, theta: ArrayLike) -> np.ndarray:
    """Basic rotation R_ij(θ) in R^n; θ may be an array, giving a stack of shape θ.shape + (n,
    n)."""
    if not (0 <= i < n and 0 <= j < n and i != j):
        raise ValueError(f"plane ({i}, {j}) is not a coordinate plane of R^{n}")
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    out = np.broadcast_to(np.eye(n), theta.shape + (n, n)).copy()
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def euler_to_matrix(angles: ArrayLike) -> np.ndarray:
    """Direction cosine matrix of the n-D Euler angles (1, 3, 6 or 10 ... angles, in radians).

    ``angles`` may carry leading batch dimensions: shape (..., n(n-1)/2) -> (..., n, n).
    """
    angles = np.asarray(angles, dtype=float)
    if angles.ndim == 0:
        raise ValueError("euler_to_matrix needs a sequence of angles, got a scalar")
    if not np.all(np.isfinite(angles)):
        raise ValueError("Euler angles must be finite numbers")
    n = dimension_for_angle_count(angles.shape[-1])
    batch = angles.shape[:-1]
    result = np.broadcast_to(np.eye(n), batch + (n, n)).copy()
    for index, (i, j) in enumerate(euler_planes(n)):
        # Right-multiplying by R_ij mixes columns i and j only; cheaper than a full matmul.
        c = np.cos(angles[..., index])[..., None]
        s = np.sin(angles[..., index])[..., None]
        col_i = result[..., :, i].copy()
        col_j = result[..., :, j]
        result[..., :, i] = c * col_i + s * col_j
        result[..., :, j] = -s * col_i + c * col_j
    return result


def _strip_last_axis(vector: np.ndarray) -> list[float]:
    """Angles of one phase: the rotations in planes (0,1)...(m-2,m-1) that carry e_{m-1} to vector.

    Works on a copy: after each angle is found, its rotation is undone on the vector (the paper's
    left-multiplication by R(-θ)), so component k-1 is the non-negative norm of all components
    before k when θ_k is read.
    """
    v = np.array(vector, dtype=float)
    m = v.shape[0]
    scale = max(float(np.linalg.norm(v)), 1.0)
    angles = []
    for k in range(1, m):
        a, b = v[k - 1], v[k]
        if math.hypot(a, b) <= GIMBAL_TOLERANCE * scale:
            theta = 0.0  # gimbal lock: this angle is free; later angles carry the rotation
        elif k == 1:
            theta = math.atan2(-a, b)  # full range (-π, π]
            if theta <= -math.pi:  # atan2(-0.0, b < 0) gives -π; the range ends at +π
                theta = math.pi
        else:
            theta = math.atan2(-abs(a), b)  # a is a norm (>= 0 up to rounding): range [-π, 0]
        c, s = math.cos(theta), math.sin(theta)
        # v <- R_{k-1,k}(-θ) v: the new v[k-1] is 0, v[k] keeps the norm of v[:k+1].
        v[k - 1], v[k] = c * a + s * b, -s * a + c * b
        angles.append(theta + 0.0)  # + 0.0 turns -0.0 into 0.0
    return angles


def _check_rotation(matrix: np.ndarray) -> None:
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1] or matrix.shape[0] < 2:
        raise ValueError(f"expected a square n x n matrix with n >= 2, got shape {matrix.shape}")
    if not np.all(np.isfinite(matrix)):
        raise ValueError("matrix has non-finite entries")
    n = matrix.shape[0]
    deviation = float(np.max(np.abs(matrix.T @ matrix - np.eye(n))))
    if deviation > ORTHONORMAL_TOLERANCE:
        raise ValueError(f"matrix is not orthonormal (max |AᵀA - I| = {deviation:.3g})")
    if np.linalg.det(matrix) < 0:
        raise ValueError("matrix is a reflection (det = -1), not a rotation")


def matrix_to_euler(matrix: ArrayLike) -> np.ndarray:
    """Euler angles of a rotation matrix in R^n (n >= 2), by the paper's steps with atan2.

    Returns n(n-1)/2 angles in the documented ranges; euler_to_matrix of the result reproduces
    ``matrix`` to rounding, also at gimbal lock. Raises ValueError for a matrix that is not a
    rotation (not square, not orthonormal, or a reflection).
    """
    remaining = np.array(matrix, dtype=float)
    _check_rotation(remaining)
    angles: list[float] = []
    while remaining.shape[0] >= 2:
        m = remaining.shape[0]
        phase = _strip_last_axis(remaining[:, m - 1])
        angles.extend(phase)
        # Undo this phase on the whole matrix; its last row and column are now e_{m-1}, and the
        # (m-1)-D block left over is the rotation the later phases describe.
        remaining = _undo_phase(remaining, phase)[: m - 1, : m - 1]
    return np.array(angles)


def _undo_phase(matrix: np.ndarray, phase: list[float]) -> np.ndarray:
    """R_{m-2,m-1}(-θ_{m-1}) ... R_{0,1}(-θ_1) · matrix: the matrix seen after this phase."""
    m = matrix.shape[0]
    out = matrix
    for k, theta in enumerate(phase, start=1):
        out = plane_rotation(m, k - 1, k, -theta) @ out
    return out
