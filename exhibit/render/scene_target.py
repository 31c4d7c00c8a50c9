"""Where a kiosk frame's scene is drawn offscreen: colour, depth and, on frames that ink
intersections, the sheet buffer and the intersection pass's gate (exhibit.render.frame keeps
these per size; the passes in exhibit.render.passes draw into them)."""

from __future__ import annotations

import moderngl

#: Pixels per side of a tile of the intersection pass's gate (intersect.glsl's TILE).
TILE = 8
#: What SceneTarget.clear writes, in the passes' names for a frame's buffers
#: (exhibit.render.passes): a kiosk frame's scene passes start from these.
CLEARED = ("scene colour", "scene depth", "sheets")


class SceneTarget:
    """Where the scene is drawn: colour (texture, or MSAA renderbuffer resolved into one) and
    depth, of one size; with ``sheets``, also a float texture the surface pass writes each
    pixel's sheet and depth plane to (the intersection curves' input, intersect.glsl), bound
    only in ``sheet_framebuffer``."""

    def __init__(
        self, ctx: moderngl.Context, size: tuple[int, int], samples: int, sheets: bool = False
    ):
        self.ctx, self.size, self.samples = ctx, size, samples
        self.sheet_texture = self.sheet_framebuffer = None
        self.gate_texture = self.gate_framebuffer = None
        self.gate_size = (0, 0)
        self.texture = ctx.texture(size, 4)
        self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.texture.repeat_x = self.texture.repeat_y = False
        self._color: moderngl.Renderbuffer | None = None
        self._resolved: moderngl.Framebuffer | None = None
        if samples:
            self._color = ctx.renderbuffer(size, 4, samples=samples)
            self._depth = ctx.depth_renderbuffer(size, samples=samples)
            self.framebuffer = ctx.framebuffer([self._color], self._depth)
            self._resolved = ctx.framebuffer([self.texture])
        else:
            self._depth = ctx.depth_renderbuffer(size)
            self.framebuffer = ctx.framebuffer([self.texture], self._depth)
        if sheets:
            self.sheet_texture = ctx.texture(size, 4, dtype="f4", samples=samples or 0)
            if not samples:  # a multisampled texture has no filter (read with texelFetch)
                self.sheet_texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.sheet_framebuffer = ctx.framebuffer(
                [self._color if samples else self.texture, self.sheet_texture], self._depth
            )
            if not samples:  # the intersection pass's gate: one texel per 4 x 4 pixels
                self.gate_size = (-(-size[0] // TILE), -(-size[1] // TILE))
                self.gate_texture = ctx.texture(self.gate_size, 1)
                self.gate_texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
                self.gate_framebuffer = ctx.framebuffer([self.gate_texture])

    def clear(self) -> None:
        """Colour to transparent, depth to 1 (and the sheets to empty)."""
        (self.sheet_framebuffer or self.framebuffer).clear(0.0, 0.0, 0.0, 0.0, depth=1.0)

    def resolve(self) -> None:
        if self._resolved is not None:
            self.ctx.copy_framebuffer(self._resolved, self.framebuffer)

    def release(self) -> None:
        for obj in (
            self.sheet_framebuffer,
            self.framebuffer,
            self._resolved,
            self._color,
            self._depth,
            self.texture,
            self.sheet_texture,
            self.gate_framebuffer,
            self.gate_texture,
        ):
            if obj is not None:
                obj.release()
