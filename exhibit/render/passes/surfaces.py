"""The surface pass: every solid surface through the 4D pipeline in the vertex shader
(pipeline.glsl), clipped at the sensor hyperplane and the front plane by gl_ClipDistance and lit
two-sided with the Lemma 1(c) normal (surface.glsl).

Variants, one program each: "surface" (material colours), "surface_depth" (coloured by 4D depth,
DEPTH_COLOUR), each with "_sheets" (GBUFFER: a second, float attachment gets each pixel's sheet
and depth plane, the intersection pass's input), and "floor" (floor.glsl: the same triangles
through a pass-through shader, the benchmarks' floor; not part of any frame).

Reads the scene depth (the depth test runs against the clear's, or the background's). Writes
the scene colour and depth, and the sheets on frames that ink intersections. GL state on
return: depth test on with "<", depth writes on, blending off, polygon offset and clip
distances off; on inked frames the scene target's colour-only framebuffer is current again
(the sheet framebuffer is bound only while this pass draws).
"""

from __future__ import annotations

from typing import ClassVar

import moderngl
import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.gpu import GpuMesh
from exhibit.render.passes.shared import FrameInputs, Pipeline, set_uniforms, surface_array

#: Intersection curves (intersect.glsl): different parts of the mesh are drawn with sheet values
#: SHEET_OFFSET x radius apart, so two of them always differ by more than the sheet gap.
SHEET_OFFSET = 16.0


class SurfacePass:
    name: ClassVar[str] = "surfaces"
    reads: ClassVar[tuple[str, ...]] = ("scene depth",)
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("scene colour", "scene depth", "sheets")

    def __init__(self, ctx: moderngl.Context, pipeline: Pipeline) -> None:
        self.ctx, self.pipeline = ctx, pipeline
        p = shaders.program
        self.programs = {
            "surface": p(ctx, "surface.glsl"),
            "surface_depth": p(ctx, "surface.glsl", ("DEPTH_COLOUR",)),
            "surface_sheets": p(ctx, "surface.glsl", ("GBUFFER",)),
            "surface_depth_sheets": p(ctx, "surface.glsl", ("DEPTH_COLOUR", "GBUFFER")),
            "floor": p(ctx, "floor.glsl"),
        }

    def draw(self, frame: FrameInputs) -> None:
        ctx = self.ctx
        ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        ctx.fbo.depth_mask = True
        sheets = frame.sheets
        if sheets is not None:
            assert sheets.sheet_framebuffer is not None  # a target made with sheets
            sheets.sheet_framebuffer.use()
            ctx.viewport = (0, 0, *frame.size)
        self.draw_variant(
            frame.gpu, frame.view, frame.size, frame.options.depth_colour, sheets=sheets is not None
        )
        if sheets is not None:
            sheets.framebuffer.use()
            ctx.viewport = (0, 0, *frame.size)

    def draw_variant(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        depth_colour: bool = False,
        key: str | None = None,
        sheets: bool = False,
    ) -> None:
        """The surfaces alone into the current framebuffer (depth test on, as the caller set
        it) with one variant: ``key`` names it ("floor" for the benchmarks), else the depth
        colour and ``sheets`` choose it."""
        ctx = self.ctx
        key = key or ("surface_depth" if depth_colour else "surface")
        if sheets:
            key += "_sheets"
        prog = self.programs[key]
        self.pipeline.set_pipeline(prog, view, size)
        if "u_lights" in prog:
            lights = np.zeros((2, 3), dtype=np.float32)  # key and fill light; more are ignored
            lights[: len(view.lights[:2])] = view.lights[:2]
            shaders.uniform(prog, "u_lights").write(lights.tobytes())
        lit = key != "floor"  # the floor: one matrix and a flat colour, no clipping
        if lit:
            w0 = view.offset[3]
            set_uniforms(prog, u_w_range=(w0 - gpu.radius, w0 + gpu.radius))
        self.pipeline.clip_distances(lit)
        ctx.polygon_offset = (1.0, 1.0)
        for i, surface in enumerate(gpu.surfaces):
            if lit:
                set_uniforms(
                    prog, u_color=tuple(surface.color), u_sheet=SHEET_OFFSET * i * gpu.radius
                )
            surface_array(ctx, surface, prog, "surfaces:" + key).render(moderngl.TRIANGLES)
        ctx.polygon_offset = (0.0, 0.0)
        self.pipeline.clip_distances(False)

    def release(self) -> None:
        for program in self.programs.values():
            program.release()
