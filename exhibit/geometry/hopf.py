"""The Hopf map S^3 -> S^2 and its tori (paper, section 4.1): latitude and longitude on S^3.

h(x, y, z, w) = (2(xy + zw), 2(xw - yz), (x² + z²) - (y² + w²)). The preimage of the latitude
Z = a is the torus x² + z² = (1 + a)/2, y² + w² = (1 - a)/2; of a pole (a = ±1), a great circle.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def hopf_map(points: ArrayLike) -> np.ndarray:
    """h: S^3 -> S^2 applied to points (..., 4)."""
    x, y, z, w = np.moveaxis(np.asarray(points, dtype=float), -1, 0)
    return np.stack(
        [2 * (x * y + z * w), 2 * (x * w - y * z), (x * x + z * z) - (y * y + w * w)], axis=-1
    )


def torus_radii(latitude: float) -> tuple[float, float]:
    """Radii (of the xz circle, of the yw circle) of the torus over latitude Z = a, |a| <= 1."""
    if not -1.0 <= latitude <= 1.0:
        raise ValueError(f"latitude must lie in [-1, 1], got {latitude}")
    return float(np.sqrt((1 + latitude) / 2)), float(np.sqrt((1 - latitude) / 2))


def hopf_torus(latitude: float, alpha: ArrayLike, beta: ArrayLike) -> np.ndarray:
    """Points of the torus over Z = latitude at angles alpha (xz circle) and beta (yw circle).

    Returns shape broadcast(alpha, beta) + (4,). A pole (latitude ±1) gives its fibre circle.
    """
    r_xz, r_yw = torus_radii(latitude)
    alpha, beta = np.broadcast_arrays(np.asarray(alpha, float), np.asarray(beta, float))
    return np.stack(
        [r_xz * np.cos(alpha), r_yw * np.cos(beta), r_xz * np.sin(alpha), r_yw * np.sin(beta)],
        axis=-1,
    )


def hopf_torus_tangents(
    latitude: float, alpha: ArrayLike, beta: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """∂/∂alpha and ∂/∂beta of hopf_torus: the tangents Lemma 1(b) needs."""
    r_xz, r_yw = torus_radii(latitude)
    alpha, beta = np.broadcast_arrays(np.asarray(alpha, float), np.asarray(beta, float))
    zero = np.zeros_like(alpha)
    t_alpha = np.stack([-r_xz * np.sin(alpha), zero, r_xz * np.cos(alpha), zero], axis=-1)
    t_beta = np.stack([zero, -r_yw * np.sin(beta), zero, r_yw * np.cos(beta)], axis=-1)
    return t_alpha, t_beta
