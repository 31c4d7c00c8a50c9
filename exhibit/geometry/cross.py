"""The generalised cross product ⊗ of n-1 vectors in R^n (the paper's section 2), and blade norms.

⊗(a, b, c) is the determinant whose first row is the basis (i, j, k, l) and whose other rows are
a, b, c; so ⊗(a, b, c) · d = det[d; a; b; c], it is orthogonal to each argument, and its length is
the (n-1)-volume spanned by them. In R^3 it is the ordinary cross product.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def generalized_cross(*vectors: ArrayLike) -> np.ndarray:
    """⊗ of n-1 vectors in R^n; each argument may carry the same leading batch dimensions.

    Zero (not NaN) when the vectors are linearly dependent.
    """
    if not vectors:
        raise ValueError("generalized_cross needs n-1 vectors in R^n")
    rows = np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in vectors]), axis=-2)
    n = rows.shape[-1]
    if rows.shape[-2] != n - 1:
        raise ValueError(
            f"generalized_cross needs n-1 vectors of R^n: got {rows.shape[-2]} "
            f"vectors of length {n}"
        )
    if n == 2:
        return np.stack([rows[..., 0, 1], -rows[..., 0, 0]], axis=-1)
    # Cofactor expansion along the basis row: component i = (-1)^i det(rows without column i).
    components = [(-1) ** i * np.linalg.det(np.delete(rows, i, axis=-1)) for i in range(n)]
    return np.stack(components, axis=-1)


def cross4(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> np.ndarray:
    """⊗(a, b, c) in R^4, written out: this is the per-vertex work of Lemma 1(b), so it is
    vectorised
    without the general determinant."""
    a, b, c = (np.asarray(v, dtype=float) for v in (a, b, c))
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    cx, cy, cz, cw = np.moveaxis(c, -1, 0)
    # 2x2 minors of the (b, c) rows, shared by the four 3x3 cofactors.
    m_zw = bz * cw - bw * cz
    m_yw = by * cw - bw * cy
    m_yz = by * cz - bz * cy
    m_xw = bx * cw - bw * cx
    m_xz = bx * cz - bz * cx
    m_xy = bx * cy - by * cx
    return np.stack(
        [
            ay * m_zw - az * m_yw + aw * m_yz,
            -(ax * m_zw - az * m_xw + aw * m_xz),
            ax * m_yw - ay * m_xw + aw * m_xy,
            -(ax * m_yz - ay * m_xz + az * m_xy),
        ],
        axis=-1,
    )


def bivector_norm(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """|a ∧ b| = sqrt(|a|²|b|² - (a·b)²): the area spanned by a and b (0 when parallel)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    aa = np.einsum("...i,...i", a, a)
    bb = np.einsum("...i,...i", b, b)
    ab = np.einsum("...i,...i", a, b)
    return np.sqrt(np.maximum(aa * bb - ab * ab, 0.0))
