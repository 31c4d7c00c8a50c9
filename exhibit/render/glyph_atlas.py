"""The HUD's glyph atlas: every glyph (and every text halo) the HUD has shown, rasterised once
into one single-channel texture, so a line of text is a run of quads and a number that changes
costs an instance-buffer write, not a texture (exhibit.render.hud_draw draws them)."""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import moderngl
import numpy as np
from PIL import Image, ImageDraw

from exhibit.render.text import font


@dataclass
class Glyph:
    """Where a glyph sits in the atlas (texels) and how it is placed: its image's left edge is
    ``left`` pixels from the pen position, its top at the line's top."""

    u: int
    v: int
    width: int
    height: int
    left: int


def rasterise_glyph(char: str, style: str, size: int) -> tuple[np.ndarray, int]:
    """One glyph's coverage (uint8, the line's height, one column of margin each side) and its
    image's left edge from the pen position, as Pillow draws it."""
    f = font(style, size)
    ascent, descent = f.getmetrics()
    left, _, right, _ = f.getbbox(char)
    left = min(int(math.floor(left)), 0) - 1
    width = max(int(math.ceil(right)) - left + 1, 1)
    image = Image.new("L", (width, ascent + descent), 0)
    ImageDraw.Draw(image).text((-left, 0), char, font=f, fill=255)
    return np.asarray(image), left


#: The eight directions a halo spreads a glyph in (exhibit.render.hud's text halos).
HALO_DIRECTIONS = ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, 1), (-1, 1), (1, -1))


def halo_steps(reach: int) -> list[int]:
    """The distances a halo of ``reach`` pixels moves its glyph by: half of it and all of it."""
    return sorted({max(1, reach // 2), reach})


class GlyphAtlas:
    """Every glyph the HUD has shown, rasterised once by Pillow at its pixel size into one
    single-channel texture (shelf packing): a line of text is then a run of quads placed at whole
    pixels, drawn with every other atlas text in one instanced call, so a number that changes
    costs a small instance-buffer write instead of a new texture. Glyphs are placed texel for
    pixel (NEAREST), as crisp as whole-line rasterising; monospaced text advances by the font's
    fixed advance, so digits never jitter, and proportional text keeps Pillow's kerning (pen
    positions are the lengths of the line's prefixes). When the atlas fills up it starts again
    empty (the HUD uses a few hundred glyphs, so that is rare); when one line does not fit in an
    empty atlas (text hundreds of pixels tall, an 8192 x 8192 render) it doubles its size."""

    SIZE = 1024

    def __init__(self, ctx: moderngl.Context, size: int = SIZE):
        self.ctx = ctx
        self.size = size
        self.texture = self._new_texture(size)
        self._glyphs: dict[tuple[str, int, str], Glyph] = {}
        self._halos: dict[tuple[str, int, str, int, float], Glyph] = {}
        self._layouts: OrderedDict[tuple[str, str, int], list[tuple[int, Glyph]]] = OrderedDict()
        self.resets = 0
        self._clear()

    def _new_texture(self, size: int) -> moderngl.Texture:
        texture = self.ctx.texture((size, size), 1, dtype="f1")
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        texture.repeat_x = texture.repeat_y = False
        texture.write(np.zeros((size, size), dtype=np.uint8).tobytes())
        return texture

    def _grow(self) -> bool:
        """Double the texture and start again empty; False at the GL's largest texture."""
        limit = int(self.ctx.info.get("GL_MAX_TEXTURE_SIZE", 8192))
        if 2 * self.size > limit:
            return False
        self.texture.release()
        self.size *= 2
        self.texture = self._new_texture(self.size)
        self.resets += 1
        self._clear()
        return True

    def _clear(self) -> None:
        self._glyphs.clear()
        self._halos.clear()
        self._layouts.clear()
        # A 2x2 solid texel block at the origin: panels are glyph quads stretched over it.
        self.texture.write(np.full((2, 2), 255, dtype=np.uint8).tobytes(), viewport=(0, 0, 2, 2))
        self.solid = Glyph(0, 0, 2, 2, 0)
        self._x, self._y, self._shelf = 4, 0, 4

    def glyph(self, char: str, style: str, size: int) -> Glyph:
        key = (style, size, char)
        found = self._glyphs.get(key)
        if found is not None:
            return found
        image, left = rasterise_glyph(char, style, size)
        glyph = self._glyphs[key] = self._place(image, left)
        return glyph

    def halo(self, char: str, style: str, size: int, reach: int, alpha: float) -> Glyph:
        """The dark halo around a glyph as one image, padded by ``reach``: the glyph's coverage
        moved in the eight directions by ``halo_steps(reach)`` pixels and laid over itself with
        ``alpha``, 1 - prod(1 - alpha * coverage), which is what sixteen glyph quads blended
        over each other leave. One quad instead of sixteen: halos were a quarter of the HUD's
        cost on software GL (docs/PERFORMANCE.md)."""
        key = (style, size, char, reach, alpha)
        found = self._halos.get(key)
        if found is not None:
            return found
        image, left = rasterise_glyph(char, style, size)
        coverage = image / 255.0
        h, w = coverage.shape
        clear = np.ones((h + 2 * reach, w + 2 * reach))
        for step in halo_steps(reach):
            for ox, oy in HALO_DIRECTIONS:
                y0, x0 = reach + oy * step, reach + ox * step
                clear[y0 : y0 + h, x0 : x0 + w] *= 1.0 - alpha * coverage
        halo = np.round((1.0 - clear) * 255.0).astype(np.uint8)
        glyph = self._halos[key] = self._place(halo, left - reach)
        return glyph

    def _place(self, image: np.ndarray, left: int) -> Glyph:
        """Shelf-pack one single-channel image into the texture, emptying it when full (the
        caller's layout notices by ``resets``)."""
        height, width = image.shape
        while max(width, height) + 4 > self.size:
            if not self._grow():  # larger than the GL's largest texture: shown as nothing
                return Glyph(0, 0, 0, 0, left)
        if self._x + width + 1 > self.size:
            self._x, self._y, self._shelf = 0, self._y + self._shelf + 1, 0
        if self._y + height > self.size or width > self.size:
            self.resets += 1
            self._clear()
        glyph = Glyph(self._x, self._y, width, height, left)
        self.texture.write(
            np.ascontiguousarray(image).tobytes(),
            viewport=(glyph.u, glyph.v, width, height),
            alignment=1,
        )
        self._x += width + 1
        self._shelf = max(self._shelf, height)
        return glyph

    def halo_layout(
        self, text: str, style: str, size: int, reach: int, alpha: float
    ) -> list[tuple[int, Glyph]] | None:
        """(x offset of the halo image, halo) for each visible character of one line, placed as
        ``layout`` places the glyphs (the halo image starts ``reach`` pixels up and left); None
        when the line's glyphs and halos do not fit in the atlas together (text hundreds of
        pixels tall: the caller moves the glyphs themselves instead)."""
        for attempt in range(4):  # emptied on the way: the earlier halos are gone, again
            resets = self.resets
            out = [
                (dx - reach, self.halo(char, style, size, reach, alpha))
                for (dx, _), char in zip(
                    self.layout(text, style, size), (c for c in text if not c.isspace())
                )
            ]
            if self.resets == resets:
                return out
            if attempt and not self._grow():
                break
        return None

    def layout(self, text: str, style: str, size: int) -> list[tuple[int, Glyph]]:
        """(x offset of the glyph image, glyph) for each visible character of one line."""
        key = (text, style, size)
        found = self._layouts.get(key)
        if found is not None:
            self._layouts.move_to_end(key)
            return found
        f = font(style, size)
        if style == "mono":
            advance = f.getlength("0")
            pens = [i * advance for i in range(len(text))]
        else:
            pens = [f.getlength(text[:i]) for i in range(len(text))]
        for attempt in range(4):
            resets = self.resets
            out = [
                (int(round(pen)) + 1 + glyph.left, glyph)
                for pen, char in zip(pens, text)
                if not char.isspace()
                for glyph in (self.glyph(char, style, size),)
            ]
            if self.resets == resets:
                break
            # The atlas was emptied while laying out: lay out again, in a larger atlas when
            # the line alone filled it; at the GL's largest texture its first glyphs are lost.
            if attempt and not self._grow():
                break
        self._layouts[key] = out
        while len(self._layouts) > 256:
            self._layouts.popitem(last=False)
        return out

    def release(self) -> None:
        self.texture.release()
