"""The whole 4D -> clip-space pipeline as one homogeneous 4x5 matrix (docs/GEOMETRY.md).

    (p, 1) --pose 5x5--> view coords --sensor 4x5--> (X, Y, Z, H) = (x, y, z, 1 - r w)
           --eye 4x4--> clip coords (x_c, y_c, z_c, w_c),   w_c = H - r_eye Z = 1 - r w - r_eye z

The sensor projection is projective, so in homogeneous coordinates it is linear and composes with
the rigid motion and the eye's camera into ``matrix`` (4x5): gl_Position = matrix · (p, 1). The
renderer uploads exactly these numbers as uniforms, so CPU checks and GPU pictures share one
definition. Two clip planes, also linear in (p, 1), go to gl_ClipDistance:

* the sensor hyperplane H = 1 - r w >= 0: points behind the sensor are cut exactly there, so no
  triangle is stretched across the screen when the sensor enters the object (Figure 8);
* the paper's front clipping plane, at ``front_distance`` towards the eye, tilted by
  ``front_pitch`` about the screen's x-axis: sin(pitch) y + cos(pitch) z <= distance survives.

Depth: z_ndc runs from -1 at the near plane to +1 at the far plane and grows away from the eye.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from exhibit.geometry.projection import Projected
from exhibit.geometry.view import ViewState

#: The near plane sits this fraction of the eye distance in front of the eye.
NEAR_FRACTION = 0.01


def sensor_matrix(r: float) -> np.ndarray:
    """4x5 map (p, 1) -> (x, y, z, 1 - r w): the sensor projection in homogeneous coordinates."""
    m = np.zeros((4, 5))
    m[0, 0] = m[1, 1] = m[2, 2] = 1.0
    m[3, 3] = -r
    m[3, 4] = 1.0
    return m


def depth_range(view: ViewState) -> tuple[float, float]:
    """(near, far) as z coordinates of the 3D image: the near plane just in front of the eye (or
    depth_extent towards the viewer for an eye at infinity), the far plane depth_extent behind
    the origin."""
    far = -view.depth_extent
    near = (1.0 - NEAR_FRACTION) / view.eye_r if view.eye_r > 0 else view.depth_extent
    return near, far


def eye_matrix(view: ViewState, aspect: float) -> np.ndarray:
    """4x4 map of the 3D image (X, Y, Z, H) to clip coordinates: zoom, eye perspective, depth,
    and the lens shift that puts ``view.center`` at the middle of the screen."""
    if not (math.isfinite(aspect) and aspect > 0):
        raise ValueError(f"aspect ratio must be positive, got {aspect}")
    r2 = view.eye_r
    near, far = depth_range(view)
    # z_ndc = (alpha z + beta) / (1 - r2 z) is -1 at the near plane and +1 at the far plane.
    alpha = (-2.0 + r2 * (near + far)) / (near - far)
    beta = (1.0 - r2 * far) - alpha * far
    m = np.zeros((4, 4))
    m[0, 0] = 1.0 / (view.half_height * aspect)
    m[1, 1] = 1.0 / view.half_height
    m[2, 2] = alpha
    m[2, 3] = beta
    m[3, 2] = -r2
    m[3, 3] = 1.0
    # The lens shift: ndc -= center / (half extent), i.e. clip -= that times clip w.
    m[0] -= view.center[0] / (view.half_height * aspect) * m[3]
    m[1] -= view.center[1] / view.half_height * m[3]
    return m


def front_plane(view: ViewState) -> np.ndarray:
    """Row acting on (X, Y, Z, H): distance·H - sin(pitch)·Y - cos(pitch)·Z, kept where >= 0.

    With no front plane (distance inf) the row is (0, 0, 0, 1): H >= 0, already required.
    """
    if math.isinf(view.front_distance):
        return np.array([0.0, 0.0, 0.0, 1.0])
    s, c = math.sin(view.front_pitch), math.cos(view.front_pitch)
    return np.array([0.0, -s, -c, view.front_distance])


@dataclass(frozen=True)
class ClipTransform:
    """The pipeline for one view and aspect ratio: what the renderer uploads each frame."""

    #: 4x5: clip = matrix · (p, 1).
    matrix: np.ndarray
    #: 2x5 rows for gl_ClipDistance[0..1]: sensor hyperplane, front clipping plane.
    clip_planes: np.ndarray
    #: 5x5 scene -> view rigid motion; its 4x4 block turns tangents and normals.
    pose: np.ndarray

    @staticmethod
    def _homogeneous(points: ArrayLike) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        if points.shape[-1:] != (4,):
            raise ValueError(f"expected points of R^4 (last axis 4), got shape {points.shape}")
        return np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)

    def clip(self, points: ArrayLike) -> np.ndarray:
        """Clip coordinates (..., 4) of scene points (..., 4)."""
        return self._homogeneous(points) @ self.matrix.T

    def clip_distances(self, points: ArrayLike) -> np.ndarray:
        """gl_ClipDistance values (..., 2); a point survives where all are >= 0."""
        return self._homogeneous(points) @ self.clip_planes.T

    def to_ndc(self, points: ArrayLike) -> Projected:
        """Normalised device coordinates and whether each point is visible (in front of both
        centres, inside both clip planes and inside the view volume)."""
        clip = self.clip(points)
        w = clip[..., 3]
        ok = (w > 0) & np.all(self.clip_distances(points) >= 0, axis=-1)
        safe = np.where(ok, w, 1.0)
        ndc = np.where(ok[..., None], clip[..., :3] / safe[..., None], 0.0)
        ok &= np.all(np.abs(ndc) <= 1.0, axis=-1)
        return Projected(ndc, ok)

    def to_pixels(self, points: ArrayLike, width: int, height: int) -> Projected:
        """Image coordinates (x right, y down, pixel i covers [i, i+1)) and visibility."""
        ndc, ok = self.to_ndc(points)
        x = (ndc[..., 0] + 1.0) * 0.5 * width
        y = (1.0 - ndc[..., 1]) * 0.5 * height
        return Projected(np.stack([x, y], axis=-1), ok)


def clip_transform(view: ViewState, aspect: float = 1.0) -> ClipTransform:
    """Compose pose, sensor and eye into the one 4x5 map (and the two clip planes)."""
    pose = view.pose()
    image = sensor_matrix(view.sensor_r) @ pose  # (p, 1) -> (X, Y, Z, H), 4x5
    matrix = eye_matrix(view, aspect) @ image
    planes = np.stack([image[3], front_plane(view) @ image])
    return ClipTransform(matrix=matrix, clip_planes=planes, pose=pose)
