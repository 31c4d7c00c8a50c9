"""Crisp HUD text: each string is rasterised by Pillow at the size it is shown, so one texel lands
on one pixel at any resolution; textures are cached by (string, font) and the least recently
used are released, so steady numbers cost nothing and changing ones one small upload."""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import moderngl
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from exhibit.render.context import RenderUnavailable

#: Fonts with the Greek and math glyphs the HUD needs (θ, ∞); Debian: fonts-dejavu-core.
FONT_DIRS = (Path("/usr/share/fonts/truetype/dejavu"), Path("/usr/share/fonts/dejavu"))
FONT_FILES = {"sans": "DejaVuSans.ttf", "bold": "DejaVuSans-Bold.ttf", "mono": "DejaVuSansMono.ttf"}


@lru_cache(maxsize=64)
def font(style: str, size: int) -> ImageFont.FreeTypeFont:
    """DejaVu when installed, else Pillow's bundled scalable font (Latin only)."""
    for folder in FONT_DIRS:
        path = folder / FONT_FILES[style]
        if path.exists():
            return ImageFont.truetype(str(path), size)
    default = ImageFont.load_default(size)
    if not isinstance(default, ImageFont.FreeTypeFont):  # a Pillow built without FreeType
        raise RenderUnavailable(
            "no scalable font: install fonts-dejavu-core, or a Pillow with FreeType"
        )
    return default


@lru_cache(maxsize=1)
def has_greek() -> bool:
    return any((folder / FONT_FILES["sans"]).exists() for folder in FONT_DIRS)


def rasterise(text: str, style: str, size: int) -> np.ndarray:
    """(h, w) uint8 coverage of one line of text, top row first."""
    f = font(style, size)
    ascent, descent = f.getmetrics()
    width = max(int(math.ceil(f.getlength(text))) + 2, 1)
    image = Image.new("L", (width, ascent + descent), 0)
    ImageDraw.Draw(image).text((1, 0), text, font=f, fill=255)
    return np.asarray(image)


@lru_cache(maxsize=4096)
def text_width(text: str, style: str, size: int) -> float:
    """Advance width in pixels; cached, since the HUD measures the same labels every frame."""
    return font(style, size).getlength(text)


def line_height(style: str, size: int) -> int:
    ascent, descent = font(style, size).getmetrics()
    return ascent + descent


#: Dashes that join two clauses: a line never starts with one (it would read as a list item
#: or a minus sign), so each stays on the line of the word before it.
DASHES = ("–", "—", "-")


def units(text: str) -> list[str]:
    """The pieces a line may break between: words, with a dash that follows a space ("a – b",
    "a - b", "a —b") glued to the word before it."""
    out: list[str] = []
    for word in text.split():
        if out and word.startswith(DASHES) and (word[0] != "-" or not word.strip("-")):
            out[-1] = f"{out[-1]} {word}"
        else:
            out.append(word)
    return out


def split_word(word: str, style: str, size: int, width: float) -> list[str]:
    """``word`` broken by characters into pieces no wider than ``width`` (at least one
    character each): a word too long for any line (a URL, a 2,000-character mistake) is
    wrapped visibly instead of making a text wider than the screen or than GL can hold."""
    if text_width(word, style, size) <= width:
        return [word]
    pieces = []
    while word:
        low, high = 1, len(word)  # the longest prefix that fits, by bisection
        while low < high:
            middle = (low + high + 1) // 2
            if text_width(word[:middle], style, size) <= width:
                low = middle
            else:
                high = middle - 1
        pieces.append(word[:low])
        word = word[low:]
    return pieces


def fitted_units(text: str, style: str, size: int, width: float) -> list[str]:
    """:func:`units`, each no wider than ``width`` (an over-long one broken by characters)."""
    return [piece for unit in units(text) for piece in split_word(unit, style, size, width)]


def ellipsize(text: str, style: str, size: int, width: float) -> str:
    """``text`` ending in "…" (shortened as needed) within ``width``: a line cut short."""
    text = text.rstrip()
    while text and text_width(text + "…", style, size) > width:
        text = text[:-1].rstrip()
    return text + "…"


def wrap(text: str, style: str, size: int, width: float, break_words: bool = False) -> list[str]:
    """Greedy word wrap to a pixel width, never starting a line with a dash; with
    ``break_words`` a word wider than the width is broken by characters (else it overhangs)."""
    lines, current = [], ""
    for unit in fitted_units(text, style, size, width) if break_words else units(text):
        trial = f"{current} {unit}".strip()
        if current and text_width(trial, style, size) > width:
            lines.append(current)
            current = unit
        else:
            current = trial
    if current:
        lines.append(current)
    return lines


def wrap_balanced(
    text: str, style: str, size: int, width: float, break_words: bool = False
) -> list[str]:
    """Word wrap to a pixel width in as few lines as greedy wrapping needs, with the lines as
    even as possible and never one word alone on the last line (an orphan reads as an
    afterthought, and a ragged panel wastes the screen the picture needs).

    The narrowest width that still gives the greedy line count is found by bisection; wrapping
    to it evens the lines. A last line of one word then takes the previous line's last word
    when that still fits the width."""
    lines = wrap(text, style, size, width, break_words)
    if len(lines) < 2:
        return lines
    pieces = fitted_units(text, style, size, width) if break_words else units(text)
    low, high = max(text_width(u, style, size) for u in pieces), float(width)
    for _ in range(14):
        middle = 0.5 * (low + high)
        if len(wrap(text, style, size, middle, break_words)) <= len(lines):
            high = middle
        else:
            low = middle
    lines = wrap(text, style, size, high, break_words)
    if len(units(lines[-1])) == 1 and len(units(lines[-2])) >= 3:
        *head, moved = units(lines[-2])
        candidate = f"{moved} {lines[-1]}"
        if text_width(candidate, style, size) <= width:
            lines[-2:] = [" ".join(head), candidate]
    return lines


@dataclass
class TextTexture:
    texture: moderngl.Texture
    width: int
    height: int


class TextCache:
    def __init__(self, ctx: moderngl.Context, capacity: int = 192):
        self.ctx = ctx
        self.capacity = capacity
        self._items: OrderedDict[tuple[str, str, int], TextTexture] = OrderedDict()
        white = np.full((1, 1), 255, dtype=np.uint8)
        self.white = ctx.texture((1, 1), 1, white.tobytes())

    def get(self, text: str, style: str, size: int) -> TextTexture:
        key = (text, style, size)
        item = self._items.get(key)
        if item is not None:
            self._items.move_to_end(key)
            return item
        pixels = rasterise(text, style, size)
        h, w = pixels.shape
        texture = self.ctx.texture((w, h), 1, np.ascontiguousarray(pixels).tobytes(), alignment=1)
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        texture.repeat_x = texture.repeat_y = False
        item = TextTexture(texture, w, h)
        self._items[key] = item
        while len(self._items) > self.capacity:
            _, old = self._items.popitem(last=False)
            old.texture.release()
        return item

    def release(self) -> None:
        for item in self._items.values():
            item.texture.release()
        self._items.clear()
        self.white.release()


# ---------------------------------------------------------------------- cached blocks and glyphs


def block_image(
    lines: list[tuple[str, str, int, tuple]], pad: int, panel: tuple[float, float, float, float]
) -> np.ndarray:
    """A text panel as one premultiplied RGBA image (h, w, 4) uint8, top row first: the panel
    colour under every line's coverage in its own colour, composited exactly as drawing the panel
    and then each line with "over" blending would. ``lines``: (text, style, size, rgba)."""
    width = int(math.ceil(max(text_width(t, s, px) for t, s, px, _ in lines))) + 2 * pad
    height = sum(line_height(s, px) for _, s, px, _ in lines) + 2 * pad
    color = np.zeros((height, width, 3), dtype=np.float32)
    alpha = np.full((height, width), float(panel[3]), dtype=np.float32)
    color[:] = np.asarray(panel[:3], dtype=np.float32) * panel[3]
    y = pad
    for text, style, px, rgba in lines:
        cover = rasterise(text, style, px).astype(np.float32) / 255.0 * float(rgba[3])
        h, w = cover.shape
        w = min(w, width - pad)
        cover = cover[:, :w]
        region = (slice(y, y + h), slice(pad, pad + w))
        color[region] = np.asarray(rgba[:3], dtype=np.float32) * cover[..., None] + color[
            region
        ] * (1.0 - cover[..., None])
        alpha[region] = cover + alpha[region] * (1.0 - cover)
        y += line_height(style, px)
    out = np.concatenate([color, alpha[..., None]], axis=-1)
    return np.clip(np.rint(out * 255.0), 0, 255).astype(np.uint8)
