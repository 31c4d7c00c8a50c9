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
from dataclasses import dataclass

import moderngl

from exhibit.geometry.view import ViewState
from exhibit.render import inset as inset_look
from exhibit.render import shaders
from exhibit.render.gpu import GpuMesh
from exhibit.render.hud import TextMark
from exhibit.render.layout import Rect
from exhibit.render.options import RenderOptions
from exhibit.render.quality import Quality, software_renderer
from exhibit.render.renderer import HudInfo, Renderer

#: Pixels per side of a tile of the intersection pass's gate (intersect.glsl's TILE).
TILE = 8
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


class FramePipeline:
    """Draws whole kiosk frames at any quality level into a destination framebuffer (a
    window's screen, or an offscreen single-sampled one), and crossfades between two of them
    (capture() the outgoing frame, then draw() the new ones with ``fade``)."""

    def __init__(self, ctx: moderngl.Context, renderer: Renderer, samples: int = 4):
        self.ctx = ctx
        self.renderer = renderer
        #: MSAA samples used by "msaa" levels (0 or 1: msaa falls back to none).
        self.samples = min(samples, ctx.max_samples) if samples > 1 else 0
        program = shaders.program
        self.programs = {
            "fxaa": program(ctx, "composite.glsl", ("FXAA",)),
            "plain": program(ctx, "composite.glsl"),
            "upscale": program(ctx, "composite.glsl", ("UPSCALE",)),
            "fade": program(ctx, "fade.glsl"),
        }
        self._vaos = {k: ctx.vertex_array(p, []) for k, p in self.programs.items()}
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
        gpu,
        view,
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
        gpu,
        view,
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
        self._draw(gpu, view, destination, size, options, None, quality)
        if inset is not None:
            self._inset(inset, destination, size)
        fading = fade > 0.0 and self._snapshot is not None and self._snapshot[0].size == size
        if fading:
            ctx = self.ctx
            destination.use()
            ctx.viewport = (0, 0, *size)
            ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)
            assert self._snapshot is not None  # fading needs it
            self._snapshot[0].use(0)
            prog = self.programs["fade"]
            prog["u_snapshot"] = 0
            prog["u_alpha"] = float(min(fade, 1.0))
            self._vaos["fade"].render(moderngl.TRIANGLES, vertices=3)
            ctx.disable(moderngl.BLEND)
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
        gpu,
        view,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        options: RenderOptions,
        hud: HudInfo | None,
        quality: Quality,
    ) -> None:
        ctx, renderer = self.ctx, self.renderer
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
        target.framebuffer.use()
        ctx.viewport = (0, 0, *scene_size)
        ctx.fbo.depth_mask = True
        target.clear()
        renderer.render_scene(gpu, view, scene_size, options, sheets=target if inked else None)
        target.resolve()
        ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        source = target.texture
        if scene_size == size:
            self._pass("fxaa" if aa == "fxaa" else "plain", source, destination, size, options)
        else:
            if aa == "fxaa":
                smooth = self.target(scene_size, 0, "fxaa")
                self._pass("fxaa", source, smooth.framebuffer, scene_size, options)
                source = smooth.texture
            self._pass("upscale", source, destination, size, options)
        if options.hud and hud is not None:
            renderer.render_hud(gpu, view, hud, size, options.hud_drift, options.text)

    def _inset(self, inset: "Inset", destination, size: tuple[int, int]) -> None:
        """The inset's own small picture (the direct path: its background, no antialiasing,
        on software GL a few ms), then laid into the frame with a border and its label."""
        x, y, w, h = (int(round(v)) for v in inset.rect)
        if w < 16 or h < 16:
            return
        ctx, renderer = self.ctx, self.renderer
        target = self.target((w, h), 0, "inset")
        renderer.render(inset.gpu, inset.view, target.framebuffer, inset_look.OPTIONS)
        destination.use()
        ctx.viewport = (0, 0, *size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        viewport = (float(size[0]), float(size[1]))
        # the framebuffer's rows run bottom to top: the texel rectangle is flipped
        renderer._quads(
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
            renderer._panel_row(bx, by, bw, bh, inset_look.BORDER, rows)
        if inset.label:
            px = max(10, round(0.085 * h))
            # on a dark tab in the corner: the inset's picture may be light behind it
            glyphs: list = []
            box = renderer._glyph_rows(
                inset.label, "sans", px, x + 0.5 * px, y + 0.4 * px, inset_look.LABEL, glyphs
            )
            renderer._panel_row(
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
        renderer._quads(
            "glyphs", renderer.atlas.texture, (renderer.atlas.size,) * 2, rows, viewport
        )
        ctx.disable(moderngl.BLEND)

    def _pass(self, key: str, source, destination, size, options: RenderOptions) -> None:
        destination.use()
        self.ctx.viewport = (0, 0, *size)
        prog = self.programs[key]
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
        self._vaos[key].render(moderngl.TRIANGLES, vertices=3)

    def release(self) -> None:
        self.release_snapshot()
        for target in self._targets.values():
            target.release()
        self._targets.clear()
        for vao in self._vaos.values():
            vao.release()
        for prog in self.programs.values():
            prog.release()


class FrameTimer:
    """How long each frame's drawing takes, in milliseconds, for the frame governor.

    On a real GPU: GL timer queries around the frame, read two frames later (by then they are
    done, so reading never stalls the pipeline). On software GL (and where a query cannot be
    made) the GPU is the CPU: the wall time from begin() to a glFinish at end(), which costs
    nothing there because presenting the frame waits for the rasteriser anyway."""

    LATENCY = 2

    def __init__(self, ctx: moderngl.Context, clock=time.perf_counter, wall: bool | None = None):
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
