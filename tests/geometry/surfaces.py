"""Small analytic 2-surfaces in R^4 with exact tangents, for checking the lemmas independently."""

import numpy as np


class PolynomialSurface:
    """X(s, t) = Σ c_ij s^i t^j (i + j <= 3) with random 4D coefficients: generic and smooth."""

    POWERS = [(i, j) for i in range(4) for j in range(4) if i + j <= 3]

    def __init__(self, seed: int):
        rng = np.random.default_rng(seed)
        self.coefficients = rng.normal(scale=0.6, size=(len(self.POWERS), 4))

    def point(self, s, t):
        return sum(c * s**i * t**j for c, (i, j) in zip(self.coefficients, self.POWERS))

    def tangents(self, s, t):
        ds = sum(
            c * i * s ** (i - 1) * t**j
            for c, (i, j) in zip(self.coefficients, self.POWERS)
            if i > 0
        )
        dt = sum(
            c * j * s**i * t ** (j - 1)
            for c, (i, j) in zip(self.coefficients, self.POWERS)
            if j > 0
        )
        return ds, dt


def finite_difference_tangents(function, s, t, h=1e-5):
    """Central differences of function(s, t) in s and t."""
    return (
        (function(s + h, t) - function(s - h, t)) / (2 * h),
        (function(s, t + h) - function(s, t - h)) / (2 * h),
    )


def parallel_error(a, b):
    """Angle (radians, about |sin|) between two lines: 0 when parallel or antiparallel.

    Computed from the unit vectors' difference, which keeps full precision for small angles
    (1 - cos² would lose half the digits)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    chord = min(np.linalg.norm(a - b), np.linalg.norm(a + b))
    return 2 * np.arcsin(min(chord / 2, 1.0))
