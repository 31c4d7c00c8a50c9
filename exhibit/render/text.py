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
    return ImageFont.load_default(size)


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


def text_width(text: str, style: str, size: int) -> float:
    return font(style, size).getlength(text)


def line_height(style: str, size: int) -> int:
    ascent, descent = font(style, size).getmetrics()
    return ascent + descent


def wrap(text: str, style: str, size: int, width: float) -> list[str]:
    """Greedy word wrap to a pixel width."""
    lines, current = [], ""
    for word in text.split():
        trial = f"{current} {word}".strip()
        if current and text_width(trial, style, size) > width:
            lines.append(current)
            current = word
        else:
            current = trial
    if current:
        lines.append(current)
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
