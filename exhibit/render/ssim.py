"""SSIM (Wang, Bovik, Sheikh & Simoncelli 2004) in numpy, to compare antialiased pictures with a
reference: the mean structural similarity of the luma, with the paper's 11x11 Gaussian window
(sigma 1.5) and constants K1 = 0.01, K2 = 0.03 for 8-bit images. 1.0 is identical."""

from __future__ import annotations

import numpy as np


def _gaussian(size: int = 11, sigma: float = 1.5) -> np.ndarray:
    x = np.arange(size) - (size - 1) / 2
    g = np.exp(-x * x / (2 * sigma * sigma))
    return g / g.sum()


def _filter(image: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Separable 'valid' convolution along both axes."""
    k = len(kernel)
    rows = sum(kernel[i] * image[i : image.shape[0] - k + 1 + i] for i in range(k))
    return sum(kernel[i] * rows[:, i : rows.shape[1] - k + 1 + i] for i in range(k))


def luma(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image, dtype=np.float64)
    if image.ndim == 3:
        image = image[..., :3] @ np.array([0.299, 0.587, 0.114])
    return image


def ssim(
    a: np.ndarray, b: np.ndarray, data_range: float = 255.0, mask: np.ndarray | None = None
) -> float:
    """Mean SSIM of two pictures of the same shape ((h, w) grey or (h, w, 3) RGB); with a
    boolean ``mask`` of that (h, w), the mean over the windows centred on its pixels only."""
    values = ssim_map(a, b, data_range)
    if mask is not None:
        values = values[_valid(mask)]
    return float(values.mean()) if values.size else 1.0  # an empty mask: nothing differs


def _valid(mask: np.ndarray) -> np.ndarray:
    """The mask cropped like the 'valid' SSIM map (5 pixels off every side)."""
    return np.asarray(mask, dtype=bool)[5:-5, 5:-5]


def edge_mask(reference: np.ndarray, other: np.ndarray, grow: int = 3) -> np.ndarray:
    """Where two renderings of one scene differ (the antialiased edges), grown by ``grow``
    pixels: SSIM over this mask measures the edges alone, not the flat areas that every
    method leaves alike."""
    diff = np.abs(luma(reference) - luma(other)) > 0.5
    out = diff.copy()
    for _ in range(grow):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def ssim_map(a: np.ndarray, b: np.ndarray, data_range: float = 255.0) -> np.ndarray:
    """The SSIM of each 11x11 window ('valid' positions: 10 pixels smaller each way)."""
    if np.shape(a) != np.shape(b):
        raise ValueError(f"pictures differ in shape: {np.shape(a)} and {np.shape(b)}")
    x, y = luma(a), luma(b)
    if min(x.shape) < 11:
        raise ValueError("pictures must be at least 11 pixels each way")
    g = _gaussian()
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    mx, my = _filter(x, g), _filter(y, g)
    sxx = _filter(x * x, g) - mx * mx
    syy = _filter(y * y, g) - my * my
    sxy = _filter(x * y, g) - mx * my
    num = (2 * mx * my + c1) * (2 * sxy + c2)
    den = (mx * mx + my * my + c1) * (sxx + syy + c2)
    return num / den
