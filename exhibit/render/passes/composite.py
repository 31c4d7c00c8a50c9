"""The composite passes of a kiosk frame (composite.glsl, fade.glsl): full-screen triangles that
lay the offscreen scene (premultiplied colour, cleared to transparent) over the background
gradient into the destination, in one of three variants, and the crossfade's snapshot over it.

    "fxaa"     FXAA, at the scene's size (into the screen, or into a smaller texture)
    "plain"    the resolved MSAA scene as it is
    "upscale"  bilinear, from a smaller render scale to the screen
    "fade"     the captured outgoing frame at an opacity (a crossfade)

Why one pass per frame at full size: on software GL every full-screen pass costs several
milliseconds at 1080p whatever it does (exhibit.render.frame's table).

Reads the scene colour (a texture). Writes the screen (the destination framebuffer, all of it:
no clear needed). GL state: the composites leave depth test, blending and face culling off; the
fade turns blending on and off again.
"""

from __future__ import annotations

from typing import ClassVar

import moderngl

from exhibit.render import shaders
from exhibit.render.options import RenderOptions
from exhibit.render.passes.shared import PostFrame

VARIANTS = ("fxaa", "plain", "upscale")


class CompositePass:
    name: ClassVar[str] = "composite"
    reads: ClassVar[tuple[str, ...]] = ("scene colour",)
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("screen",)

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        p = shaders.program
        self.programs = {
            "fxaa": p(ctx, "composite.glsl", ("FXAA",)),
            "plain": p(ctx, "composite.glsl"),
            "upscale": p(ctx, "composite.glsl", ("UPSCALE",)),
            "fade": p(ctx, "fade.glsl"),
        }
        self._vaos = {key: ctx.vertex_array(prog, []) for key, prog in self.programs.items()}

    def draw(self, frame: PostFrame) -> None:
        """The frame's scene over the background into its destination: FXAA or plain at full
        scale; at a smaller render scale upscaled (after FXAA at the scene's size, for FXAA)."""
        target = frame.scene_target()
        source = target.texture
        destination, size, options = frame.destination, frame.size, frame.options
        if frame.scene_size == size:
            variant = "fxaa" if frame.antialiasing == "fxaa" else "plain"
            self.compose(variant, source, destination, size, options)
            return
        if frame.smooth is not None:  # FXAA at the scene's size first
            self.compose("fxaa", source, frame.smooth.framebuffer, frame.scene_size, options)
            source = frame.smooth.texture
        self.compose("upscale", source, destination, size, options)

    def compose(
        self,
        variant: str,
        source: moderngl.Texture,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        options: RenderOptions,
    ) -> None:
        """``source`` over the background into ``destination`` (drawable ``size``)."""
        ctx = self.ctx
        ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        destination.use()
        ctx.viewport = (0, 0, *size)
        prog = self.programs[variant]
        top, bottom = options.background
        source.use(0)
        for name, value in (
            ("u_scene", 0),
            ("u_size", (float(size[0]), float(size[1]))),
            ("u_top", tuple(top)),
            ("u_bottom", tuple(bottom)),
        ):
            if name in prog:
                prog[name] = value
        self._vaos[variant].render(moderngl.TRIANGLES, vertices=3)

    def fade(
        self,
        snapshot: moderngl.Texture,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        alpha: float,
    ) -> None:
        """The captured frame over ``destination`` at opacity ``alpha`` (a crossfade)."""
        ctx = self.ctx
        destination.use()
        ctx.viewport = (0, 0, *size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
        snapshot.use(0)
        prog = self.programs["fade"]
        prog["u_snapshot"] = 0
        prog["u_alpha"] = float(min(alpha, 1.0))
        self._vaos["fade"].render(moderngl.TRIANGLES, vertices=3)
        ctx.disable(moderngl.BLEND)

    def release(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        for program in self.programs.values():
            program.release()
