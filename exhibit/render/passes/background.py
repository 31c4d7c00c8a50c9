"""The background pass of the direct path: a vertical gradient drawn as the frame's clear.

Why a pass and not a clear: it writes every pixel's colour and (at the far plane, the depth test
always passing, depth writes on) its depth of 1.0, so the frame needs no clear of its own; on
llvmpipe a clear, even of depth alone, costs more than the depth writes (docs/PERFORMANCE.md).
Kiosk frames at the other levels clear their offscreen scene to transparent instead and lay the
background in the composite pass.

Reads nothing. Writes the scene colour and depth (the current framebuffer, its viewport set).
Shader: background.glsl. GL state on return: depth test on with "<", depth writes on, blending
and face culling off.
"""

from __future__ import annotations

from typing import ClassVar

import moderngl

from exhibit.render import shaders
from exhibit.render.passes.shared import FrameInputs, set_uniforms


class BackgroundPass:
    name: ClassVar[str] = "background"
    reads: ClassVar[tuple[str, ...]] = ()
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("scene colour", "scene depth")

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self.programs = {"background": shaders.program(ctx, "background.glsl")}
        self._vao = ctx.vertex_array(self.programs["background"], [])

    def draw(self, frame: FrameInputs) -> None:
        ctx = self.ctx
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "1"  # GL_ALWAYS
        ctx.fbo.depth_mask = True
        top, bottom = frame.options.background
        set_uniforms(self.programs["background"], u_top=tuple(top), u_bottom=tuple(bottom))
        self._vao.render(moderngl.TRIANGLES, vertices=3)
        ctx.depth_func = "<"

    def release(self) -> None:
        self._vao.release()
        for program in self.programs.values():
            program.release()
