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

A frame is one value (exhibit.render.frame_request.FrameRequest), and its way through is a list
of passes (FramePipeline.plan): the post chain's (exhibit.render.passes.post: clear, resolve,
composite, inset, fade, hud) around the scene's (Renderer.passes_for), each saying what it reads
and writes (tests/render/test_passes.py holds every level to reading only what was written).

Why one module of this size: one kiosk frame's passes at a quality level, in the order they run."""

from __future__ import annotations

import time
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass

import moderngl

from exhibit.render.frame_request import FrameRequest, Inset
from exhibit.render.passes.composite import CompositePass
from exhibit.render.passes.post import (
    ClearPass,
    ClearSheetsPass,
    FadePass,
    HudPass,
    InsetPass,
    PostPass,
    ResolvePass,
)
from exhibit.render.passes.shared import PostFrame, RenderPass
from exhibit.render.quality import software_renderer
from exhibit.render.renderer import Renderer
from exhibit.render.scene_target import SceneTarget

__all__ = ["FramePipeline", "FramePlan", "FrameRequest", "FrameTimer", "Inset", "MAX_TARGETS"]

#: Targets kept for recently used (size, antialiasing) pairs; a benchmark alternating levels
#: must not reallocate every frame, and a kiosk needs one or two.
MAX_TARGETS = 6


@dataclass(frozen=True)
class FramePlan:
    """A frame's passes in the order they run: the post chain's ``before`` the scene (the
    clear), the scene's passes (exhibit.render.renderer.Renderer.passes_for; on the direct
    path with the background), the post chain ``after`` it, and what they all draw from."""

    frame: PostFrame
    before: tuple[PostPass, ...]
    scene: tuple[RenderPass, ...]
    after: tuple[PostPass, ...]

    @property
    def direct(self) -> bool:
        """The direct path: the scene drawn straight into the destination."""
        return self.frame.target is None

    @property
    def passes(self) -> list[RenderPass | PostPass]:
        return [*self.before, *self.scene, *self.after]

    def unwritten_reads(self) -> list[str]:
        """Each read of a buffer that no earlier pass wrote ("pass: buffer"; an optional read
        only where a later pass writes it): none, or the plan does not hold together. On the
        direct path the scene passes draw straight into the screen."""
        passes, written, problems = self.passes, set[str](), []
        for i, each in enumerate(passes):
            later = {name for after in passes[i + 1 :] for name in after.writes}
            problems += [f"{each.name}: {name}" for name in each.reads if name not in written]
            problems += [
                f"{each.name}: {name} (written later)"
                for name in each.optional_reads
                if name not in written and name in later
            ]
            written |= set(each.writes)
            if self.direct and "scene colour" in written:
                written.add("screen")
        return problems


class FramePipeline:
    """Draws whole kiosk frames (exhibit.render.frame_request.FrameRequest, ``quality`` set) at
    any quality level into a destination framebuffer (a window's screen, or an offscreen
    single-sampled one), and crossfades between two of them (capture() the outgoing frame,
    then draw() the new ones with ``fade``). plan() says which passes a frame runs."""

    def __init__(self, ctx: moderngl.Context, renderer: Renderer, samples: int = 4):
        self.ctx = ctx
        self.renderer = renderer
        #: MSAA samples used by "msaa" levels (0 or 1: msaa falls back to none).
        self.samples = min(samples, ctx.max_samples) if samples > 1 else 0
        #: The composite passes: the scene over the background, FXAA or not, upscaled or not,
        #: and the crossfade's snapshot (exhibit.render.passes.composite).
        self.composite = CompositePass(ctx)
        #: The rest of the post chain (exhibit.render.passes.post).
        self.clear, self.clear_sheets = ClearPass(ctx), ClearSheetsPass(ctx)
        self.resolve = ResolvePass()
        self.inset = InsetPass(ctx, renderer, self.target)
        self.fade = FadePass(self.composite)
        self.hud = HudPass(ctx, renderer)
        self._targets: OrderedDict[tuple, SceneTarget] = OrderedDict()
        #: The outgoing frame of a crossfade: (texture, framebuffer, depth), kept at the screen
        #: size.
        self._snapshot: (
            tuple[moderngl.Texture, moderngl.Framebuffer, moderngl.Renderbuffer] | None
        ) = None
        #: The outgoing frame's request, whose words are faded out on their own.
        self._leaving: FrameRequest | None = None
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

    def plan(
        self,
        request: FrameRequest,
        destination: moderngl.Framebuffer,
        size: tuple[int, int],
        picture_only: bool = False,
    ) -> FramePlan:
        """The passes ``request`` runs into ``destination`` (drawable ``size``), in order, and
        what they draw from; ``picture_only``: the picture a crossfade starts from (no inset,
        no fade, no words)."""
        quality = request.quality
        if quality is None:
            raise ValueError("a kiosk frame needs a quality level: options.quality is None")
        size = (int(size[0]), int(size[1]))
        options = request.options.at_quality(quality)
        aa = quality.antialiasing
        if aa == "msaa" and not self.samples:
            aa = "none"
        scene_size = self.scene_size(size, quality.scale)
        inked = options.intersections and options.surfaces and bool(request.gpu.surfaces)
        direct = aa == "none" and scene_size == size and not inked
        target = smooth = None
        before: list[PostPass] = []
        after: list[PostPass] = []
        if not direct:
            target = self.target(
                scene_size, self.samples if aa == "msaa" else 0, "sheets" if inked else "scene"
            )
            before.append(self.clear_sheets if inked else self.clear)
            if target.samples:
                after.append(self.resolve)
            if aa == "fxaa" and scene_size != size:
                smooth = self.target(scene_size, 0, "fxaa")
            after.append(self.composite)
        sliced = request.view.slice_axis is not None
        scene = self.renderer.passes_for(options, inked, sliced, background=direct)
        snapshot, words, alpha = None, None, 1.0
        if not picture_only:
            if request.inset is not None:
                after.append(self.inset)
            words = request
            if request.fade > 0.0 and self._snapshot is not None:
                snapshot = self._snapshot[0] if self._snapshot[0].size == size else None
            if snapshot is not None:
                after.append(self.fade)
                fade = min(request.fade, 1.0)
                if fade > 0.5 and self._leaving is not None:
                    words, alpha = self._leaving, 2.0 * fade - 1.0
                else:
                    alpha = max(0.0, 1.0 - 2.0 * fade)
            if words.has_words:
                after.append(self.hud)
            else:
                words = None
        frame = PostFrame(
            request, options, destination, size, scene_size, aa, target, smooth, snapshot, words,
            alpha,
        )  # fmt: skip
        return FramePlan(frame, tuple(before), tuple(scene), tuple(after))

    def capture(self, request: FrameRequest, size: tuple[int, int]) -> None:
        """Draw the picture a crossfade starts from: the last frame of what is leaving the
        screen (drawn again, so nothing has to be read back), without its inset and words,
        which draw() fades out on their own (the request is kept for that)."""
        size = (int(size[0]), int(size[1]))
        if self._snapshot is None or self._snapshot[0].size != size:
            self.release_snapshot()
            texture = self.ctx.texture(size, 4)
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            # with depth, as a screen has: the direct level draws the scene straight into it
            depth = self.ctx.depth_renderbuffer(size)
            self._snapshot = (texture, self.ctx.framebuffer([texture], depth), depth)
        self._run(self.plan(request, self._snapshot[1], size, picture_only=True))
        self._leaving = request if request.has_words else None

    def release_snapshot(self) -> None:
        if self._snapshot is not None:
            for obj in reversed(self._snapshot):
                obj.release()
            self._snapshot = None
        self._leaving = None

    def draw(
        self, request: FrameRequest, destination: moderngl.Framebuffer, size: tuple[int, int]
    ) -> None:
        """One frame into ``destination`` (whose drawable size is ``size``): its plan's passes.
        With ``request.fade`` > 0 the captured picture is laid over it with that opacity;
        ``request.inset`` (exhibit.render.inset) is drawn over the picture in its corner.

        Words never cross-dissolve (two titles legible on top of each other for a second):
        while ``fade`` runs from 1 to 0 the outgoing words fade out over its first half and
        the new ones fade in over its second, as the pictures crossfade underneath."""
        self.texts = []
        timer = self.renderer.timer
        timer.begin_frame()
        try:
            plan = self.plan(request, destination, size)
            self.texts = plan.frame.texts
            self._run(plan)
        finally:
            timer.end_frame()

    def _run(self, plan: FramePlan) -> None:
        """The plan's passes in order: the post chain's each timed under its name, the scene's
        by the renderer (which times each of them)."""
        frame, renderer, timer = plan.frame, self.renderer, self.renderer.timer
        for post in plan.before:
            with timer.section(post.name):
                post.draw(frame)
        request, options = frame.request, frame.options
        if frame.target is None:
            renderer.render(
                request.gpu, request.view, frame.destination, options, None, size=frame.size
            )
        else:
            sheets = frame.target if frame.inked else None
            renderer.render_scene(request.gpu, request.view, frame.scene_size, options, sheets)
        for post in plan.after:
            with timer.section(post.name):
                post.draw(frame)

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
