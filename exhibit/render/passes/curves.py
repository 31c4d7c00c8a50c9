"""The curve pass: the mesh's curves, wire meshes and markers as screen-space capsules
(curves.glsl), depth-tested against the surfaces: opaque cores with depth writes, then
antialiased rims blended over them.

On frames that ink intersections the curves are hidden where their centre is behind a sheet
(centre_test.glsl, at each segment end, reading the sheet buffer's depth planes: a curve on the
outline of a fold stays, one just behind it goes); the direct path has no sheet buffer and skips
the test.

Reads the scene depth (and the sheets, for the centre test). Writes the scene colour and depth.
Shader: curves.glsl (one program; the centre test is a uniform). GL state on return: depth test
and blending on (BLEND_OVER), depth function "<=", depth writes on.
"""

from __future__ import annotations

from typing import ClassVar

import moderngl

from exhibit.render import shaders
from exhibit.render.gpu import CENTRE_UNITS, LINE_BIAS
from exhibit.render.passes.shared import (
    BLEND_OVER,
    FrameInputs,
    Pipeline,
    segment_array,
    set_uniforms,
)


class CurvePass:
    name: ClassVar[str] = "curves"
    reads: ClassVar[tuple[str, ...]] = ("scene depth",)
    #: Read where an earlier pass wrote them (the centre test on inked frames).
    optional_reads: ClassVar[tuple[str, ...]] = ("sheets",)
    writes: ClassVar[tuple[str, ...]] = ("scene colour", "scene depth")

    def __init__(self, ctx: moderngl.Context, pipeline: Pipeline) -> None:
        self.ctx, self.pipeline = ctx, pipeline
        self.programs = {"curves": shaders.program(ctx, "curves.glsl")}

    def draw(self, frame: FrameInputs) -> None:
        ctx, gpu, sheets = self.ctx, frame.gpu, frame.sheets
        ctx.enable(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
        ctx.depth_func = "<="
        prog = self.programs["curves"]
        self.pipeline.set_pipeline(prog, frame.view, frame.size)
        centre_test = 0
        if sheets is not None:
            assert sheets.sheet_texture is not None  # a target made with sheets
            sheets.sheet_texture.use(CENTRE_UNITS[1 if sheets.samples else 0])
            centre_test = 2 if sheets.samples else 1
        set_uniforms(
            prog,
            u_line_bias=LINE_BIAS,
            u_width_scale=frame.width_scale * frame.options.curve_width,
            u_centre_test=centre_test,
            u_sag=gpu.sag,
            u_surface_depth=CENTRE_UNITS[0],
            u_surface_depth_ms=CENTRE_UNITS[1],
        )
        for key, buffer, count in (
            ("curves:lines", gpu.lines, gpu.line_count),
            ("curves:markers", gpu.markers, gpu.marker_count),
        ):
            if buffer is None or not count:
                continue
            vao = segment_array(ctx, gpu, buffer, prog, key)
            for rim in (0, 1):
                prog["u_pass"] = rim
                ctx.fbo.depth_mask = rim == 0
                vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=count)
        ctx.fbo.depth_mask = True

    def release(self) -> None:
        for program in self.programs.values():
            program.release()
