"""The post chain of a kiosk frame as passes (exhibit.render.frame puts them in order around the
scene passes): each says what it reads and writes in the passes' names for a frame's buffers
("scene colour", "scene depth", "sheets", "screen"), and draws from a PostFrame
(exhibit.render.passes.shared), decided before the first pass.

    clear      the offscreen scene target: colour transparent, depth 1 (and the sheets)
    resolve    the MSAA scene into its texture
    composite  the scene over the background into the screen (exhibit.render.passes.composite)
    inset      the time-slice inset's own small picture laid into its corner, with its label
    fade       the captured outgoing frame over the screen (a crossfade)
    hud        the HUD's words at the screen's full resolution (over a crossfade: the outgoing
               words fade out, then the new ones in)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar, Protocol

import moderngl

from exhibit.render import inset as inset_look
from exhibit.render.hud import TextMark
from exhibit.render.layout import Rect
from exhibit.render.passes.composite import CompositePass
from exhibit.render.passes.shared import PostFrame
from exhibit.render.renderer import Renderer
from exhibit.render.scene_target import CLEARED, SceneTarget

SCREEN = ("screen",)


class PostPass(Protocol):
    """A pass of a kiosk frame's post chain: its name (the pass timer's section), what it
    reads and writes, and its drawing."""

    name: ClassVar[str]
    reads: ClassVar[tuple[str, ...]]
    optional_reads: ClassVar[tuple[str, ...]]
    writes: ClassVar[tuple[str, ...]]

    def draw(self, frame: PostFrame) -> None: ...


class ClearPass:
    """The offscreen scene target cleared, and bound for the scene passes."""

    name: ClassVar[str] = "clear"
    reads: ClassVar[tuple[str, ...]] = ()
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("scene colour", "scene depth")

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx

    def draw(self, frame: PostFrame) -> None:
        target = frame.scene_target()
        target.framebuffer.use()
        self.ctx.viewport = (0, 0, *frame.scene_size)
        self.ctx.fbo.depth_mask = True
        target.clear()


class ClearSheetsPass(ClearPass):
    """ClearPass on frames that ink intersections: the sheet buffer is cleared too."""

    writes: ClassVar[tuple[str, ...]] = CLEARED


class ResolvePass:
    """The multisampled scene resolved into its texture (MSAA levels)."""

    name: ClassVar[str] = "resolve"
    reads: ClassVar[tuple[str, ...]] = ("scene colour",)
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = ("scene colour",)

    def draw(self, frame: PostFrame) -> None:
        frame.scene_target().resolve()


class InsetPass:
    """The inset's own small picture (the direct path: its background, no antialiasing, on
    software GL a few ms), then laid into the frame with a border and its label. ``targets``
    gives a cached target of a size (exhibit.render.frame.FramePipeline.target)."""

    name: ClassVar[str] = "inset"
    reads: ClassVar[tuple[str, ...]] = SCREEN
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = SCREEN

    def __init__(
        self,
        ctx: moderngl.Context,
        renderer: Renderer,
        targets: Callable[[tuple[int, int], int, str], SceneTarget],
    ) -> None:
        self.ctx, self.renderer, self.targets = ctx, renderer, targets

    def draw(self, frame: PostFrame) -> None:
        inset, size = frame.request.inset, frame.size
        if inset is None:
            return
        x, y, w, h = (int(round(v)) for v in inset.rect)
        if w < 16 or h < 16:
            return
        ctx, renderer, drawing = self.ctx, self.renderer, self.renderer.drawing
        target = self.targets((w, h), 0, "inset")
        renderer.render(inset.gpu, inset.view, target.framebuffer, inset_look.OPTIONS)
        frame.destination.use()
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
            frame.texts.append(TextMark("inset label", inset.label, Rect(*box), inset_look.LABEL))
        drawing.atlas_quads(rows, viewport)
        ctx.disable(moderngl.BLEND)


class FadePass:
    """The captured outgoing frame over the screen at the request's ``fade`` (a crossfade),
    with the composite pass's fade program."""

    name: ClassVar[str] = "fade"
    reads: ClassVar[tuple[str, ...]] = SCREEN
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = SCREEN

    def __init__(self, composite: CompositePass) -> None:
        self.composite = composite

    def draw(self, frame: PostFrame) -> None:
        if frame.snapshot is not None:
            self.composite.fade(frame.snapshot, frame.destination, frame.size, frame.request.fade)


class HudPass:
    """The HUD of ``frame.words`` over the screen at opacity ``frame.alpha`` (exhibit.render
    .hud), at the screen's full resolution."""

    name: ClassVar[str] = "hud"
    reads: ClassVar[tuple[str, ...]] = SCREEN
    optional_reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[str, ...]] = SCREEN

    def __init__(self, ctx: moderngl.Context, renderer: Renderer) -> None:
        self.ctx, self.renderer = ctx, renderer

    def draw(self, frame: PostFrame) -> None:
        words = frame.words
        if words is None or words.hud is None:
            return
        frame.destination.use()
        self.ctx.viewport = (0, 0, *frame.size)
        options = words.options
        self.renderer.hud.draw(
            words.gpu,
            words.view,
            words.hud,
            frame.size,
            options.hud_drift,
            options.text,
            frame.alpha,
        )
