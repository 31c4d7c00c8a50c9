"""A kiosk frame at a quality level (exhibit.render.quality): the 3D scene drawn offscreen at
the level's render scale, with multisampling or not, then composite passes to the screen that lay
it over the background and antialias it with FXAA (or just resolve and upscale it), then the HUD
at the screen's full resolution, always crisp:

    antialiasing  scale 1                                 scale s < 1
    fxaa          scene -> FXAA+bg -> screen               scene -> FXAA+bg (size s) -> upscale
    msaa          MSAA scene -> resolve -> plain+bg        MSAA scene -> resolve -> upscale+bg
    none          the direct path (Renderer.render)        scene -> upscale+bg

The scene target holds premultiplied colour cleared to transparent, so the background costs a few
instructions in a pass that runs anyway, and the screen is never cleared. On software GL every
full-screen pass costs several milliseconds at 1080p whatever it does, so there is never more than
one at full size. FrameTimer measures what a frame costs the GPU (timer queries) or, on software
GL where the "GPU" is the same CPU cores, the wall time of the frame's work up to glFinish.

Why one module of this size: one kiosk frame's passes at a quality level, in the order they run."""

from __future__ import annotations

import time
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass

import moderngl

from exhibit.geometry.view import ViewState
from exhibit.render import inset as inset_look
from exhibit.render.gpu import GpuMesh
from exhibit.render.hud import TextMark
from exhibit.render.layout import Rect
from exhibit.render.options import RenderOptions
from exhibit.render.passes.composite import CompositePass
from exhibit.render.quality import Quality, software_renderer
from exhibit.render.renderer import HudInfo, Renderer
from exhibit.render.scene_target import SceneTarget

#: Targets kept for recently used (size, antialiasing) pairs; a benchmark alternating levels
#: must not reallocate every frame, and a kiosk needs one or two.
MAX_TARGETS = 6


@dataclass(frozen=True)
class Inset:
    """The time-slice inset for one frame: a small scene (exhibit.render.inset), its view, where
    it goes (x, y, width, height in pixels from the top-left) and its label."""

    gpu: GpuMesh
    view: ViewState
    rect: tuple[float, float, float, float]
    label: str = ""


class FramePipeline:
    """Draws whole kiosk frames at any quality level into a destination framebuffer (a
    window's screen, or an offscreen single-sampled one), and crossfades between two of them
    (capture() the outgoing frame, then draw() the new ones with ``fade``)."""

    def __init__(self, ctx: moderngl.Context, renderer: Renderer, samples: int = 4):
        self.ctx = ctx
        self.renderer = renderer
        #: MSAA samples used by "msaa" levels (0 or 1: msaa falls back to none).
        self.samples = min(samples, ctx.max_samples) if samples > 1 else 0
        #: The composite passes: the scene over the background, FXAA or not, upscaled or not,
        #: and the crossfade's snapshot (exhibit.render.passes.composite).
        self.composite = CompositePass(ctx)
        self._targets: OrderedDict[tuple, SceneTarget] = OrderedDict()
        #: The outgoing frame of a crossfade: (texture, framebuffer, depth), kept at the screen
        #: size.
        self._snapshot: (
            tuple[moderngl.Texture, moderngl.Framebuffer, moderngl.Renderbuffer] | None
        ) = None
        #: The outgoing frame's words (gpu, view, options, hud), faded out on their own.
        self._leaving: tuple | None = None
        #: The latest frame's inset label (exhibit.render.hud.TextMark), for the contrast checks;
        #: the HUD's own are the renderer's ``hud.texts``.
        self.texts: list = []

    def target(self, size: tuple[int, int], samples: int, kind: str = "scene") -> SceneTarget:
        """A cached target; kind "sheets" has the intersection curves' sheet buffer."""
        width, height = size
        key = ((width, height), samples, kind)
        found = self._targets.get(key)
        if found is not None:
            self._targets.move_to_end(key)
            return found
        target = self._targets[key] = SceneTarget(
            self.ctx, (width, height), samples, sheets=kind == "sheets"
        )
        while len(self._targets) > MAX_TARGETS:
            self._targets.popitem(last=False)[1].release()
        return target

    @staticmethod
    def scene_size(size: tuple[int, int], scale: float) -> tuple[int, int]:
        return (max(1, round(size[0] * scale)), max(1, round(size[1] * scale)))

    def capture(
        self,
        gpu: GpuMesh,
        view: ViewState,
        size: tuple[int, int],
        options: RenderOptions,
        hud: HudInfo | None,
        quality: Quality,
    ) -> None:
        """Draw the picture a crossfade starts from: the last frame of what is leaving the
        screen (drawn again, so nothing has to be read back), without its words, which
        draw() fades out on their own (``hud`` is kept for that)."""
        size = (int(size[0]), int(size[1]))
        if self._snapshot is None or self._snapshot[0].size != size:
            self.release_snapshot()
            texture = self.ctx.texture(size, 4)
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            # with depth, as a screen has: the direct level draws the scene straight into it
            depth = self.ctx.depth_renderbuffer(size)
            self._snapshot = (texture, self.ctx.framebuffer([texture], depth), depth)
        self._draw(gpu, view, self._snapshot[1], size, options, None, quality)
        self._leaving = (gpu, view, options, hud) if options.hud and hud is not None else None

    def release_snapshot(self) -> None:
        if self._snapshot is not None:
            for obj in reversed(self._snapshot):
                obj.release()
            self._snapshot = None
        self._leaving = None

    def draw(
        self,
        gpu: GpuMesh,
        view: ViewState,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        options: RenderOptions,
        hud: HudInfo | None,
        quality: Quality,
        fade: float = 0.0,
        inset: Inset | None = None,
    ) -> None:
        """One frame at ``quality`` into ``destination`` (whose drawable size is ``size``);
        with ``fade`` > 0 the captured picture is laid over it with that opacity; ``inset``
        (the time-slice inset, exhibit.render.inset) is drawn over the picture in its corner.

        Words never cross-dissolve (two titles legible on top of each other for a second):
        while ``fade`` runs from 1 to 0 the outgoing words fade out over its first half and
        the new ones fade in over its second, as the pictures crossfade underneath."""
        size = (int(size[0]), int(size[1]))
        self.texts = []
        timer = self.renderer.timer
        timer.begin_frame()
        try:
            self._frame(gpu, view, destination, size, options, hud, quality, fade, inset)
        finally:
            timer.end_frame()

    def _frame(
        self,
        gpu: GpuMesh,
        view: ViewState,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        options: RenderOptions,
        hud: HudInfo | None,
        quality: Quality,
        fade: float,
        inset: Inset | None,
    ) -> None:
        timer = self.renderer.timer
        self._draw(gpu, view, destination, size, options, None, quality)
        if inset is not None:
            with timer.section("inset"):
                self._inset(inset, destination, size)
        fading = fade > 0.0 and self._snapshot is not None and self._snapshot[0].size == size
        if fading:
            assert self._snapshot is not None  # fading needs it
            with timer.section("fade"):
                self.composite.fade(self._snapshot[0], destination, size, fade)
        words = (gpu, view, options, hud)
        alpha = 1.0
        if fading:
            fade = min(fade, 1.0)
            if fade > 0.5 and self._leaving is not None:
                words, alpha = self._leaving, 2.0 * fade - 1.0
            else:
                alpha = max(0.0, 1.0 - 2.0 * fade)
        gpu, view, options, hud = words
        if options.hud and hud is not None:
            destination.use()
            self.ctx.viewport = (0, 0, *size)
            self.renderer.render_hud(gpu, view, hud, size, options.hud_drift, options.text, alpha)

    def _draw(
        self,
        gpu: GpuMesh,
        view: ViewState,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        options: RenderOptions,
        hud: HudInfo | None,
        quality: Quality,
    ) -> None:
        ctx, renderer, timer = self.ctx, self.renderer, self.renderer.timer
        options = options.at_quality(quality)
        size = (int(size[0]), int(size[1]))
        aa = quality.antialiasing
        if aa == "msaa" and not self.samples:
            aa = "none"
        scene_size = self.scene_size(size, quality.scale)
        inked = options.intersections and options.surfaces and bool(gpu.surfaces)
        if aa == "none" and scene_size == size and not inked:
            renderer.render(gpu, view, destination, options, hud, size=size)
            return
        target = self.target(
            scene_size, self.samples if aa == "msaa" else 0, "sheets" if inked else "scene"
        )
        with timer.section("clear"):
            target.framebuffer.use()
            ctx.viewport = (0, 0, *scene_size)
            ctx.fbo.depth_mask = True
            target.clear()
        renderer.render_scene(gpu, view, scene_size, options, sheets=target if inked else None)
        if target.samples:
            with timer.section("resolve"):
                target.resolve()
        source = target.texture
        with timer.section("composite"):
            if scene_size == size:
                variant = "fxaa" if aa == "fxaa" else "plain"
                self.composite.compose(variant, source, destination, size, options)
            else:
                if aa == "fxaa":
                    smooth = self.target(scene_size, 0, "fxaa")
                    self.composite.compose("fxaa", source, smooth.framebuffer, scene_size, options)
                    source = smooth.texture
                self.composite.compose("upscale", source, destination, size, options)
        if options.hud and hud is not None:
            renderer.render_hud(gpu, view, hud, size, options.hud_drift, options.text)

    def _inset(self, inset: Inset, destination, size: tuple[int, int]) -> None:
        """The inset's own small picture (the direct path: its background, no antialiasing,
        on software GL a few ms), then laid into the frame with a border and its label."""
        x, y, w, h = (int(round(v)) for v in inset.rect)
        if w < 16 or h < 16:
            return
        ctx, renderer, drawing = self.ctx, self.renderer, self.renderer.drawing
        target = self.target((w, h), 0, "inset")
        renderer.render(inset.gpu, inset.view, target.framebuffer, inset_look.OPTIONS)
        destination.use()
        ctx.viewport = (0, 0, *size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        viewport = (float(size[0]), float(size[1]))
        # the framebuffer's rows run bottom to top: the texel rectangle is flipped
        drawing.quads(
            "image",
            target.texture,
            (w, h),
            [(x, y, w, h, 0, h, w, -h, 1.0, 1.0, 1.0, 1.0)],
            viewport,
        )
        rows: list = []
        edge = max(1, round(h / 180))
        for bx, by, bw, bh in (
            (x, y, w, edge),
            (x, y + h - edge, w, edge),
            (x, y, edge, h),
            (x + w - edge, y, edge, h),
        ):
            drawing.panel_row(bx, by, bw, bh, inset_look.BORDER, rows)
        if inset.label:
            px = max(10, round(0.085 * h))
            # on a dark tab in the corner: the inset's picture may be light behind it
            glyphs: list = []
            box = drawing.glyph_rows(
                inset.label, "sans", px, x + 0.5 * px, y + 0.4 * px, inset_look.LABEL, glyphs
            )
            drawing.panel_row(
                x + edge,
                y + edge,
                box[2] + 0.4 * px - x - edge,
                box[3] + 0.3 * px - y - edge,
                inset_look.TAB,
                rows,
            )
            if renderer.hud.ink:
                rows += glyphs
            self.texts.append(TextMark("inset label", inset.label, Rect(*box), inset_look.LABEL))
        drawing.atlas_quads(rows, viewport)
        ctx.disable(moderngl.BLEND)

    def release(self) -> None:
        self.release_snapshot()
        for target in self._targets.values():
            target.release()
        self._targets.clear()
        self.composite.release()


class FrameTimer:
    """How long each frame's drawing takes, in milliseconds, for the frame governor.

    On a real GPU: GL timer queries around the frame, read two frames later (by then they are
    done, so reading never stalls the pipeline). On software GL (and where a query cannot be
    made) the GPU is the CPU: the wall time from begin() to a glFinish at end(), which costs
    nothing there because presenting the frame waits for the rasteriser anyway."""

    LATENCY = 2

    def __init__(
        self,
        ctx: moderngl.Context,
        clock: Callable[[], float] = time.perf_counter,
        wall: bool | None = None,
    ) -> None:
        self.ctx = ctx
        self.clock = clock
        if wall is None:
            wall = software_renderer(ctx.info.get("GL_RENDERER", ""))
        self._queries: deque[moderngl.Query] = deque()
        self._free: list[moderngl.Query] = []
        self._current: moderngl.Query | None = None
        self.mode = "wall" if wall else "gpu"
        self._start = 0.0
        #: The latest measured frame time (ms), None before the first.
        self.last_ms: float | None = None

    def begin(self) -> None:
        if self.mode == "gpu":
            try:
                query = self._free.pop() if self._free else self.ctx.query(time=True)
                query.mglo.begin()
                self._current = query
                return
            except Exception:  # noqa: BLE001 - no timer queries: measure wall time instead
                self.mode = "wall"
        self._start = self.clock()

    def end(self) -> float | None:
        """Finish measuring this frame; returns the newest completed measurement (ms)."""
        if self.mode == "gpu" and self._current is not None:
            self._current.mglo.end()
            self._queries.append(self._current)
            self._current = None
            if len(self._queries) > self.LATENCY:
                query = self._queries.popleft()
                self.last_ms = query.elapsed / 1e6
                self._free.append(query)
            return self.last_ms
        self.ctx.finish()
        self.last_ms = (self.clock() - self._start) * 1000.0
        return self.last_ms

    def release(self) -> None:
        # moderngl queries have no release(); they go with their context.
        self._queries.clear()
        self._free.clear()
