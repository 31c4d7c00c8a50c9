"""The renderer: one object per GL context, serving the offscreen EGL target and the GLFW window.

A frame of the 4D scene is an ordered list of passes (exhibit.render.passes), chosen by the
options and the quality level (passes_for): background (the direct path's clear), surfaces,
intersections (frames with the sheet buffer), the Lemma 3 outlines, curves and markers, then
the Lemma 2 discs and the live slice; kiosk frames add composite passes (exhibit.render.frame),
and the HUD is drawn last at full resolution (exhibit.render.hud). Each pass owns its programs
and GL state; this module only orders them, times them on frames asked to be measured
(exhibit.render.pass_timer), and keeps the old entry points (draw_surfaces, draw_intersections)
that benchmarks call.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl

from exhibit.geometry.pipeline import ClipTransform
from exhibit.geometry.view import ViewState
from exhibit.render.gpu import GpuMesh, upload
from exhibit.render.hud import Hud
from exhibit.render.hud_draw import HudDrawing
from exhibit.render.hud_info import HudInfo
from exhibit.render.layout import TextSizes
from exhibit.render.options import RenderOptions
from exhibit.render.pass_timer import PassTimer, PassTimes
from exhibit.render.passes.background import BackgroundPass
from exhibit.render.passes.curves import CurvePass
from exhibit.render.passes.intersections import IntersectionPass
from exhibit.render.passes.shared import FrameInputs, Pipeline, RenderPass
from exhibit.render.passes.silhouettes import silhouette_passes
from exhibit.render.passes.surfaces import SurfacePass
from exhibit.render.scene_target import SceneTarget
from exhibit.render.glyph_atlas import GlyphAtlas
from exhibit.render.text import TextCache
from exhibit.surfaces.mesh import Mesh4D

if TYPE_CHECKING:  # compiled on first use (Renderer.ids)
    from exhibit.render.passes.ids import ObjectIdPass


class Renderer:
    """Compiles every pass's programs once per context; draws any uploaded mesh in any
    ViewState as the ordered passes its options select."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        #: The frame's clip transform, computed once for every pass.
        self.pipeline = Pipeline(ctx)
        self.background = BackgroundPass(ctx)
        self.surfaces = SurfacePass(ctx, self.pipeline)
        self.intersections = IntersectionPass(ctx, self.pipeline)
        self.outlines, self.marks = silhouette_passes(ctx, self.pipeline)
        self.curves = CurvePass(ctx, self.pipeline)
        #: HUD text and quads (exhibit.render.hud_draw), and the HUD's cached panels and layout.
        self.drawing = HudDrawing(ctx)
        self.hud = Hud(self.drawing, self.pipeline)
        #: Per-pass times of frames asked to be measured (measure_next_frame).
        self.timer = PassTimer(ctx)
        self._ids: ObjectIdPass | None = None

    @property
    def programs(self) -> dict[str, moderngl.Program]:
        """Every pass's programs by variant name (tests check their uniforms)."""
        found: dict[str, moderngl.Program] = dict(self.drawing.programs)
        for render_pass in self._passes():
            found.update(render_pass.programs)
        return found

    @property
    def text(self) -> TextCache:
        """The notice screen's text textures (HudDrawing.text)."""
        return self.drawing.text

    @property
    def atlas(self) -> GlyphAtlas:
        """The HUD's glyph atlas (HudDrawing.atlas)."""
        return self.drawing.atlas

    def _passes(self) -> tuple[RenderPass, ...]:
        return (
            self.background,
            self.surfaces,
            self.intersections,
            self.outlines,
            self.curves,
            self.marks,
        )

    # ------------------------------------------------------------------ meshes

    def upload(self, mesh: Mesh4D) -> GpuMesh:
        """Buffers for a mesh, written once; draw it in any view with render() (each pass
        binds its vertex arrays to them on first use)."""
        return upload(self.ctx, mesh)

    # ------------------------------------------------------------------ the pass list

    def passes_for(
        self,
        options: RenderOptions,
        inked: bool = False,
        sliced: bool = False,
        background: bool = True,
    ) -> list[RenderPass]:
        """The scene's passes in the order they run: ``inked`` frames have the sheet buffer
        (intersections, the curves' centre test), ``sliced`` views draw the live slice, and
        ``background`` is the direct path's (kiosk frames clear an offscreen target instead)."""
        passes: list[RenderPass] = [self.background] if background else []
        if options.surfaces:
            passes.append(self.surfaces)
        if inked:
            passes.append(self.intersections)
        if options.silhouettes and options.silhouette_width > 0:
            passes.append(self.outlines)
        if options.curves:
            passes.append(self.curves)
        pinch = options.pinch_points and options.silhouettes and options.pinch_size > 0
        if sliced or pinch:
            passes.append(self.marks)
        return passes

    # ------------------------------------------------------------------ a frame

    def measure_next_frame(self) -> None:
        """Time each pass of the next frame (exhibit.render.pass_timer); other frames pay
        nothing."""
        self.timer.measure_next_frame()

    @property
    def pass_times(self) -> PassTimes | None:
        """The latest measured frame's per-pass times (None before the first)."""
        return self.timer.latest

    def clip_transform(self, view: ViewState, size: tuple[int, int]) -> ClipTransform:
        """exhibit.geometry.clip_transform for this view and size, computed once per frame."""
        return self.pipeline.clip_transform(view, size)

    def set_pipeline(
        self, program: moderngl.Program, view: ViewState, size: tuple[int, int]
    ) -> ClipTransform:
        """The view's pipeline uniforms into one program (passes.shared.Pipeline)."""
        return self.pipeline.set_pipeline(program, view, size)

    def clip_distances(self, on: bool) -> None:
        """The two gl_ClipDistance planes on or off (passes.shared.Pipeline)."""
        self.pipeline.clip_distances(on)

    def render(
        self,
        gpu: GpuMesh,
        view: ViewState,
        framebuffer: moderngl.Framebuffer,
        options: RenderOptions = RenderOptions(),
        hud: HudInfo | None = None,
        size: tuple[int, int] | None = None,
    ) -> None:
        """Draw one frame of gpu in view into framebuffer; size overrides the framebuffer's own
        (a window's default framebuffer changes size with the window). The direct path: the
        background is a pass of its own and antialiasing is the framebuffer's multisampling
        (the kiosk's frames go through exhibit.render.frame, which draws its "direct" quality
        level, and its crossfade snapshot at that level, with this)."""
        self.timer.begin_frame()
        try:
            framebuffer.use()
            width, height = size or framebuffer.size
            self.ctx.viewport = (0, 0, width, height)
            self._draw_scene(gpu, view, (width, height), options, None, background=True)
            if options.hud and hud is not None:
                self.render_hud(gpu, view, hud, (width, height), options.hud_drift, options.text)
        finally:
            self.timer.end_frame()

    def render_scene(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions = RenderOptions(),
        sheets: SceneTarget | None = None,
    ) -> None:
        """Surfaces, live silhouettes, curves and markers into the current framebuffer (its
        viewport set, colour and depth cleared): everything that lives in the 4D scene.

        ``sheets`` (exhibit.render.frame.SceneTarget with sheets, cleared): the surfaces are
        drawn into its framebuffer with the per-pixel sheet and depth plane beside the colour,
        and the intersection curves of the 3D image are inked from them (intersect.glsl);
        everything else goes to its colour-only framebuffer."""
        self._draw_scene(gpu, view, size, options, sheets, background=False)

    def _draw_scene(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions,
        sheets: SceneTarget | None,
        background: bool,
    ) -> None:
        inked = sheets is not None and options.surfaces and options.intersections
        inked = inked and bool(gpu.surfaces)
        frame = FrameInputs(gpu, view, size, options, sheets if inked else None)
        sliced = view.slice_axis is not None
        for render_pass in self.passes_for(options, inked, sliced, background):
            with self.timer.section(render_pass.name):
                render_pass.draw(frame)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        self.ctx.depth_func = "<"

    def draw_surfaces(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        depth_colour: bool = False,
        key: str | None = None,
        sheets: bool = False,
    ) -> None:
        """The surface pass alone (depth test on, current framebuffer): also what the benchmark
        times against its CPU baseline and its pass-through floor (key="floor"). With
        ``sheets`` the current framebuffer has the sheet attachment (SurfacePass)."""
        self.surfaces.draw_variant(gpu, view, size, depth_colour, key, sheets)

    def draw_intersections(
        self,
        gpu: GpuMesh,
        sheets: SceneTarget,
        size: tuple[int, int],
        options: RenderOptions,
        view: ViewState | None = None,
    ) -> None:
        """The intersection pass alone over ``sheets`` (IntersectionPass.ink)."""
        self.intersections.ink(gpu, sheets, size, options, view)

    # ------------------------------------------------------------------ object ids

    @property
    def ids(self) -> ObjectIdPass:
        """The object-id pass (exhibit.render.passes.ids), compiled on first use: only reviews
        and tests read ids, so the kiosk's start does not pay for it."""
        if self._ids is None:
            from exhibit.render.passes.ids import ObjectIdPass

            self._ids = ObjectIdPass(self.ctx, self.pipeline)
        return self._ids

    # ------------------------------------------------------------------ HUD

    def notice(
        self, lines: list[str], size: tuple[int, int], drift: tuple[float, float] = (0.0, 0.0)
    ) -> None:
        """The notice screen (exhibit.render.hud_draw.HudDrawing.notice)."""
        self.drawing.notice(lines, size, drift)

    def render_hud(
        self,
        gpu: GpuMesh,
        view: ViewState,
        hud: HudInfo,
        size: tuple[int, int],
        drift: tuple[float, float] = (0.0, 0.0),
        sizes: TextSizes | None = None,
        alpha: float = 1.0,
    ) -> None:
        """The HUD over the current framebuffer at its full resolution (exhibit.render.hud);
        ``sizes``: exhibit.render.layout.TextSizes (None: the defaults); ``alpha`` fades it."""
        with self.timer.section("hud"):
            self.hud.draw(gpu, view, hud, size, drift, sizes, alpha)

    def release(self) -> None:
        self.hud.release()
        self.drawing.release()
        if self._ids is not None:
            self._ids.release()
        for render_pass in self._passes():
            render_pass.release()
        self.timer.release()
