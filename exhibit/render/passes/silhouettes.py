"""The silhouette passes (silhouette.glsl, per triangle in a geometry shader): the live Lemma 3
outlines as antialiased ink, and, in a later pass, the marks: Lemma 2 points' discs and the live
slice curve (ViewState.slice_axis/slice_at).

Two passes, since neither writes depth (Framebuffer.depth_mask: a segment must not hide its
own next one) and without depth writes what a later triangle emits covers what an earlier one
did: one pass would let ink cross the discs. The outlines run before the curves (a scene curve
that is itself an outline, the offset curve of Figures 9-14, covers the ink); the marks run
last, over the wire frames, the curves and the ink. The marks pass runs the program with the
slice's tangency test ("silhouette_slice", TOUCHING, two more vec4 a vertex) on a surface only
when the slice is near one of its critical values (gpu.silhouette_key), so only those frames
pay for it; the outline pass runs the OUTLINES variant, which hands the geometry stage the ink's
inputs alone.

Both read the scene depth and write the scene colour. GL state on return: depth test and
blending on (BLEND_OVER), depth function "<=", depth writes on.
"""

from __future__ import annotations

from typing import ClassVar

import moderngl
import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.gpu import LINE_BIAS, SLICE_WIDTH, GpuSurface, silhouette_key
from exhibit.render.marks import PINCH_COLOR, darker
from exhibit.render.passes.shared import (
    BLEND_OVER,
    FrameInputs,
    Pipeline,
    set_uniforms,
    surface_array,
)
from exhibit.surfaces.slice import SLICE_MATERIAL

#: The slice curve drawn live: the slice's colour (its width: gpu.SLICE_WIDTH).
SLICE_COLOR = SLICE_MATERIAL.color


class _SilhouettePass:
    reads: ClassVar[tuple[str, ...]] = ("scene depth",)
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("scene colour",)
    #: silhouette.glsl's variants this pass draws with: (key, defines).
    variants: ClassVar[tuple[tuple[str, tuple[str, ...]], ...]] = ()

    def __init__(self, ctx: moderngl.Context, pipeline: Pipeline) -> None:
        self.ctx, self.pipeline = ctx, pipeline
        self.programs = {
            key: shaders.program(ctx, "silhouette.glsl", defines) for key, defines in self.variants
        }

    def program_key(self, surface: GpuSurface, view: ViewState, slice_width: float) -> str:
        return self.variants[0][0]

    def _draw(self, frame: FrameInputs, ink_width: float, slice_width: float, pinch: float) -> None:
        """One pass over every surface: zero widths tell the geometry shader what to skip."""
        ctx, view = self.ctx, frame.view
        ctx.enable(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
        ctx.depth_func = "<="
        axis = np.zeros(4)
        if view.slice_axis is not None:
            axis[view.slice_axis] = 1.0
        ctx.fbo.depth_mask = False
        ready: dict[str, moderngl.Program] = {}  # programs with this pass's uniforms set
        for surface in frame.gpu.surfaces:
            key = self.program_key(surface, view, slice_width)
            if key not in ready:
                ready[key] = prog = self.programs[key]
                self.pipeline.set_pipeline(prog, view, frame.size)
                set_uniforms(
                    prog,
                    u_line_bias=LINE_BIAS,
                    u_width_scale=frame.width_scale,
                    u_pass=1,
                    u_slice_axis=tuple(axis),
                    u_slice_at=view.slice_at,
                    u_pinch=(*PINCH_COLOR, pinch),
                    u_slice_style=(*SLICE_COLOR, slice_width),
                )
            ready[key]["u_ink"] = (*darker(surface.color), ink_width)
            surface_array(ctx, surface, ready[key], "silhouettes:" + key).render(moderngl.TRIANGLES)
        ctx.fbo.depth_mask = True

    def release(self) -> None:
        for program in self.programs.values():
            program.release()


class OutlinePass(_SilhouettePass):
    """The Lemma 3 outlines of every surface, before the curves: silhouette.glsl's OUTLINES
    variant, whose vertices carry less than half of what the marks need (on llvmpipe the
    geometry stage's cost grows with it: docs/PERFORMANCE.md)."""

    name: ClassVar[str] = "outlines"
    variants = (("silhouette_outlines", ("OUTLINES",)),)

    def draw(self, frame: FrameInputs) -> None:
        self._draw(frame, frame.options.silhouette_width, 0.0, 0.0)


class MarksPass(_SilhouettePass):
    """The Lemma 2 discs and the live slice, over everything else."""

    name: ClassVar[str] = "marks"
    variants = (("silhouette", ()), ("silhouette_slice", ("TOUCHING",)))

    def program_key(self, surface: GpuSurface, view: ViewState, slice_width: float) -> str:
        return silhouette_key(surface, view, slice_width)

    def draw(self, frame: FrameInputs) -> None:
        options = frame.options
        slice_width = SLICE_WIDTH if frame.view.slice_axis is not None else 0.0
        pinch = options.pinch_size if options.pinch_points and options.silhouettes else 0.0
        self._draw(frame, 0.0, slice_width, pinch)


def silhouette_passes(ctx: moderngl.Context, pipeline: Pipeline) -> tuple[OutlinePass, MarksPass]:
    """The outline and marks passes."""
    return OutlinePass(ctx, pipeline), MarksPass(ctx, pipeline)
