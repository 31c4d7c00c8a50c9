"""ViewState: everything that decides what the visitor sees, as one immutable value.

Readings of the six Euler angles (the paper, section 3.2, uses one set of angles both ways):

* ``"screen"`` (default): the angles orient the screen's frame (x6, y6, z6, w6) in the world; the
  sensor lies along w6, the eye along z6. θ1, θ2, θ3 are the sensor's polar coordinates in R^4 —
  they change the 4D -> 3D shadow; θ4, θ5 are the eye's azimuth and incidence and θ6 the twist —
  they only turn the 3D image. View coordinates are Aᵀ · world.
* ``"object"``: the angles orient the object (world = A · body) under a fixed sensor and eye.
  View coordinates are A · body.

The exhibit uses the screen reading by default: it is the paper's own interface, and it gives
every knob one visible job (three knobs move the 4D viewpoint, three orbit and twist the picture),
which a visitor can learn by turning them. The eye orbit (eye_azimuth, eye_incidence, twist) is a
further 3D rotation of the image after the sensor projection, in the same convention as θ4, θ5,
θ6; it lets a scene or the renderer's --eye option place the eye without touching the angles.

Distances are stored as reciprocals (sensor_r = 1/d, eye_r = 1/d_eye; 0 = at infinity) so an
animation or a knob can sweep smoothly through infinity. The eye's zoom is ``half_height``, the
visible half-height of the plane through the origin; the field of view follows from it and eye_r,
so moving the eye keeps the object's size at the origin fixed (like the sensor sweep, continuous
through an orthographic eye).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any


import numpy as np
from numpy.typing import ArrayLike

from exhibit.geometry.rotations import euler_to_matrix

READINGS = ("screen", "object")
DEFAULT_LIGHTS = ((0.35, 0.55, 1.0), (-0.6, -0.35, 0.45))


def _floats(value, length: int, name: str) -> tuple[float, ...]:
    try:
        items = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {length} numbers, got {value!r}") from None
    if len(items) != length:
        raise ValueError(f"{name} must be {length} numbers, got {len(items)}")
    if not all(math.isfinite(v) for v in items):
        raise ValueError(f"{name} must be finite numbers, got {items}")
    return items


@dataclass(frozen=True)
class ViewState:
    """Orientation, projection centres, clipping and lights. Angles in radians."""

    #: θ1..θ6, the paper's 4D Euler angles.
    angles: tuple[float, ...] = (0.0,) * 6
    #: How the angles are read: "screen" (default) or "object"; see the module docstring.
    reading: str = "screen"
    #: 1 / sensor distance; 0 = sensor at infinity (orthographic 4D -> 3D).
    sensor_r: float = 0.0
    #: Translation in view coordinates after the rotation (e.g. the hypersphere moved by +1 in w).
    offset: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
    #: The eye's 3D orbit after the sensor projection: azimuth, incidence, twist (like θ4, θ5, θ6).
    eye_azimuth: float = 0.0
    eye_incidence: float = 0.0
    twist: float = 0.0
    #: 1 / eye distance; 0 = eye at infinity (orthographic 3D -> 2D).
    eye_r: float = 1.0 / 8.0
    #: Visible half-height of the picture at the origin, in scene units.
    half_height: float = 2.0
    #: The point of the 3D image's plane through the origin (scene units, x right, y up) shown
    #: at the centre of the screen: a lens shift, moving the whole picture without changing its
    #: perspective, so framing can place it beside the text panels (exhibit.geometry.framing).
    center: tuple[float, float] = (0.0, 0.0)
    #: The front clipping plane: distance from the origin towards the eye (inf = off) and pitch
    #: (radians, tilting it about the screen's x-axis, as in Figure 8).
    front_distance: float = math.inf
    front_pitch: float = 0.0
    #: Directions towards the lights in eye coordinates (x right, y up, z towards the viewer).
    lights: tuple[tuple[float, float, float], ...] = field(default=DEFAULT_LIGHTS)
    #: Depth of the visible region in scene units (the far plane lies this far behind the origin).
    depth_extent: float = 100.0
    #: The slice S ∩ {x_axis = at} drawn glowing on the surfaces (axis 0..3 of the scene's own
    #: coordinates, e.g. 3 = the collision's t; None: no slice).
    slice_axis: int | None = None
    slice_at: float = 0.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "angles", _floats(self.angles, 6, "angles"))
        set_(self, "offset", _floats(self.offset, 4, "offset"))
        set_(self, "center", _floats(self.center, 2, "center"))
        if self.reading not in READINGS:
            raise ValueError(f"reading must be one of {READINGS}, got {self.reading!r}")
        for name in ("sensor_r", "eye_r"):
            value = float(getattr(self, name))
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be >= 0 (1/distance, 0 = at infinity), got {value}")
            set_(self, name, value)
        for name in ("eye_azimuth", "eye_incidence", "twist", "front_pitch"):
            value = float(getattr(self, name))
            if not math.isfinite(value):
                raise ValueError(f"{name} must be a finite angle in radians, got {value}")
            set_(self, name, value)
        for name in ("half_height", "depth_extent"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
            set_(self, name, value)
        if self.slice_axis is not None:
            if self.slice_axis not in (0, 1, 2, 3) or isinstance(self.slice_axis, bool):
                raise ValueError(f"slice_axis must be 0..3 or None, got {self.slice_axis!r}")
            set_(self, "slice_axis", int(self.slice_axis))
        slice_at = float(self.slice_at)
        if not math.isfinite(slice_at):
            raise ValueError(f"slice_at must be a finite number, got {slice_at}")
        set_(self, "slice_at", slice_at)
        front = float(self.front_distance)
        if math.isnan(front):
            raise ValueError("front_distance must be a number or inf (no front clipping)")
        if self.eye_r > 0 and math.isfinite(front) and front >= 1.0 / self.eye_r:
            raise ValueError(
                f"front_distance {front} must be less than the eye distance {1.0 / self.eye_r}"
            )
        set_(self, "front_distance", front)
        lights = []
        for index, light in enumerate(self.lights):
            direction = np.array(_floats(light, 3, f"lights[{index}]"))
            length = float(np.linalg.norm(direction))
            if length == 0:
                raise ValueError(f"lights[{index}] must be a nonzero direction")
            lights.append(tuple(float(v) for v in direction / length))
        set_(self, "lights", tuple(lights))

    # ------------------------------------------------------------------ derived quantities

    @property
    def sensor_distance(self) -> float:
        return math.inf if self.sensor_r == 0 else 1.0 / self.sensor_r

    @property
    def eye_distance(self) -> float:
        return math.inf if self.eye_r == 0 else 1.0 / self.eye_r

    @property
    def field_of_view(self) -> float:
        """Vertical field of view in degrees (0 for an eye at infinity)."""
        return math.degrees(2.0 * math.atan(self.half_height * self.eye_r))

    def replace(self, **changes: Any) -> ViewState:
        """A copy with ``changes`` to its fields, checked by __post_init__. Any: callers build
        the changes as dicts of several fields' values (timelines/model.py, commands/render.py),
        which a TypedDict of the fields would refuse."""
        return dataclasses.replace(self, **changes)

    def with_sensor_distance(self, distance: float) -> ViewState:
        """Place the sensor at ``distance`` (math.inf for orthographic)."""
        return self.replace(sensor_r=_reciprocal(distance, "sensor distance"))

    def with_eye(self, distance: float, field_of_view: float | None = None) -> ViewState:
        """Place the eye at ``distance``; with a field of view (degrees) also set the zoom."""
        eye_r = _reciprocal(distance, "eye distance")
        if field_of_view is None:
            return self.replace(eye_r=eye_r)
        if not 0 < field_of_view < 180 or eye_r == 0:
            raise ValueError("field of view needs a finite eye distance and 0 < degrees < 180")
        half_height = math.tan(math.radians(field_of_view) / 2.0) / eye_r
        return self.replace(eye_r=eye_r, half_height=half_height)

    def orientation(self) -> np.ndarray:
        """The direction cosine matrix A of the six angles (world = A · body)."""
        return euler_to_matrix(self.angles)

    def rotation(self) -> np.ndarray:
        """4x4 rotation from scene (world/body) coordinates to view coordinates, eye orbit
        included."""
        a = self.orientation()
        base = a.T if self.reading == "screen" else a
        eye = np.eye(4)
        eye[:3, :3] = euler_to_matrix([self.eye_azimuth, self.eye_incidence, self.twist])
        return eye.T @ base

    def pose(self) -> np.ndarray:
        """5x5 homogeneous rigid motion: view = rotation · p + offset."""
        pose = np.eye(5)
        pose[:4, :4] = self.rotation()
        pose[:4, 4] = self.offset
        return pose

    def to_view(self, points: ArrayLike) -> np.ndarray:
        """Scene points (..., 4) in view coordinates."""
        points = np.asarray(points, dtype=float)
        return points @ self.rotation().T + np.asarray(self.offset)

    def vectors_to_view(self, vectors: ArrayLike) -> np.ndarray:
        """Scene directions (tangents, normals) in view coordinates: rotated, not translated."""
        return np.asarray(vectors, dtype=float) @ self.rotation().T

    def sensor_direction(self) -> np.ndarray:
        """Unit vector, in scene coordinates, from the origin towards the sensor."""
        return self.rotation()[3].copy()

    def eye_direction(self) -> np.ndarray:
        """Unit vector, in scene coordinates, from the origin towards the eye."""
        return self.rotation()[2].copy()


def _reciprocal(distance: float, name: str) -> float:
    distance = float(distance)
    if math.isnan(distance) or distance <= 0:
        raise ValueError(f"{name} must be positive (or inf), got {distance}")
    return 0.0 if math.isinf(distance) else 1.0 / distance
