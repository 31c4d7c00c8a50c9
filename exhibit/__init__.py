"""4D surface exhibit: 2-surfaces in R^4 polygonized once, rotated by the six 4D Euler angles and
projected 4D -> 3D (sensor) -> 2D (eye), after Hoffmann & Zhou, "Visualization of Surfaces in
Four-Dimensional Space"."""

__version__ = "0.1.0"
