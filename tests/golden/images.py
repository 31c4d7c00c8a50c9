"""Golden-image comparison and the checks computed from a rendered picture.

Comparison is perceptual: SSIM (exhibit.render.ssim, the published formula with its 11x11
Gaussian window) on each colour channel, so a curve that changes colour but not brightness is
still seen; twice: over the whole frame, and as the worst 24x24-pixel tile, so a change in a small
place (one missing curve, one changed word) is not averaged away. Pixel-exact comparison would
fail on any Mesa update (llvmpipe's rasteriser and FXAA move edge pixels by a level or two); the
thresholds sit between such noise and the smallest change that matters (GOLDEN_SSIM, TILE_SSIM).

The checks read the picture itself, with the layout only to say where to look:
- no surface pixel under a HUD panel nor in the screen's margin (the surfaces drawn alone, same
  view, on black);
- every marker label on the screen, and its ink where its rectangle says;
- the caption's capitals at least 1/45 of the screen height, measured on the glyph's pixels.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from PIL import Image

from exhibit.render.layout import HudLayout, Rect
from exhibit.render.options import RenderOptions
from exhibit.render.ssim import luma, ssim, ssim_map

GOLDEN_DIR = Path(__file__).resolve().parent
#: The least SSIM (the lowest channel's) of a whole frame against its golden image, and of its
#: worst 24x24 tile. Measured at 480x270 on Figures 6, 11 and 15 (tests/golden/README.md):
#: the same frame again gives 1.0 and 1.0; Mesa-like noise (every edge pixel off by up to 6
#: levels, every pixel by 1) 0.990 and 0.973 at worst (0.9498 in the tile of Figure 15 drawn
#: z up, where the pipe's dense green grid lies on the dark background: TILE_SSIM 0.94); θ1
#: turned by 0.25 degrees 0.985-0.996
#: and 0.84-0.87; the zoom off by 1 % 0.88-0.98 and 0.12-0.48; the silhouettes gone 0.988-0.993
#: and 0.60-0.81; the intersection curves gone 0.997 and 0.80-0.82; one word of the caption
#: changed 0.989-0.992 and 0.60-0.66. The tile catches what the whole frame averages away.
GOLDEN_SSIM = 0.985
TILE_SSIM = 0.94
TILE = 24
#: The surfaces alone, on black, for the panel check.
SURFACES_ONLY = RenderOptions(
    hud=False,
    curves=False,
    silhouettes=False,
    pinch_points=False,
    intersections=False,
    background=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
)


def load(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))


def channel_ssim(a: np.ndarray, b: np.ndarray) -> float:
    """The lowest SSIM of the three colour channels."""
    return min(ssim(a[..., c].astype(float), b[..., c].astype(float)) for c in range(3))


def worst_tile(a: np.ndarray, b: np.ndarray, tile: int = TILE) -> tuple[float, int, int]:
    """The lowest mean SSIM of a ``tile`` x ``tile`` tile of any channel, and the tile's
    top-left corner (x, y) in the picture."""
    worst = (1.0, 0, 0)
    for c in range(3):
        values = ssim_map(a[..., c].astype(float), b[..., c].astype(float))  # 5 px in per side
        h, w = values.shape
        for y in range(0, max(1, h - tile // 2), tile):
            for x in range(0, max(1, w - tile // 2), tile):
                score = float(values[y : y + tile, x : x + tile].mean())
                if score < worst[0]:
                    worst = (score, x + 5, y + 5)
    return worst


def compare(name: str, image: np.ndarray, update: bool, out: Path) -> None:
    """``image`` against tests/golden/``name``.png, or written there with ``update``. On a
    mismatch the picture and a difference image go to ``out`` and the message names them."""
    path = GOLDEN_DIR / f"{name}.png"
    if update:
        Image.fromarray(image).save(path, optimize=True)
        return
    if not path.exists():
        raise AssertionError(
            f"no golden image {path}: render it on purpose with "
            "`pytest tests/golden -m slow --update-golden`, then look at it"
        )
    golden = load(path)
    problems = []
    if golden.shape != image.shape:
        problems.append(
            f"size {image.shape[1]}x{image.shape[0]}, the golden image is "
            f"{golden.shape[1]}x{golden.shape[0]}"
        )
    else:
        whole = channel_ssim(image, golden)
        if whole < GOLDEN_SSIM:
            problems.append(f"SSIM {whole:.4f} < {GOLDEN_SSIM}")
        tile, x, y = worst_tile(image, golden)
        if tile < TILE_SSIM:
            problems.append(
                f"SSIM {tile:.4f} < {TILE_SSIM} in the {TILE}x{TILE} tile at ({x}, {y})"
            )
    if problems:
        out.mkdir(parents=True, exist_ok=True)
        Image.fromarray(image).save(out / f"{name}.png")
        if golden.shape == image.shape:
            diff = np.abs(image.astype(int) - golden.astype(int)).max(axis=-1)
            Image.fromarray(np.clip(diff * 4, 0, 255).astype(np.uint8)).save(
                out / f"{name}-diff.png"
            )
        raise AssertionError(
            f"{name}: " + "; ".join(problems) + f" (this run: {out / name}.png,"
            f" difference x4: {out / name}-diff.png; if the change is meant, "
            "`pytest tests/golden -m slow --update-golden` and look)"
        )


def surface_pixels_under_panels(surfaces: np.ndarray, panels: list[Rect]) -> list[str]:
    """Where a surface shows under a panel, one line per panel (none: empty list)."""
    lit = surfaces.max(axis=-1) > 8
    out = []
    for rect in panels:
        y0, y1 = max(0, int(rect.y0)), max(0, math.ceil(rect.y1))
        x0, x1 = max(0, int(rect.x0)), max(0, math.ceil(rect.x1))
        n = int(lit[y0:y1, x0:x1].sum())
        if n:
            out.append(f"{n} surface pixels under the panel {tuple(round(v) for v in rect)}")
    return out


def surface_pixels_in_the_margin(surfaces: np.ndarray, margin: float) -> list[str]:
    """Where a surface reaches into the screen's margin (2 px of it are allowed for rasterising
    and antialiasing): the free area ends ``margin`` pixels in from every edge."""
    ys, xs = np.nonzero(surfaces.max(axis=-1) > 8)
    if not xs.size:
        return ["no surface drawn"]
    height, width = surfaces.shape[:2]
    edge = margin - 2
    box = (int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max()))
    inside = box[0] >= edge and box[1] >= edge and box[2] < width - edge and box[3] < height - edge
    return (
        []
        if inside
        else [
            f"the surfaces span {box}, into the {margin:g} px margin of the {width}x{height} screen"
        ]
    )


def label_problems(image: np.ndarray, labels, color) -> list[str]:
    """Each marker label inside the screen with its ink (the marker's colour) where its
    rectangle says; one line per problem."""
    height, width = image.shape[:2]
    color = np.asarray(color, dtype=float) * 255
    out = []
    for text, rect, _, _ in labels:
        if not (rect.x0 >= 0 and rect.x1 <= width and rect.y0 >= 0 and rect.y1 <= height):
            out.append(
                f"label {text!r} at {tuple(round(v) for v in rect)} is not inside the "
                f"{width}x{height} screen"
            )
            continue
        box = image[int(rect.y0) : math.ceil(rect.y1), int(rect.x0) : math.ceil(rect.x1)]
        ink = (np.abs(box.astype(float) - color).max(axis=-1) < 40).mean()
        if ink < 0.05:
            out.append(f"label {text!r}: only {ink:.1%} of its rectangle is in its colour")
    return out


def caption_cap_height(image: np.ndarray, layout: HudLayout, drift: tuple[float, float]) -> int:
    """The height in pixels of the first glyph of the caption's first line (a capital: the
    caller checks the text), measured on the picture: the ink brighter than halfway between
    the panel and the text."""
    from exhibit.render.text import line_height

    block = layout.title_block
    assert block is not None and layout.caption_lines, "no caption drawn"
    dx, dy = drift
    top = (
        round(block.y0 + dy)
        + layout.pad
        + sum(line_height("bold", layout.title_px) for _ in layout.title_lines)
    )
    left = round(block.x0 + dx) + layout.pad
    band = luma(
        image[top : top + line_height("sans", layout.body_px), left - 1 : left + 3 * layout.body_px]
    )
    panel, ink = np.percentile(band, 5), band.max()
    on = band > (panel + ink) / 2
    columns = np.nonzero(on.any(axis=0))[0]
    assert columns.size, "no caption ink where the layout puts the caption"
    first = [columns[0]]
    for c in columns[1:]:
        if c != first[-1] + 1:
            break
        first.append(c)
    rows = np.nonzero(on[:, first[0] : first[-1] + 1].any(axis=1))[0]
    return int(rows.max() - rows.min() + 1)


def min_cap_height(height: int) -> int:
    """The least caption cap height the exhibit allows on a screen ``height`` pixels tall
    (1/45 of it; a pixel less for rounding the glyph's anti-aliased edge)."""
    return math.floor(height / 45)
