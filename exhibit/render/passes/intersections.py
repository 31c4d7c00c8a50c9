"""The intersection pass: ink where sheets of the 3D image cross (intersect.glsl), from the
per-pixel sheet and depth plane the surface pass wrote beside the colour.

Single-sampled: a gate pass at one texel per tile (GATE) marks the tiles where two sheets meet,
then one point per marked tile runs the ink's 9 taps there alone (TILES). Multisampled: one
full-screen pass (MULTISAMPLE). Both only inside the box around the surfaces on screen.

Reads the sheets. Writes the scene colour (and the target's gate texture, its own). GL state on
return: depth test on, blending, scissor and program point size off; the scene target's colour
framebuffer current with the frame's viewport.
"""

from __future__ import annotations

from typing import ClassVar

import moderngl
import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.gpu import GpuMesh, surface_sample
from exhibit.render.options import RenderOptions
from exhibit.render.passes.shared import BLEND_OVER, FrameInputs, Pipeline, set_uniforms
from exhibit.render.scene_target import SceneTarget


#: Two front pixels belong to different sheets when their 4D depths differ by more than
#: SHEET_GAP x the mesh's radius (surfaces.SHEET_OFFSET keeps different parts further apart).
SHEET_GAP = 0.05
#: Crossings the curves show: the sine of the angle between the two sheets (depth scaled to
#: pixels by the mesh's extent on screen, from gpu.surface_sample's vertices). The ink fades in
#: linearly from MIN_CROSSING (none) to FULL_CROSSING (full): the angle is continuous along a
#: crossing curve but noisy from facet to facet, and a hard cut-off (0.2 until issue 32) drew a
#: curve whose angle runs near it in dashes (Figure 16).
MIN_CROSSING = 0.1
FULL_CROSSING = 0.3
INTERSECTION_INK = (0.05, 0.05, 0.07)
#: The widest curve the 3x3 neighbourhood draws whole, as a half width in pixels (a 1 px core
#: and a 1 px antialiased rim: a pixel up to 1 px from the crossing always has a neighbour
#: across it).
INTERSECTION_MAX_HALF_WIDTH = 0.5

Box = tuple[int, int, int, int]


def screen_extent(
    pipeline: Pipeline, gpu: GpuMesh, view: ViewState, size: tuple[int, int]
) -> tuple[float, Box | None]:
    """(pixels per unit of window depth, scissor box) from a sample of the mesh's vertices on
    screen: crossing angles are measured with depth in the same units as x and y, and the pass
    runs only over the box around the surfaces (padded, since the sample leaves vertices out;
    the whole screen when a vertex is clipped, e.g. near the sensor)."""
    sample = surface_sample(gpu)
    width, height = size
    ndc, ok = pipeline.clip_transform(view, size).to_ndc(sample)
    if ok.sum() < 2:
        return 1.0, None
    box = None
    if ok.all():
        lo, hi = ndc[:, :2].min(axis=0), ndc[:, :2].max(axis=0)
        pad = 0.1 * (hi - lo) + 8.0 / np.array([width, height])
        x0, y0 = np.floor((np.clip(lo - pad, -1, 1) + 1) * 0.5 * (width, height)).astype(int)
        x1, y1 = np.ceil((np.clip(hi + pad, -1, 1) + 1) * 0.5 * (width, height)).astype(int)
        box = (int(x0), int(y0), int(x1 - x0), int(y1 - y0))
    ndc = ndc[ok]
    span = np.ptp(ndc, axis=0)
    pixels = max(span[0] * width, span[1] * height) * 0.5
    depth = span[2] * 0.5
    return (float(pixels / depth) if depth > 1e-12 else 1.0), box


class IntersectionPass:
    name: ClassVar[str] = "intersections"
    reads: ClassVar[tuple[str, ...]] = ("sheets",)
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("scene colour",)

    def __init__(self, ctx: moderngl.Context, pipeline: Pipeline) -> None:
        self.ctx, self.pipeline = ctx, pipeline
        p = shaders.program
        self.programs = {
            "intersect": p(ctx, "intersect.glsl", ("TILES",)),
            "intersect_gate": p(ctx, "intersect.glsl", ("GATE",)),
            "intersect_ms": p(ctx, "intersect.glsl", ("MULTISAMPLE",)),
        }
        self._vaos = {key: ctx.vertex_array(prog, []) for key, prog in self.programs.items()}

    def draw(self, frame: FrameInputs) -> None:
        assert frame.sheets is not None  # the pass list has this pass on inked frames only
        self.ink(frame.gpu, frame.sheets, frame.size, frame.options, frame.view)

    def ink(
        self,
        gpu: GpuMesh,
        sheets: SceneTarget,
        size: tuple[int, int],
        options: RenderOptions,
        view: ViewState | None = None,
    ) -> None:
        """Ink the crossings over ``sheets.framebuffer`` from its sheet texture (the surfaces
        drawn with sheets); ``view`` None: no scissor and a depth scale of 1."""
        ctx = self.ctx
        sheets.framebuffer.use()
        ctx.viewport = (0, 0, *size)
        key = "intersect_ms" if sheets.samples else "intersect"
        prog = self.programs[key]
        assert sheets.sheet_texture is not None  # a target made with sheets
        sheets.sheet_texture.use(0)
        half = 0.5 * options.intersection_width * options.width_scale(size[1])
        scale, box = (
            screen_extent(self.pipeline, gpu, view, size) if view is not None else (1.0, None)
        )
        set_uniforms(
            prog,
            u_geometry=0,
            u_size=(float(size[0]), float(size[1])),
            u_depth_scale=scale,
            u_half_width=min(half, INTERSECTION_MAX_HALF_WIDTH),
            u_sheet_gap=SHEET_GAP * gpu.radius,
            u_min_angle=MIN_CROSSING,
            u_full_angle=FULL_CROSSING,
            u_ink=INTERSECTION_INK,
        )
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        if sheets.samples:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
            ctx.scissor = box
            self._vaos[key].render(moderngl.TRIANGLES, vertices=3)
        else:
            # The gate, one pixel per tile, then one point per tile, drawn only where the gate
            # found two sheets: the ink's 9 taps run on the tiles along the crossings alone.
            assert sheets.gate_framebuffer is not None and sheets.gate_texture is not None
            set_uniforms(
                self.programs["intersect_gate"],
                u_geometry=0,
                u_size=(float(size[0]), float(size[1])),
                u_sheet_gap=SHEET_GAP * gpu.radius,
                u_depth_scale=scale,
                u_min_angle=MIN_CROSSING,
            )
            sheets.gate_framebuffer.use()
            ctx.viewport = (0, 0, *sheets.gate_size)
            self._vaos["intersect_gate"].render(moderngl.TRIANGLES, vertices=3)
            sheets.framebuffer.use()
            ctx.viewport = (0, 0, *size)
            sheets.gate_texture.use(1)
            set_uniforms(prog, u_gate=1, u_tiles_x=sheets.gate_size[0])
            ctx.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
            ctx.blend_func = BLEND_OVER  # type: ignore[assignment]  # stubs: 2 ints; 4 are valid
            ctx.scissor = box
            self._vaos[key].render(
                moderngl.POINTS, vertices=sheets.gate_size[0] * sheets.gate_size[1]
            )
            ctx.disable(moderngl.PROGRAM_POINT_SIZE)
        ctx.scissor = None
        ctx.disable(moderngl.BLEND)
        ctx.enable(moderngl.DEPTH_TEST)

    def release(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        for program in self.programs.values():
            program.release()
