"""What the HUD, the inset's frame and the notice screen draw with: text and quads in pixels from
the top-left, over the current framebuffer at the screen's full resolution.

Instanced quads from the glyph atlas (glyphs.glsl: glyphs and solid panels; RGBA_TEXTURE: an
image such as the cached title block or the inset's picture), 2D capsules (overlay.glsl: the
gizmo, leader lines, discs; its DIAMOND variant: the first-contact marker) and a line of text
as its own texture (text.glsl: the notice screen). Kept apart from the picture's passes: they
never touch the 4D scene.
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from exhibit.render import shaders
from exhibit.render.passes.shared import BLEND_OVER, BLEND_PREMULTIPLIED
from exhibit.render.glyph_atlas import GlyphAtlas
from exhibit.render.text import TextCache, line_height, text_width

OVERLAY_FLOATS = 9  # a (2), b (2), rgba (4), width (1)
GLYPH_FLOATS = 12  # rect (4), texel rect (4), rgba (4)

Point = tuple[float, float]
Rgba = Sequence[float]
#: A capsule of the overlay: (a, b, rgba, width), in pixels from the top-left.
Capsule = tuple[Point, Point, Rgba, float]
Viewport = tuple[float, float]


class HudDrawing:
    """Owns the HUD's programs, its instance buffers, the glyph atlas and the text cache."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        p = shaders.program
        self.programs = {
            "overlay": p(ctx, "overlay.glsl"),
            "diamond": p(ctx, "overlay.glsl", ("DIAMOND",)),
            "text": p(ctx, "text.glsl"),
            "glyphs": p(ctx, "glyphs.glsl"),
            "image": p(ctx, "glyphs.glsl", ("RGBA_TEXTURE",)),
        }
        self._text_vao = ctx.vertex_array(self.programs["text"], [])
        self._overlay_buffer = ctx.buffer(reserve=64 * OVERLAY_FLOATS * 4, dynamic=True)
        self._overlay_vaos = {
            name: ctx.vertex_array(
                self.programs[name],
                [(self._overlay_buffer, "2f 2f 4f 1f/i", "in_a", "in_b", "in_color", "in_width")],
            )
            for name in ("overlay", "diamond")
        }
        self._glyph_buffer = ctx.buffer(reserve=256 * GLYPH_FLOATS * 4, dynamic=True)
        self._glyph_vaos = {
            name: ctx.vertex_array(
                self.programs[name],
                [(self._glyph_buffer, "4f 4f 4f/i", "in_rect", "in_uv", "in_color")],
            )
            for name in ("glyphs", "image")
        }
        self.text = TextCache(ctx)
        self.atlas = GlyphAtlas(ctx)

    def notice(
        self, lines: list[str], size: tuple[int, int], drift: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        """Lines of text centred on a dark screen, into the current framebuffer: what the kiosk
        shows when it has nothing else, so the screen says what is wrong instead of staying
        black. ``drift`` moves the text (burn-in care: it may stay up for weeks)."""
        ctx, (width, height) = self.ctx, size
        ctx.viewport = (0, 0, width, height)
        ctx.fbo.clear(0.06, 0.06, 0.08, 1.0)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        px = max(10, round(0.03 * height))
        step = line_height("sans", px)
        y = (height - step * len(lines)) / 2 + drift[1]
        for line in lines:
            x = (width - text_width(line, "sans", px)) / 2 + drift[0]
            self.text_line(
                line, "sans", px, x, y, (0.85, 0.85, 0.82, 1.0), (float(width), float(height))
            )
            y += step
        ctx.disable(moderngl.BLEND)

    def text_line(
        self, text: str, style: str, size: int, x: float, y: float, color: Rgba, viewport: Viewport
    ) -> tuple[int, int]:
        """Draw text with its top-left corner at (x, y) in pixels from the top-left, as its own
        texture (the notice screen; the HUD uses the glyph atlas); returns its size."""
        if not text:
            return 0, 0
        item = self.text.get(text, style, size)
        x, y = round(x), round(y)
        prog = self.programs["text"]
        item.texture.use(0)
        prog["u_texture"] = 0
        prog["u_viewport"] = viewport
        prog["u_rect"] = (x, viewport[1] - y - item.height, item.width, item.height)
        prog["u_color"] = tuple(color)
        self._text_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        return item.width, item.height

    def overlay(self, items: Sequence[Capsule], viewport: Viewport, shape: str = "overlay") -> None:
        """Draw 2D capsules (a, b, rgba, width) given in pixels from the top-left; ``shape``
        "diamond": each a filled diamond at a, ``width`` from tip to tip."""
        if not items:
            return
        rows = np.array(
            [
                (ax, viewport[1] - ay, bx, viewport[1] - by, *rgba, width)
                for (ax, ay), (bx, by), rgba, width in items
            ],
            dtype=np.float32,
        )
        data = rows.tobytes()
        if len(data) > self._overlay_buffer.size:
            self._overlay_buffer.orphan(len(data))
        self._overlay_buffer.write(data)
        prog = self.programs[shape]
        prog["u_viewport"] = viewport
        prog["u_pass"] = 1
        self.ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
        self._overlay_vaos[shape].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=len(rows))

    def quads(
        self,
        program: str,
        texture: moderngl.Texture,
        texture_size: tuple[float, float],
        rows: list[tuple],
        viewport: Viewport,
    ) -> None:
        """Instanced quads (x, y, w, h, u, v, tw, th, r, g, b, a) with ``program`` ("glyphs":
        from the atlas; "image": a whole RGBA texture), premultiplied blending."""
        if not rows:
            return
        data = np.asarray(rows, dtype=np.float32).tobytes()
        if len(data) > self._glyph_buffer.size:
            self._glyph_buffer.orphan(max(len(data), 2 * self._glyph_buffer.size))
        self._glyph_buffer.write(data)
        prog = self.programs[program]
        texture.use(0)
        prog["u_texture"] = 0
        prog["u_viewport"] = viewport
        prog["u_texture_size"] = tuple(float(v) for v in texture_size)
        self.ctx.blend_func = BLEND_PREMULTIPLIED
        self._glyph_vaos[program].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=len(rows))

    def atlas_quads(self, rows: list[tuple], viewport: Viewport) -> None:
        """Glyphs and panels from the atlas (glyph_rows, panel_row)."""
        self.quads("glyphs", self.atlas.texture, (self.atlas.size, self.atlas.size), rows, viewport)

    def glyph_rows(
        self, text: str, style: str, px: int, x: float, y: float, color: Rgba, rows: list
    ) -> tuple[int, int, int, int]:
        """Instances for one line of text whose top-left corner is at (x, y); returns the box
        its glyph images cover, (x0, y0, x1, y1) in pixels (empty at (x, y) for no glyphs)."""
        x, y = round(x), round(y)
        x0 = x1 = x
        y1 = y
        for i, (dx, g) in enumerate(self.atlas.layout(text, style, px)):
            rows.append((x + dx, y, g.width, g.height, g.u, g.v, g.width, g.height, *color))
            x0 = x + dx if i == 0 else min(x0, x + dx)
            x1, y1 = max(x1, x + dx + g.width), max(y1, y + g.height)
        return (x0, y, x1, y1)

    def panel_row(self, x: float, y: float, w: float, h: float, color: Rgba, rows: list) -> None:
        """An instance for a solid panel (the atlas' solid texel) at (x, y), w x h pixels."""
        g = self.atlas.solid
        rows.append(
            (round(x), round(y), round(w), round(h), g.u + 0.5, g.v + 0.5, 1.0, 1.0, *color)
        )

    def release(self) -> None:
        self.text.release()
        self.atlas.release()
        vaos = [self._text_vao, *self._overlay_vaos.values(), *self._glyph_vaos.values()]
        for vao in vaos:
            vao.release()
        self._overlay_buffer.release()
        self._glyph_buffer.release()
        for program in self.programs.values():
            program.release()
