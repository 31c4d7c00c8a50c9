"""The HUD a visitor reads: the title and caption panel, the numbers, the 4D axes gizmo and the
marker labels, drawn over the finished picture at the screen's full resolution.

Where everything goes comes from exhibit.render.layout (pure, shared with the framing), so the
panels drawn here are exactly the ones the picture was fitted around. Text is sized there for a
room (cap heights as a fraction of the screen height, RenderOptions.text).

Marker labels ("first contact, t = ...") are what a caption points at, so they must always be
readable: the marker is drawn again here, above the surfaces, as a diamond with a dark halo (a
hollow diamond when the point itself is behind a sheet, exhibit.geometry.occlusion), a shape no
other mark has: the Lemma 2 points are discs, and a colour-blind visitor tells the two apart by
their corners. Its label sits in the first of a few places around it that is on the screen and
off every panel and other label, on a halo of its own, with a leader line to the point whenever
it is not right beside it.

The key under the numbers lists every kind of mark the frame has (exhibit.render.hud_key):
Lemma 2 discs, the first contact, Lemma 3 outlines, the slice, axis lines, each as its shape
and colour beside its words; ``Hud.explained`` names the id pass's objects it explains.

Draw calls: the cached title block, the overlay capsules (gizmo, leader lines, tags' dots),
the marker diamonds, every other panel and glyph from the atlas, then the key's swatches.

Why one module of this size: the HUD's panels, gizmo and labels, drawn from one layout."""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Iterable
from typing import NamedTuple

import moderngl
import numpy as np

from exhibit.geometry.view import ViewState
from exhibit.render.gpu import GpuMesh
from exhibit.render.hud_cover import OPAQUE, HudCover
from exhibit.render.gizmo_layout import gizmo_caption_rect, gizmo_labels, gizmo_tips
from exhibit.render.hud_draw import HudDrawing
from exhibit.render.hud_labels import marker_labels, object_tags
from exhibit.render.hud_key import KeyEntry, key_entries, key_swatch_items
from exhibit.render.marks import HALO, INK, legible
from exhibit.render.hud_info import HudInfo
from exhibit.render.object_tags import TagAnchors, picture_box
from exhibit.render.passes.shared import Pipeline
from exhibit.render.layout import (
    HudLayout,
    Rect,
    TextSizes,
    hud_layout,
    key_swatch,
    status_lines,
)
from exhibit.render.glyph_atlas import HALO_DIRECTIONS, halo_steps
from exhibit.render.text import block_image, has_greek, line_height, text_width
from exhibit.scenes import palette

#: The HUD's panels: nearly opaque, so text stays legible over a bright surface brought close
#: (a visitor may drive the sensor in until the picture fills the screen).
PANEL = (0.0, 0.0, 0.0, 0.88)
DIM = (0.8, 0.82, 0.86, 1.0)
#: The axis colours of Figures 6-8's scene (x red, y amber, z green, w blue), from the palette
#: every visitor can tell apart (exhibit.scenes.palette).
AXIS_COLORS = (palette.RED, palette.AMBER, palette.LAVENDER, palette.BLUE)
#: The gizmo's letters: the axis colours lifted to LEGIBLE (the lines keep AXIS_COLORS).
AXIS_LETTERS = tuple(legible(c) for c in AXIS_COLORS)
#: The "4D axes" line under the gizmo.
AXES_CAPTION = (0.75, 0.77, 0.8, 1.0)


class TextMark(NamedTuple):
    """One piece of text drawn in a frame, for the contrast checks (tests/golden/contrast.py):
    what it is (``kind``: title, caption, numbers, key, axis letter, axes caption, marker
    label, object tag, inset label), its words, the box its glyphs cover and the colour they
    are drawn in (rgba, alpha as drawn, a fade included)."""

    kind: str
    text: str
    rect: Rect
    rgba: tuple[float, float, float, float]


class Hud:
    """HUD state of one renderer: the cached title block and the latest layout."""

    #: Title panels and layouts kept: every scene's and every attract caption's, in every
    #: language shown (about 45 each as shipped), so a scene change, a new caption or a new
    #: language costs no wrapping or rasterising (15 ms at 1080p) once warm.
    CACHED = 128

    def __init__(self, drawing: HudDrawing, pipeline: Pipeline) -> None:
        #: Text and quads (exhibit.render.hud_draw); the frame's clip transform, shared with
        #: the picture's passes (marker labels and tags sit on the points the picture shows).
        self.drawing, self.pipeline = drawing, pipeline
        #: key -> (texture, width, height) of title and caption panels, least recent first.
        self._blocks: OrderedDict[tuple, tuple] = OrderedDict()
        self._layouts: OrderedDict[tuple, HudLayout] = OrderedDict()
        #: How many title panels have been rasterised (each is kept for reuse).
        self.rasterised = 0
        self.layout: HudLayout | None = None
        #: The latest labels drawn: (marker label, Rect, point (x, y), hidden), for checks.
        self.labels: list[tuple[str, Rect, tuple[float, float], bool]] = []
        #: The gizmo's latest letters: (axis name, Rect), in axis order, for checks.
        self.gizmo_labels: list[tuple[str, Rect]] = []
        #: Every piece of text of the latest HUD (TextMark), for the contrast checks.
        self.texts: list[TextMark] = []
        #: The latest object tags drawn: (words, Rect, point (x, y), hidden), for checks.
        self.tags: list[tuple[str, Rect, tuple[float, float], bool]] = []
        #: The object name each of ``tags`` was asked for (HudInfo.tags), in the same order.
        self.tag_objects: list[str] = []
        #: Where each tag's dot sits on its object: the dot marks the object in its own colour,
        #: so it is not counted as covering it (HudCover).
        self.tag_dots: list[tuple] = []
        #: The latest key's entries (KeyEntry), in the order drawn.
        self.key: list[KeyEntry] = []
        #: The id pass's objects (exhibit.render.passes.ids.object_names) the latest key
        #: explains, each once: the marks' "pinch points", "outline", "slice", a labelled
        #: marker's name ("initial colliding point"), axis lines' names ("x axis").
        self.explained: list[str] = []
        #: What the latest HUD covers of the picture (panels, text, lines, discs), so a claim
        #: counts only what a visitor sees of an object (exhibit.render.hud_cover).
        self.cover = HudCover()
        #: Paces the tags' anchor checks (each mesh keeps its own anchors).
        self.anchors = TagAnchors()
        #: False: every glyph is left out (halos and panels stay), so a check can see what
        #: lies behind the text; never in a kiosk.
        self.ink = True

    def layout_for(
        self,
        size: tuple[int, int],
        hud: HudInfo,
        sizes: TextSizes,
        entries: tuple[str, ...] | None = None,
    ) -> HudLayout:
        """The layout of ``hud`` with the key ``entries`` (their words; None: every entry its
        words carry)."""
        key = (tuple(size), hud.title, hud.caption, hud.note, sizes, hud.words, entries)
        layout = self._layouts.get(key)
        if layout is None:
            layout = self._layouts[key] = hud_layout(
                size, hud.title, (hud.caption, hud.note), sizes, words=hud.words, key=entries
            )
            while len(self._layouts) > self.CACHED:
                self._layouts.popitem(last=False)
        self._layouts.move_to_end(key)
        self.layout = layout
        return layout

    def warm(self, size: tuple[int, int], huds: Iterable[HudInfo], sizes: TextSizes) -> None:
        """Lay out and rasterise these HUDs' panels ahead of time (the kiosk's start-up)."""
        for hud in list(huds)[-self.CACHED :]:
            self._title_block(self.layout_for(size, hud, sizes))

    def _title_block(self, layout: HudLayout):
        """The title and caption panel as one cached texture, rewrapped and redrawn only when
        the words or the screen size change: (texture, width, height, lines), texture None
        when there is nothing to show; ``lines`` are (kind, text, Rect in the block, rgba)."""
        key = (
            layout.title_lines,
            layout.caption_lines,
            layout.title_px,
            layout.body_px,
            layout.pad,
        )
        block = self._blocks.get(key)
        if block is None:
            block = self._blocks[key] = self._rasterise(layout)
            while len(self._blocks) > self.CACHED:
                _, (old, *_) = self._blocks.popitem(last=False)
                if old is not None:
                    old.release()
        self._blocks.move_to_end(key)
        return block

    def _rasterise(self, layout: HudLayout) -> tuple:
        self.rasterised += 1
        lines = [(t, "bold", layout.title_px, INK) for t in layout.title_lines]
        lines += [(t, "sans", layout.body_px, DIM) for t in layout.caption_lines]
        if not lines:
            return (None, 0, 0, ())
        image = block_image(lines, layout.pad, PANEL)
        h, w = image.shape[:2]
        ctx = self.drawing.ctx
        texture = ctx.texture((w, h), 4, np.ascontiguousarray(image).tobytes(), alignment=1)
        texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        texture.repeat_x = texture.repeat_y = False
        boxes, y = [], layout.pad
        for text, style, px, rgba in lines:
            x1 = min(layout.pad + math.ceil(text_width(text, style, px)), w - layout.pad)
            boxes.append(
                (
                    "title" if style == "bold" else "caption",
                    text,
                    Rect(layout.pad, y, x1, y + line_height(style, px)),
                    rgba,
                )
            )
            y += line_height(style, px)
        return (texture, w, h, tuple(boxes))

    def draw(
        self,
        gpu: GpuMesh,
        view: ViewState,
        hud: HudInfo,
        size: tuple[int, int],
        drift: tuple[float, float] = (0.0, 0.0),
        sizes: TextSizes | None = None,
        alpha: float = 1.0,
    ) -> None:
        """The whole HUD over the current framebuffer; ``alpha`` < 1 fades all of it alike
        (a crossfade shows the outgoing words fading out, then the new ones fading in)."""
        d = self.drawing
        alpha = min(max(float(alpha), 0.0), 1.0)
        self.texts = []
        self.cover = HudCover()
        self.key, self.explained = [], []
        if alpha == 0.0:
            return
        sizes = sizes or TextSizes()
        width, height = size
        d.ctx.viewport = (0, 0, width, height)
        d.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        d.ctx.enable(moderngl.BLEND)
        dx, dy = drift
        viewport = (float(width), float(height))
        ct = self.pipeline.clip_transform(view, size)
        entries = key_entries(gpu, view, hud, ct, size)
        layout = self.layout_for(size, hud, sizes, tuple(e.text for e in entries))
        body, pad = layout.body_px, layout.pad

        texture, block_w, block_h, block_lines = self._title_block(layout)
        title_rect = None
        if texture is not None:
            block = layout.title_block
            assert block is not None  # a texture means lines, and lines a title block
            x, y = round(block.x0 + dx), round(block.y0 + dy)
            title_rect = Rect(x, y, x + block_w, y + block_h) if alpha >= OPAQUE else None
            if self.ink:
                d.quads(
                    "image",
                    texture,
                    (block_w, block_h),
                    [(x, y, block_w, block_h, 0, 0, block_w, block_h, 1.0, 1.0, 1.0, alpha)],
                    viewport,
                )
            else:  # the panel alone, as the block draws it under its words
                panel: list[tuple] = []
                d.panel_row(x, y, block_w, block_h, (*PANEL[:3], PANEL[3] * alpha), panel)
                d.atlas_quads(panel, viewport)
            self.texts += [
                TextMark(
                    kind,
                    text,
                    Rect(x + b.x0, y + b.y0, x + b.x1, y + b.y1),
                    (*rgba[:3], rgba[3] * alpha),
                )
                for kind, text, b, rgba in block_lines
            ]

        rows: list[tuple] = []
        status = layout.status_block
        d.panel_row(status.x0 + dx, status.y0 - dy, status.width, status.height, PANEL, rows)
        mono_h = line_height("mono", body)
        lines = status_lines(view, sizes.infinity_beyond, hud.words)
        if not has_greek():
            lines = [t.replace("θ", "t").replace("∞", "inf").replace("°", "") for t in lines]
        for i, text in enumerate(lines):
            self._text(
                "numbers",
                text,
                "mono",
                body,
                status.x0 + dx + pad,
                status.y0 - dy + pad + i * mono_h,
                INK,
                rows,
            )

        # The key under the numbers: each kind of mark's shape and colour, then its words.
        key_items: list[tuple] = []
        key_diamonds: list[tuple] = []
        for entry, (text, kx, ky) in zip(entries, layout.key):
            left, top = status.x0 + dx + kx, status.y0 - dy + ky
            centre = (left + 0.45 * key_swatch(body), top + 0.55 * line_height("sans", body))
            key_items += key_swatch_items(entry, centre, body, key_diamonds)
            self._text("key", text, "sans", body, left + key_swatch(body), top, INK, rows)
        self.key = list(entries)
        self.explained = list(dict.fromkeys(name for e in entries for name in e.objects))
        items = self._gizmo(view, hud.axes, layout, rows, hud.axes_label)
        # Labels keep off the picture where there is room (wire frames would cross them).
        self.anchors.tick(ct)
        labelled = hud.tags or any(m.label for m in gpu.mesh.markers)
        picture = picture_box(gpu, ct, size) if labelled else None
        diamonds: list[tuple] = []
        items += marker_labels(self, gpu, view, size, layout, rows, hud.word, picture, diamonds)
        items += object_tags(self, gpu, view, size, layout, rows, hud.tags, picture)
        if alpha < 1.0:
            rows = [(*row[:11], row[11] * alpha) for row in rows]
            items, key_items, diamonds, key_diamonds = (
                [(a, b, (*rgba[:3], rgba[3] * alpha), w) for a, b, rgba, w in capsules]
                for capsules in (items, key_items, diamonds, key_diamonds)
            )
            self.texts = [
                t
                if t.kind in ("title", "caption")
                else t._replace(rgba=(*t.rgba[:3], t.rgba[3] * alpha))
                for t in self.texts
            ]
        d.overlay(items, viewport)
        d.overlay(diamonds, viewport, "diamond")
        d.atlas_quads(rows, viewport)
        d.overlay(key_items, viewport)  # on its panel, which the glyph quads drew
        d.overlay(key_diamonds, viewport, "diamond")
        # A diamond lies inside the disc of its width: recorded as that disc.
        marks = [c for c in items if c[:2] not in self.tag_dots]
        self.cover = HudCover.of(title_rect, rows, marks + diamonds + key_items + key_diamonds)
        d.ctx.disable(moderngl.BLEND)

    def _gizmo(
        self, view, axes, layout: HudLayout, rows: list, axes_label: str = "4D axes"
    ) -> list[tuple]:
        """Where the scene's x, y, z, w axes point on screen; the end disc grows for an axis
        pointing towards the sensor (out of the 3D image, into the 4th dimension). Returns its
        capsules; its letters (placed apart: exhibit.render.gizmo_layout.gizmo_labels) go to
        ``rows``, and to ``gizmo_labels`` for checks."""
        body = layout.body_px
        radius = layout.gizmo_radius
        cx, cy = layout.gizmo_center
        rot = view.rotation()
        tips = gizmo_tips(rot, layout)
        self.gizmo_labels = gizmo_labels(rot, axes, layout, axes_label)
        items = [((cx, cy), (cx, cy), PANEL, 2 * (radius + body))]
        for i in np.argsort(rot[2]):  # back to front along the eye's z
            rgba = (*AXIS_COLORS[i], 1.0)
            items.append(((cx, cy), tips[i], rgba, max(1.5, 0.036 * radius)))
            items.append(
                (tips[i], tips[i], rgba, max(3.0, 0.16 * radius * (1.0 + 0.7 * rot[3, i])))
            )
            label, rect = self.gizmo_labels[i]
            # on a halo: a letter may sit over another axis' line (w pointing at the sensor)
            self._halo_text(
                "axis letter", label, "bold", body, rect.x0, rect.y0, (*AXIS_LETTERS[i], 1.0), rows
            )
        # As large as the caption: every word on screen meets the size rule. It hangs below
        # the disc, so it has a halo of its own for a picture behind it.
        caption = gizmo_caption_rect(axes_label, layout)
        self._halo_text(
            "axes caption", axes_label, "sans", body, caption.x0, caption.y0, AXES_CAPTION, rows
        )
        return items

    def _text(self, kind, text, style, px, x, y, color, rows) -> None:
        """One line of glyphs in ``color`` (none when ``ink`` is off), kept in ``texts``."""
        if self.ink:
            box = self.drawing.glyph_rows(text, style, px, x, y, color, rows)
        else:
            box = self.drawing.glyph_rows(text, style, px, x, y, color, [])
        self.texts.append(TextMark(kind, text, Rect(*box), tuple(color)))

    def _halo_text(self, kind, text, style, px, x, y, color, rows) -> None:
        """Text on a dark halo: the glyphs drawn dark around it first, then in colour."""
        halo_rows(self.drawing, text, style, px, x, y, rows)
        self._text(kind, text, style, px, x, y, color, rows)

    def release(self) -> None:
        for texture, *_ in self._blocks.values():
            if texture is not None:
                texture.release()
        self._blocks.clear()
        self._layouts.clear()


def halo_rows(
    drawing: HudDrawing, text: str, style: str, px: int, x: float, y: float, rows: list
) -> None:
    """A dark halo for a line of text at (x, y): its glyphs in HALO, moved in eight directions
    by two distances (at least 1 and 2 pixels; px / 10 at most), so no pixel of the picture
    touches a stroke (text over a bright surface keeps 7:1, tests/golden/contrast.py). Each
    glyph's halo is one image in the atlas (GlyphAtlas.halo), drawn as one quad; where a line
    and its halos do not fit in the atlas together, sixteen moved copies of its glyphs."""
    reach = max(2, round(px / 10))
    x, y = round(x), round(y)
    r, g, b, alpha = HALO
    laid = drawing.atlas.halo_layout(text, style, px, reach, alpha)
    if laid is None:
        for step in halo_steps(reach):
            for ox, oy in HALO_DIRECTIONS:
                drawing.glyph_rows(text, style, px, x + ox * step, y + oy * step, HALO, rows)
        return
    for dx, halo in laid:
        rows.append(
            (x + dx, y - reach, halo.width, halo.height, halo.u, halo.v, halo.width, halo.height)
            + (r, g, b, 1.0)
        )
